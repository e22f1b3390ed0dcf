#!/usr/bin/python3
"""Hostile-input corpus for the `host` CLI: runs many bad (and a few valid) inputs against the
release binary and classifies every outcome.

    /usr/bin/python3 scripts/hostile_corpus.py [HOST_BINARY] [SCRATCH_DIR] [--md FILE]

HOST_BINARY defaults to target/release/host, SCRATCH_DIR to a fresh temporary directory, FILE to
docs/results/hostile_corpus.md (both relative to the repository root). Needs no numpy; writes
.vdb files with python3-openvdb (`pyopenvdb`) when it is importable (those cases are skipped
otherwise). Every case runs sequentially in its own directory under SCRATCH_DIR, with
`--backend cpu` where the subcommand takes it, tiny sizes, a wall-clock timeout and an
address-space limit (`ulimit -v`).

A case is a dict: name, argv (after the binary), expect ("refuse", "ok" or "either": a clean
refusal and a clean success are both acceptable), and optionally setup (a function of the case
directory that writes the inputs), words (that stderr must contain), env (extra environment),
timeout (s), vmem (KiB for ulimit -v), max_seconds (a refusal slower than this is BAD), protect
(files that must be byte-identical afterwards, whatever the outcome), outputs (files a
success must have written) and stdout_closed (stdout is a pipe nobody reads: writes fail with
EPIPE; a clean exit, a clean error or death by SIGPIPE are fine, a panic is not).

Outcomes:
  OK_REFUSED     exit 1, stderr starts with "error:" (after any "warning:" lines), nothing written
  OK_RENDERED    exit 0 for a case marked "ok" or "either", no non-finite numbers printed/written
  REFUSED_VALID  a clean refusal of a case marked "ok" (a wrong expectation or an over-strict check)
  BAD            panic, abort, signal, OOM kill, hang, other exit code, an accepted "refuse" case,
                 "inf"/"NaN" printed or non-finite numbers in a JSON by a successful run, a file
                 written or changed by a failed run, a protected file changed, missing words
"""
import datetime
import hashlib
import json
import os
import random
import re
import shlex
import shutil
import signal
import stat
import struct
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIX = os.path.join(ROOT, "tests", "fixtures")
MAL = os.path.join(FIX, "malformed")
TIMEOUT = 120  # s, default wall-clock limit of one run
VMEM = 4000000  # KiB, default `ulimit -v`
HOST = None  # absolute path of the binary, set in main() (setups that render inputs use it)

try:
    import pyopenvdb as vdb
except ImportError:  # the .vdb-writing cases are skipped
    vdb = None

# ------------------------------------------------------------------------------------------------
# Inputs written by setups (all deterministic).


def fix(name):
    return os.path.join(FIX, name)


def mal(name):
    return os.path.join(MAL, name)


def write(d, name, data):
    path = os.path.join(d, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb" if isinstance(data, bytes) else "w") as f:
        f.write(data)
    return path


def copy(src, name):
    return lambda d: shutil.copyfile(src, os.path.join(d, name))


def truncated(src, n):
    def setup(d):
        with open(src, "rb") as f:
            write(d, "t" + os.path.splitext(src)[1], f.read()[:n])
    return setup


def flipped(src, seed, count):
    """`count` bytes of `src` replaced by random ones (seeded), past the first 16 bytes."""
    def setup(d):
        data = bytearray(open(src, "rb").read())
        rng = random.Random(seed)
        for _ in range(count):
            data[rng.randrange(16, len(data))] = rng.randrange(256)
        write(d, "f" + os.path.splitext(src)[1], bytes(data))
    return setup


def garbage(name, n, seed, prefix=b""):
    rng = random.Random(seed)
    return lambda d: write(d, name, prefix + bytes(rng.randrange(256) for _ in range(n)))


VDB_MAGIC = struct.pack("<q", 0x56444220)
NVDB_MAGIC = struct.pack("<Q", 0x304244566F6E614E)


def sparse_file(name, size, prefix):
    def setup(d):
        with open(os.path.join(d, name), "wb") as f:
            f.write(prefix)
            f.truncate(size)
    return setup


def fifo(name):
    return lambda d: os.mkfifo(os.path.join(d, name))


def mknod_null(name):
    """A character device like /dev/null (1, 3) made in the case's own folder, never the
    system's; where this user may not make one (not root), a FIFO instead, so the case still
    checks that a special file is refused and kept."""
    def setup(d):
        p = os.path.join(d, name)
        try:
            os.mknod(p, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
        except PermissionError:
            os.mkfifo(p)
    return setup


def summary_json(name="r.json"):
    """A render's JSON summary written by the binary itself: its `scene` names it as `json`."""
    def setup(d):
        subprocess.run([HOST, "render", "--backend", "cpu", "--resolution", "16", "--width", "8",
                        "--height", "4", "--spp", "1", "-q", "-o", os.path.join(d, "s.exr"),
                        "--json", name], cwd=d, check=True, capture_output=True)
    return setup


def ref_shard(name="ref.shard"):
    """An eval reference shard written by the binary itself."""
    def setup(d):
        subprocess.run([HOST, "eval", "--backend", "cpu", "--resolution", "16", "--width", "8",
                        "--height", "8", "--spp", "2", "-q", "--estimators", "jackknife",
                        "--out-dir", "evs", "--reference-shard", name], cwd=d, check=True,
                       capture_output=True)
    return setup


def render_shard(name="part.shard"):
    """A render shard written by the binary itself."""
    def setup(d):
        subprocess.run([HOST, "render", "--backend", "cpu", "--resolution", "16", "--width", "8",
                        "--height", "4", "--spp", "1", "-q", "--shard", name], cwd=d, check=True,
                       capture_output=True)
    return setup


def fnv1a64(data, h=0xcbf29ce484222325):
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def forged_shard(name, edit, rehash=True):
    """After `render_shard(name)`: the header JSON edited by `edit(dict)`; with `rehash`, the
    header hash recomputed so that only the field checks can refuse it (format 2: magic, u32
    header length, u64 FNV-1a of magic + length + header, header, totals)."""
    def setup(d):
        p = os.path.join(d, name)
        raw = open(p, "rb").read()
        n = struct.unpack("<I", raw[8:12])[0]
        header = json.loads(raw[20:20 + n])
        edit(header)
        text = json.dumps(header, separators=(",", ":")).encode()
        length = struct.pack("<I", len(text))
        h = fnv1a64(b"JKSHARD2" + length + text) if rehash else struct.unpack("<Q", raw[12:20])[0]
        open(p, "wb").write(b"JKSHARD2" + length + struct.pack("<Q", h) + text + raw[20 + n:])
    return setup


def cut_file(name, keep):
    def setup(d):
        p = os.path.join(d, name)
        data = open(p, "rb").read()
        open(p, "wb").write(data[:keep])
    return setup


def symlink(target, name):
    return lambda d: os.symlink(target, os.path.join(d, name))


def mkdir(name):
    return lambda d: os.makedirs(os.path.join(d, name))


def hardlink(src, name):
    return lambda d: os.link(os.path.join(d, src), os.path.join(d, name))


def both(*setups):
    def setup(d):
        for s in setups:
            s(d)
    return setup


def hdr(name, w, h, texel=(128, 128, 128, 129), dims=None, body=None):
    """A Radiance .hdr with flat (uncompressed) scanlines; `dims` overrides the resolution line,
    `body` the pixel bytes."""
    line = dims if dims is not None else f"-Y {h} +X {w}"
    head = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{line}\n".encode()
    data = body if body is not None else bytes(texel) * (w * h)
    return lambda d: write(d, name, head + data)


def hdr_bad_rle(name):
    """16 wide, 2 high, new-style RLE whose first run claims 200 texels of a 16-texel line."""
    scan = bytes([2, 2, 0, 16]) + bytes([128 + 127, 5]) * 2 + bytes([200]) + bytes(200)
    return hdr(name, 16, 2, body=scan * 2)


def float_grid(name, voxels, grid="density", voxel_size=1.0):
    """A .vdb (pyopenvdb) with one float grid, voxels = {(i, j, k): value}."""
    def setup(d):
        g = vdb.FloatGrid()
        g.name = grid
        acc = g.getAccessor()
        for ijk, v in voxels.items():
            acc.setValueOn(ijk, v)
        g.transform = vdb.createLinearTransform(voxelSize=voxel_size)
        vdb.write(os.path.join(d, name), grids=[g])
    return setup


def rendered_exr(name, extra=()):
    """An EXR made by the binary itself (e.g. to feed back as an environment map)."""
    def setup(d):
        subprocess.run([HOST, "render", "--backend", "cpu", "--resolution", "16", "--width", "8",
                        "--height", "4", "--spp", "1", "-q", "-o", os.path.join(d, name),
                        *extra], check=True, capture_output=True)
        os.remove(os.path.join(d, os.path.splitext(name)[0] + ".png"))
    return setup


def real_eval(subdir="ev0", mutate=None):
    """A real `host eval` output directory, optionally mutated (mutate(dir) after the run)."""
    def setup(d):
        out = os.path.join(d, subdir)
        subprocess.run([HOST, "eval", "--backend", "cpu", "--resolution", "16", "--width", "8",
                        "--height", "8", "--spp", "2", "-q", "--estimators", "jackknife",
                        "--out-dir", out], check=True, capture_output=True)
        if mutate:
            mutate(out)
    return setup


def eval_json_nan(out):
    p = os.path.join(out, "eval.json")
    text = open(p).read()
    text = re.sub(r'("bias"\s*:\s*)[-0-9.eE+]+', r"\1NaN", text)
    text = re.sub(r'("std"\s*:\s*)[-0-9.eE+]+', r"\1Infinity", text)
    open(p, "w").write(text)


def eval_drop_images(out):
    for f in os.listdir(out):
        if f.endswith(".exr"):
            os.remove(os.path.join(out, f))


# ------------------------------------------------------------------------------------------------
# Command prefixes (tiny sizes, CPU backend).

EMBEDDED = ("cloud", "explosion", "constant")
RENDER = ["render", "--backend", "cpu", "--width", "32", "--height", "32", "--spp", "1", "-q"]
EVAL = ["eval", "--backend", "cpu", "--width", "16", "--height", "16", "--spp", "2", "-q",
        "--out-dir", "ev", "--estimators", "jackknife"]
BENCH = ["bench", "--backend", "cpu", "--width", "16", "--height", "16", "--spp", "2",
         "--reps", "1", "--warmup", "0", "--estimators", "jackknife", "-q", "--json", "b.json"]
REPORT = ["report", "--backend", "cpu", "--width", "16", "--height", "16", "--spp", "2",
          "--integrator-spp", "2", "--estimators", "jackknife", "-q", "-o", "rep"]
PROBE = ["probe", "--backend", "cpu", "--count", "4096"]
STUDY_SMALL = {
    "normal": ["--trials", "1000", "--sweep-trials", "100"],
    "distributions": ["--trials", "1000", "--points", "2"],
    "profile": ["--trials", "1000"],
    "table1": ["--trials", "1000"],
    "histogram": ["--trials", "1000"],
    "convergence": ["--trials", "100", "--max-n", "400", "--points", "6"],  # 2 N >= 100
    "mis-bias": ["--nx", "4", "--ny", "4", "--trials", "100"],
}


BOOL_FLAGS = {"-q", "--quiet", "--sweep", "--clamp-negative", "--equal-time",
              "--ratio-roulette"}


def flag_items(argv):
    """argv as [(flag or None, [tokens])]: a flag with its value, or a lone token."""
    items, i = [], 0
    while i < len(argv):
        a = argv[i]
        if isinstance(a, str) and a.startswith("-") and "=" not in a and a not in BOOL_FLAGS \
                and i + 1 < len(argv):
            items.append((a, [a, argv[i + 1]]))
            i += 2
        else:
            name = a.split("=", 1)[0] if isinstance(a, str) and a.startswith("-") else None
            items.append((name, [a]))
            i += 1
    return items


def merge(base, extra):
    """base + extra, where a flag given in extra replaces the same flag of base (so that a case
    can override a default such as --width without clap refusing a repeated flag)."""
    extra = list(extra)
    given = {f for f, _ in flag_items(extra) if f}
    return [t for f, toks in flag_items(base) if f not in given for t in toks] + extra


def vol_args(vol):
    """--volume and, for an embedded volume, a small --resolution."""
    if vol is None:
        vol = "cloud"
    args = ["--volume", vol]
    return args + (["--resolution", "32"] if vol in EMBEDDED else [])


def render(*extra, vol=None, out=True):
    outs = ["-o", "r.exr", "--json", "r.json"] if out else []
    return merge(RENDER + vol_args(vol) + outs, extra)


def direct(*extra, vol=None):
    return render("--integrator", "direct", *extra, vol=vol)


def evaluate(*extra, vol=None):
    return merge(EVAL + vol_args(vol), extra)


def bench(*extra, vol=None):
    return merge(BENCH + vol_args(vol), extra)


def report(*extra, emb=True):
    return merge(REPORT + (["--resolution", "32"] if emb else []), extra)


def probe(*extra):
    return merge(PROBE, extra)


def study(name, *extra):
    return ["study", name] + merge(["--threads", "2", "-q", "--plot", "s.png", "--json",
                                    "s.json"] + STUDY_SMALL[name], extra)


RENDER_OUT = ["r.exr", "r.png", "r.json"]

# ------------------------------------------------------------------------------------------------
# The case table.


def case(name, argv, expect, **kw):
    return dict(name=name, argv=argv, expect=expect, **kw)


def malformed_expected():
    """tests/fixtures/malformed/EXPECTED: (file, grid or None, words)."""
    rows = []
    for line in open(os.path.join(MAL, "EXPECTED")):
        if line.startswith("#") or not line.strip():
            continue
        file, grid, words = line.rstrip("\n").split("\t")
        rows.append((file, None if grid == "-" else grid, words.split(" | ")))
    return rows


def cases():
    C = []
    add = lambda *a, **k: C.append(case(*a, **k))

    # --- Valid baselines: one per subcommand (classifies the machinery, not the inputs).
    add("render_baseline", render(), "ok", outputs=RENDER_OUT)
    add("render_default_subcommand", RENDER[1:] + vol_args(None) + ["-o", "r.exr"], "ok",
        outputs=["r.exr", "r.png"])
    add("eval_baseline", evaluate(), "ok", outputs=["ev/eval.json"])
    add("bench_baseline_quiet", bench(), "ok", outputs=["b.json"])
    add("report_baseline", report("--volumes", "cloud"), "ok", outputs=["rep/index.html"])
    add("probe_baseline", probe(), "ok")
    for s in STUDY_SMALL:
        add(f"study_{s}_baseline", study(s), "ok", outputs=["s.json"])
    add("version", ["--version"], "ok")

    # --- Volume paths that are not volume files.
    add("vol_empty_string", render(vol=""), "refuse")
    add("vol_nonexistent_vdb", render(vol="nope.vdb"), "refuse", words=["nope.vdb"])
    add("vol_nonexistent_noext", render(vol="nope"), "refuse")
    add("vol_empty_vdb", render(vol="e.vdb"), "refuse", setup=lambda d: write(d, "e.vdb", b""))
    add("vol_empty_nvdb", render(vol="e.nvdb"), "refuse", setup=lambda d: write(d, "e.nvdb", b""))
    add("vol_directory", render(vol="d.vdb"), "refuse", setup=mkdir("d.vdb"))
    add("vol_fifo", render(vol="p.vdb"), "refuse", setup=fifo("p.vdb"), timeout=20)
    add("vol_fifo_nvdb", render(vol="p.nvdb"), "refuse", setup=fifo("p.nvdb"), timeout=20)
    add("vol_dev_zero", render(vol="/dev/zero"), "refuse")
    add("vol_symlink_dev_zero_vdb", render(vol="z.vdb"), "refuse",
        setup=symlink("/dev/zero", "z.vdb"), timeout=60)
    add("vol_symlink_dev_zero_nvdb", render(vol="z.nvdb"), "refuse",
        setup=symlink("/dev/zero", "z.nvdb"), timeout=60)
    add("vol_symlink_dev_urandom_nvdb", render(vol="u.nvdb"), "refuse",
        setup=symlink("/dev/urandom", "u.nvdb"), timeout=60)
    add("vol_symlink_dev_null_vdb", render(vol="n.vdb"), "refuse",
        setup=symlink("/dev/null", "n.vdb"))
    add("vol_symlink_loop", render(vol="loop.vdb"), "refuse", setup=symlink("loop.vdb", "loop.vdb"))
    add("vol_symlink_dangling", render(vol="dang.vdb"), "refuse",
        setup=symlink("missing.vdb", "dang.vdb"))
    add("vol_proc_self_mem", render(vol="m.vdb"), "refuse", setup=symlink("/proc/self/mem", "m.vdb"))
    add("vol_sparse_10GB_vdb_magic", render(vol="big.vdb"), "refuse",
        setup=sparse_file("big.vdb", 10 << 30, VDB_MAGIC + struct.pack("<I", 224)))
    add("vol_sparse_10GB_nvdb_magic", render(vol="big.nvdb"), "refuse",
        setup=sparse_file("big.nvdb", 10 << 30, NVDB_MAGIC))
    add("vol_uppercase_name", render(vol="CLOUD"), "either")
    add("vol_uppercase_ext", render(vol="D.VDB"), "either", setup=copy(fix("density_zip.vdb"), "D.VDB"))
    add("vol_newline_in_name", render(vol="a\nb.vdb"), "ok",
        setup=copy(fix("density_zip.vdb"), "a\nb.vdb"))
    add("vol_dash_name", RENDER + ["--volume=-v.vdb", "-o", "r.exr"], "ok",
        setup=copy(fix("density_zip.vdb"), "-v.vdb"))
    add("vol_non_utf8_name", RENDER + [b"--volume", b"\xff.vdb", b"-o", b"r.exr"], "either",
        setup=lambda d: shutil.copyfile(fix("density_zip.vdb"), os.path.join(os.fsencode(d), b"\xff.vdb")))
    add("vol_wrong_extension_valid_content", render(vol="v.txt"), "refuse",
        setup=copy(fix("density_zip.vdb"), "v.txt"))
    add("vol_vdb_content_named_nvdb", render(vol="v.nvdb"), "refuse",
        setup=copy(fix("density_zip.vdb"), "v.nvdb"))

    # --- Garbage .vdb / .nvdb.
    add("garbage_vdb_4k", render(vol="g.vdb"), "refuse", setup=garbage("g.vdb", 4096, 1))
    add("garbage_nvdb_4k", render(vol="g.nvdb"), "refuse", setup=garbage("g.nvdb", 4096, 2))
    add("garbage_vdb_magic_then_random", render(vol="g.vdb"), "refuse",
        setup=garbage("g.vdb", 4096, 3, VDB_MAGIC))
    add("garbage_nvdb_magic_then_random", render(vol="g.nvdb"), "refuse",
        setup=garbage("g.nvdb", 4096, 4, NVDB_MAGIC))
    add("garbage_vdb_magic_then_ff", render(vol="g.vdb"), "refuse",
        setup=lambda d: write(d, "g.vdb", VDB_MAGIC + b"\xff" * 4096))
    add("garbage_nvdb_magic_then_ff", render(vol="g.nvdb"), "refuse",
        setup=lambda d: write(d, "g.nvdb", NVDB_MAGIC + b"\xff" * 4096))
    add("garbage_vdb_zeros", render(vol="g.vdb"), "refuse",
        setup=lambda d: write(d, "g.vdb", bytes(4096)))
    add("garbage_nvdb_text", render(vol="g.nvdb"), "refuse",
        setup=lambda d: write(d, "g.nvdb", "this is not a volume\n" * 50))

    # --- Truncated fixtures.
    for src in ["density_zip.vdb", "density_blosc.vdb", "density_raw.vdb", "tiles.vdb",
                "sparse_patches.vdb", "density.nvdb", "density_fp16.nvdb", "sparse_patches.nvdb",
                "multi.nvdb"]:
        n = os.path.getsize(fix(src))
        ext = os.path.splitext(src)[1]
        for cut in sorted({1, 8, 100, n // 3, n // 2, n - 100, n - 1}):
            add(f"trunc_{src}_{cut}of{n}", render(vol="t" + ext), "refuse",
                setup=truncated(fix(src), cut))

    # --- Fixtures with random bytes changed (loading or refusing are both fine; crashing is not).
    for src in ["density_zip.vdb", "density_raw.vdb", "density.nvdb", "sparse_patches.vdb",
                "sparse_patches.nvdb"]:
        ext = os.path.splitext(src)[1]
        for seed in range(6):
            add(f"flip_{src}_seed{seed}", render(vol="f" + ext), "either",
                setup=flipped(fix(src), 1000 + seed, 1 + 3 * seed))

    # --- tests/fixtures/malformed: every file must be refused, with its words.
    for file, grid, words in malformed_expected():
        argv = render(vol=mal(file)) + (["--grid", grid] if grid else [])
        add(f"malformed_{file}", argv, "refuse", words=words)
    add("malformed_duplicate_names_vdb_grid1", render("--grid", "density[1]",
        vol=mal("duplicate_names.vdb")), "ok", outputs=RENDER_OUT)
    add("malformed_duplicate_names_nvdb_grid0", render("--grid", "density[0]",
        vol=mal("duplicate_names.nvdb")), "ok", outputs=RENDER_OUT)
    for g in ["density[2]", "density[-1]", "density[", "density[1", "density[]", "density[x]",
              "density[99999999999999999999999]", "density [1]", ""]:
        add(f"grid_dup_{g or 'empty'}", render("--grid", g, vol=mal("duplicate_names.vdb")),
            "refuse")
    add("malformed_negative_clamped", render("--clamp-negative",
        vol=mal("negative_density.vdb")), "ok")
    add("malformed_nan_clamped", render("--clamp-negative", vol=mal("nan_density.vdb")), "refuse")
    add("malformed_through_eval", evaluate(vol=mal("huge_grid_count.vdb")), "refuse")
    add("malformed_through_bench", bench(vol=mal("truncated_leaves.vdb")), "refuse")

    # --- Valid fixtures (and the ones the loaders must refuse).
    for f in ["density_zip.vdb", "density_blosc.vdb", "density_half_zip.vdb", "tiles.vdb",
              "upper_tile.vdb", "scale_translate.vdb", "sparse_patches.vdb", "density.nvdb",
              "sparse_patches.nvdb", "two_far.vdb"]:
        add(f"fixture_{f}", render(vol=fix(f)), "ok", outputs=RENDER_OUT)
    for f in ["multi.vdb", "affine.vdb", "root_tile.vdb", "density_fp16.nvdb", "huge.vdb",
              "two_corners.vdb"]:
        add(f"fixture_{f}", render(vol=fix(f)), "either")
    for f in ["empty.vdb", "int.vdb", "vec3.vdb", "wide.vdb"]:
        add(f"fixture_{f}", render(vol=fix(f)), "refuse")
    add("fixture_huge_brick2", render("--brick-size", "2", vol=fix("huge.vdb")), "refuse")
    add("fixture_two_corners_brick256", render("--brick-size", "256",
        vol=fix("two_corners.vdb")), "either")
    add("fixture_multi_grid_flames", render("--grid", "flames", vol=fix("multi.vdb")), "ok")
    add("fixture_multi_nvdb_grid_temperature", render("--grid", "temperature",
        vol=fix("multi.nvdb")), "ok")
    add("fixture_single_grid_density1", render("--grid", "density[1]",
        vol=fix("density_zip.vdb")), "refuse")

    # --- Volumes written with pyopenvdb.
    if vdb is not None:
        add("pyvdb_density_3e38", render(vol="h.vdb"), "refuse",
            setup=float_grid("h.vdb", {(0, 0, 0): 3e38, (1, 0, 0): 1.0}))
        add("pyvdb_density_1e30", render(vol="h.vdb"), "either",
            setup=float_grid("h.vdb", {(0, 0, 0): 1e30, (3, 3, 3): 1.0}), timeout=60)
        add("pyvdb_subnormal", render(vol="s.vdb"), "either",
            setup=float_grid("s.vdb", {(0, 0, 0): 1e-44, (5, 5, 5): 1e-40}))
        add("pyvdb_single_voxel", render(vol="one.vdb"), "ok",
            setup=float_grid("one.vdb", {(7, -3, 2): 1.0}))
        add("pyvdb_voxel_1e-4", render(vol="tiny.vdb"), "either",  # OpenVDB's smallest
            setup=float_grid("tiny.vdb", {(0, 0, 0): 1.0, (9, 9, 9): 2.0}, voxel_size=1e-4))
        add("pyvdb_voxel_1e12", render(vol="big.vdb"), "either",
            setup=float_grid("big.vdb", {(0, 0, 0): 1.0, (9, 9, 9): 2.0}, voxel_size=1e12))
        add("pyvdb_grid_named_density[1]", render("--grid", "density[1]", vol="n.vdb"), "either",
            setup=float_grid("n.vdb", {(0, 0, 0): 1.0}, grid="density[1]"))
        add("pyvdb_far_voxels_2^30", render(vol="far.vdb"), "either",
            setup=float_grid("far.vdb", {(0, 0, 0): 1.0, (1 << 30, 0, 0): 1.0}))

    # --- --grid with embedded volumes, --resolution with files.
    add("grid_with_embedded", render("--grid", "density"), "refuse")
    add("resolution_with_file_render", RENDER + ["--volume", fix("density_zip.vdb"),
        "--resolution", "32", "-o", "r.exr"], "refuse", words=["--resolution"])
    add("resolution_with_file_eval", EVAL + ["--volume", fix("density_zip.vdb"),
        "--resolution", "32"], "refuse", words=["--resolution"])
    add("resolution_with_file_bench", BENCH + ["--volume", fix("density_zip.vdb"),
        "--resolution", "32"], "refuse", words=["--resolution"])
    add("resolution_7", RENDER + ["--resolution", "7", "-o", "r.exr"], "refuse")
    add("resolution_1025", RENDER + ["--resolution", "1025", "-o", "r.exr"], "refuse")
    # Valid (8 to 1024); renders under 4 GB in about a minute on 2 cores.
    add("resolution_1024_under_4GB", RENDER + ["--resolution", "1024", "-o", "r.exr"], "either")

    # --- Numeric flags at hostile values (--flag=value so that "-1" and "" reach the parser).
    values = ["0", "-1", "1e40", "nan", "inf", "", "1,2"]
    valid = {("density-scale", "0"): "either", ("hg-g", "0"): "ok", ("albedo", "0"): "ok",
             ("env-scale", "0"): "ok", ("env-rotate", "0"): "ok", ("env-rotate", "-1"): "ok"}
    for flag in ["width", "height", "spp", "n", "fov", "density-scale", "exposure", "brick-size",
                 "hg-g", "albedo", "env-scale", "env-rotate"]:
        mk = direct if flag in ("hg-g", "albedo", "env-scale", "env-rotate") else render
        for v in values:
            add(f"render_{flag}={v or 'empty'}", mk(f"--{flag}={v}"),
                valid.get((flag, v), "refuse"))
    for flag, ok0 in [("width", False), ("spp", False), ("n", False), ("fov", False),
                      ("reference-spp", False), ("bias-scale", False), ("std-scale", False)]:
        for v in ["0", "-1", "nan", "1e40"]:
            add(f"eval_{flag}={v}", evaluate(f"--{flag}={v}"), "refuse")
    for v in ["0", "-1", "nan", "1e40"]:
        add(f"eval_integrators_direct_hg-g={v}", evaluate("--integrators", "direct",
            f"--hg-g={v}"), "ok" if v == "0" else "refuse")
    for flag, okv in [("reps", ()), ("warmup", ("0",)), ("spp", ()), ("n", ())]:
        for v in ["0", "-1", "nan", "1e40"]:
            add(f"bench_{flag}={v}", bench(f"--{flag}={v}"), "ok" if v in okv else "refuse")
    for flag, okv in [("count", ()), ("tau", ("0",)), ("sigma", ("0",)), ("seed", ("0",))]:
        for v in ["0", "-1", "nan", "1e40"]:
            add(f"probe_{flag}={v}", probe(f"--{flag}={v}"), "ok" if v in okv else "refuse")
    for s in STUDY_SMALL:
        for flag, v in [("threads", "0"), ("threads", "1025"), ("trials", "1"),
                        ("trials", "nan"), ("seed", "-1"), ("seed", "18446744073709551616")]:
            add(f"study_{s}_{flag}={v}", study(s, f"--{flag}={v}"), "refuse")

    # --- Other out-of-range flags of render.
    for flag, v, exp in [("spp", "1048577", "refuse"), ("width", "16385", "refuse"),
                         ("n", "4097", "refuse"), ("n", "4096", "ok"), ("fov", "180", "refuse"),
                         ("fov", "179.9999", "either"), ("brick-size", "257", "refuse"),
                         ("brick-size", "3", "either"), ("brick-size", "256", "either"),
                         ("seed", "4294967296", "refuse"), ("seed", "-1", "refuse"),
                         ("f-delta", "0", "refuse"), ("f-delta", "11", "refuse"),
                         ("estimator", "bogus", "refuse"), ("integrator", "bogus", "refuse"),
                         ("lookup", "bogus", "refuse"), ("up", "w", "refuse"),
                         ("supervoxel-format", "bc4", "ok"), ("exposure", "1e38", "either")]:
        add(f"render_{flag}={v}", render(f"--{flag}={v}"), exp)
    add("render_16384x16384_under_1GB", render("--width", "16384", "--height", "16384"),
        "refuse", vmem=1000000)
    add("render_density_scale_3e38_cloud", render("--density-scale", "3e38"), "refuse")
    add("render_density_scale_3.4e38_file", render("--density-scale", "3.4e38",
        vol=fix("density_zip.vdb")), "refuse")
    for est in ["track-length", "ratio", "unbiased-rm", "regular", "jackknife-adaptive"]:
        add(f"render_density_scale_1e30_{est}", render("--density-scale", "1e30",
            "--estimator", est), "either", timeout=60)
    add("render_path_density_scale_1e6_albedo1", render("--integrator", "path",
        "--density-scale", "1e6", "--albedo", "1", "--max-depth", "1024", "--rr-depth",
        "1024"), "either", timeout=60)

    # --- Adaptive super-voxels.
    for extra, exp in [(["--cell-size", "3"], "refuse"), (["--cell-size", "16"], "refuse"),
                       (["--cell-size", "0"], "refuse"), (["--split-ratio", "0"], "refuse"),
                       (["--split-ratio", "1.5"], "refuse"), (["--split-occupancy", "nan"],
                                                             "refuse"),
                       (["--brick-size", "2", "--cell-size", "2"], "refuse"),
                       (["--cell-size", "4"], "ok")]:
        add("adaptive_" + "_".join(extra), render("--supervoxels", "adaptive", *extra), exp)
    add("cell_size_without_adaptive", render("--cell-size", "4"), "either")

    # --- Camera.
    add("camera_inside_volume", render("--camera", "0,0,0"), "ok")
    add("camera_at_1e30", render("--camera", "1e30,1e30,1e30"), "either")
    add("camera_at_3.4e38", render("--camera", "3.4e38,3.4e38,3.4e38"), "either")
    add("camera_nan", render("--camera", "nan,0,0"), "refuse")
    add("camera_inf", render("--camera", "inf,0,0"), "refuse")
    add("camera_two_values", render("--camera", "1,2"), "refuse")
    add("camera_four_values", render("--camera", "1,2,3,4"), "refuse")
    add("look_at_equals_camera", render("--camera", "0,0,-3", "--look-at", "0,0,-3"), "refuse")
    add("look_at_nearly_camera", render("--camera", "0,0,-3", "--look-at", "0,0,-3.0000001"),
        "either")
    add("camera_looking_along_up", render("--camera", "0,5,0", "--look-at", "0,0,0"), "either")
    add("look_at_nan", render("--look-at", "0,nan,0"), "refuse")
    add("fov_3e-6_render", render("--fov", "3e-6"), "ok", words=["warning"])
    add("fov_3e-6_eval", evaluate("--fov", "3e-6"), "refuse", words=["reference pixels"])
    add("fov_3e-6_eval_integrators", evaluate("--fov", "3e-6", "--integrators", "direct"),
        "refuse", words=["reference pixels"])
    add("eval_camera_looking_away", evaluate("--camera", "0,0,-3", "--look-at", "0,0,-10"),
        "refuse")
    add("eval_camera_at_1e30", evaluate("--camera", "1e30,1e30,1e30"), "refuse")

    # --- Lights and environments.
    add("light_3e38_path", render("--integrator", "path", "--light", "0,0,0,3e38"), "refuse")
    add("light_3e38_direct", direct("--light", "0,0,0,3e38"), "refuse")
    add("light_3e38_equiangular", render("--integrator", "equiangular", "--light",
        "0,0,0,3e38"), "either")
    add("light_nan", direct("--light", "nan,0,0,1"), "refuse")
    add("light_intensity_nan", direct("--light", "0,0,0,nan"), "refuse")
    add("light_three_values", direct("--light", "0,0,0"), "refuse")
    add("light_negative_intensity", direct("--light", "0,0,0,-1"), "refuse")
    add("light_zero_intensity", direct("--light", "0,0,0,0"), "either")
    add("light_at_1e30", direct("--light", "1e30,0,0,1"), "either")
    add("sun_zero_direction", direct("--sun", "0,0,0"), "refuse")
    add("sun_from_below", direct("--sun", "0,-1,0"), "either")
    add("sun_nan", direct("--sun", "nan,1,0"), "refuse")
    add("sun_negative_intensity", direct("--sun", "0,1,0,-1"), "refuse")
    add("sun_radius_90", direct("--sun", "0,1,0,1,90"), "either")
    add("sun_radius_negative", direct("--sun", "0,1,0,1,-1"), "refuse")
    add("sun_intensity_3e38", direct("--sun", "0,1,0,3e38"), "either")
    add("sun_subnormal_direction", direct("--sun", "1e-45,0,0"), "either")
    add("sun_six_values", direct("--sun", "0,1,0,1,1,1"), "refuse")
    for spec, exp in [("random:0", "either"), ("random:100000", "either"), ("random:-1", "refuse"),
                      ("random:abc", "refuse"), ("random:1,abc", "refuse"), ("random", "refuse"),
                      ("random:", "refuse"), ("random:4294967296", "refuse"),
                      ("random:10,18446744073709551616", "refuse"), ("uniform:3", "refuse")]:
        add(f"lights_{spec}", direct("--lights", spec), exp)
    add("lights_random_100000_restir", render("--integrator", "restir", "--lights",
        "random:100000"), "either")
    add("env_nonexistent_exr", direct("--env", "nonexistent.exr"), "refuse")
    add("env_text_as_exr", direct("--env", "t.exr"), "refuse",
        setup=lambda d: write(d, "t.exr", "not an image\n"))
    add("env_text_as_hdr", direct("--env", "t.hdr"), "refuse",
        setup=lambda d: write(d, "t.hdr", "not an image\n"))
    add("env_hdr_claims_100000x50000", direct("--env", "h.hdr"), "refuse",
        setup=hdr("h.hdr", 0, 0, dims="-Y 50000 +X 100000", body=bytes(16)))
    add("env_hdr_valid_4x2", direct("--env", "h.hdr"), "ok", setup=hdr("h.hdr", 4, 2))
    add("env_hdr_0x0", direct("--env", "h.hdr"), "refuse", setup=hdr("h.hdr", 0, 0))
    add("env_hdr_negative_dims", direct("--env", "h.hdr"), "refuse",
        setup=hdr("h.hdr", 0, 0, dims="-Y -5 +X 4", body=bytes(80)))
    add("env_hdr_bad_rle", direct("--env", "h.hdr"), "refuse", setup=hdr_bad_rle("h.hdr"))
    add("env_hdr_truncated_pixels", direct("--env", "h.hdr"), "refuse",
        setup=hdr("h.hdr", 4, 2, body=bytes(10)))
    add("env_hdr_max_exponent", direct("--env", "h.hdr"), "either",
        setup=hdr("h.hdr", 4, 2, texel=(255, 255, 255, 255)))
    add("env_fifo_hdr", direct("--env", "p.hdr"), "refuse", setup=fifo("p.hdr"), timeout=20)
    add("env_dev_zero_hdr", direct("--env", "z.hdr"), "refuse",
        setup=symlink("/dev/zero", "z.hdr"), timeout=60)
    add("env_directory_exr", direct("--env", "d.exr"), "refuse", setup=mkdir("d.exr"))
    add("env_rendered_exr", direct("--env", "e.exr"), "either", setup=rendered_exr("e.exr"))
    add("env_truncated_exr", direct("--env", "e.exr"), "refuse",
        setup=both(rendered_exr("full.exr"), lambda d: write(d, "e.exr", open(
            os.path.join(d, "full.exr"), "rb").read()[:200])))
    add("env_scale_1e38_sky", direct("--env-scale", "1e38"), "either")
    add("env_none_no_lights", direct("--env", "none"), "either")
    add("env_with_transmittance_render", render("--env", "sky"), "either")

    # --- Integrator options.
    for extra, exp in [(["--shadows", "msm4"], "ok"),  # the default sky has a sun
                       (["--shadows", "msm4", "--env", "none", "--light", "0,0,0,1"], "refuse"),
                       (["--shadows", "msm4", "--sun", "0,1,0"], "ok"),
                       (["--msm-res", "7", "--shadows", "msm4", "--sun", "0,1,0"], "refuse"),
                       (["--msm-filter", "box:0", "--shadows", "msm4", "--sun", "0,1,0"], "refuse"),
                       (["--msm-filter", "gauss:65", "--shadows", "msm4", "--sun", "0,1,0"],
                        "refuse"),
                       (["--msm-filter", "box", "--shadows", "msm4", "--sun", "0,1,0"], "refuse"),
                       (["--msm-filter", "box:abc", "--shadows", "msm4", "--sun", "0,1,0"],
                        "refuse"),
                       (["--msm-storage", "u16", "--shadows", "msm6", "--sun", "0,1,0"],
                        "refuse")]:
        add("direct_" + "_".join(extra), direct(*extra), exp)
    for extra, exp in [(["--max-depth", "0"], "refuse"), (["--rr-depth", "1025"], "refuse"),
                       (["--hg-g", "1"], "refuse"), (["--hg-g", "-0.9999999"], "either"),
                       (["--albedo", "1,1,1", "--hg-g", "0.999999"], "either"),
                       (["--albedo", "1.0000001"], "refuse")]:
        add("path_" + "_".join(extra), render("--integrator", "path", *extra), exp)
    for extra in [["--restir-candidates", "0"], ["--restir-candidates", "1025"],
                  ["--restir-floor", "0"], ["--restir-passes", "17"], ["--restir-radius", "0"],
                  ["--restir-neighbours", "65"], ["--restir-mis", "bogus"],
                  ["--restir-m-cap=-1"], ["--restir-n", "0"], ["--restir-target", "bogus"]]:
        add("restir_" + "_".join(extra), render("--integrator", "restir", *extra), "refuse")
    add("restir_reuse_ok", render("--integrator", "restir", "--restir-passes", "2"), "ok")

    # --- Outputs (render).
    vol_copy = copy(fix("density_zip.vdb"), "v.vdb")
    add("out_onto_volume", RENDER + ["--volume", "v.vdb", "-o", "v.vdb"], "refuse",
        setup=vol_copy, protect=["v.vdb"])
    add("json_onto_volume", RENDER + ["--volume", "v.vdb", "-o", "r.exr", "--json", "v.vdb"],
        "refuse", setup=vol_copy, protect=["v.vdb"])
    add("out_symlink_to_volume", RENDER + ["--volume", "v.vdb", "-o", "l.exr"], "refuse",
        setup=both(vol_copy, symlink("v.vdb", "l.exr")), protect=["v.vdb"])
    add("json_symlink_to_volume", RENDER + ["--volume", "v.vdb", "-o", "r.exr", "--json",
        "l.json"], "refuse", setup=both(vol_copy, symlink("v.vdb", "l.json")), protect=["v.vdb"])
    add("png_sidecar_symlink_to_volume", RENDER + ["--volume", "v.vdb", "-o", "r.exr"], "refuse",
        setup=both(vol_copy, symlink("v.vdb", "r.png")), protect=["v.vdb"])
    add("out_hardlink_to_volume", RENDER + ["--volume", "v.vdb", "-o", "h.exr"], "either",
        setup=both(vol_copy, hardlink("v.vdb", "h.exr")), protect=["v.vdb"])
    add("out_nonexistent_dir", render(out=False) + ["-o", "new/sub/r.exr"], "either")
    add("out_under_a_file", render(out=False) + ["-o", "f.txt/r.exr"], "refuse",
        setup=lambda d: write(d, "f.txt", "x"))
    add("out_is_directory", render(out=False) + ["-o", "d.exr"], "refuse", setup=mkdir("d.exr"))
    add("out_png_sidecar_is_directory", render(out=False) + ["-o", "r.exr"], "refuse",
        setup=mkdir("r.png"))
    add("out_not_exr", render(out=False) + ["-o", "r.png"], "refuse")
    add("out_empty", render(out=False) + ["-o", ""], "refuse")
    add("out_in_proc", render(out=False) + ["-o", "/proc/hostile.exr"], "refuse")
    add("out_dot_exr", render(out=False) + ["-o", ".exr"], "either")
    add("json_same_as_out", render(out=False) + ["-o", "r.exr", "--json", "r.exr"], "refuse")
    add("json_same_as_png", render(out=False) + ["-o", "r.exr", "--json", "r.png"], "refuse")
    add("json_is_directory", render(out=False) + ["-o", "r.exr", "--json", "jd"], "refuse",
        setup=mkdir("jd"))
    add("json_nonexistent_dir", render(out=False) + ["-o", "r.exr", "--json", "nd/r.json"],
        "either")
    add("existing_outputs_kept_on_failure", render("--width", "0"), "refuse",
        setup=lambda d: [write(d, f, "old") for f in ("r.exr", "r.png", "r.json")])

    # --- eval.
    add("eval_integrators_unknown", evaluate("--integrators", "bogus"), "refuse")
    add("eval_estimators_unknown", evaluate("--estimators", "bogus"), "refuse")
    add("eval_estimators_empty", evaluate("--estimators", ""), "refuse")
    add("eval_estimators_duplicate", evaluate("--estimators", "jackknife,jackknife"), "either")
    add("eval_estimators_trailing_comma", evaluate("--estimators", "jackknife,"), "either")
    add("eval_equal_time_without_integrators", evaluate("--equal-time"), "refuse")
    add("eval_hg_g_without_integrators", evaluate("--hg-g", "0.5"), "refuse")
    add("eval_integrators_direct_ok", evaluate("--integrators", "direct"), "ok",
        outputs=["ev/eval.json"])
    add("eval_integrators_direct_light_3e38", evaluate("--integrators", "direct", "--light",
        "0,0,0,3e38"), "refuse")
    add("eval_integrators_path_max_depth_0", evaluate("--integrators", "path", "--max-depth",
        "0"), "refuse")
    add("eval_spp_1", evaluate("--spp", "1"), "refuse")
    add("eval_out_dir_is_file", evaluate("--out-dir", "f.txt"), "refuse", setup=lambda d: write(d, "f.txt", "x"))
    add("eval_out_dir_empty", evaluate("--out-dir", ""), "refuse")
    add("eval_json_onto_volume", EVAL + ["--volume", "v.vdb", "--json", "v.vdb"], "refuse",
        setup=vol_copy, protect=["v.vdb"])
    add("eval_json_is_out_dir", evaluate("--json", "ev"), "refuse")
    add("eval_json_onto_reference_exr", evaluate("--json", "ev/reference.exr"), "refuse")
    add("eval_env_hdr_huge_claim", evaluate("--integrators", "direct", "--env", "h.hdr"),
        "refuse", setup=hdr("h.hdr", 0, 0, dims="-Y 50000 +X 100000", body=bytes(16)))
    add("eval_file_volume_ok", evaluate(vol=fix("density_zip.vdb")), "ok")
    add("eval_env_JK_GPU_MAX_BUFFER_BYTES_abc", evaluate(), "refuse",
        env={"JK_GPU_MAX_BUFFER_BYTES": "abc"}, words=["JK_GPU_MAX_BUFFER_BYTES"])

    # --- report.
    add("report_from_eval_nonexistent", report("--from-eval", "nope", emb=False), "refuse")
    add("report_from_eval_garbage_json", report("--from-eval", "g.json", emb=False), "refuse",
        setup=lambda d: write(d, "g.json", "{not json"))
    add("report_from_eval_empty_dir", report("--from-eval", "ed", emb=False), "refuse", setup=mkdir("ed"))
    add("report_from_eval_render_json", report("--from-eval", "r.json", emb=False), "refuse",
        setup=lambda d: subprocess.run([HOST] + render(), cwd=d, check=True, capture_output=True))
    add("report_from_eval_valid", report("--from-eval", "ev0", emb=False), "ok", setup=real_eval(),
        outputs=["rep/index.html"])
    add("report_from_eval_nan_numbers", report("--from-eval", "ev0", emb=False), "either",
        setup=real_eval(mutate=eval_json_nan))
    add("report_from_eval_images_deleted", report("--from-eval", "ev0", emb=False), "refuse",
        setup=real_eval(mutate=eval_drop_images))
    add("report_out_is_eval_dir", report("-o", "ev0", "--from-eval", "ev0", emb=False), "either",
        setup=real_eval(), protect=["ev0/eval.json"])
    add("report_resolution_only_files", report("--volumes", fix("density_zip.vdb"),
        "--resolution", "64", emb=False), "refuse")
    add("report_volumes_file_ok", report("--volumes", fix("density_zip.vdb"), emb=False), "ok")
    add("report_volumes_empty", report("--volumes", ""), "refuse")
    add("report_volumes_unknown", report("--volumes", "bogus"), "refuse")
    add("report_volumes_cloud_then_unknown", report("--volumes", "cloud,bogus"), "refuse")
    add("report_volumes_malformed", report("--volumes", mal("bad_magic.vdb"), emb=False), "refuse")
    add("report_integrators_unknown", report("--volumes", "cloud", "--integrators", "bogus"),
        "refuse")
    add("report_out_is_file", report("-o", "f.txt"), "refuse",
        setup=lambda d: write(d, "f.txt", "x"))
    add("report_bias_scale_0", report("--volumes", "cloud", "--bias-scale", "0"), "refuse")
    add("report_fov_nan", report("--volumes", "cloud", "--fov", "nan"), "refuse")

    # --- bench.
    add("bench_sweep_files_nonexistent", bench("--sweep-files", "nope.vdb"), "refuse",
        max_seconds=10, words=["nope.vdb"])
    add("bench_sweep_files_malformed", bench("--sweep-files", mal("bad_magic.vdb")), "refuse",
        max_seconds=10)
    add("bench_sweep_files_empty", bench("--sweep-files", ""), "refuse", max_seconds=10)
    add("bench_sweep_files_fifo", bench("--sweep-files", "p.vdb"), "refuse", setup=fifo("p.vdb"),
        timeout=20)
    add("bench_sweep_files_ok", bench("--sweep-files", fix("density_zip.vdb"),
        "--sweep-estimators", "jackknife"), "either")
    add("bench_sweep_small_ok", bench("--sweep", "--sweep-resolutions", "16", "--sweep-sizes",
        "8", "--sweep-estimators", "jackknife", "--plot", "p.png"), "ok")
    add("bench_sweep_resolutions_7", bench("--sweep", "--sweep-resolutions", "7"), "refuse")
    add("bench_sweep_sizes_0", bench("--sweep", "--sweep-sizes", "0"), "refuse")
    add("bench_sweep_sizes_empty", bench("--sweep", "--sweep-sizes", ""), "refuse")
    add("bench_sweep_estimators_bogus", bench("--sweep", "--sweep-estimators", "bogus"), "refuse")
    add("bench_plot_jpg", bench("--sweep", "--plot", "p.jpg"), "refuse")
    add("bench_estimators_bogus", bench("--estimators", "bogus"), "refuse")
    add("bench_reps_1001", bench("--reps", "1001"), "refuse")
    add("bench_warmup_101", bench("--warmup", "101"), "refuse")
    add("bench_json_onto_volume", bench("--json", "v.vdb", vol="v.vdb"),
        "refuse", setup=vol_copy, protect=["v.vdb"])
    add("bench_plot_symlink_to_sweep_file", bench("--sweep", "--sweep-resolutions", "16",
        "--sweep-sizes", "8", "--sweep-estimators", "jackknife", "--sweep-files", "v.vdb",
        "--plot", "p.png"), "refuse",
        setup=both(vol_copy, symlink("v.vdb", "p.png")), protect=["v.vdb"])

    # --- probe.
    for extra, exp in [(["--count", "67108865"], "refuse"), (["--count", "1e3"], "refuse"),
                       (["--tau", "21"], "refuse"), (["--tau", "inf"], "refuse"),
                       (["--sigma", "10.5"], "refuse"), (["--tau", "0", "--sigma", "10"], "ok"),
                       (["--tau", "20", "--sigma", "10"], "ok"), (["--count", "1"], "ok")]:
        add("probe_" + "_".join(extra), probe(*extra), exp)

    # --- studies.
    add("study_no_subcommand", ["study"], "refuse")
    for s_ in STUDY_SMALL:
        add(f"{s_}_plot_jpg", study(s_, "--plot", "s.jpg"), "refuse")
    add("study_unknown_subcommand", ["study", "bogus"], "refuse")
    add("normal_extreme_sigma10_tau0", study("normal", "--sigma", "10", "--tau", "0"), "ok")
    add("normal_extreme_sigma10_tau20", study("normal", "--sigma", "10", "--tau", "20"), "ok")
    add("normal_seed_max", study("normal", "--seed", "18446744073709551615"), "ok")
    add("distributions_exponential_left_sigma10", study("distributions", "--dist",
        "exponential-left", "--sigma-max", "10"), "either")
    add("distributions_dist_bogus", study("distributions", "--dist", "bogus"), "refuse")
    add("distributions_points_0", study("distributions", "--points", "0"), "refuse")
    for ns in ["", "0", "2,,5", "1000001", ",".join(["2"] * 17), "2;5", "-1", "1e3", "2,nan"]:
        add(f"histogram_n={ns[:20] or 'empty'}", study("histogram", f"--n={ns}"), "refuse")
    add("histogram_trials_2e7+1", study("histogram", "--trials", "20000001"), "refuse")
    add("histogram_bins_0", study("histogram", "--bins", "0"), "refuse")
    add("convergence_max_n_50_slope", study("convergence", "--max-n", "50"), "either")
    add("convergence_max_n_0", study("convergence", "--max-n", "0"), "refuse")
    add("convergence_points_1", study("convergence", "--points", "1"), "refuse")
    add("convergence_sampling_bogus", study("convergence", "--sampling", "bogus"), "refuse")
    add("table1_total_1", study("table1", "--total", "1"), "refuse")
    add("table1_total_1025", study("table1", "--total", "1025"), "refuse")
    add("table1_min_n_13", study("table1", "--min-n", "13"), "refuse")
    add("table1_min_n_0", study("table1", "--min-n", "0"), "refuse")
    add("profile_m_1", study("profile", "--m", "1"), "refuse")
    add("profile_m_65", study("profile", "--m", "65"), "refuse")
    add("profile_n_0", study("profile", "--n", "0"), "refuse")
    for g, exp in [("0,0,0,0", "refuse"), ("1,0,1,-1", "either"), ("nan,0,1,0", "refuse"),
                   ("1,2,3", "refuse"), ("1e7,0,1,0", "refuse"), ("1,0,-1,1", "either")]:
        add(f"mis_bias_g={g}", study("mis-bias", f"--g={g}"), exp)
    for flag, v in [("limit", "0"), ("nx", "0"), ("nx", "1025"), ("tau-max", "0"),
                    ("sigma-max", "nan")]:
        add(f"mis_bias_{flag}={v}", study("mis-bias", f"--{flag}={v}"), "refuse")

    # --- study --profile files.
    profiles = [
        ("nonexistent", None, "refuse"),
        ("empty", "", "refuse"),
        ("one_point", "0,1\n", "refuse"),
        ("header_only", "t,mu\n", "refuse"),
        ("t_not_increasing", "0,1\n1,2\n1,3\n", "refuse"),
        ("t_decreasing", "0,1\n-1,2\n", "refuse"),
        ("negative_mu", "0,1\n1,-2\n", "refuse"),
        ("nan", "0,1\n1,nan\n", "refuse"),
        ("inf_t", "0,1\ninf,2\n", "refuse"),
        ("overflow_1e308", "0,0\n1e308,1e308\n", "refuse"),
        ("three_columns", "0,1,2\n1,2,3\n", "refuse"),
        ("text_after_data", "0,1\n1,2\nfoo,bar\n", "refuse"),
        ("semicolons", "0;1\n1;2\n", "refuse"),
        ("constant", "0,1\n1,1\n2,1\n", "refuse"),  # table1: either (bias 0 is defined)
        ("all_zero", "0,0\n1,0\n", "refuse"),
        ("mu_1e150", "0,0\n1,1e150\n", "either"),
        ("subnormal_span", "0,1\n1e-320,2\n", "either"),
        ("span_1e300_mu_tiny", "0,1e-300\n1e300,2e-300\n", "either"),
        ("crlf_and_comments", "# c\r\nt,mu\r\n0,1\r\n1,2\r\n2,0.5\r\n", "ok"),
        ("valid", "0,0\n0.5,2\n1,0.5\n", "ok"),
    ]
    for sub in ["profile", "table1", "histogram", "convergence"]:
        for label, text, exp in profiles:
            if sub != "profile" and label not in ("empty", "overflow_1e308", "mu_1e150",
                                                  "subnormal_span", "constant", "valid"):
                continue
            setup = None if text is None else (lambda t: lambda d: write(d, "p.csv", t))(text)
            if sub == "table1" and label == "constant":
                exp = "either"
            add(f"{sub}_profile_{label}", study(sub, "--profile", "p.csv"), exp, setup=setup)
    add("profile_invalid_utf8", study("profile", "--profile", "p.csv"), "refuse",
        setup=lambda d: write(d, "p.csv", b"0,1\n1,\xff\xfe\n"))
    add("profile_directory", study("profile", "--profile", "pd"), "refuse", setup=mkdir("pd"))
    add("profile_fifo", study("profile", "--profile", "p.csv"), "refuse", setup=fifo("p.csv"),
        timeout=20)
    add("profile_dev_zero", study("profile", "--profile", "/dev/zero"), "refuse", timeout=30)
    add("profile_sparse_65MB", study("profile", "--profile", "p.csv"), "refuse",
        setup=sparse_file("p.csv", 65 << 20, b"0,1\n1,2\n"))
    add("profile_symlink_loop", study("profile", "--profile", "p.csv"), "refuse",
        setup=symlink("p.csv", "p.csv"))
    good = lambda d: write(d, "p.csv", "0,0\n0.5,2\n1,0.5\n")
    add("study_json_onto_profile", ["study", "profile", "--threads", "2", "-q", "--trials",
        "1000", "--profile", "p.csv", "--json", "p.csv", "--plot", "s.png"], "refuse",
        setup=good, protect=["p.csv"])
    add("study_plot_symlink_to_profile", ["study", "profile", "--threads", "2", "-q", "--trials",
        "1000", "--profile", "p.csv", "--plot", "l.png"], "refuse",
        setup=both(good, symlink("p.csv", "l.png")), protect=["p.csv"])
    add("study_json_is_directory", study("normal", "--json", "jd"), "refuse", setup=mkdir("jd"))

    # --- stdout closed by the reader (like `host ... | head -1` after the first line).
    for label, argv in [("render", render()), ("eval", evaluate()), ("bench", bench()),
                        ("probe", probe()), ("study_profile", study("profile"))]:
        add(f"stdout_closed_{label}", argv, "either", stdout_closed=True)

    # --- Environment variables.
    for v, exp in [("abc", "refuse"), ("0", "either"), ("-1", "refuse"), ("", "refuse"),
                   ("99999999999999999999999", "refuse"), ("\udcff", "refuse")]:
        label = v.encode("utf-8", "surrogateescape").hex() if v == "\udcff" else (v or "empty")
        words = ["JK_GPU_MAX_BUFFER_BYTES"] if exp == "refuse" else None
        add(f"env_JK_GPU_MAX_BUFFER_BYTES={label}", render(), exp,
            env={"JK_GPU_MAX_BUFFER_BYTES": v}, words=words)
    add("env_JK_GPU_MAX_BUFFER_BYTES=abc_bench", bench(), "refuse",
        env={"JK_GPU_MAX_BUFFER_BYTES": "abc"}, words=["JK_GPU_MAX_BUFFER_BYTES"])
    add("env_JK_LOG_bogus", render(), "ok", env={"JK_LOG": "bogus"})
    add("env_JK_LOG_trace", render(), "ok", env={"JK_LOG": "trace"})
    add("env_JK_VULKAN_DEVICE_bogus_cpu", render(), "either", env={"JK_VULKAN_DEVICE": "bogus"})

    # --- Trust round 3: outputs onto inputs through every path, devices and FIFOs as outputs,
    # checks before the work.
    toml = lambda name="s.toml": (lambda d: write(d, name, "spp = 2\nseed = 5\n"))
    add("eval_scene_summary_keeps_summary", evaluate("--scene", "r.json"), "either",
        setup=summary_json(), protect=["r.json"])
    add("bench_scene_summary_keeps_summary", bench("--scene", "r.json"), "either",
        setup=summary_json(), protect=["r.json"])
    add("eval_json_onto_scene", evaluate("--scene", "s.toml", "--json", "s.toml"), "refuse",
        setup=toml(), protect=["s.toml"], words=["would overwrite the input --scene"])
    add("bench_json_onto_scene", bench("--scene", "s.toml", "--json", "s.toml"), "refuse",
        setup=toml(), protect=["s.toml"], words=["would overwrite the input --scene"])
    add("write_scene_onto_volume", render("--volume", "v.vdb", "--write-scene", "v.vdb"),
        "refuse", setup=vol_copy, protect=["v.vdb"], words=["would overwrite the input --volume"])
    add("write_scene_symlink_to_volume", render("--volume", "v.vdb", "--write-scene", "l.toml"),
        "refuse", setup=both(vol_copy, symlink("v.vdb", "l.toml")), protect=["v.vdb"],
        words=["same file"])
    add("write_scene_onto_env", direct("--env", "p.hdr", "--write-scene", "p.hdr"), "refuse",
        setup=hdr("p.hdr", 4, 2), protect=["p.hdr"], words=["would overwrite the input --env"])
    add("write_scene_symlink_to_env", direct("--env", "p.hdr", "--write-scene", "l.toml"),
        "refuse", setup=both(hdr("p.hdr", 4, 2), symlink("p.hdr", "l.toml")),
        protect=["p.hdr"], words=["same file"])
    add("write_scene_inapplicable_flag", render("--hg-g", "0.5", "--write-scene", "w.toml"),
        "refuse", words=["--hg-g"])
    add("reference_shard_onto_volume", evaluate("--reference-shard", "v.vdb", vol="v.vdb"),
        "refuse", setup=vol_copy, protect=["v.vdb"], words=["would overwrite the input --volume"])
    add("reference_shard_onto_scene", evaluate("--scene", "s.toml", "--reference-shard",
        "s.toml"), "refuse", setup=toml(), protect=["s.toml"], words=["input --scene"])
    add("eval_json_onto_reference_from", evaluate("--reference-from", "ref.shard", "--json",
        "ref.shard"), "refuse", setup=ref_shard(), protect=["ref.shard"],
        words=["would overwrite the input --reference-from"])
    add("eval_json_symlink_to_reference_from", evaluate("--reference-from", "ref.shard",
        "--json", "l.json"), "refuse", setup=both(ref_shard(), symlink("ref.shard", "l.json")),
        protect=["ref.shard"], words=["same file"])
    add("merge_json_onto_shard", ["merge", "part.shard", "-q", "--json", "part.shard"], "refuse",
        setup=render_shard(), protect=["part.shard"], words=["would overwrite the input"])
    add("report_onto_eval_folder_file", report("--from-eval", "ev0", "--out", "ev0/.."),
        "either", setup=real_eval(), protect=["ev0/eval.json"])
    for flag, name in [("--json", "o.json"), ("-o", "o.exr"), ("--write-scene", "o.toml"),
                       ("--shard", "o.shard")]:
        argv = {"-o": render(out=False) + ["-o", name],
                "--shard": render(out=False) + ["--shard", name]}.get(flag, render(flag, name))
        add(f"fifo_output_{flag.strip('-')}", argv, "refuse", setup=fifo(name), timeout=20,
            words=["FIFO"])
        add(f"chardev_output_{flag.strip('-')}", argv, "either", setup=mknod_null(name),
            protect=[name])
    add("fifo_output_study_json", study("profile", "--json", "o.json"), "refuse",
        setup=fifo("o.json"), timeout=20, words=["FIFO"])
    add("fifo_output_bench_json", bench("--json", "o.json"), "refuse", setup=fifo("o.json"),
        timeout=20, words=["FIFO"])
    add("fifo_output_eval_json", evaluate("--json", "o.json"), "refuse", setup=fifo("o.json"),
        timeout=20, words=["FIFO"])
    add("output_name_245_bytes", render("--json", "n" * 245 + ".json"), "ok")
    add("output_name_260_bytes", render("--json", "n" * 260 + ".json"), "refuse",
        words=["255"], max_seconds=10)
    add("layers_twice", render("--layers", "samples,samples"), "refuse",
        words=["--layers", "twice"], max_seconds=10)
    add("scene_from_proc", render("--scene", "/proc/self/maps"), "refuse",
        words=["/proc/self/maps"])
    add("scene_positional_after_flags", RENDER + vol_args(None) + ["-o", "r.exr", "s.toml"],
        "ok", setup=toml(), outputs=["r.exr"])
    add("shard_of_a_summary_scene", ["render", "r.json", "--shard", "x.shard", "-q"], "ok",
        setup=summary_json(), outputs=["x.shard"], protect=["r.json"])
    # Shards that lie: forged headers (with a correct header hash), edited or cut files, and a
    # changed volume file behind them.
    shard_set = lambda *more: both(vol_copy, lambda d: subprocess.run(
        [HOST, "render", "--backend", "cpu", "--width", "8", "--height", "4", "--spp", "1", "-q",
         "--volume", "v.vdb", "--shard", "part.shard"], cwd=d, check=True, capture_output=True),
        *more)
    merge_argv = ["merge", "part.shard", "-q", "-o", "m.exr"]

    def setkey(k, v):
        return lambda h: h.__setitem__(k, v)
    for label, edit in [("no_images", setkey("images", [])),
                        ("huge_image", lambda h: h.update(width=100000, height=100000)),
                        ("samples_past_spp", setkey("samples", [0, 9])),
                        ("zero_spp", setkey("spp", 0)),
                        ("unknown_kind", setkey("kind", "bogus")),
                        ("payload_bytes_huge", setkey("payload_bytes", 1 << 62))]:
        add(f"shard_forged_{label}", merge_argv, "refuse",
            setup=shard_set(forged_shard("part.shard", edit)), protect=["part.shard"],
            max_seconds=10)
    add("shard_header_edited_unhashed", merge_argv, "refuse",
        setup=shard_set(forged_shard("part.shard", setkey("seed_note", 1), rehash=False)),
        words=["changed or damaged"])
    add("shard_cut_short", merge_argv, "refuse", setup=shard_set(cut_file("part.shard", 300)))
    add("shard_volume_changed", merge_argv, "refuse",
        setup=shard_set(lambda d: open(os.path.join(d, "v.vdb"), "ab").write(b"\0")),
        words=["v.vdb"])
    add("shard_volume_missing", merge_argv, "refuse",
        setup=shard_set(lambda d: os.remove(os.path.join(d, "v.vdb"))), words=["v.vdb"])
    return C


# ------------------------------------------------------------------------------------------------
# The runner.


def snapshot(d):
    """{relative path: (kind, digest)} of everything under d, not following symlinks and never
    opening a FIFO; large files by size and mtime."""
    snap = {}
    for top, dirs, files in os.walk(d, followlinks=False):
        for name in dirs + files:
            p = os.path.join(top, name)
            rel = os.path.relpath(p, d)
            st = os.lstat(p)
            if os.path.islink(p):
                snap[rel] = ("link", os.readlink(p))
            elif os.path.isdir(p):
                snap[rel] = ("dir", None)
            elif not os.path.isfile(p):
                snap[rel] = ("special", None)
            elif st.st_size > 64 << 20:
                snap[rel] = ("file", (st.st_size, st.st_mtime_ns))
            else:
                with open(p, "rb") as f:
                    snap[rel] = ("file", hashlib.sha256(f.read()).hexdigest())
    return snap


def run_case(c, scratch, index):
    d = os.path.join(scratch, f"{index:03d}_{re.sub(r'[^A-Za-z0-9_.=-]', '_', c['name'])[:60]}")
    os.makedirs(d)
    if c.get("setup"):
        c["setup"](d)
    before = snapshot(d)
    env = dict(os.environ)
    env.pop("RUST_BACKTRACE", None)
    env.update(c.get("env") or {})
    vmem = c.get("vmem", VMEM)
    cmd = ["sh", "-c", f'ulimit -v {vmem} && exec "$0" "$@"', HOST] + list(c["argv"])
    timeout = c.get("timeout", TIMEOUT)
    t0 = time.monotonic()
    stdout = subprocess.PIPE
    if c.get("stdout_closed"):  # a pipe whose read end is already closed: writes fail (EPIPE)
        read_end, stdout = os.pipe()
        os.close(read_end)
    proc = subprocess.Popen(cmd, cwd=d, env=env, stdin=subprocess.DEVNULL, stdout=stdout,
                            stderr=subprocess.PIPE, start_new_session=True)
    if c.get("stdout_closed"):
        os.close(stdout)
    try:
        out, err = proc.communicate(timeout=timeout)
        timed_out = False
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        timed_out = True
    seconds = time.monotonic() - t0
    after = snapshot(d)
    return dict(dir=d, rc=proc.returncode, stdout=(out or b"").decode("utf-8", "replace"),
                stderr=err.decode("utf-8", "replace"), seconds=seconds, timed_out=timed_out,
                before=before, after=after)


# ------------------------------------------------------------------------------------------------
# The classifier.

NONFINITE_WORD = re.compile(r"(?<![\w/.-])(-?inf(inity)?|nan)(?![\w/-])", re.IGNORECASE)
STAT_KEY = re.compile(r"^(mean.*|bias|std|rmse|abs_bias|.*_mean)$")


def json_problems(path):
    """Non-finite numbers in a JSON file: NaN/Infinity tokens, or null under a statistic's key."""
    problems = []

    def constant(tok):
        problems.append(f"{tok} token")
        return 0.0

    try:
        data = json.load(open(path), parse_constant=constant)
    except (ValueError, UnicodeDecodeError) as e:
        return [f"unparsable JSON ({e})"]

    def walk(v, key):
        if isinstance(v, dict):
            for k, x in v.items():
                walk(x, k)
        elif isinstance(v, list):
            for x in v:
                walk(x, key)
        elif v is None and key and STAT_KEY.match(key):
            problems.append(f"null {key}")
        elif isinstance(v, float) and v != v:
            problems.append(f"NaN {key}")

    walk(data, None)
    return sorted(set(problems))


def clean_refusal(stderr):
    """stderr starts with "error:", possibly after "warning:" lines (and their continuations)."""
    if stderr.startswith("error:"):
        return True
    lines = stderr.splitlines()
    for i, line in enumerate(lines):
        if line.startswith("error:"):
            return all(l.startswith("warning:") or l.startswith(" ") or not l.strip()
                       for l in lines[:i]) and lines[0].startswith("warning:")
    return False


SIGNALS = {-6: "SIGABRT", -9: "SIGKILL (OOM?)", -11: "SIGSEGV", -7: "SIGBUS", -4: "SIGILL",
           -8: "SIGFPE", 134: "abort (134)", 137: "killed (137)", 139: "segfault (139)",
           101: "panic (101)"}


def classify(c, r):
    """(outcome, reason)."""
    rc, err, expect = r["rc"], r["stderr"], c["expect"]
    before, after = r["before"], r["after"]
    changed = sorted(p for p in after if before.get(p) != after[p] and after[p][0] != "dir")
    new_dirs = sorted(p for p in after if p not in before and after[p][0] == "dir")
    protect = [p for p in c.get("protect", []) if before.get(p) != after.get(p)]
    if r["timed_out"]:
        return "BAD", f"hang: killed after {c.get('timeout', TIMEOUT)} s"
    if "panicked" in err:
        return "BAD", "panic"
    if c.get("stdout_closed") and rc in (-13, 141):
        return "OK_RENDERED", "ended by SIGPIPE (as `yes | head` does)"
    if rc in SIGNALS or rc < 0:
        return "BAD", SIGNALS.get(rc, f"signal {-rc}")
    if "memory allocation of" in err:
        return "BAD", "allocation failure"
    if protect:
        return "BAD", "protected file changed: " + ", ".join(protect)
    if rc == 0:
        if expect == "refuse":
            return "BAD", "accepted a bad input (exit 0)"
        problems = []
        stdout = re.sub(r"<=\s*inf\b", "", r["stdout"])  # mis-bias's row label "sigma <= inf"
        for m in NONFINITE_WORD.finditer(stdout):
            problems.append(f"stdout prints {m.group(0)!r}")
        for p in changed:
            if p.endswith(".json"):
                problems += [f"{p}: {q}" for q in json_problems(os.path.join(r["dir"], p))]
        missing = [p for p in c.get("outputs", []) if p not in after]
        if missing:
            problems.append("missing outputs: " + ", ".join(missing))
        missing_words = [w for w in c.get("words") or [] if w not in err]
        if missing_words:
            problems.append("stderr lacks " + ", ".join(repr(w) for w in missing_words))
        if problems:
            return "BAD", "; ".join(sorted(set(problems)))
        return "OK_RENDERED", ""
    if rc == 1 and clean_refusal(err):
        if changed and not c.get("stdout_closed"):  # there, outputs may precede the summary
            return "BAD", "failed run wrote/changed: " + ", ".join(changed)
        if c.get("max_seconds") and r["seconds"] > c["max_seconds"]:
            return "BAD", f"refusal took {r['seconds']:.1f} s (> {c['max_seconds']} s)"
        missing_words = [w for w in c.get("words") or [] if w not in err]
        if missing_words:
            return "BAD", "stderr lacks " + ", ".join(repr(w) for w in missing_words)
        note = ("left empty directories: " + ", ".join(new_dirs)) if new_dirs else ""
        if expect == "ok":
            return "REFUSED_VALID", note
        return "OK_REFUSED", note
    if rc == 1:
        return "BAD", "exit 1 without a clean 'error:' message"
    return "BAD", f"exit code {rc}"


# ------------------------------------------------------------------------------------------------
# Report.


def shell_words(argv):
    return " ".join(shlex.quote(a if isinstance(a, str) else os.fsdecode(a)) for a in argv)


def first_line(text):
    for line in text.splitlines():
        if line.strip():
            return line.strip()
    return ""


def machine():
    mem = "?"
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal:"):
                mem = f"{int(line.split()[1]) / 1024 / 1024:.1f} GiB"
    except OSError:
        pass
    return f"{os.cpu_count()} CPUs (nproc {subprocess.run(['nproc'], capture_output=True, text=True).stdout.strip()}), {mem} memory"


def main():
    global HOST
    args = sys.argv[1:]
    md = os.path.join(ROOT, "docs", "results", "hostile_corpus.md")
    if "--md" in args:
        i = args.index("--md")
        md = args[i + 1]
        del args[i:i + 2]
    HOST = os.path.abspath(args[0] if args else os.path.join(ROOT, "target", "release", "host"))
    scratch = os.path.abspath(args[1]) if len(args) > 1 else tempfile.mkdtemp(prefix="hostile_")
    os.makedirs(scratch, exist_ok=True)
    if not os.access(HOST, os.X_OK):
        sys.exit(f"no executable at {HOST}")
    table = cases()
    names = [c["name"] for c in table]
    assert len(names) == len(set(names)), "duplicate case names"
    print(f"{len(table)} cases, binary {HOST}, scratch {scratch}", flush=True)
    rows = []
    t_start = time.monotonic()
    for i, c in enumerate(table):
        try:
            r = run_case(c, scratch, i)
            outcome, reason = classify(c, r)
        except Exception as e:  # a setup that failed: report it, do not stop the corpus
            r = dict(rc=None, stdout="", stderr=f"(setup failed: {e!r})", seconds=0.0)
            outcome, reason = "SETUP_FAILED", repr(e)
        rows.append((c, r, outcome, reason))
        print(f"[{i + 1:3d}/{len(table)}] {outcome:13s} rc={r['rc']!s:>4} {r['seconds']:6.2f}s "
              f"{c['name']}  {reason}", flush=True)
    total = time.monotonic() - t_start

    counts = {}
    for _, _, outcome, _ in rows:
        counts[outcome] = counts.get(outcome, 0) + 1
    print()
    print(f"{'case':50s} {'expect':7s} {'outcome':13s} {'rc':>4s} {'s':>6s}  stderr")
    for c, r, outcome, reason in rows:
        print(f"{c['name'][:50]:50s} {c['expect']:7s} {outcome:13s} {r['rc']!s:>4s} "
              f"{r['seconds']:6.2f}  {first_line(r['stderr'])[:110]}")
    print()
    for k in sorted(counts):
        print(f"{k}: {counts[k]}")
    print(f"total: {len(rows)} cases in {total:.0f} s")

    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                           capture_output=True, text=True).stdout.strip()
    cell = lambda s: s.replace("|", "\\|").replace("\n", " ").replace("`", "'")
    lines = [
        "# Hostile-input corpus",
        "",
        f"- Date: {datetime.datetime.now().strftime('%Y-%m-%d %H:%M')}",
        f"- Commit: `{commit}`" + (" (with uncommitted changes to tracked files)" if dirty else ""),
        f"- Binary: `{os.path.relpath(HOST, ROOT) if HOST.startswith(ROOT) else HOST}` (built "
        f"{datetime.datetime.fromtimestamp(os.path.getmtime(HOST)).strftime('%Y-%m-%d %H:%M:%S')})",
        f"- Machine: {machine()}",
        f"- Limits per run: `ulimit -v {VMEM}` KiB (unless noted), {TIMEOUT} s wall clock "
        "(unless noted), `--backend cpu`",
        f"- Command: `/usr/bin/python3 {shell_words(sys.argv)}`",
        f"- {len(rows)} cases in {total:.0f} s",
        "",
        "Outcomes: OK_REFUSED (exit 1, a clean `error:`), OK_RENDERED (exit 0 where valid), "
        "REFUSED_VALID (a clean refusal of a case marked ok), BAD (crash, hang, accepted bad "
        "input, non-finite output, output written by a failed run, ...). Expectation `either`: "
        "a clean refusal and a clean success are both fine. See `scripts/hostile_corpus.py`.",
        "",
        "| Outcome | Cases |",
        "|---|---|",
    ] + [f"| {k} | {counts[k]} |" for k in sorted(counts)] + [""]
    bad = [(c, r, o, why) for c, r, o, why in rows if o not in ("OK_REFUSED", "OK_RENDERED")]
    if bad:
        lines += ["## Cases to look at", ""]
        for c, r, o, why in bad:
            tail = "\n".join(r["stderr"].rstrip().splitlines()[-6:])
            lines += [f"### {c['name']} ({o})", "",
                      f"- argv: `host {cell(shell_words(c['argv']))}`",
                      f"- expect: {c['expect']}; exit {r['rc']}; {r['seconds']:.2f} s; {why}",
                      "", "```", tail or "(empty stderr)", "```", ""]
    lines += ["## All cases", "",
              "| Case | Expect | Outcome | Exit | s | First line of stderr | Note |",
              "|---|---|---|---|---|---|---|"]
    for c, r, outcome, reason in rows:
        lines.append(f"| {cell(c['name'])} | {c['expect']} | {outcome} | {r['rc']} | "
                     f"{r['seconds']:.2f} | {cell(first_line(r['stderr'])[:160])} | "
                     f"{cell(reason)} |")
    os.makedirs(os.path.dirname(os.path.abspath(md)), exist_ok=True)
    with open(md, "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {md}")


if __name__ == "__main__":
    main()
