#!/usr/bin/python3
"""Writes the shared cloud of the peer comparison (issue 62) as OpenVDB and Mitsuba .vol files.

The cloud is host's embedded `cloud` (engine/src/scene/procedural.rs: a smooth union of six ellipsoids
displaced by 5 octaves of hashed gradient-noise fBm), ported to numpy in float32 and sampled at
the centres of an N^3 grid spanning [-1, 1]^3 world units (voxel size 2/N; voxel i's centre at
(i + 0.5) * 2/N - 1), exactly as host generates `--volume cloud --resolution N`.

Outputs (in --out-dir, default /tmp/peers):
  cloud.vdb  float grid "density", fog volume; index->world: scale 2/N, translate 1/N - 1, so
             OpenVDB's voxel centre (integer index i) is at (i + 0.5) * 2/N - 1.
  cloud.vol  Mitsuba 3 binary grid ("VOL" v3, float32, 1 channel, x fastest), bbox [-1, 1]^3
             (Mitsuba's gridvolume puts value i at (i + 0.5)/N of its unit cube: the same centres
             once the cube is mapped to [-1, 1]^3).
  cloud.npy  the float32 array [x][y][z].

Install: Debian `apt-get install -y python3-openvdb python3-numpy` (for /usr/bin/python3;
OpenVDB 10). Run:  /usr/bin/python3 scripts/results/peers/make_volume.py [--n 128] [--out-dir DIR]
"""
import argparse
import os
import struct

import numpy as np

F = np.float32
BLOBS = [  # centre, radii
    ([0.0, -0.378, 0.0], [0.874, 0.314, 0.694]),
    ([-0.358, -0.042, 0.09], [0.448, 0.448, 0.448]),
    ([0.202, 0.07, -0.09], [0.515, 0.515, 0.515]),
    ([0.022, 0.45, 0.045], [0.358, 0.336, 0.358]),
    ([0.538, -0.132, 0.224], [0.336, 0.336, 0.336]),
    ([-0.582, -0.222, -0.246], [0.336, 0.291, 0.336]),
]
BLEND = F(0.2)
AMP = F(0.3)
OCTAVES = 5
LACUNARITY = F(2.03)
HASH_MUL = [0x8DA6B343, 0xD8163841, 0xCB1AB31F]
GX = np.array([1, -1, 1, -1, 1, -1, 1, -1, 0, 0, 0, 0, 1, -1, 0, 0], F)
GY = np.array([1, 1, -1, -1, 0, 0, 0, 0, 1, -1, 1, -1, 1, 1, -1, -1], F)
GZ = np.array([0, 0, 0, 0, 1, 1, -1, -1, 1, 1, -1, -1, 0, 0, 1, -1], F)


def fmix(h):
    h = h ^ (h >> np.uint32(16))
    h = h * np.uint32(0x7FEB352D)
    h = h ^ (h >> np.uint32(15))
    h = h * np.uint32(0x846CA68B)
    return h ^ (h >> np.uint32(16))


def floor_i32(x):
    i = x.astype(np.int32)  # truncation, as Rust's `as i32`
    return np.where(i.astype(F) > x, i - 1, i)


def fade(t):
    return t * t * t * (t * (t * F(6) - F(15)) + F(10))


def lerp(t, a, b):
    return a + t * (b - a)


def noise(p, seed):
    ix, iy, iz = (floor_i32(c) for c in p)
    x, y, z = (c - i.astype(F) for c, i in zip(p, (ix, iy, iz)))
    u, v, w = fade(x), fade(y), fade(z)
    with np.errstate(over="ignore"):
        u32 = lambda a: a.astype(np.int64).astype(np.uint32)
        hx = [u32(ix) * np.uint32(HASH_MUL[0]), (u32(ix) + np.uint32(1)) * np.uint32(HASH_MUL[0])]
        hy = [u32(iy) * np.uint32(HASH_MUL[1]), (u32(iy) + np.uint32(1)) * np.uint32(HASH_MUL[1])]
        sz = np.uint32((seed * 0x9E3779B9) & 0xFFFFFFFF)
        hz = [sz ^ (u32(iz) * np.uint32(HASH_MUL[2])),
              sz ^ ((u32(iz) + np.uint32(1)) * np.uint32(HASH_MUL[2]))]

        def g(dx, dy, dz):
            i = (fmix(hx[dx] ^ hy[dy] ^ hz[dz]) & np.uint32(15)).astype(np.intp)
            return GX[i] * (x - F(dx)) + GY[i] * (y - F(dy)) + GZ[i] * (z - F(dz))

        x00 = lerp(u, g(0, 0, 0), g(1, 0, 0))
        x10 = lerp(u, g(0, 1, 0), g(1, 1, 0))
        x01 = lerp(u, g(0, 0, 1), g(1, 0, 1))
        x11 = lerp(u, g(0, 1, 1), g(1, 1, 1))
    return np.clip(lerp(w, lerp(v, x00, x10), lerp(v, x01, x11)), F(-1), F(1))


def fbm(p, freq, octaves, seed):
    s, amp = np.zeros_like(p[0]), F(1)
    q = [c * F(freq) for c in p]
    off = [F(17.31), F(-9.7), F(5.3)]
    for o in range(octaves):
        s = s + amp * noise(q, seed + o)
        amp = amp * F(0.5)
        r = [F(0.8) * q[1] + F(0.6) * q[2],
             F(-0.8) * q[0] + F(0.36) * q[1] - F(0.48) * q[2],
             F(-0.6) * q[0] - F(0.48) * q[1] + F(0.64) * q[2]]
        q = [r[i] * LACUNARITY + off[i] for i in range(3)]
    return s


def blobs_field(p):
    acc = np.full_like(p[0], F(-1e9))
    for c, r in BLOBS:
        d = [(p[i] - F(c[i])) * (F(1) / F(r[i])) for i in range(3)]
        b = F(1) - np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        h = np.maximum(BLEND - np.abs(acc - b), F(0)) / BLEND
        acc = np.maximum(acc, b) + h * h * BLEND * F(0.25)
    return acc


def cloud(n):
    s = F(2.0) / F(n)
    c = (np.arange(n, dtype=F) + F(0.5)) * s - F(1)
    x, y, z = np.meshgrid(c, c, c, indexing="ij")
    f = blobs_field([x, y, z])
    sm = fbm([x, y, z], 2.5, OCTAVES, 11)
    g = f + AMP * sm
    d = np.clip((g - F(0)) / F(0.12), F(0), F(1)) * np.clip(F(0.35) + F(0.9) * g + F(0.8) * sm, F(0), F(1))
    bound = F(2.0 - 2.0 / (1 << OCTAVES))
    d = np.where(f + AMP * bound < 0, F(0), d)
    return d.astype(F)


def write_vol(path, d):
    nx, ny, nz = d.shape
    with open(path, "wb") as fh:
        fh.write(b"VOL" + bytes([3]) + struct.pack("<i", 1) + struct.pack("<4i", nx, ny, nz, 1))
        fh.write(struct.pack("<6f", -1, -1, -1, 1, 1, 1))
        fh.write(np.ascontiguousarray(d.transpose(2, 1, 0)).astype("<f4").tobytes())  # x fastest


def write_vdb(path, d):
    import pyopenvdb as vdb

    n = d.shape[0]
    s = 2.0 / n
    g = vdb.FloatGrid()
    g.copyFromArray(d.astype(np.float32), ijk=(0, 0, 0), tolerance=0)
    m = [[s, 0, 0, 0], [0, s, 0, 0], [0, 0, s, 0], [0.5 * s - 1, 0.5 * s - 1, 0.5 * s - 1, 1]]
    g.transform = vdb.createLinearTransform(m)
    g.name = "density"
    g.gridClass = vdb.GridClass.FOG_VOLUME
    vdb.write(path, grids=[g])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=128)
    ap.add_argument("--out-dir", default="/tmp/peers")
    a = ap.parse_args()
    os.makedirs(a.out_dir, exist_ok=True)
    d = cloud(a.n)
    np.save(os.path.join(a.out_dir, "cloud.npy"), d)
    write_vol(os.path.join(a.out_dir, "cloud.vol"), d)
    write_vdb(os.path.join(a.out_dir, "cloud.vdb"), d)
    print(f"{a.n}^3 voxels, {int((d > 0).sum())} nonzero, mean {d.mean():.5f}, max {d.max():.4f}")


if __name__ == "__main__":
    main()
