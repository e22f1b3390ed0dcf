#!/usr/bin/env python3
"""Host's path tracer against Cycles 3.4, Cycles 5.0 and Mitsuba 3 on one scene (issue 62).

The scene: the cloud of make_volume.py (128^3, [-1, 1]^3 world units) with extinction 8 x
density, albedo (0.9, 0.7, 0.5), Henyey-Greenstein g = 0.5, a white world of radiance 1 and
nothing else, host's default camera (docs/results/peers.md has the conventions). For each peer
and seed (1..M, or --first-seed on) one render at --spp; printed per peer: the image mean of the Rec. 709 luminance
over the volume's pixels (host's camera transmittance below 0.99 at 1 spp, as in
scripts/results/variance_per_sample.py) and over the whole image, each +- its standard error across
the seeds, z = (mean - host's) / combined SE, the variance per sample (the pixel variance
across seeds x spp, averaged over the volume's pixels: scripts/results/variance_per_sample.py's
`var_x_spp`), the render's wall time (each renderer's own render call, see the scripts) and ms
per sample (per spp of the whole image), and the screen-space shift (pixels) that best explains
the mean image's difference from host's (least squares on host's gradients; an offset of the
volume or camera shows up there long before it does in the means).

With --reference REF.exr, also the RMSE of each render's luminance against REF's (volume pixels
and whole image), and with --equal-time SECONDS each peer's spp is set from a calibration
render at --spp so that one render takes about SECONDS (the equal-time comparison). With
--overhead, a 1-spp render per peer gives its fixed cost per render (Cycles 5.0's unbiased
volumes spend about 6 s before the first sample on this scene) and the marginal ms per spp.

Needs: numpy, OpenEXR (pip), Blender 3.4 (`apt-get install -y blender`), bpy 5.0.1 and mitsuba
in a Python 3.11 venv (`python3.11 -m venv /tmp/peers/venv511 && /tmp/peers/venv511/bin/pip
install bpy==5.0.1 mitsuba numpy OpenEXR`), optionally `apt-get install -y libllvm19` for
Mitsuba's llvm_ad_rgb, and the volume (`/usr/bin/python3 scripts/results/peers/make_volume.py`, needs
`apt-get install -y python3-openvdb`). Every render runs under `nice -n 19` unless --no-nice.

    /tmp/peers/venv511/bin/python scripts/results/peers/compare.py --host /tmp/peer-host --spp 16 \
        --seeds 4 --size 64 [--peers host,cycles34,cycles50,cycles50-biased,mitsuba] \
        [--albedo 0] [--keep DIR] [--json OUT] [--reference REF.exr] [--equal-time S]
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
from variance_per_sample import luminance, white_probe  # noqa: E402
VENV_PY = "/tmp/peers/venv511/bin/python"
# host's default framing of this volume (its JSON summary: occupied world bounds
# [-0.96875, -0.75, -0.796875]..[0.9375, 0.8125, 0.78125], camera 0.8 x bounding radius /
# sin(fov / 2) from their centre along (0.35, 0.25, -1)), given explicitly to every renderer.
CAMERA = "1.084895,0.8173357,-3.1521554"
LOOK_AT = "-0.015625,0.03125,-0.0078125"
FOV = "40"
ALL_PEERS = "host,host-indep,cycles34,cycles50,cycles50-biased,mitsuba,mitsuba-llvm"


def peer_command(peer, a, out, spp, seed, tmp):
    """The command line rendering `peer` at spp/seed into `out`, and how to read its time."""
    scene = ["--size", str(a.size), "--albedo", a.albedo, "--hg-g", a.hg_g,
             "--density-scale", a.density_scale, f"--camera={CAMERA}", f"--look-at={LOOK_AT}",
             "--fov", FOV, "--spp", str(spp), "--seed", str(seed), "--out", out,
             "--threads", str(a.threads)]
    cyc = os.path.join(HERE, "render_cycles.py")
    mit = os.path.join(HERE, "render_mitsuba.py")
    if peer.startswith("host"):
        cmd = [a.host, "render", "-q", "--volume", a.vdb, "--density-scale", a.density_scale,
               "--integrator", "path", "--backend", "cpu", "--albedo", a.albedo,
               "--hg-g", a.hg_g,
               "--env", os.path.join(tmp, "white.hdr") if a.host_env == "probe" else a.host_env,
               f"--camera={CAMERA}", f"--look-at={LOOK_AT}", "--fov", FOV,
               "--width", str(a.size), "--height", str(a.size), "--spp", str(spp),
               "--seed", str(seed), "--max-depth", str(a.host_max_depth), "--rr-depth", "5",
               "--out", out, "--json", out + ".json"] + a.host_flags.split()
        if peer == "host-indep":
            cmd += ["--sampler", "independent"]
    elif peer == "cycles34":
        cmd = [a.blender, "-b", "--factory-startup", "-t", str(a.threads), "-P", cyc, "--",
               "--vdb", a.vdb, "--offset-voxels", str(a.cycles34_offset)] + scene
    elif peer.startswith("cycles50"):
        cmd = [VENV_PY, cyc, "--vdb", a.vdb] + scene
        if peer == "cycles50-biased":
            cmd.append("--biased")
    elif peer.startswith("mitsuba"):
        cmd = [VENV_PY, mit, "--vol", a.vol] + scene
        if peer == "mitsuba-llvm":
            cmd += ["--variant", "llvm_ad_rgb", "--warmup"]
    else:
        raise SystemExit(f"unknown peer {peer}")
    return (["nice", "-n", "19"] if a.nice else []) + cmd


def render(peer, a, out, spp, seed, tmp):
    cmd = peer_command(peer, a, out, spp, seed, tmp)
    env = dict(os.environ, RAYON_NUM_THREADS=str(a.threads))
    t = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.monotonic() - t
    if p.returncode != 0 or not os.path.exists(out):
        sys.stderr.write(p.stdout[-3000:] + p.stderr[-3000:])
        raise SystemExit(f"{peer} failed: {' '.join(cmd)}")
    if peer.startswith("host"):
        seconds = json.load(open(out + ".json"))["elapsed_ms"] / 1000.0
    else:
        m = re.findall(r"render_seconds ([0-9.]+)", p.stdout)
        seconds = float(m[-1]) if m else wall
    return seconds, wall, " ".join(cmd)


def shift(diff, ref, mask):
    """Screen-space shift (dx, dy) in pixels with diff ~ -(dx dI/dx + dy dI/dy) (least squares)."""
    gy, gx = np.gradient(ref)
    A = np.stack([-gx[mask], -gy[mask]], axis=1)
    sol, *_ = np.linalg.lstsq(A, diff[mask], rcond=None)
    return float(sol[0]), float(sol[1])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--host", default="/tmp/peer-host")
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--vdb", default="/tmp/peers/cloud.vdb")
    ap.add_argument("--vol", default="/tmp/peers/cloud.vol")
    ap.add_argument("--peers", default="host,cycles34,cycles50,cycles50-biased,mitsuba",
                    help=f"comma-separated, of {ALL_PEERS}")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--seeds", type=int, default=4, help="renders per peer, seeds F..F+M-1")
    ap.add_argument("--first-seed", type=int, default=1, help="F")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--albedo", default="0.9,0.7,0.5")
    ap.add_argument("--hg-g", default="0.5")
    ap.add_argument("--density-scale", default="8")
    ap.add_argument("--host-max-depth", type=int, default=1024)
    ap.add_argument("--host-flags", default="", help="extra host render flags, one string")
    ap.add_argument("--host-env", default="constant:1",
                    help="host's white world: constant:1 (as the peers' constant worlds), or "
                         "probe (a 4x2 .hdr light probe of radiance 1, sampled by texel: the "
                         "tables before the constant environment)")
    ap.add_argument("--cycles34-offset", type=float, default=-0.5,
                    help="voxels to move Cycles 3.4's volume by along x, y, z (its half-voxel convention)")
    ap.add_argument("--no-nice", dest="nice", action="store_false")
    ap.add_argument("--keep", help="keep the EXRs in this folder")
    ap.add_argument("--json")
    ap.add_argument("--reference", help="EXR whose luminance the RMSE is measured against")
    ap.add_argument("--equal-time", type=float, help="seconds per render: spp from a calibration at --spp")
    ap.add_argument("--overhead", action="store_true",
                    help="also a 1-spp render per peer (seed 0): fixed cost per render, and marginal ms/spp")
    a = ap.parse_args()
    tmp = a.keep or tempfile.mkdtemp(prefix="peers.")
    os.makedirs(tmp, exist_ok=True)
    white_probe(os.path.join(tmp, "white.hdr"))

    # The volume's pixels, as variance_per_sample.py: host's camera transmittance at 1 spp.
    mask_exr = os.path.join(tmp, "mask.exr")
    # Host's defaults (no --host-flags): the same pixels whatever estimator is compared.
    flags, a.host_flags = a.host_flags, ""
    cmd = peer_command("host", a, mask_exr, 1, 0, tmp) + ["--layers", "camera-transmittance"]
    a.host_flags = flags
    subprocess.run(cmd, check=True, capture_output=True)
    mask = luminance(mask_exr, "camera-transmittance") < 0.99
    ref = luminance(a.reference) if a.reference else None
    print(f"{a.size}x{a.size}, {a.spp} spp, {a.seeds} seeds, {int(mask.sum())} volume pixels"
          + (f", equal time {a.equal_time} s" if a.equal_time else ""), flush=True)

    rows = []
    for peer in a.peers.split(","):
        spp = a.spp
        if a.equal_time:
            sec, _, _ = render(peer, a, os.path.join(tmp, f"{peer}_cal.exr"), a.spp, 999, tmp)
            spp = max(1, int(round(a.equal_time / (sec / a.spp))))
        one = None
        if a.overhead:
            one, _, _ = render(peer, a, os.path.join(tmp, f"{peer}_1spp_s0.exr"), 1, 0, tmp)
        images, seconds, walls, rmse = [], [], [], []
        for seed in range(a.first_seed, a.first_seed + a.seeds):
            out = os.path.join(tmp, f"{peer}_{spp}spp_s{seed}.exr")
            sec, wall, cmdline = render(peer, a, out, spp, seed, tmp)
            img = luminance(out, "radiance" if peer.startswith("host") else None)
            images.append(img)
            seconds.append(sec)
            walls.append(wall)
            if ref is not None:
                d2 = (img - ref) ** 2
                rmse.append((float(np.sqrt(d2[mask].mean())), float(np.sqrt(d2.mean()))))
        st = np.stack(images)
        vol_means = st[:, mask].mean(axis=1)
        img_means = st.reshape(len(images), -1).mean(axis=1)
        n = len(images)
        se = lambda x: float(x.std(ddof=1) / np.sqrt(n)) if n > 1 else float("nan")
        row = {
            "peer": peer, "spp": spp, "seeds": n, "command": cmdline,
            "mean_vol": float(vol_means.mean()), "se_vol": se(vol_means),
            "mean_img": float(img_means.mean()), "se_img": se(img_means),
            "var_x_spp": float(st.var(axis=0, ddof=1)[mask].mean() * spp) if n > 1 else float("nan"),
            "render_seconds": float(np.mean(seconds)), "process_seconds": float(np.mean(walls)),
            "ms_per_spp": 1000.0 * float(np.mean(seconds)) / spp,
            "mean_image": st.mean(axis=0),
        }
        if one is not None:
            row["seconds_1spp"] = one
            row["marginal_ms_per_spp"] = 1000.0 * (row["render_seconds"] - one) / max(spp - 1, 1)
        if rmse:
            row["rmse_vol"] = float(np.mean([r[0] for r in rmse]))
            row["rmse_img"] = float(np.mean([r[1] for r in rmse]))
        rows.append(row)
    base = next((r for r in rows if r["peer"] == "host"), rows[0])
    print(f"{'peer':16} {'spp':>5} {'mean(volume px)':>18} {'z':>6} {'mean(image)':>18} {'z':>6} "
          f"{'var x spp':>10} {'s/render':>9} {'ms/spp':>8} {'shift px':>14}"
          + ("  RMSE vol / img" if ref is not None else ""))
    for r in rows:
        zv = (r["mean_vol"] - base["mean_vol"]) / np.hypot(r["se_vol"], base["se_vol"]) if r is not base else 0.0
        zi = (r["mean_img"] - base["mean_img"]) / np.hypot(r["se_img"], base["se_img"]) if r is not base else 0.0
        dx, dy = shift(r["mean_image"] - base["mean_image"], base["mean_image"], mask) if r is not base else (0.0, 0.0)
        r.update(z_vol=float(zv), z_img=float(zi), shift_px=[dx, dy])
        print(f"{r['peer']:16} {r['spp']:5d} {r['mean_vol']:9.5f} +- {r['se_vol']:.5f} {zv:6.2f} "
              f"{r['mean_img']:9.5f} +- {r['se_img']:.5f} {zi:6.2f} {r['var_x_spp']:10.4f} "
              f"{r['render_seconds']:9.3f} {r['ms_per_spp']:8.2f} {dx:+6.3f},{dy:+6.3f}"
              + (f"  {r['rmse_vol']:.5f} / {r['rmse_img']:.5f}" if "rmse_vol" in r else "")
              + (f"  {r['seconds_1spp']:7.3f} {r['marginal_ms_per_spp']:8.2f}" if "seconds_1spp" in r else ""),
              flush=True)
    if a.keep:
        for r in rows:
            np.save(os.path.join(a.keep, f"{r['peer']}_mean.npy"), r["mean_image"])
        np.save(os.path.join(a.keep, "mask.npy"), mask)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"command": sys.argv, "size": a.size, "spp": a.spp, "seeds": a.seeds,
                       "pixels": int(mask.sum()),
                       "rows": [{k: v for k, v in r.items() if k != "mean_image"} for r in rows]},
                      f, indent=2)


if __name__ == "__main__":
    main()
