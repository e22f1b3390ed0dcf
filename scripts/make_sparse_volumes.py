#!/usr/bin/python3
"""Sparse OpenVDB volumes written by OpenVDB itself (Debian's python3-openvdb), for the sparse
loader's tests and benchmarks. Run with Debian's /usr/bin/python3.

  make_sparse_volumes.py fixture OUT.vdb     small, checked in as tests/fixtures/sparse_patches.vdb:
                                             patches of leaves far apart, a tile, negative and
                                             unaligned coordinates, half-float storage
  make_sparse_volumes.py disney OUT.vdb      bbox 993x675x1224, 15 % of its 16^3 blocks occupied in
                                             cloud-like clusters, half-float (Blosc), ~120 M voxels
  make_sparse_volumes.py two OUT.vdb         two active voxels at opposite corners of a 1000^3 box
  make_sparse_volumes.py line OUT.vdb        two active voxels 10^6 voxels apart along x, checked
                                             in as tests/fixtures/two_far.vdb
  make_sparse_volumes.py corners OUT.vdb     two active voxels at the corners of a 20001^3 box of
                                             voxels 5e25 wide, tests/fixtures/two_corners.vdb
  make_sparse_volumes.py wide OUT.vdb        two active voxels 2^32 - 1 apart along x (longer than
                                             the loaders take), checked in as tests/fixtures/wide.vdb
  make_sparse_volumes.py series DIR          the sparse series of `host bench --sweep-files`: bboxes
                                             256^3 and 1/2, 3/4, 1 x the Disney bbox, each with 15 %
                                             of its 16^3 blocks occupied: DIR/sparse_{256,half,
                                             three_quarters,disney}.vdb

Deterministic: numpy's generator with a fixed seed.
"""
import sys

import numpy as np
import pyopenvdb as vdb


def blur(a, passes=3):
    """A smooth random field: repeated 3-tap box filters along each axis (wrapping)."""
    for _ in range(passes):
        for axis in range(3):
            a = (np.roll(a, 1, axis) + a + np.roll(a, -1, axis)) / 3.0
    return a


def grid(name="density"):
    g = vdb.FloatGrid()
    g.name = name
    g.gridClass = vdb.GridClass.FOG_VOLUME
    g.transform = vdb.createLinearTransform(voxelSize=0.05)
    return g


def fixture(out):
    rng = np.random.default_rng(15)
    g = grid()
    # Patches of active voxels whose corners lie off the 8-voxel lattice, some negative.
    for corner, shape in [((-21, 3, -9), (13, 9, 20)), ((37, -14, 5), (6, 30, 7)), ((90, 70, 60), (5, 5, 5))]:
        values = rng.uniform(0.0, 2.0, size=shape).astype(np.float32)
        values[values < 0.4] = 0.0  # some zero-valued active voxels
        g.copyFromArray(values, ijk=corner, tolerance=-1.0)
    # A constant active tile (a lower node's 8^3 tile) and a few single voxels.
    g.fill((64, 0, 8), (71, 7, 15), 0.75, active=True)
    acc = g.getAccessor()
    for ijk, v in [((-30, 80, 61), 3.5), ((100, -20, -17), 1e-3), ((5, 5, 5), 0.0)]:
        acc.setValueOn(ijk, v)
    g.saveFloatAsHalf = True
    vdb.write(out, grids=[g])


DISNEY = (993, 675, 1224)


def disney(out):
    clustered(out, DISNEY)


def series(directory):
    import os
    os.makedirs(directory, exist_ok=True)
    for name, dims in [("256", (256, 256, 256)),
                       ("half", tuple(d // 2 for d in DISNEY)),
                       ("three_quarters", tuple(3 * d // 4 for d in DISNEY)),
                       ("disney", DISNEY)]:
        clustered(os.path.join(directory, f"sparse_{name}.vdb"), dims)


def clustered(out, dims):
    """15 % of the 16^3 blocks of a `dims` box occupied, in cloud-like clusters."""
    rng = np.random.default_rng(1224)
    dims = np.array(dims)
    blocks = -(-dims // 16)
    field = blur(rng.standard_normal(size=tuple(blocks)), passes=4)
    occupied = field > np.quantile(field, 0.85)
    g = grid()
    acc_values = 0
    for b in np.argwhere(occupied):
        lo = b * 16
        hi = np.minimum(lo + 16, dims)
        shape = tuple(hi - lo)
        base = max(field[tuple(b)], 0.0) * 4.0
        values = (base * rng.uniform(0.2, 1.0, size=shape)).astype(np.float32)
        g.copyFromArray(values, ijk=tuple(int(v) for v in lo), tolerance=-1.0)
        acc_values += values.size
    g.saveFloatAsHalf = True
    vdb.write(out, grids=[g])
    print(f"{out}: {int(occupied.sum())} of {occupied.size} 16^3 blocks occupied "
          f"({occupied.mean():.1%}), {acc_values} active voxels")


def two(out):
    g = grid()
    acc = g.getAccessor()
    acc.setValueOn((0, 0, 0), 1.0)
    acc.setValueOn((999, 999, 999), 1.0)
    vdb.write(out, grids=[g])


def line(out):
    g = grid()
    acc = g.getAccessor()
    acc.setValueOn((0, 0, 0), 1.0)
    acc.setValueOn((1000000, 0, 0), 1.0)
    vdb.write(out, grids=[g])


def corners(out):
    """Two voxels at the corners of a 20001^3 box (8.0e12 voxels), 1e30 world units apart (voxel
    size 5e25): only two leaves to store, and a brick grid that fits only with large bricks."""
    g = grid()
    acc = g.getAccessor()
    acc.setValueOn((0, 0, 0), 1.0)
    acc.setValueOn((20000, 20000, 20000), 1.0)
    g.transform = vdb.createLinearTransform(voxelSize=5e25)
    vdb.write(out, grids=[g])


def wide(out):
    """Two voxels 2^32 - 1 apart along x: a box longer than any loader takes (2^31 per axis)."""
    g = grid()
    acc = g.getAccessor()
    acc.setValueOn((-2**31, 0, 0), 1.0)
    acc.setValueOn((2**31 - 1, 0, 0), 1.0)
    vdb.write(out, grids=[g])


if __name__ == "__main__":
    modes = {"fixture": fixture, "disney": disney, "two": two, "line": line, "series": series,
             "wide": wide, "corners": corners}
    if len(sys.argv) != 3 or sys.argv[1] not in modes:
        sys.exit(__doc__)
    modes[sys.argv[1]](sys.argv[2])
