"""The pictures of a run (mesorheo runs this at the end of `run` and `restart`, rank 0):

    python -c "$(cat src/run_plots.py)" OUT

- OUT/observables.png: every column of OUT/observables.csv against time, one panel each, the
  start-up included, the end of run.equilibration marked, the summary's mean ± standard error
  after it drawn as a band;
- OUT/velocity_profile.png (cases that record "velocity_profile"): the measured u_x(y) with its
  error bars against the case's reference profile (the linear shear profile of Lees–Edwards
  shear, or the one a profile reference gives), and each start-up profile check's bins.

Prints the PNGs written, one a line. Exits 1 with a one-line reason when matplotlib is missing.
"""
import csv
import json
import math
import sys
from pathlib import Path

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as e:
    sys.exit(f"matplotlib is not available to {sys.executable} ({e})")

out = Path(sys.argv[1])
summary = {}
if (out / "summary.json").exists():
    summary = json.loads((out / "summary.json").read_text())
case = summary.get("case", {})
title = case.get("title", out.name)
dt = None
try:
    dt = float(case["integrator"]["dt"])
except (KeyError, TypeError, ValueError):
    pass
equilibration = (case.get("run") or {}).get("equilibration", 0)
observables = summary.get("observables", {})
written = []


def short(text, n=90):
    return text if len(text) <= n else text[: n - 1] + "…"


with open(out / "observables.csv", newline="") as f:
    rows = list(csv.reader(f))
header, rows = rows[0], [r for r in rows[1:] if len(r) == len(rows[0])]
if rows and len(header) > 2:
    time = [float(r[1]) for r in rows]
    names = header[2:]
    columns = min(len(names), 2 if len(names) > 1 else 1)
    lines = math.ceil(len(names) / columns)
    fig, axes = plt.subplots(
        lines, columns, figsize=(6.0 * columns, 2.4 * lines + 0.8), squeeze=False, sharex=True
    )
    for k, name in enumerate(names):
        ax = axes[k // columns][k % columns]
        values = [float(r[k + 2]) for r in rows]
        ax.plot(time, values, lw=0.9, color="C0")
        if dt is not None and equilibration:
            ax.axvline(equilibration * dt, color="0.5", ls="--", lw=0.8)
        o = observables.get(name)
        if isinstance(o, dict) and "mean" in o and dt is not None:
            mean, se = o["mean"], o.get("stderr", 0.0) or 0.0
            t0 = equilibration * dt
            ax.plot([t0, time[-1]], [mean, mean], color="C3", lw=1.2,
                    label=f"mean after equilibration {mean:.5g} ± {se:.2g}")
            ax.fill_between([t0, time[-1]], mean - se, mean + se, color="C3", alpha=0.25)
            ax.legend(fontsize=7, loc="best")
        ax.set_ylabel(name, fontsize=8)
        ax.tick_params(labelsize=7)
    for k in range(len(names), lines * columns):
        axes[k // columns][k % columns].axis("off")
    for ax in axes[-1]:
        ax.set_xlabel("time t (simulation units)", fontsize=8)
    fig.suptitle(short(title) + "\nobservables against time (dashed: end of equilibration)",
                 fontsize=9)
    fig.tight_layout()
    png = out / "observables.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    written.append(png)

profile = summary.get("velocity_profile") or []
startups = [v for v in summary.get("validation", []) if v.get("profile")]
if profile or startups:
    references = [r.get("kind", "") for r in case.get("reference", []) or []]
    has_reference = any("profile" in k for k in references)
    fig, ax = plt.subplots(figsize=(6.0, 4.2))
    if profile:
        y = [p["y"] for p in profile]
        ax.errorbar([p["mean"] for p in profile], y, xerr=[p["stderr"] for p in profile],
                    fmt="o", ms=4, color="C0", label="measured ⟨u_x⟩(y), time average")
        if has_reference:
            ax.plot([p["expected"] for p in profile], y, "-", color="C3",
                    label="reference: " + ", ".join(k for k in references if "profile" in k))
    for k, v in enumerate(startups):
        bins = v["profile"]
        ax.plot([b[1] for b in bins], [b[0] for b in bins], "s", ms=3, color=f"C{k + 1}",
                label=short(f"{v['name']} (measured)", 60))
        ax.plot([b[2] for b in bins], [b[0] for b in bins], "-", color=f"C{k + 1}", lw=0.9,
                label="exact")
    ax.set_xlabel("u_x (simulation units)")
    ax.set_ylabel("y")
    ax.set_title(short(title, 70) + "\nvelocity profile", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    png = out / "velocity_profile.png"
    fig.savefig(png, dpi=110)
    plt.close(fig)
    written.append(png)

for png in written:
    print(png)
