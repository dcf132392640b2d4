#!/usr/bin/env python3
"""Plots and a Markdown table from the dumbbell speed/accuracy sweep (issue #5).

  cargo run --release --example dumbbell_accuracy > docs/dumbbell_accuracy.csv
  python3 tools/dumbbell_accuracy.py docs/dumbbell_accuracy.csv docs/dumbbell_accuracy.png

Top row: error in η_p/(Gλ), bottom row: error in Ψ₁/(2Gλ²), against the cost of the point
(log-log; the process CPU time, cpu_s, which on a shared machine is the 1-core cost — the wall
time, wall_s, is in the table), one column per knob: N_d, Δt × integrator, control variates, FENE Δt. Filled markers:
|estimate − exact| (Hookean: exact continuum value 1; FENE: Richardson Δt → 0 reference);
open markers of the same colour: the statistical error bar σ of that point. Where the error is
below ~2σ the point is noise-limited; where it is well above σ the error is bias (time step).
The table (stdout) is for docs/validation.md.
"""
import csv, sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def load(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def series(rows):
    """(label, rows) groups within a knob."""
    groups = {}
    for r in rows:
        k = r["knob"]
        if k == "nd":
            label = "Heun, Δt = 0.02λ, 100 particles"
        elif k == "dt":
            label = r["scheme"]
        elif k == "cv":
            label = f"Wi {r['wi']}, N_d {r['n_d']}"
        else:
            label = f"b {r['b']}, Wi {r['wi']}"
        groups.setdefault((k, label), []).append(r)
    return groups


def annotate(r, k):
    if k == "nd":
        return f"N_d={r['n_d']}"
    if k in ("dt", "fene"):
        return f"Δt={r['dt']}"
    return "cv" if r["cv"] == "1" else "plain"


def main():
    rows = load(sys.argv[1])
    out = sys.argv[2] if len(sys.argv) > 2 else "docs/dumbbell_accuracy.png"
    knobs = [("nd", "N_d (Hookean, Wi = 1)"), ("dt", "Δt × integrator (Hookean, Wi = 1)"),
             ("cv", "control variates (Hookean, Heun)"), ("fene", "Δt, FENE semi-implicit")]
    fig, axes = plt.subplots(2, 4, figsize=(19, 9))
    groups = series(rows)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for col, (knob, title) in enumerate(knobs):
        for row, (q, name) in enumerate([("eta", "η_p/(Gλ)"), ("psi1", "Ψ₁/(2Gλ²)")]):
            ax = axes[row][col]
            i = 0
            for (k, label), rs in groups.items():
                if k != knob:
                    continue
                c = colours[i % len(colours)]
                i += 1
                if knob == "cv":
                    for cv, marker in (("0", "o"), ("1", "s")):
                        sub = [r for r in rs if r["cv"] == cv]
                        t = [float(r["cpu_s"]) for r in sub]
                        ax.loglog(t, [max(float(r[q + "_err"]), 1e-6) for r in sub], marker,
                                  color=c, label=f"{label}, {'cv' if cv == '1' else 'plain'} (err)")
                        ax.loglog(t, [float(r[q + "_se"]) for r in sub], marker, mfc="none",
                                  color=c)
                    continue
                t = [float(r["cpu_s"]) for r in rs]
                ax.loglog(t, [max(float(r[q + "_err"]), 1e-6) for r in rs], "o-", color=c,
                          label=f"{label} (err)")
                ax.loglog(t, [float(r[q + "_se"]) for r in rs], "o--", mfc="none", color=c,
                          label=f"{label} (σ)")
                for r in rs:
                    ax.annotate(annotate(r, knob), (float(r["cpu_s"]), max(float(r[q + "_err"]), 1e-6)),
                                fontsize=7, xytext=(3, 3), textcoords="offset points")
            ax.set_title(f"{title}: {name}", fontsize=10)
            ax.set_xlabel("cost per point: CPU s on 1 core")
            ax.set_ylabel(f"error in {name}")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
    fig.suptitle("Dumbbell ensembles in steady shear: error (filled) and statistical σ (open) vs "
                 "1-core CPU time; precision (f32) pending")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    # Markdown table.
    print("| knob | spring | scheme | Wi | Δt/λ | N_d | particles | cv | η_p/(Gλ) ± σ | err | bias "
          "| Ψ₁/(2Gλ²) ± σ | err | bias | wall s | CPU s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        spring = {"hookean": "Hookean", "hookean f32": "Hookean, f32 storage"}.get(
            r["spring"], f"FENE b = {r['b']}")
        bias = lambda v: f"{float(v):+.4f}" if v else "–"
        print(f"| {r['knob']} | {spring} | {r['scheme']} | {r['wi']} | {r['dt']} | {r['n_d']} | "
              f"{r['particles']} | {'on' if r['cv'] == '1' else 'off'} | "
              f"{float(r['eta']):.4f} ± {float(r['eta_se']):.4f} | {float(r['eta_err']):.4f} | "
              f"{bias(r['eta_bias'])} | {float(r['psi1']):.4f} ± {float(r['psi1_se']):.4f} | "
              f"{float(r['psi1_err']):.4f} | {bias(r['psi1_bias'])} | {float(r['wall_s']):.2f} | "
              f"{float(r['cpu_s']):.2f} |")


if __name__ == "__main__":
    main()
