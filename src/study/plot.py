# Error against cost of a `mesorheo study` (embedded in the binary; run as
# python -c SCRIPT study.csv study.png TITLE [TARGET]). Every completed point with its
# statistical error bar, the Pareto front as a line, the recommended point ringed, the target
# tolerance dashed. When the points report their stored ensemble bytes per particle, a second
# panel draws the same errors against memory with the memory/error front.
import csv
import sys

import matplotlib
import matplotlib.transforms

matplotlib.use("Agg")
import matplotlib.pyplot as plt

csv_path, png_path, title = sys.argv[1], sys.argv[2], sys.argv[3]
target = float(sys.argv[4]) if len(sys.argv) > 4 and sys.argv[4] else None
with open(csv_path, newline="") as f:
    reader = csv.reader(f)
    head = next(reader)
    rows = [dict(zip(head, r)) for r in reader]
knobs = head[: head.index("status")]
observables = [h[: -len(":mean")] for h in head if h.endswith(":mean")]
# The reference point itself (error 0) has no place on a log axis.
done = [r for r in rows if r["status"] == "done" and float(r["error"]) > 0]
# The memory panel only where the memory varies (a sweep over N_d or BDDFS grids).
with_memory = bool(done) and all(r.get("bytes_per_particle") for r in done) and \
    len({r["bytes_per_particle"] for r in done}) > 1
axes_spec = [("core_seconds", "pareto", "cost (core-seconds)")]
if with_memory:
    axes_spec.append(("bytes_per_particle", "pareto_memory", "stored ensemble bytes per particle"))
fig, axes = plt.subplots(1, len(axes_spec), figsize=(7 * len(axes_spec), 5), squeeze=False)
for ax, (cost_col, front_col, xlabel) in zip(axes[0], axes_spec):
    for r in done:
        cost = float(r[cost_col])
        err = float(r["error"])
        # The statistical part of the observable that sets the point's error.
        worst = max(observables, key=lambda o: float(r[o + ":error"]))
        stat = float(r[worst + ":statistical"])
        lower = min(stat, err * 0.999)
        ax.errorbar(
            cost,
            err,
            yerr=[[lower], [stat]],
            fmt="o",
            color="C1" if r[front_col] == "1" else "C0",
            ms=5,
            capsize=2,
        )
        if r["recommended"] == "1":
            ax.plot(cost, err, "o", ms=14, mfc="none", mec="C3", mew=1.5, label="recommended")
    front = sorted(
        (float(r[cost_col]), float(r["error"])) for r in done if r[front_col] == "1"
    )
    if front:
        ax.plot(*zip(*front), "-", color="C1", lw=1, label="Pareto front")
    if target is not None:
        ax.axhline(target, ls="--", color="C3", lw=1, label=f"target {target:g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("error (" + ", ".join(observables) + "; largest)")
    ax.set_title(title + "\npoints: " + ", ".join(knobs), fontsize=9)
    ax.legend(fontsize=7)
fig.tight_layout()
# Labels after the layout, so their extents are final: the recommended point first, then the
# Pareto front, then the rest by error; a label that would overlap one already placed (or a
# point's marker) tries three other corners and is left out if all overlap. Every point, labelled
# or not, is a row of study.csv.
fig.canvas.draw()
renderer = fig.canvas.get_renderer()
for ax, (cost_col, front_col, _) in zip(axes[0], axes_spec):
    placed = []
    markers = []
    for r in done:
        x, y = ax.transData.transform((float(r[cost_col]), float(r["error"])))
        markers.append(matplotlib.transforms.Bbox.from_extents(x - 3, y - 3, x + 3, y + 3))
    order = sorted(
        done,
        key=lambda r: (r["recommended"] != "1", r[front_col] != "1", float(r["error"])),
    )
    hidden = 0
    for r in order:
        label = " ".join(r[k] for k in knobs)
        at = (float(r[cost_col]), float(r["error"]))
        for dx, dy, ha, va in ((4, 3, "left", "bottom"), (4, -3, "left", "top"),
                               (-4, 3, "right", "bottom"), (-4, -3, "right", "top")):
            text = ax.annotate(label, at, fontsize=6, xytext=(dx, dy), textcoords="offset points",
                               ha=ha, va=va)
            box = text.get_window_extent(renderer).expanded(1.05, 1.1)
            inside = ax.get_window_extent(renderer).contains(box.x0, box.y0) and \
                ax.get_window_extent(renderer).contains(box.x1, box.y1)
            own = ax.transData.transform(at)
            clash = any(box.overlaps(b) for b in placed) or any(
                box.overlaps(m) for m in markers
                if not (abs(m.x0 + 3 - own[0]) < 1e-6 and abs(m.y0 + 3 - own[1]) < 1e-6))
            if inside and not clash:
                placed.append(box)
                break
            text.remove()
        else:
            hidden += 1
    if hidden:
        ax.text(0.99, 0.01, f"{hidden} labels left out where they would overlap (study.csv lists every point)",
                transform=ax.transAxes, ha="right", va="bottom", fontsize=6, color="0.4")
fig.savefig(png_path, dpi=110)
