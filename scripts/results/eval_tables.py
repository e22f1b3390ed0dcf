#!/usr/bin/env python3
"""Prints the `host eval` tables (markdown) of docs/results/transmittance.md (transmittance evals)
docs/results/scattering.md (integrator evals) and docs/results/direct.md (lit integrator evals) from eval JSON files written by `host eval`.

Usage: scripts/results/eval_tables.py [--merit] docs/results/eval_cloud.json [more.json ...]

With --merit, transmittance evals print the equal-time table of docs/results/transmittance.md's
telescoping section instead: MSE x time per estimate, relative to the jackknife's.
Transmittance evals (key `estimators`), single-scattering integrator evals (key `integrators`) and
lit integrator evals (key `entries`: docs/results/direct.md; with moment shadow maps,
docs/results/shadows.md) are accepted.
"""
import json
import sys


def name_of(d):
    """The short volume name: the first word of the JSON's `volume`."""
    return d["volume"].split(" ")[0]


def transmittance_table(d):
    head = (
        f"**{name_of(d)}** ({d['volume']}, {d['width']}x{d['height']}, {d['spp']} estimates "
        f"per pixel, {d['lookup']} lookups, {d['evaluated_pixels']} pixels; {d['backend']}: "
        f"{d['device']})\n\n"
        "| estimator | mean bias | mean abs bias | noise floor | mean std | RMSE | samples/ray | capped rays | ms |\n"
        "|---|---|---|---|---|---|---|---|---|"
    )
    rows = [
        f"| `{e['name']}` | {e['mean_bias']:+.5f} | {e['mean_abs_bias']:.5f} | "
        f"{e['abs_bias_noise_floor']:.5f} | {e['mean_std']:.4f} | {e['rmse']:.4f} | "
        f"{e['mean_samples_per_ray']:.2f} | {e.get('capped_rays', 0)} | {e['elapsed_ms']:.0f} |"
        for e in d["estimators"]
    ]
    return "\n".join([head] + rows)


def merit_table(d):
    """Equal-time figure of merit of a transmittance eval: MSE of one estimate (RMSE^2) times the
    time of one estimate (the entry's elapsed time over width x height x spp), and its ratio to
    the jackknife's (below 1: better than the jackknife at equal time)."""
    head = (
        f"**{name_of(d)}** ({d['width']}x{d['height']}, {d['spp']} estimates per pixel, "
        f"{d['lookup']} lookups, {d['evaluated_pixels']} pixels; {d['backend']})\n\n"
        "| estimator | mean bias | mean std | RMSE | samples/ray | ns / estimate | MSE x ns | vs jackknife |\n"
        "|---|---|---|---|---|---|---|---|"
    )
    count = d["width"] * d["height"] * d["spp"]

    def merit(e):
        return e["rmse"] ** 2 * e["elapsed_ms"] * 1e6 / count

    jk = next(e for e in d["estimators"] if e["name"] == "jackknife")
    rows = [
        f"| `{e['name']}` | {e['mean_bias']:+.5f} | {e['mean_std']:.4f} | {e['rmse']:.4f} | "
        f"{e['mean_samples_per_ray']:.2f} | {e['elapsed_ms'] * 1e6 / count:.0f} | "
        f"{merit(e):.4f} | {merit(e) / merit(jk):.2f}x |"
        for e in d["estimators"]
    ]
    return "\n".join([head] + rows)


def integrator_table(d):
    head = (
        "| integrator | SMAPE | mean bias | mean abs error | mean L | lookups/ray | capped rays | ms per spp |\n"
        "|---|---|---|---|---|---|---|---|"
    )
    rows = [
        f"| `{i['name']}` | {i['smape']:.4f} | {i['mean_bias']:+.5f} | {i['mean_abs_error']:.5f} | "
        f"{i['mean_radiance']:.5f} | {i['mean_samples_per_ray']:.2f} | {i.get('capped_rays', 0)} | "
        f"{i['ms_per_frame']:.1f} |"
        for i in d["integrators"]
    ]
    return "\n".join([head] + rows)


def lit_table(d):
    """The shadow-ray table of docs/results/direct.md: one row per entry of a lit integrator's
    eval (`host eval --integrators direct|path`); ms per spp from the entry's time, std^2 x ms the
    equal-time figure of merit."""
    head = (
        "| shadow rays | SMAPE | mean bias +- s.e. | mean std | lookups / camera ray | ms / spp | std^2 x ms | capped rays | jackknife outside rays |\n"
        "|---|---|---|---|---|---|---|---|---|"
    )
    rows = []
    for e in d["entries"]:
        ms = e["elapsed_ms"] / e.get("spp", d["spp"])
        rows.append(
            f"| `{e['name']}` | {e['smape']:.4f} | {e['mean_bias']:+.5f} +- {e['mean_bias_se']:.5f} | "
            f"{e['mean_std']:.4f} | {e['lookups_per_ray']:.2f} | {ms:.1f} | "
            f"{e['mean_std'] ** 2 * ms:.2f} | {e.get('capped_rays', 0)} | "
            f"{e.get('jackknife_outside_rays', 0)} |"
        )
    return "\n".join([head] + rows)


def msm_table(d):
    """The table of docs/results/shadows.md: a lit eval whose entries carry `paired_rms` (moment
    shadow maps beside shadow rays). Render ms per spp excludes a map's build; the RMSE columns
    are sqrt(std^2 / n + b^2) with n the samples that fit the time of 1 (or 64) jackknife samples
    and b the paired RMS of a map (0 for shadow rays)."""
    head = (
        "| shadows toward the sun | SMAPE | mean bias +- s.e. | paired RMS | mean std | lookups / camera ray | render ms / spp | map build ms | map size | RMSE, 1-spp jackknife time | RMSE, 64-spp jackknife time |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|"
    )

    def render_ms(e):
        m = e.get("shadow_map")
        build = m["build_ms"] if m else 0.0
        return (e["elapsed_ms"] - build) / e.get("spp", d["spp"])

    jk = next(e for e in d["entries"] if e["name"].endswith("/jackknife"))
    rows = []
    for e in d["entries"]:
        m = e.get("shadow_map")
        ms = render_ms(e)
        b = e["paired_rms"] if m else 0.0
        rmse = [
            (e["mean_std"] ** 2 / (k * render_ms(jk) / ms) + b * b) ** 0.5 for k in (1, 64)
        ]
        build = f"{m['build_ms']:.0f}" if m else "-"
        size = f"{m['bytes'] // 1024} KiB" if m else "-"
        rows.append(
            f"| `{e['name']}` | {e['smape']:.4f} | {e['mean_bias']:+.5f} +- {e['mean_bias_se']:.5f} | "
            f"{e['paired_rms']:.5f} | {e['mean_std']:.4f} | {e['lookups_per_ray']:.2f} | {ms:.2f} | "
            f"{build} | {size} | {rmse[0]:.4f} | {rmse[1]:.5f} |"
        )
    return "\n".join([head] + rows)


def main():
    args = sys.argv[1:]
    merit = bool(args) and args[0] == "--merit"
    if merit:
        args = args[1:]
    if not args:
        sys.exit(__doc__)
    for path in args:
        try:
            with open(path) as f:
                d = json.load(f)
        except (OSError, ValueError) as e:
            sys.exit(f"error: {path}: {e}")
        if "estimators" in d:
            print(merit_table(d) if merit else transmittance_table(d))
        elif "integrators" in d:
            print(integrator_table(d))
        elif "entries" in d and all("paired_rms" in e for e in d["entries"]):
            print(msm_table(d))
        elif "entries" in d:
            print(lit_table(d))
        else:
            sys.exit(f"error: {path}: neither a transmittance nor an integrator eval")
        print()


if __name__ == "__main__":
    main()
