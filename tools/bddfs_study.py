#!/usr/bin/env python3
"""Tables and curves of the BDDFS study (studies/bddfs_t2.toml) from its study.csv.

    .venv/bin/python tools/bddfs_study.py docs/studies/bddfs_t2.csv docs/studies/bddfs_t2_law.png

Prints, per point, η_p, its error against the Fokker–Planck value, the BDDFS − BD difference at
the same N_d and Δt (the runs share seed, initial dumbbells and noise keys), the grid's predicted
r = λΔQ²/(6Δt) (src/models/bddfs.rs), the stored bytes per particle and the memory and CPU ratios
against BD at the same N_d and Δt. The figure: (left) the BDDFS − BD difference of η_p against r
for every n_c and Δt, the ΔQ²/Δt law being a single straight line through the origin whichever
of n_c and Δt sets r; (right) the stored bytes per particle against N_d.
"""
import csv
import math
import sys

Q_MAX = math.sqrt(50.0)  # the grid spans [−√b, √b]², b = 50
LAMBDA = 1.0


def load(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    out = []
    for r in rows:
        if r["status"] != "done":
            continue
        method = r["method"]
        cells = int(method.split("cells=")[1].split()[0]) if "cells=" in method else None
        n_d = int(r["ensemble"].split("per_particle=")[1].split()[0])
        particles = int(r["ensemble"].split("particles=")[1].split()[0])
        dt = float(r["integrator.dt"])
        out.append(dict(
            cells=cells, n_d=n_d, particles=particles, dt=dt,
            eta=float(r["polymer_viscosity:mean"]), se=float(r["polymer_viscosity:stderr"]),
            error=float(r["polymer_viscosity:error"]),
            stat=float(r["polymer_viscosity:statistical"]),
            bytes=float(r["bytes_per_particle"]), core=float(r["core_seconds"]),
            r=(2 * Q_MAX / cells) ** 2 * LAMBDA / (6 * dt) if cells else 0.0))
    return out


def main():
    csv_path = sys.argv[1]
    png = sys.argv[2] if len(sys.argv) > 2 else None
    pts = load(csv_path)
    bd = {(p["n_d"], p["dt"]): p for p in pts if p["cells"] is None}
    print("| n_c | N_d × particles | Δt/λ | r | η_p | error vs FP (2σ) | BDDFS − BD | "
          "B/particle | BD/BDDFS memory | core-s | CPU vs BD |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    diffs = []
    for p in sorted(pts, key=lambda p: (p["cells"] or 0, p["n_d"], -p["dt"])):
        b = bd.get((p["n_d"], p["dt"]))
        if p["cells"] and b:
            d = p["eta"] / b["eta"] - 1.0
            sd = abs(p["eta"] / b["eta"]) * math.hypot(p["se"] / p["eta"], b["se"] / b["eta"])
            diffs.append((p, d, sd))
            diff = f"{100 * d:+.2f} ± {100 * sd:.2f} %"
            mem = f"{b['bytes'] / p['bytes']:.1f}×"
            cpu = f"{100 * (p['core'] / b['core'] - 1):+.0f} %"
        else:
            diff, mem, cpu = "–", "1", "–"
        print(f"| {p['cells'] or 'BD'} | {p['n_d']} × {p['particles']} | {p['dt']:g} | "
              f"{100 * p['r']:.2f} % | {p['eta']:.4f} ± {p['se']:.4f} | "
              f"{100 * p['error']:.2f} % ({100 * 2 * p['stat']:.2f} %) | {diff} | "
              f"{p['bytes']:.0f} | {mem} | {p['core']:.1f} | {cpu} |")
    # The ΔQ²/Δt law: d = c r, c by weighted least squares through the origin, over the points
    # with r ≤ 20 % (the law is first order in r).
    fit = [(p["r"], d, sd) for p, d, sd in diffs if p["r"] <= 0.2]
    if fit:
        sw = sum(r * r / s ** 2 for r, _, s in fit)
        c = sum(r * d / s ** 2 for r, d, s in fit) / sw
        sc = 1 / math.sqrt(sw)
        chi2 = sum(((d - c * r) / s) ** 2 for r, d, s in fit)
        print(f"\nBDDFS − BD = c r over {len(fit)} points with r ≤ 20 %: c = {c:.3f} ± {sc:.3f}, "
              f"χ² = {chi2:.1f} for {len(fit) - 1} degrees of freedom")
    if not png:
        return
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (a, m) = plt.subplots(1, 2, figsize=(12, 5))
    markers = {0.08: "o", 0.04: "s", 0.02: "^", 0.01: "D"}
    cells = sorted({p["cells"] for p, _, _ in diffs})
    for i, nc in enumerate(cells):
        for dt, mk in markers.items():
            sel = [(p["r"], d, sd) for p, d, sd in diffs if p["cells"] == nc and p["dt"] == dt]
            if sel:
                a.errorbar([s[0] for s in sel], [s[1] for s in sel], yerr=[s[2] for s in sel],
                           fmt=mk, color=f"C{i}", ms=5, capsize=2,
                           label=f"n_c = {nc}, Δt = {dt:g}")
    if fit:
        xs = [min(r for r, _, _ in fit), max(r for p, _, _ in diffs for r in [p["r"]])]
        a.plot(xs, [c * x for x in xs], "k-", lw=1, label=f"fit {c:.2f} r (r ≤ 20 %)")
    a.axhspan(-0.01, 0.01, color="0.9", zorder=0)
    a.set_xscale("log")
    a.set_yscale("symlog", linthresh=1e-3)
    a.set_xlabel("r = λΔQ²/(6Δt)")
    a.set_ylabel("(η_p BDDFS − η_p BD) / η_p BD (same N_d, Δt, seed)")
    a.set_title("The grid's bias against r: one line whichever of n_c, Δt sets r", fontsize=9)
    a.legend(fontsize=5, ncol=2)
    for i, nc in enumerate([None] + cells):
        sel = sorted((p["n_d"], p["bytes"]) for p in pts if p["cells"] == nc and p["dt"] == 0.04)
        if sel:
            m.plot(*zip(*sel), "o-", color="k" if nc is None else f"C{i - 1}",
                   label="BD" if nc is None else f"BDDFS n_c = {nc}")
    m.set_xscale("log")
    m.set_yscale("log")
    m.set_xlabel("N_d (dumbbells per particle)")
    m.set_ylabel("stored bytes per particle (end of run, Δt = 0.04)")
    m.set_title("Memory per particle", fontsize=9)
    m.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == "__main__":
    main()
