#!/usr/bin/env python3
"""Variance per pixel sample of `host render`, independent against stratified samples.

For each sampler and shadow estimator, M renders at 1 spp and M at S spp with seeds 1..M; the
variance of a pixel's luminance across the renders, averaged over the volume's pixels (camera
transmittance below 0.99), gives Var(one sample) and S x Var(mean of S samples). Their ratio is
what stratification gains (1 for independent samples). The image means are compared too.

Needs numpy and OpenEXR (pip install numpy OpenEXR). Writes a table to stdout and, with --json,
every number.

    python3 scripts/results/variance_per_sample.py target/release/host [--renders 8] [--spp 64]
        [--size 128] [--json docs/results/stratification.json] [-- extra host flags]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np
import OpenEXR


def white_probe(path, w=4, h=2):
    """An equirectangular Radiance .hdr of radiance 1 everywhere (flat RGBE scanlines)."""
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(f"-Y {h} +X {w}\n".encode())
        f.write(bytes([128, 128, 128, 129]) * (w * h))


def luminance(path, part_name=None):
    """The Rec. 709 luminance of part `part_name` (default: the first part), or of its Y
    channel, of an EXR."""
    with OpenEXR.File(path, separate_channels=True) as f:
        for part in f.parts:
            if part_name is not None and part.name() != part_name:
                continue
            ch = part.channels
            if "Y" in ch:
                return np.asarray(ch["Y"].pixels, dtype=np.float64)
            r, g, b = (np.asarray(ch[c].pixels, dtype=np.float64) for c in "RGB")
            return 0.2126 * r + 0.7152 * g + 0.0722 * b
    raise SystemExit(f"{path}: no part {part_name}")


def render(host, out, spp, seed, flags):
    t = time.monotonic()
    subprocess.run(
        [host, "render", "-q", "--spp", str(spp), "--seed", str(seed), "--out", out] + flags,
        check=True,
    )
    return time.monotonic() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("host")
    ap.add_argument("--renders", type=int, default=8)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--samplers", default="independent,sobol")
    ap.add_argument("--estimators", default="ratio,jackknife")
    ap.add_argument("--integrator", default="path", help="path, direct, ... or none (transmittance)")
    ap.add_argument("--json")
    a, extra = ap.parse_known_args()
    a.extra = [x for x in extra if x != "--"]
    tmp = tempfile.mkdtemp(prefix="variance_per_sample.")
    probe = os.path.join(tmp, "white.hdr")
    white_probe(probe)
    scene = [
        "--density-scale", "8", "--width", str(a.size), "--height", str(a.size), "--backend", "cpu",
    ]
    lit = ["--albedo", "0.9,0.7,0.5", "--hg-g", "0.5", "--env", probe]
    if a.integrator != "none":
        scene = ["--integrator", a.integrator] + scene + lit
    scene += a.extra
    part = "radiance" if a.integrator != "none" else "transmittance"
    mask_exr = os.path.join(tmp, "mask.exr")
    subprocess.run(
        [a.host, "render", "-q", "--spp", "1", "--out", mask_exr, "--layers",
         "camera-transmittance", "--integrator", "path"]
        + [x for x in scene if x not in ("--integrator", a.integrator)]
        + ([] if a.integrator != "none" else lit),
        check=True,
    )
    # The volume's pixels: where the camera rays' transmittance estimate (1 spp) is below 0.99
    # in a first render (the cloud's silhouette, the same for every configuration).
    mask = luminance(mask_exr, "camera-transmittance") < 0.99
    rows = []
    for sampler in a.samplers.split(","):
        for est in a.estimators.split(","):
            flags = scene + ["--sampler", sampler, "--estimator", est]
            result = {"sampler": sampler, "estimator": est}
            for spp in (1, a.spp):
                images, seconds = [], 0.0
                for seed in range(1, a.renders + 1):
                    out = os.path.join(tmp, f"{sampler}_{est}_{spp}_{seed}.exr")
                    seconds += render(a.host, out, spp, seed, flags)
                    images.append(luminance(out, part))
                stack = np.stack(images)
                var = stack.var(axis=0, ddof=1)[mask].mean() * spp
                result[f"spp{spp}"] = {
                    "var_x_spp": var,
                    "mean": stack.mean(axis=0)[mask].mean(),
                    # Standard error of the image mean over the M renders.
                    "mean_se": stack[:, mask].mean(axis=1).std(ddof=1) / np.sqrt(a.renders),
                    "seconds_per_render": seconds / a.renders,
                }
            result["gain"] = result["spp1"]["var_x_spp"] / result[f"spp{a.spp}"]["var_x_spp"]
            rows.append(result)
            print(
                f"{sampler:12} {est:10} Var(1 spp) {result['spp1']['var_x_spp']:.4f}  "
                f"{a.spp} x Var(mean of {a.spp}) {result[f'spp{a.spp}']['var_x_spp']:.4f}  "
                f"gain {result['gain']:.2f}x  mean {result[f'spp{a.spp}']['mean']:.4f} "
                f"+- {result[f'spp{a.spp}']['mean_se']:.4f}  "
                f"{result[f'spp{a.spp}']['seconds_per_render']:.1f} s/render",
                flush=True,
            )
    if a.json:
        with open(a.json, "w") as f:
            json.dump(
                {
                    "command": sys.argv,
                    "renders": a.renders,
                    "spp": a.spp,
                    "size": a.size,
                    "pixels": int(mask.sum()),
                    "scene": [x if x != probe else "white.hdr" for x in scene],
                    "rows": rows,
                },
                f,
                indent=2,
            )


if __name__ == "__main__":
    main()
