"""Renders the peer comparison's cloud (issue 62) with Mitsuba 3's volpath to a linear EXR.

Install (any Python >= 3.8; the comparison used 3.11):
  python3.11 -m venv /tmp/peers/venv511 && /tmp/peers/venv511/bin/pip install mitsuba numpy
  (llvm_ad_rgb also needs `apt-get install -y libllvm19`: Debian 12's LLVM 15 cannot compile
  Dr.Jit's kernels; the script points DRJIT_LIBLLVM_PATH at LLVM 19 when it is there)
Run:
  /tmp/peers/venv511/bin/python scripts/results/peers/render_mitsuba.py --out a.exr --spp 16 --seed 1 \
      [--variant scalar_rgb|llvm_ad_rgb] [--threads 2]

Scene (host's conventions, see docs/results/peers.md): a `heterogeneous` medium, sigma_t = 8 x
a `gridvolume` read from cloud.vol (make_volume.py; trilinear, values at the cell centres of
the unit cube, mapped onto [-1, 1]^3 by to_world), constant RGB albedo, `hg` phase g; inside a
`cube` [-1, 1]^3 with a `null` BSDF; a `constant` emitter of radiance 1; a `perspective` camera
with host's position, look-at, up +y and vertical FOV; `hdrfilm` with a box filter (1 pixel),
no border sampling; `independent` sampler; `volpath` with max_depth -1 (no cap) and rr_depth 5.
Prints "render_seconds <t>" (mi.render only; with llvm_ad_rgb this includes JIT compilation,
printed apart as "compile_seconds" from a 1-spp warm-up at another seed when --warmup is given).
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from scene import add_scene_args  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--vol", default="/tmp/peers/cloud.vol")
    add_scene_args(ap)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--max-depth", type=int, default=-1)
    ap.add_argument("--rr-depth", type=int, default=5)
    ap.add_argument("--filter", default="trilinear", help="gridvolume filter_type: trilinear or nearest")
    ap.add_argument("--warmup", action="store_true", help="a 1-spp render first (JIT), not timed")
    a = ap.parse_args()

    import os

    # Dr.Jit's LLVM backend needs an LLVM newer than Debian 12's default 15 (which fails with
    # "Cannot select ... fminimum"): apt-get install -y libllvm19.
    if "llvm" in a.variant and "DRJIT_LIBLLVM_PATH" not in os.environ:
        for lib in ("/usr/lib/x86_64-linux-gnu/libLLVM-19.so", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"):
            if os.path.exists(lib):
                os.environ["DRJIT_LIBLLVM_PATH"] = lib
                break
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(a.variant)
    dr.set_thread_count(a.threads)
    T = mi.ScalarTransform4f
    alb = [float(x) for x in a.albedo.split(",")]
    alb = alb * 3 if len(alb) == 1 else alb
    eye = [float(x) for x in a.camera.split(",")]
    target = [float(x) for x in a.look_at.split(",")]
    scene = mi.load_dict({
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": a.max_depth, "rr_depth": a.rr_depth},
        "sensor": {
            "type": "perspective",
            "fov": a.fov,
            "fov_axis": "y",
            "near_clip": 1e-3,
            "far_clip": 1e4,
            "to_world": T().look_at(origin=eye, target=target, up=[0, 1, 0]),
            "sampler": {"type": "independent", "sample_count": a.spp, "seed": a.seed},
            "film": {
                "type": "hdrfilm", "width": a.size, "height": a.size, "pixel_format": "rgb",
                "rfilter": {"type": "box"}, "sample_border": False,
            },
        },
        "env": {"type": "constant", "radiance": {"type": "rgb", "value": [1.0, 1.0, 1.0]}},
        "cloud": {
            "type": "cube",
            "bsdf": {"type": "null"},
            "interior": {
                "type": "heterogeneous",
                "sigma_t": {
                    "type": "gridvolume", "filename": a.vol, "filter_type": a.filter,
                    "to_world": T().translate([-1.0, -1.0, -1.0]).scale([2.0, 2.0, 2.0]),
                },
                "albedo": {"type": "constvolume", "value": {"type": "rgb", "value": alb}},
                "scale": a.density_scale,
                "phase": {"type": "hg", "g": a.hg_g},
            },
        },
    })
    if a.warmup:
        t = time.monotonic()
        img = mi.render(scene, spp=1, seed=a.seed + 1_000_003)
        dr.eval(img)
        print(f"compile_seconds {time.monotonic() - t:.4f}", flush=True)
    t = time.monotonic()
    img = mi.render(scene, spp=a.spp, seed=a.seed)
    dr.eval(img)
    dr.sync_thread()
    print(f"render_seconds {time.monotonic() - t:.4f}", flush=True)
    mi.Bitmap(img).write(a.out)


if __name__ == "__main__":
    main()
