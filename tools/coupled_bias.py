#!/usr/bin/env python3
"""The coupled CONNFFESSIT shear's bias against Oldroyd-B, over Wi × N_d × resolution × p_b.

Hookean dumbbells are the Oldroyd-B fluid as N_d → ∞, so in steady shear at Wi = λγ̇

    η = η_s + η_p,        N₁ = 2 η_p λ γ̇²          (exact, no shear thinning).

Each point runs `cases/connffessit_shear_2d.toml` with overrides (λ = 1, γ̇ = Wi, η_s = η_p = 0.5)
and reads both stresses from its summary.json: the momentum flux of the pair forces
(`viscosity`, `first_normal_stress_difference`) and the particles' constitutive mean
(`viscosity_constitutive`, `first_normal_stress_difference_constitutive`).
docs/theory/sph_momentum_flux.md explains why they differ. The bias of a setting is the mean
over its seeds; its error bar is the seed scatter divided by √(seeds), or the mean block error
when there is one seed.

The Mach number is held at γ̇L/c₀ ≤ 0.2: c₀ = 10 max(1, Wi/2), with Δt scaled by 1/max(1, Wi/2)
(the acoustic limit). Resolution: Δ = L/√(density), h = 3Δ, the particle mass ρ₀Δ², Δt ∝ Δ².

    python3 tools/coupled_bias.py --binary target/release/mesorheo --out out/coupled_bias \\
        --wi 0.5 1 2 4 --nd 100 1000 --pb 5 20 --seeds 1 2 --density 400
    python3 tools/coupled_bias.py --out out/coupled_bias --report docs/coupled_bias.png

Finished points (their summary.json) are not run again. `--report` draws bias against Wi (PNG)
and prints the Markdown table.
"""

import argparse
import csv
import json
import math
import os
import subprocess
import sys

CASE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "cases", "connffessit_shear_2d.toml")
ETA_S = ETA_P = 0.5
LAMBDA = 1.0


NOISE_SUFFIX = {"independent": "", "configuration_fields": "_cf"}


def point_name(wi, nd, pb, density, seed, noise="independent", pt=0.0, support=3.0):
    """The folder of one point; the transport pressure and the support appear when they are not
    the stock 0 and 3Δ (so the points run before they existed keep their names)."""
    extra = (f"_pt{pt:g}" if pt else "") + (f"_h{support:g}" if support != 3.0 else "")
    return f"wi{wi:g}_nd{nd}_pb{pb:g}{extra}_rho{density:g}_seed{seed}{NOISE_SUFFIX[noise]}"


def overrides(wi, nd, pb, density, seed, noise="independent", pt=0.0, support=3.0):
    """The --set overrides of one point."""
    scale = max(1.0, wi / 2.0)
    spacing = 1.0 / math.sqrt(density)
    # Δt of the stock case (1.5e-3 at Δ = 0.05, c₀ = 10), ∝ Δ (acoustic) and Δ² (viscous): the
    # smaller of the two.
    ratio = spacing / 0.05
    dt = 1.5e-3 * min(ratio, ratio * ratio) / scale
    steps = int(round(18.0 * LAMBDA / dt))
    return [
        f"seed={seed}",
        f"box.shear_rate={wi}",
        f"particles.density={density}",
        f"particles.mass={1.0 / density}",
        f"fluid.smoothing_length={support * spacing}",
        f"fluid.sound_speed={10.0 * scale}",
        f"fluid.background_pressure={pb}",
        f"fluid.transport_pressure={pt}",
        f"fluid.polymer.per_particle={nd}",
        f'fluid.polymer.noise="{noise}"',
        f"integrator.dt={dt}",
        f"neighbour.skin={0.4 * spacing}",
        f"run.steps={steps}",
        f"run.equilibration={steps // 2}",
        "diagnostics.blocks=3",
        'diagnostics.observables=["viscosity","first_normal_stress_difference",'
        '"constitutive_stress","momentum","velocity_profile"]',
    ]


def run_point(binary, out, wi, nd, pb, density, seed, threads, noise, pt=0.0, support=3.0):
    folder = os.path.join(out, point_name(wi, nd, pb, density, seed, noise, pt, support))
    summary = os.path.join(folder, "summary.json")
    if os.path.exists(summary):
        return summary
    cmd = [binary, "run", CASE, "--out", folder, "-q", "-t", str(threads)]
    for s in overrides(wi, nd, pb, density, seed, noise, pt, support):
        cmd += ["--set", s]
    print("running", point_name(wi, nd, pb, density, seed, noise, pt, support), flush=True)
    # A reference miss exits 3 (the stock case's references are for Wi = 1): not an error here.
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode not in (0, 3) or not os.path.exists(summary):
        sys.exit(f"{' '.join(cmd)} failed ({r.returncode}):\n{r.stderr[-2000:]}")
    return summary


def read_points(out):
    rows = []
    for name in sorted(os.listdir(out)):
        path = os.path.join(out, name, "summary.json")
        if not os.path.exists(path):
            continue
        s = json.load(open(path))
        o = s["observables"]
        fields = {"cf": 1.0 if name.endswith("_cf") else 0.0, "pt": 0.0, "h": 3.0}
        for token in name.split("_"):
            for key in ("wi", "nd", "pb", "pt", "h", "rho", "seed"):
                if token.startswith(key):
                    fields[key] = float(token[len(key):])
        wi = fields["wi"]
        eta_exact = ETA_S + ETA_P
        n1_exact = 2.0 * ETA_P * LAMBDA * wi * wi
        row = dict(fields)
        for label, key, exact in [
            ("eta_flux", "viscosity", eta_exact),
            ("n1_flux", "first_normal_stress_difference", n1_exact),
            ("eta_constitutive", "viscosity_constitutive", eta_exact),
            ("n1_constitutive", "first_normal_stress_difference_constitutive", n1_exact),
        ]:
            row[label] = o[key]["mean"] / exact - 1.0
            row[label + "_err"] = o[key]["stderr"] / exact
        row["core_seconds"] = s["loop_seconds"] * s["ranks"] * s["threads"]
        rows.append(row)
    return rows


def aggregate(rows):
    """Mean bias over seeds per setting, with its error bar."""
    groups = {}
    for r in rows:
        groups.setdefault((r["cf"], r["wi"], r["nd"], r["pb"], r["pt"], r["h"], r["rho"]), []).append(r)
    out = []
    for key, members in sorted(groups.items()):
        g = dict(zip(("cf", "wi", "nd", "pb", "pt", "h", "rho"), key))
        g["seeds"] = len(members)
        for label in ("eta_flux", "n1_flux", "eta_constitutive", "n1_constitutive"):
            values = [m[label] for m in members]
            mean = sum(values) / len(values)
            if len(values) > 1:
                var = sum((v - mean) ** 2 for v in values) / (len(values) - 1)
                err = math.sqrt(var / len(values))
            else:
                err = members[0][label + "_err"]
            g[label], g[label + "_err"] = mean, err
        g["core_seconds"] = sum(m["core_seconds"] for m in members) / len(members)
        out.append(g)
    return out


def report(out, png):
    groups = aggregate(read_points(out))
    with open(os.path.join(out, "coupled_bias.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(groups[0].keys()))
        w.writeheader()
        w.writerows(groups)
    print("| noise | Wi | N_d | p_b | p_t | h/Δ | particles | seeds | η flux | N₁ flux | η constitutive | N₁ constitutive | core-s/run |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    pct = lambda g, k: f"{100 * g[k]:+.2f} ± {100 * g[k + '_err']:.2f} %"
    for g in groups:
        print(
            f"| {'configuration fields' if g['cf'] else 'independent'} | {g['wi']:g} | {g['nd']:g} | {g['pb']:g} | {g['pt']:g} | {g['h']:g} | {g['rho']:g} | {g['seeds']} | "
            f"{pct(g, 'eta_flux')} | {pct(g, 'n1_flux')} | {pct(g, 'eta_constitutive')} | "
            f"{pct(g, 'n1_constitutive')} | {g['core_seconds']:.0f} |"
        )
    if png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        kinds = sorted({g["cf"] for g in groups})
        fig, axes = plt.subplots(
            len(kinds), 2, figsize=(13, 4.2 * len(kinds)), sharex=True, squeeze=False
        )
        colours = plt.get_cmap("tab10")
        for row, cf in zip(axes, kinds):
            settings = sorted(
                {(g["nd"], g["pb"], g["pt"], g["h"], g["rho"]) for g in groups if g["cf"] == cf}
            )
            noise = "configuration fields" if cf else "independent noise"
            for ax, quantity, title in [
                (row[0], "eta", "shear viscosity η"),
                (row[1], "n1", "first normal stress difference N₁"),
            ]:
                for c, (nd, pb, pt, h, rho) in enumerate(settings):
                    sel = [
                        g
                        for g in groups
                        if (g["cf"], g["nd"], g["pb"], g["pt"], g["h"], g["rho"])
                        == (cf, nd, pb, pt, h, rho)
                    ]
                    wi = [g["wi"] for g in sel]
                    for kind, style in (("flux", "-o"), ("constitutive", "--s")):
                        k = f"{quantity}_{kind}"
                        ax.errorbar(
                            wi,
                            [100 * g[k] for g in sel],
                            yerr=[100 * g[k + "_err"] for g in sel],
                            fmt=style,
                            color=colours(c % 10),
                            capsize=3,
                            label=f"{kind}, N_d = {nd:g}, p_b = {pb:g}, p_t = {pt:g}, h = {h:g}Δ, N = {rho:g}",
                        )
                ax.axhline(0.0, color="k", lw=0.8)
                ax.set_xscale("log", base=2)
                ax.set_xlabel("Wi = λγ̇")
                ax.set_ylabel("measured / Oldroyd-B − 1 (%)")
                ax.set_title(f"{title}, {noise}")
            row[1].legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5))
        fig.suptitle("CONNFFESSIT shear (2D, Hookean dumbbells): bias against Oldroyd-B")
        fig.tight_layout()
        fig.savefig(png, dpi=110)
        print(f"wrote {png}")


def main():
    a = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    a.add_argument("--binary", default="target/release/mesorheo")
    a.add_argument("--out", default="out/coupled_bias")
    a.add_argument("--wi", type=float, nargs="*", default=[])
    a.add_argument("--nd", type=int, nargs="*", default=[100])
    a.add_argument("--pb", type=float, nargs="*", default=[5.0])
    a.add_argument("--seeds", type=int, nargs="*", default=[1])
    a.add_argument("--density", type=float, nargs="*", default=[400.0])
    a.add_argument(
        "--pt",
        type=float,
        nargs="*",
        default=[0.0],
        help="fluid.transport_pressure (the transport velocity; 0: none, points named …_ptP when set)",
    )
    a.add_argument(
        "--support",
        type=float,
        nargs="*",
        default=[3.0],
        help="the smoothing length in lattice spacings (points named …_hS when not 3)",
    )
    a.add_argument("--threads", type=int, default=1)
    a.add_argument(
        "--noise",
        nargs="*",
        default=["independent"],
        choices=list(NOISE_SUFFIX),
        help="fluid.polymer.noise of the runs (configuration_fields: points named …_cf)",
    )
    a.add_argument("--report", metavar="PNG", nargs="?", const="", default=None)
    args = a.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for density in args.density:
        for nd in args.nd:
            for pb in args.pb:
                for pt in args.pt:
                    for support in args.support:
                        for wi in args.wi:
                            for seed in args.seeds:
                                for noise in args.noise:
                                    run_point(
                                        args.binary, args.out, wi, nd, pb, density, seed,
                                        args.threads, noise, pt, support,
                                    )
    if args.report is not None:
        report(args.out, args.report or None)


if __name__ == "__main__":
    main()
