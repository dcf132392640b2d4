#!/usr/bin/env python3
"""The fit behind `check`'s DPD time-step limit (src/models/dpd/time_step.rs, `dpd_limits`).

Reads the measured stability maps (docs/stability/dpd_maps.txt and the CSVs beside it, including
the maps over seeds that measure the scatter of a limit) and the blow-ups of the γ × Δt study
(docs/studies/dpd_gamma_dt.csv), evaluates the limit with the coefficients of src/models/dpd/time_step.rs
(parsed from its `dpd_fit` module, so the two cannot drift), and prints the score: the points
whose limit passes 0.97 × SCATTER_MARGIN × the first unstable step (must be none), the points where the limit
accepts < 80 % of the stable range, the worst and the median fraction.

`--fit N` runs N generations of scipy's differential evolution (best/1/bin; scipy is needed
only here and is not a dependency of the project): it minimises a smooth count of the points
below 80 % minus twice the worst fraction, with a penalty above any feasible cost on an
accepted unstable step (0.5 % is kept for the rounding), over the box `BOUNDS`; the result is
rounded to 3 significant digits and scored again. `--polish T` then runs T seconds of a local
search that keeps every unstable step refused.

Where the coefficients of src/models/dpd/time_step.rs came from: such an evolution over the 101
points measured before the seed maps (seed 1, 800 generations, the same model and cost with a
penalty of 200 × the log of the largest excess); α₂, α₃, the ideal-gas scale and F₂, F₃ scaled
down by 0.5 % steps until the 137 points accepted no unstable step; then `--polish 240 --seed 1`.
On 2026-11-27 the first held-out set (20 maps × seeds 1–3) accepted one unstable step (a 3D
random start, a = 5, γ = 25); it was folded in, RANDOM_START_FRICTION_3D added (0.9 to start
from a feasible point), and `--polish 300 --seed 1` run over the 197 points. The second
held-out set (20 maps) then accepted 4 of its 60 unstable steps: it was folded in,
RANDOM_START_FRICTION_2D and LAMBDA_EXPONENT added (0.62 and 0.6 to start feasible), and
`--polish 240 --seed 1` run over 257 points. The third held-out set (22 maps, chosen before
that refit was evaluated there) accepted 6 of its 66 (13 with the limit before): folded in, both
random-start factors set to 0.52 to start feasible, `--polish 300 --seed 1` over 323 points.
The fourth set then failed on a 3D lattice map (softstart refit, 381 points); the fifth (16 maps) accepted 2 of its 48 unstable steps (2D ideal gas, γ = 18):
folded in (2026-11-27, stab6), SCATTER_MARGIN = 0.9 added (fixed: `evaluate` holds the boundary
without it at 0.97 × every unstable step, so the limit stays ≤ 0.873 ×), c₀ lowered to 0.937
to start feasible, `--polish 240 --seed 1` over 429 points (the current coefficients). The
maps of the current held-out sets (docs/stability/dpd_held_out4.txt, dpd_held_out6.txt) are
refused here: a map of those lists in dpd_maps.txt stops the tool; `--update-csv` writes their
check columns without reading their measured ones. A rerun
of `--fit` from scratch on all points ended worse (17 below 80 % on 137): the search is a tool,
not a proof of the optimum. `tests/extremes.rs` checks the same numbers against the library
itself.

`--update-csv` rewrites the `check_*` columns of the maps' CSVs with the coefficients of
src/models/dpd/time_step.rs (the measured columns are untouched), so the tables of docs/validation.md
(`MESORHEO_STABILITY_TABLES_ONLY=1 ./run validate dpd_stability`) print the current limit.

    python3 tools/dpd_stability_fit.py [--table] [--fit N --seed S] [--polish T] [--update-csv]
"""
import argparse
import csv
import json
import math
import re
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
STOCK = {  # the stock cases' DPD parameters (m = r_c = k_BT = 1, s = 2, s̄ = 1)
    "dpd_equilibrium_2d.toml": dict(dim=2, n=4.0, a=25.0, gamma=4.5, lam=0.65, random=True),
    "dpd_equilibrium_3d.toml": dict(dim=3, n=3.0, a=25.0, gamma=4.5, lam=0.65, random=True),
}
MARGIN = 0.97  # the bisection brackets the boundary to 3 %
# The search box of --fit (MEASURED_LAMBDA is the λ of the maps, not fitted).
BOUNDS = dict(
    ALPHA_2D=(0.9, 1.6), ALPHA_3D=(0.9, 1.6),
    IDEAL_GAS_SCALE=(0.6, 2.0), IDEAL_GAS_FLUCTUATION=(0.0, 0.9), IDEAL_GAS_3D=(0.7, 1.6),
    REPULSION_GAIN_2D=(1.5, 5.0), REPULSION_GAIN_3D=(1.5, 5.0), REPULSION_SCALE_KT=(3.0, 80.0),
    THERMAL_RELIEF_2D=(0.0, 40.0), THERMAL_RELIEF_3D=(0.0, 40.0),
    THERMAL_RELIEF_SCALE_KT=(1.0, 200.0), RELIEF_EXPONENT=(0.3, 1.0),
    RANDOM_START_RELIEF=(1.0, 5.0), RANDOM_START_THERMAL=(0.0, 1.0),
    RANDOM_START_FRICTION_2D=(0.4, 1.0), RANDOM_START_FRICTION_3D=(0.4, 1.0),
    LAMBDA_EXPONENT=(0.5, 1.2),
    FREE_FLIGHT_2D=(0.15, 0.3), FREE_FLIGHT_3D=(0.15, 0.3),
    NORM_EXPONENT=(1.5, 10.0), FREE_FLIGHT_EXPONENT=(1.5, 10.0),
)


def coefficients():
    text = (ROOT / "src/models/dpd/time_step.rs").read_text()
    body = text[text.index("mod dpd_fit {"):]
    body = body[: body.index("\n}")]
    return {k: float(v) for k, v in re.findall(r"pub const (\w+): f64 = ([0-9.eE+-]+);", body)}


# The held-out sets (the fourth and sixth are held out now: the second, third and fifth were folded
# in after they were reported, see the module doc).
HELD_OUT = [ROOT / "docs/stability/dpd_held_out4.txt", ROOT / "docs/stability/dpd_held_out6.txt"]


def held_out_names():
    """The names of the held-out maps (only their first column: their points are never read)."""
    return {line.split("|")[0].strip() for path in HELD_OUT for line in path.read_text().splitlines()
            if line.strip() and not line.startswith("#")}


def points(manifest="dpd_maps.txt", measured=True):
    """The points of the maps of docs/stability/`manifest`. `measured = False` (only for
    `--update-csv` on the held-out maps) reads each point's parameters and none of its
    measured columns."""
    out = []
    refused = held_out_names() if measured else set()
    for line in (ROOT / "docs/stability" / manifest).read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        name, case, over, _, fixed = [x.strip() for x in line.split("|")]
        if name in refused:
            raise SystemExit(f"{name} is a held-out map (docs/stability/dpd_held_out4.txt or _6.txt): the fit "
                             "does not read it; move it to dpd_maps.txt only after reporting it")
        p = dict(STOCK[case])
        sweeps = 30  # fluid.soft_start_sweeps's default
        for kv in fixed.split():
            k, v = kv.split("=", 1)
            key = {"fluid.gamma": "gamma", "fluid.a": "a", "integrator.lambda": "lam",
                   "particles.density": "n"}.get(k)
            if key:
                p[key] = float(v)
            elif k == "particles.lattice":
                p["random"] = False
            elif k == "fluid.soft_start_sweeps":
                sweeps = int(v)
        # "random" is the raw uniform placement, which carries the start's margin: a random
        # start with the soft start (the default, fluid.soft_start_sweeps > 0) takes the
        # steady-state limit of a lattice start (src/models/dpd/soft_start.rs).
        p["start"] = ("lattice" if not p["random"] else
                      "soft-started random" if sweeps > 0 else "raw random")
        if p["random"] and sweeps > 0:
            p["random"] = False
        knob = over.split("=")[0]
        with open(ROOT / f"docs/stability/{name}.csv", newline="") as f:
            for row in csv.DictReader(f):
                q = dict(p, name=name, stable=float(row["largest_stable"]) if measured else None,
                         unstable=float(row["smallest_unstable"]) if measured else math.nan)
                if knob in ("fluid.a", "fluid.gamma"):  # a map over seeds keeps the physics
                    q["a" if knob == "fluid.a" else "gamma"] = float(row[knob])
                out.append(q)
    if not measured:
        return out
    # The study's blow-ups (1500-step runs of the stock 2D case): only the unstable side.
    study = {}
    with open(ROOT / "docs/studies/dpd_gamma_dt.csv", newline="") as f:
        for row in csv.DictReader(f):
            if row["status"] == "unstable":
                g, dt = float(row["fluid.gamma"]), float(row["integrator.dt"])
                study[g] = min(study.get(g, math.inf), dt)
    for g, dt in study.items():
        out.append(dict(STOCK["dpd_equilibrium_2d.toml"], gamma=g, name="study",
                        start="raw random", stable=None, unstable=dt))
    return out


def arrays(pts):
    col = lambda k: np.array([float(p[k]) for p in pts])
    return dict(dim=col("dim"), n=col("n"), a=np.maximum(col("a"), 0.0), gamma=col("gamma"),
                lam=col("lam"), random=np.array([bool(p["random"]) for p in pts]),
                stable=np.array([np.nan if p["stable"] is None else p["stable"] for p in pts]),
                unstable=col("unstable"))


def relief_root(rate, coef, relief, q):
    """The smallest Δt > 0 with rate Δt = coef (1 + (relief Δt)^q), by bisection (∞ where
    rate ≤ 0; q ≤ 1 makes the root unique)."""
    lo, hi = np.zeros_like(rate), np.full_like(rate, 1e-6)
    ok = rate > 0
    f = lambda t: rate * t - coef * (1 + (relief * t) ** q)
    for _ in range(80):  # bracket by doubling
        grow = ok & (f(hi) <= 0)
        if not grow.any():
            break
        lo, hi = np.where(grow, hi, lo), np.where(grow, 2 * hi, hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        up = f(mid) > 0
        lo, hi = np.where(up, lo, mid), np.where(up, mid, hi)
    return np.where(ok, lo, np.inf)


def limit(x, c):
    """`dpd_limits(..).combined` of src/models/dpd/time_step.rs (explicit thermostat, m = r_c = k_BT = 1)
    at every point of `x` (from `arrays`)."""
    d2 = x["dim"] == 2
    a, n, lam = x["a"], x["n"], x["lam"]
    with np.errstate(divide="ignore"):
        sum_wd = np.where(d2, n * 2 * math.pi / 12, n * 8 * math.pi / 60)
        neighbours = n * np.where(d2, math.pi, 4 / 3 * math.pi)
        cage = np.sqrt(a * neighbours / x["dim"])
        alpha = np.where(d2, c["ALPHA_2D"], c["ALPHA_3D"])
        conservative = np.where(cage > 0, alpha / np.where(cage > 0, cage, 1.0), np.inf)
        friction = x["gamma"] * sum_wd
        ideal = (c["IDEAL_GAS_SCALE"]
                 * np.maximum(1 - c["IDEAL_GAS_FLUCTUATION"] / np.sqrt(sum_wd), 0.1)
                 * np.where(d2, 1.0, c["IDEAL_GAS_3D"]))
        gain = np.where(d2, c["REPULSION_GAIN_2D"], c["REPULSION_GAIN_3D"])
        lam_factor = (c["MEASURED_LAMBDA"] / np.maximum(lam, 0.5)) ** c["LAMBDA_EXPONENT"]
        coef = ideal * (gain - (gain - 1) * np.exp(-a / c["REPULSION_SCALE_KT"])) * lam_factor
        relief = (np.where(d2, c["THERMAL_RELIEF_2D"], c["THERMAL_RELIEF_3D"])
                  * np.exp(-a / c["THERMAL_RELIEF_SCALE_KT"]))
        q = c["RELIEF_EXPONENT"]
        dissipative = relief_root(friction, coef, relief, q)
        rs = x["random"] & d2
        start = relief_root(np.where(rs, friction - c["RANDOM_START_RELIEF"] * cage, 0.0),
                            ideal * lam_factor, relief * c["RANDOM_START_THERMAL"], q)
        dissipative = np.minimum(dissipative, start)
        dissipative = dissipative * np.where(x["random"] & ~d2, c["RANDOM_START_FRICTION_3D"],
                                             np.where(x["random"], c["RANDOM_START_FRICTION_2D"], 1.0))
        free = np.where(d2, c["FREE_FLIGHT_2D"], c["FREE_FLIGHT_3D"])
        p, p2 = c["NORM_EXPONENT"], c["FREE_FLIGHT_EXPONENT"]
        inner = (conservative ** -p + dissipative ** -p) ** (-1 / p)
        return c.get("SCATTER_MARGIN", 1.0) * (inner ** -p2 + free ** -p2) ** (-1 / p2)


def evaluate(x, c):
    """(limit / (0.97 × SCATTER_MARGIN × unstable) at every point, accepted fraction at every
    map point). The fitted boundary (the limit without its scatter margin) must stay below
    0.97 × every unstable step; the margin is fixed, never fitted (the search would otherwise
    spend it on the fitted points)."""
    lim = limit(x, c)
    st = ~np.isnan(x["stable"])
    bound = MARGIN * c.get("SCATTER_MARGIN", 1.0) * x["unstable"]
    return lim / bound, np.minimum(lim[st], x["stable"][st]) / x["stable"][st]


def describe(x, c):
    excess, frac = evaluate(x, c)
    if excess.max() > 1:
        return (f"accepts an unstable step ({excess.max():.3f} × 0.97 × SCATTER_MARGIN × the "
                f"first unstable)")
    return (f"{int((frac < 0.8).sum())} below 80 %, worst {frac.min():.3f}, "
            f"median {np.median(frac):.3f}; largest limit / unstable "
            f"{(limit(x, c) / x['unstable']).max():.3f}")


def by_start(pts, x, c):
    """The accepted fraction of the stable range by start: median, worst, count below 80 %."""
    lim = limit(x, c)
    lines = []
    for kind in ("lattice", "soft-started random", "raw random"):
        sel = [i for i, p in enumerate(pts) if p["stable"] is not None and p["start"] == kind]
        if not sel:
            continue
        frac = np.minimum(lim[sel], x["stable"][sel]) / x["stable"][sel]
        lines.append(f"  {kind}: {len(sel)} points, median {np.median(frac):.3f}, worst "
                     f"{frac.min():.3f}, {int((frac < 0.8).sum())} below 80 %")
    return "\n".join(lines)


def fit(x, c0, generations, seed):
    keys = list(BOUNDS)
    lo = np.array([BOUNDS[k][0] for k in keys])
    hi = np.array([BOUNDS[k][1] for k in keys])

    def cost(v):
        c = dict(c0, **dict(zip(keys, v)))
        excess, frac = evaluate(x, c)
        soft_count = (1 / (1 + np.exp((frac - 0.8) / 0.01))).sum()
        # Infeasible (an unstable step accepted, with 0.5 % left for the rounding) costs more
        # than any feasible point.
        over = max(0.0, math.log(excess.max() / 0.995))
        return soft_count - 2 * frac.min() + (1000 * over + 200 if over > 0 else 0)

    # scipy is needed only here (it is not a dependency of the project: `pip install scipy`).
    from scipy.optimize import differential_evolution

    result = differential_evolution(cost, list(zip(lo, hi)), seed=seed, maxiter=generations,
                                    popsize=20, tol=1e-9, polish=False)
    best = result.x
    return dict(c0, **{k: float(f"{v:.3g}") for k, v in zip(keys, best)})


def update_csv(c):
    """Rewrites the check columns of every map's CSV with the limit of coefficients `c`: the
    fitted maps and the held-out ones (whose measured columns are copied, never read here)."""
    manifests = [(ROOT / "docs/stability/dpd_maps.txt", True)] + [(h, False) for h in HELD_OUT]
    for manifest, measured in manifests:
        update_csv_of(c, manifest, measured)


def update_csv_of(c, manifest, measured):
    every = points(manifest.name, measured)
    for line in manifest.read_text().splitlines():
        if line.startswith("#") or not line.strip():
            continue
        name = line.split("|")[0].strip()
        path = ROOT / f"docs/stability/{name}.csv"
        with open(path, newline="") as f:
            reader = csv.DictReader(f)
            fields, rows = reader.fieldnames, list(reader)
        pts = [p for p in every if p["name"] == name]
        assert len(pts) == len(rows), name
        for row, lim in zip(rows, limit(arrays(pts), c)):
            stable, unstable = float(row["largest_stable"]), float(row["smallest_unstable"])
            row["check_limit"] = f"{lim:.6e}"
            row["check_refuses_unstable"] = str(int(lim < unstable))
            row["check_accepts_fraction"] = f"{min(lim / stable, 1.0):.4f}"
        with open(path, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fields, lineterminator="\n")
            w.writeheader()
            w.writerows(rows)


def polish(x, c, seconds, seed):
    """Local search from `c`: perturb 1–4 coefficients by a few per cent, round to 3
    significant digits, keep the result if it accepts no unstable step and scores better
    (fewer points below 80 %, then a better worst point, then a better median)."""
    import time

    def score(c):
        excess, frac = evaluate(x, c)
        if excess.max() > 1:
            return None
        return (int((frac < 0.8).sum()), -frac.min(), -float(np.median(frac)))

    rng = np.random.default_rng(seed)
    keys = [k for k in BOUNDS]
    best, s = dict(c), score(c)
    start = time.time()
    while time.time() - start < seconds:
        t = dict(best)
        for k in rng.choice(keys, rng.integers(1, 5), replace=False):
            t[k] = min(t[k] * math.exp(rng.normal(0, 0.04)), BOUNDS[k][1])
        t = {k: float(f"{v:.3g}") for k, v in t.items()}
        r = score(t)
        if r is not None and (s is None or r < s):
            best, s = t, r
    return best


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--table", action="store_true", help="print every point")
    ap.add_argument("--fit", type=int, default=0, help="generations of the evolution")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--polish", type=float, default=0,
                    help="seconds of local search from the coefficients (after --fit)")
    ap.add_argument("--update-csv", action="store_true",
                    help="rewrite the check columns of the maps' CSVs")
    args = ap.parse_args()
    pts = points()
    x = arrays(pts)
    c = coefficients()
    n_maps = int((~np.isnan(x["stable"])).sum())
    print(f"{n_maps} map points + {len(pts) - n_maps} study blow-ups; src/models/dpd/time_step.rs: "
          f"{describe(x, c)}")
    print(by_start(pts, x, c))
    if args.table:
        lim = limit(x, c)
        for p, l in zip(pts, lim):
            frac = "" if p["stable"] is None else f"{min(l, p['stable']) / p['stable']:.2f}"
            print(f"{p['name']:28s} d={p['dim']} a={p['a']:6.1f} γ={p['gamma']:7.3f} "
                  f"limit={l:.4g} limit/unstable={l / p['unstable']:.3f} accepts={frac}")
    if args.update_csv:
        update_csv(c)
    if args.fit or args.polish:
        best = fit(x, c, args.fit, args.seed) if args.fit else c
        if args.polish:
            best = polish(x, best, args.polish, args.seed)
        print("best found:", describe(x, best))
        print(by_start(pts, x, best))
        print(json.dumps(best))


if __name__ == "__main__":
    main()
