#!/usr/bin/env python3
"""Import cycles between the modules of a crate (`host/src` by default, or e.g. `shared/src`).

Every `crate::a::b...` path and every `super::...` path in host/src/**/*.rs (comments stripped)
is an edge from the file's module to the module it names, and so is a path through a child
module the file declares (`mod x;` then `x::y`). Edges are taken at two levels:
  - top level: between the crate's top-level modules (`cli`, `commands`, `bench`, ...);
  - file level: between the modules of one top-level module (e.g. `study::table1` ->
    `study::umvu`), where a `mod` declaration is not a use.
A strongly connected component with more than one module is a cycle: it is printed and the
script exits with 1. With no cycle it prints a topological order and exits with 0.

    python3 scripts/module_cycles.py [host/src]
"""
import re
import sys
from pathlib import Path

USE_GROUP = re.compile(r"\b(crate|super)::\{([^}]*)\}", re.S)
PATH = re.compile(r"\b(crate|super)((?:::[A-Za-z_][A-Za-z0-9_]*)+)")


def strip_comments(text):
    """The source without // and /* */ comments (string literals are kept) and without its
    `#[cfg(test)]` module, whose `super::` is the file itself."""
    text = text.split("#[cfg(test)]")[0]
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def module_of(root, path):
    """Module path of a source file: host/src/a/b.rs -> ['a', 'b'], a/mod.rs -> ['a']."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] in ("mod", "lib"):
        parts = parts[:-1]
    return parts


def references(module, text):
    """Absolute module paths (lists of segments) that the text names."""
    refs = []
    for kind, group in USE_GROUP.findall(text):
        for item in group.split(","):
            item = item.strip().split(" as ")[0]
            if item:
                refs.append((kind, ["_"] + item.split("::")))
    for kind, rest in PATH.findall(text):
        refs.append((kind, ["_"] + rest.strip(":").split("::")))
    # Paths relative to a child module declared here (`mod x;` ... `x::y`).
    for child in re.findall(r"^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+([a-z_][a-z0-9_]*)\s*;", text, re.M):
        for rest in re.findall(rf"(?<![:\w]){child}((?:::[A-Za-z_][A-Za-z0-9_]*)+)", text):
            refs.append(("self", ["_", child] + rest.strip(":").split("::")))
    out = []
    for kind, segs in refs:
        segs = segs[1:]
        base = {"crate": [], "super": module[:-1], "self": module}[kind]
        out.append(base + segs)
    return out


def sccs(nodes, edges):
    """Tarjan's strongly connected components."""
    index, low, stack, on, result, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            result.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return result


def check(label, nodes, edges):
    """Prints the cycles of one graph (or its order); True when there is none."""
    comps = sccs(nodes, edges)
    cycles = [c for c in comps if len(c) > 1]
    if cycles:
        for c in cycles:
            inner = sorted(f"{a} -> {b}" for a in c for b in edges.get(a, ()) if b in c)
            print(f"{label}: cycle between {', '.join(c)}: {'; '.join(inner)}")
        return False
    # Tarjan emits components in reverse topological order: dependencies first.
    print(f"{label}: no cycle; dependencies first: {' '.join(c[0] for c in comps)}")
    return True


def main():
    root = Path(sys.argv[1] if len(sys.argv) > 1 else "host/src")
    files = sorted(p for p in root.rglob("*.rs") if p.name != "main.rs")
    modules = {tuple(module_of(root, p)) for p in files}
    top_nodes, top_edges = set(), {}
    inner = {}
    for path in files:
        module = module_of(root, path)
        if not module:
            continue  # lib.rs: declarations and re-exports only
        text = strip_comments(path.read_text())
        top = module[0]
        top_nodes.add(top)
        for ref in references(module, text):
            if not ref:
                continue
            if ref[0] != top:
                if (ref[0],) in modules:
                    top_edges.setdefault(top, set()).add(ref[0])
                continue
            # Longest module prefix of the path inside the same top-level module.
            target = max(
                (ref[:k] for k in range(1, len(ref) + 1) if tuple(ref[:k]) in modules),
                key=len,
            )
            src, dst = "::".join(module), "::".join(target)
            nodes, edges = inner.setdefault(top, (set(), {}))
            nodes.update((src, dst))
            if src != dst:
                edges.setdefault(src, set()).add(dst)
    crate = root.resolve().parent.name
    ok = check(f"{crate} (top-level modules)", top_nodes, top_edges)
    for top in sorted(inner):
        nodes, edges = inner[top]
        if len(nodes) > 1:
            ok &= check(f"{crate}::{top} (files)", nodes, edges)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
