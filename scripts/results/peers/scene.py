"""The peer comparison's scene as the command-line arguments every renderer script shares
(render_cycles.py, render_mitsuba.py): image, samples, threads and host's conventions for the
cloud (docs/results/peers.md)."""


def add_scene_args(ap):
    """Adds the shared arguments, with this scene's values as defaults, to parser `ap`."""
    ap.add_argument("--out", required=True)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--density-scale", type=float, default=8.0)
    ap.add_argument("--albedo", default="0.9,0.7,0.5")
    ap.add_argument("--hg-g", type=float, default=0.5)
    ap.add_argument("--camera", default="1.084895,0.8173357,-3.1521554")
    ap.add_argument("--look-at", default="-0.015625,0.03125,-0.0078125")
    ap.add_argument("--fov", type=float, default=40.0)
