#!/usr/bin/env python3
"""Checks that the files, folders and Rust items the docs name exist, so a rename or a removal
cannot leave the docs pointing at nothing.

Read: README.md, ARCHITECTURE.md and every .md under docs/ (the CHANGELOG is history and may
name what is gone). Checked:
  - relative markdown links [text](path#anchor): the file or folder exists (anchors unchecked);
  - repository paths in backticks, e.g. `shared/src/estimators/transmittance.rs` or `scripts/`:
    a token whose first component is a top-level folder of the repository must exist (one with
    a wildcard must match a file; braces, `eval_{cloud,explosion}.json`, are expanded and each
    expansion checked; placeholders such as `<volume>` and generated output folders, out/ and
    target/, are skipped);
  - Rust paths in backticks that start with a workspace crate, e.g.
    `shared::estimators::telescoping::telescoping`: each module resolves to a file of that crate,
    and the last name (an item) is defined in the module's file (fn, struct, enum, const,
    static, trait, type, mod or a macro_rules!) or is a module itself.

Usage: scripts/docs_check.py   (run by scripts/test.sh; exits 1 naming each dangling reference)
"""
import glob
import itertools
import os
import re
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
SKIP_PREFIXES = ("out/", "target/")
TOP = {e for e in os.listdir(ROOT) if not e.startswith(".")}
TOP_DIRS = {e for e in TOP if os.path.isdir(os.path.join(ROOT, e))} - {"out", "target"}
# Workspace crates by the name Rust code uses (package name with - as _) -> their src folder.
CRATES = {}
for d in sorted(TOP_DIRS):
    cargo = os.path.join(ROOT, d, "Cargo.toml")
    if os.path.isfile(cargo):
        m = re.search(r'^name\s*=\s*"([^"]+)"', open(cargo).read(), re.M)
        if m:
            CRATES[m.group(1).replace("-", "_")] = os.path.join(ROOT, d, "src")


def docs():
    yield "README.md"
    yield "ARCHITECTURE.md"
    for base, _, files in os.walk(os.path.join(ROOT, "docs")):
        for f in sorted(files):
            if f.endswith(".md"):
                yield os.path.relpath(os.path.join(base, f), ROOT)


def expand_braces(token):
    """`a_{x,y}.json` -> a_x.json, a_y.json (several groups multiply)."""
    parts = re.split(r"\{([^{}]*)\}", token)
    fixed, groups = parts[0::2], [g.split(",") for g in parts[1::2]]
    for combo in itertools.product(*groups):
        yield "".join(f + c for f, c in itertools.zip_longest(fixed, combo, fillvalue=""))


def code_spans(text):
    """The contents of inline code spans, outside fenced code blocks."""
    out = []
    fenced = False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if not fenced:
            out.extend(re.findall(r"`([^`\n]+)`", line))
    return out


def path_tokens(span):
    """Repository paths inside one code span (a command line may hold several)."""
    for word in re.split(r"[\s=,;()\"']+", span):
        word = word.rstrip(".:")
        if not word or "/" not in word:
            continue
        if any(c in word for c in "<>$~|[]") or word.startswith(("/", "./", "../", "http")):
            continue
        first = word.split("/")[0]
        if first not in TOP_DIRS or word.startswith(SKIP_PREFIXES):
            continue
        yield word


def braced_path_tokens(span):
    """As path_tokens, with a braced group kept whole (`eval_{a,b}.json`)."""
    for m in re.finditer(r"[A-Za-z0-9_.\-/*]*\{[^{}\s]*\}[A-Za-z0-9_.\-/{},*]*", span):
        word = m.group(0).rstrip(".:")
        first = word.split("/")[0]
        if "/" in word and first in TOP_DIRS and not word.startswith(SKIP_PREFIXES):
            yield from expand_braces(word)


def module_file(src, parts):
    """The file of module `parts` under a crate's src folder, or None."""
    base = os.path.join(src, *parts) if parts else None
    if not parts:
        for f in ("lib.rs", "main.rs"):
            if os.path.isfile(os.path.join(src, f)):
                return os.path.join(src, f)
        return None
    for cand in (base + ".rs", os.path.join(base, "mod.rs")):
        if os.path.isfile(cand):
            return cand
    return None


ITEM = r"(?:pub(?:\([^)]*\))?\s+)?(?:const\s+fn|unsafe\s+fn|fn|struct|enum|const|static|trait|type|mod|union)\s+{}\b"


def rust_path_ok(path):
    parts = path.split("::")
    crate = parts[0]
    if crate not in CRATES:
        return True  # not ours (std::, clap::, ...)
    src = CRATES[crate]
    mods = parts[1:]
    # The longest prefix that is a module; the rest (at most one name) an item of it, or an
    # associated item of a type there (Type::method: the type must be defined).
    for k in range(len(mods), -1, -1):
        f = module_file(src, mods[:k])
        if f is None:
            continue
        rest = mods[k:]
        if not rest:
            return True
        name = rest[0]
        text = open(f).read()
        if re.search(ITEM.format(re.escape(name)), text) or re.search(
            r"macro_rules!\s*" + re.escape(name) + r"\b", text
        ):
            return True
        # A re-export: `pub use ...::name` or `pub use ...::{..., name, ...}`.
        if re.search(r"pub use [^;]*\b" + re.escape(name) + r"\b[^;]*;", text):
            return True
        return False
    return False


def main():
    problems = []
    for doc in docs():
        text = open(os.path.join(ROOT, doc)).read()
        here = os.path.dirname(os.path.join(ROOT, doc))
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            path = target.split("#")[0]
            if path and not os.path.exists(os.path.normpath(os.path.join(here, path))):
                problems.append(f"{doc}: link to a missing file: {target}")
        for span in code_spans(text):
            tokens = set(braced_path_tokens(span))
            if not tokens:
                tokens = set(path_tokens(span))
            for tok in sorted(tokens):
                full = os.path.join(ROOT, tok)
                if not (glob.glob(full) if "*" in tok else os.path.exists(full)):
                    problems.append(f"{doc}: names a missing path: `{tok}`")
            for rp in re.findall(r"\b[a-z_][a-z0-9_]*(?:::[A-Za-z_][A-Za-z0-9_]*)+", span):
                if not rust_path_ok(rp):
                    problems.append(f"{doc}: names a missing Rust item: `{rp}`")
    for p in problems:
        print(p)
    if problems:
        print(f"docs_check: {len(problems)} dangling references")
        sys.exit(1)
    print("docs_check: every path, link and Rust item the docs name exists")


if __name__ == "__main__":
    main()
