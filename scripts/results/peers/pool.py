#!/usr/bin/env python3
"""Pools the renders that several `compare.py --keep DIR` runs left, per peer (issue 62).

Image means of the Rec. 709 luminance over the volume's pixels (DIR/mask.npy, the same in every
run) and over the whole image, +- their standard error across all renders of that peer and spp,
z and the relative difference against the first peer listed. Needs numpy and OpenEXR.

    /tmp/peers/venv511/bin/python scripts/results/peers/pool.py --spp 16 \
        /tmp/peers/final128 /tmp/peers/h32 /tmp/peers/s201 [--peers host,mitsuba,...]
"""
import argparse
import glob
import os
import sys

import numpy as np

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare import luminance  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dirs", nargs="+")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--peers", default="host,host-indep,cycles34,cycles50,cycles50-biased,mitsuba,mitsuba-llvm")
    a = ap.parse_args()
    masks = [np.load(os.path.join(d, "mask.npy")) for d in a.dirs]
    if any((m != masks[0]).any() for m in masks):
        raise SystemExit("the runs' masks differ")
    mask = masks[0]
    rows = []
    for p in a.peers.split(","):
        files = [f for d in a.dirs for f in sorted(glob.glob(os.path.join(d, f"{p}_{a.spp}spp_s*.exr")))]
        if len(files) < 2:
            continue
        ims = [luminance(f, "radiance" if p.startswith("host") else None) for f in files]
        v = np.array([i[mask].mean() for i in ims])
        g = np.array([i.mean() for i in ims])
        rows.append((p, len(v), v.mean(), v.std(ddof=1) / np.sqrt(len(v)), g.mean(), g.std(ddof=1) / np.sqrt(len(g))))
    b = rows[0]
    print(f"{'peer':16} {'n':>4} {'mean(volume px)':>20} {'z':>6} {'mean(image)':>20} {'z':>6} {'rel':>8}")
    for r in rows:
        zv = (r[2] - b[2]) / np.hypot(r[3], b[3]) if r is not b else 0.0
        zi = (r[4] - b[4]) / np.hypot(r[5], b[5]) if r is not b else 0.0
        print(f"{r[0]:16} {r[1]:4d} {r[2]:10.5f} +- {r[3]:.5f} {zv:6.2f} {r[4]:10.5f} +- {r[5]:.5f} {zi:6.2f} "
              f"{100 * (r[2] / b[2] - 1):+7.3f}%")


if __name__ == "__main__":
    main()
