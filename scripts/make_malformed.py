#!/usr/bin/python3
"""Writes tests/fixtures/malformed/: broken, hostile and unsupported volume files, each listed in
tests/fixtures/malformed/EXPECTED with the words its load error must contain.

Most files are valid fixtures (tests/fixtures, written by OpenVDB itself) with one field patched,
located by parsing the header the way the format defines it; the bad-density files are written
by OpenVDB's Python binding (Debian: python3-openvdb) and converted by nanovdb_convert
(libnanovdb-tools). Inputs found by fuzzing (fuzz/README.md) are added by hand as fuzz_*.
Run with Debian's /usr/bin/python3: ./scripts/make_malformed.py
"""
import math
import os
import shutil
import struct
import subprocess
import sys

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
FIX = os.path.join(ROOT, "tests", "fixtures")
OUT = os.path.join(FIX, "malformed")

# name -> (grid or "-", [substrings of the error])
EXPECTED = {}


def fixture(name):
    with open(os.path.join(FIX, name), "rb") as f:
        return bytearray(f.read())


def write(name, data, grid, *words):
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(data)
    EXPECTED[name] = (grid, list(words))


class Vdb:
    """Offsets of the fields of a .vdb file's header, first descriptor and first grid."""

    def __init__(self, data):
        self.data = data
        p = 8 + 4 + 8 + 1 + 36  # magic, version, library version, offset flag, uuid
        p = self._skip_metadata(p)
        self.grid_count_at = p
        p += 4
        self.name_len_at = p
        p = self._string(p)  # unique name
        self.type_at = p
        p = self._string(p)  # tree type
        p = self._string(p)  # instance parent
        self.grid_pos_at = p
        self.grid_pos = struct.unpack_from("<Q", data, p)[0]
        g = self.grid_pos
        self.compression_at = g
        g = self._skip_metadata(g + 4)
        self.transform_name_at = g
        n = struct.unpack_from("<I", data, g)[0]
        self.transform_name = bytes(data[g + 4:g + 4 + n]).decode()
        self.transform_params_at = g + 4 + n

    def _string(self, p):
        n = struct.unpack_from("<I", self.data, p)[0]
        return p + 4 + n

    def _skip_metadata(self, p):
        count = struct.unpack_from("<I", self.data, p)[0]
        p += 4
        for _ in range(count):
            p = self._string(p)
            p = self._string(p)
            size = struct.unpack_from("<I", self.data, p)[0]
            p += 4 + size
        return p


def vdb_files():
    base = fixture("density_zip.vdb")
    v = Vdb(base)
    assert v.transform_name == "UniformScaleMap", v.transform_name

    write("empty_file.vdb", b"", "-", "empty_file.vdb", "not an OpenVDB file", "too short")
    write("truncated_header.vdb", base[:30], "-", "truncated")
    write("truncated_leaves.vdb", base[: len(base) * 3 // 4], "-", "truncated")
    d = bytearray(base)
    d[0:4] = b"GIF8"
    write("bad_magic.vdb", d, "-", "not an OpenVDB file")
    d = bytearray(base)
    struct.pack_into("<I", d, 8, 200)
    write("old_version.vdb", d, "-", "older than", "re-save")
    d = bytearray(base)
    struct.pack_into("<I", d, v.grid_count_at, 0xFFFFFFFF)
    write("huge_grid_count.vdb", d, "-", "grid descriptor 1 of 4294967295", "truncated")
    d = bytearray(base)
    struct.pack_into("<I", d, v.name_len_at, 0x7FFFFFFF)
    write("huge_name_length.vdb", d, "-", "truncated")
    d = bytearray(base)
    struct.pack_into("<Q", d, v.grid_pos_at, 1 << 62)
    write("grid_offset_past_end.vdb", d, "-", "past the end of the file")
    d = bytearray(base)
    struct.pack_into("<I", d, v.compression_at, 0x100)
    write("bad_compression_flags.vdb", d, "-", "unknown compression flags")
    # UniformScaleMap: the scale (3 doubles), then four derived vectors.
    d = bytearray(base)
    struct.pack_into("<d", d, v.transform_params_at, math.nan)
    write("nan_transform.vdb", d, "-", "transform", "non-finite")
    d = bytearray(base)
    struct.pack_into("<d", d, v.transform_params_at + 16, 0.0)
    write("zero_scale_transform.vdb", d, "-", "transform", "singular")
    d = bytearray(base)
    d[v.transform_name_at + 4] = ord("X")
    write("nonlinear_transform.vdb", d, "-", "XniformScaleMap", "not linear")
    d = bytearray(base)
    type_len = struct.unpack_from("<I", d, v.type_at)[0]
    assert bytes(d[v.type_at + 4:v.type_at + 4 + type_len]) == b"Tree_float_5_4_3"
    d[v.type_at + 4:v.type_at + 4 + type_len] = b"Tree_int32_5_4_3"
    write("relabelled_int_grid.vdb", d, "-", "int32", "not scalar floats")

    for src, grid, words in [
        ("vec3.vdb", "-", ["velocity (vec3s)", "no float grid"]),
        ("int.vdb", "-", ["int32", "not scalar floats"]),
        ("empty.vdb", "-", ["no active voxels"]),
        ("wide.vdb", "-", ["more than 2^31 along an axis", "crop the volume"]),
        ("multi.vdb", "smoke", ["no grid named 'smoke'", "available grids"]),
    ]:
        write("unsupported_" + src, fixture(src), grid, *words)


def nvdb_files():
    base = fixture("density.nvdb")
    codec = struct.unpack_from("<H", base, 14)[0]
    assert codec == 1, "density.nvdb is expected to be ZIP-compressed"
    meta = 16
    name_size = struct.unpack_from("<I", base, meta + 136)[0]
    size_at = meta + 176 + name_size  # u64 compressed size, then the zlib stream

    write("empty_file.nvdb", b"", "-", "empty_file.nvdb", "empty")
    write("truncated_header.nvdb", base[:100], "-", "truncated")
    write("truncated_grid.nvdb", base[: len(base) // 2], "-", "truncated")
    d = bytearray(base)
    d[0:4] = b"GIF8"
    write("bad_magic.nvdb", d, "-", "not a NanoVDB file")
    d = bytearray(base)
    struct.pack_into("<H", d, 12, 0)
    write("zero_grids.nvdb", d, "-", "lists no grids")
    d = bytearray(base)
    struct.pack_into("<H", d, 12, 0xFFFF)
    write("huge_grid_count.nvdb", d, "-", "truncated")
    d = bytearray(base)
    struct.pack_into("<I", d, meta + 136, 0xFFFFFFFF)
    write("huge_name_length.nvdb", d, "-", "truncated", "grid name")
    d = bytearray(base)
    struct.pack_into("<Q", d, meta, 1 << 50)
    write("zip_bomb_claim.nvdb", d, "-", "more than zlib can produce")
    d = bytearray(base)
    struct.pack_into("<Q", d, size_at, (1 << 64) - 16)
    write("huge_compressed_size.nvdb", d, "-", "truncated")
    d = bytearray(base)
    struct.pack_into("<H", d, 14, 0)
    write("uncompressed_past_end.nvdb", d, "-", "truncated", "a grid at byte")
    d = bytearray(base)
    struct.pack_into("<Q", d, meta, struct.unpack_from("<Q", base, meta)[0] + 8)
    write("wrong_decompressed_size.nvdb", d, "-", "decompress")
    for src, grid, words in [
        ("density_blosc.nvdb", "-", ["Blosc", "re-convert"]),
        ("vec3.nvdb", "velocity", ["Vec3f", "not scalar floats"]),
        ("int.nvdb", "-", ["Int32", "not scalar floats"]),
        ("multi.nvdb", "smoke", ["no grid named 'smoke'", "available grids"]),
    ]:
        write("unsupported_" + src, fixture(src), grid, *words)


def bad_density_files():
    import pyopenvdb as vdb

    for name, value, words in [
        ("nan_density", math.nan, ["has density NaN", "(3, 4, 5)"]),
        ("inf_density", math.inf, ["has density inf", "(3, 4, 5)"]),
        ("negative_density", -0.5, ["has density -0.5", "(3, 4, 5)", "--clamp-negative"]),
    ]:
        g = vdb.FloatGrid()
        g.name = "density"
        acc = g.getAccessor()
        for ijk in [(0, 0, 0), (7, 7, 7)]:
            acc.setValueOn(ijk, 1.0)
        acc.setValueOn((3, 4, 5), value)
        path = os.path.join(OUT, name + ".vdb")
        vdb.write(path, grids=[g])
        EXPECTED[name + ".vdb"] = ("-", words)
        nvdb = os.path.join(OUT, name + ".nvdb")
        subprocess.run(["nanovdb_convert", "-f", "-z", path, nvdb], check=True,
                       stdout=subprocess.DEVNULL)
        EXPECTED[name + ".nvdb"] = ("-", words)


def grid_class_files():
    """A level set (signed distances) and an instanced grid: valid files the loader must refuse
    with advice of their own (not --clamp-negative, not "corrupt")."""
    import pyopenvdb as vdb

    ls = vdb.createLevelSetSphere(radius=2.0, center=(0, 0, 0), voxelSize=1.0, halfWidth=1.5)
    ls.name = "density"
    path = os.path.join(OUT, "level_set.vdb")
    vdb.write(path, grids=[ls])
    EXPECTED["level_set.vdb"] = ("-", ["'density' is a level set", "fog volume"])
    nvdb = os.path.join(OUT, "level_set.nvdb")
    subprocess.run(["nanovdb_convert", "-f", "-z", path, nvdb], check=True,
                   stdout=subprocess.DEVNULL)
    EXPECTED["level_set.nvdb"] = ("-", ["'density' is a level set", "fog volume"])
    fog = vdb.FloatGrid()
    fog.name = "density"
    acc = fog.getAccessor()
    for ijk in [(0, 0, 0), (7, 7, 7)]:
        acc.setValueOn(ijk, 1.0)
    instance = fog.copy()  # shares the tree: written as an instance of "density"
    instance.name = "copy"
    vdb.write(os.path.join(OUT, "instance.vdb"), grids=[fog, instance])
    EXPECTED["instance.vdb"] = ("copy", ["instance of grid 'density'", "--grid density"])
    duplicate_names()


def duplicate_names():
    """Two grids both named "density" (OpenVDB keeps both, with a hidden counter): refused
    unless one is picked as density[k], never the first one silently."""
    import pyopenvdb as vdb

    grids = []
    for k, ijk in enumerate([(0, 0, 0), (3, 3, 3)]):
        g = vdb.FloatGrid()
        g.name = "density"
        g.getAccessor().setValueOn(ijk, 1.0 + k)
        grids.append(g)
    path = os.path.join(OUT, "duplicate_names.vdb")
    vdb.write(path, grids=grids)
    words = ["2 grids are named 'density'", "--grid density[0] or --grid density[1]"]
    EXPECTED["duplicate_names.vdb"] = ("-", words)
    nvdb = os.path.join(OUT, "duplicate_names.nvdb")
    subprocess.run(["nanovdb_convert", "-f", "-z", path, nvdb], check=True,
                   stdout=subprocess.DEVNULL)
    EXPECTED["duplicate_names.nvdb"] = ("-", words)


def main():
    os.makedirs(OUT, exist_ok=True)
    keep = {f for f in os.listdir(OUT) if f.startswith("fuzz_")}
    previous = {}
    manifest = os.path.join(OUT, "EXPECTED")
    if os.path.exists(manifest):
        for line in open(manifest):
            if line.startswith("fuzz_"):
                name, rest = line.split("\t", 1)
                previous[name] = rest
    for f in os.listdir(OUT):
        if f not in keep and f != "EXPECTED":
            os.remove(os.path.join(OUT, f))
    vdb_files()
    nvdb_files()
    bad_density_files()
    grid_class_files()
    write("wrong_extension.txt", b"density", "-", "unknown volume file extension", ".vdb")
    with open(manifest, "w") as f:
        f.write("# file\tgrid (- = default)\twords the error must contain, separated by ' | '\n")
        for name in sorted(EXPECTED):
            grid, words = EXPECTED[name]
            f.write(f"{name}\t{grid}\t{' | '.join(words)}\n")
        for name in sorted(previous):
            f.write(f"{name}\t{previous[name]}")
    print(f"wrote {len(EXPECTED)} files (+ {len(keep)} fuzz inputs) to {OUT}")


if __name__ == "__main__":
    sys.exit(main())
