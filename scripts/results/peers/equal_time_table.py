#!/usr/bin/env python3
"""Prints the equal-time table of docs/results/peers.md from `compare.py --equal-time --json`
files (docs/results/peers/equal_time_10s*.json).

Each row: the peer's spp, the render's seconds, the RMSE of one render's luminance against the
4096-spp reference over the volume's pixels as measured, and that RMSE at exactly BUDGET seconds:
the reference's own variance (host's var x spp / 4096, averaged over the volume's pixels) taken
out of the MSE, and the rest scaled by (seconds / BUDGET), as the variance of a render of an
unbiased renderer falls with its time (the biased peers' bias is below their noise here: their
means agree with host's within 0.1 %). The last column: that RMSE over host's (default flags).

Usage: scripts/results/peers/equal_time_table.py [--budget 10] FILE.json [MORE.json ...]
   (run by scripts/results_check.py on docs/results/peers/equal_time_10s*.json)
"""
import argparse
import json

NAMES = {
    "host": "host `path` (defaults: sobol, jackknife)",
    "host-indep": "host `path --sampler independent`",
    "cycles34": "Cycles 3.4 (ray marching)",
    "cycles50": "Cycles 5.0 (null scattering, default)",
    "cycles50-biased": "Cycles 5.0 `volume_biased`",
    "mitsuba": "Mitsuba 3 `volpath`, scalar_rgb",
    "mitsuba-llvm": "Mitsuba 3 `volpath`, llvm_ad_rgb",
}


def label(row, flags, probe=False):
    name = NAMES.get(row["peer"], row["peer"])
    if row["peer"] == "host" and flags:
        return f"host `path {flags}`"
    if row["peer"] == "host" and probe:
        return "host `path` (defaults; the white world as a 4x2 light probe)"
    return name


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--budget", type=float, default=10.0)
    ap.add_argument("files", nargs="+")
    a = ap.parse_args()
    rows = []
    ref_var = None
    for path in a.files:
        d = json.load(open(path))
        cmd = d["command"]
        flags = cmd[cmd.index("--host-flags") + 1] if "--host-flags" in cmd else ""
        probe = "--host-env" in cmd and cmd[cmd.index("--host-env") + 1] == "probe"
        for r in d["rows"]:
            rows.append((label(r, flags, probe), r))
            if r["peer"] == "host" and not flags and not probe:
                ref_var = r["var_x_spp"] / 4096.0
    host = next(r for n, r in rows if n.startswith("host `path` (defaults"))

    def at_budget(r):
        mse = r["rmse_vol"] ** 2 - ref_var
        return (mse * r["render_seconds"] / a.budget) ** 0.5

    print(
        f"| renderer | spp | s / render | var x spp | RMSE (measured) | RMSE at {a.budget:.0f} s | "
        "vs host |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, r in rows:
        print(
            f"| {name} | {r['spp']} | {r['render_seconds']:.2f} | {r['var_x_spp']:.4f} | "
            f"{r['rmse_vol']:.5f} | {at_budget(r):.5f} | {at_budget(r) / at_budget(host):.2f}x |"
        )


if __name__ == "__main__":
    main()
