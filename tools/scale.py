#!/usr/bin/env python3
"""Scaling study and benchmark driver for mesorheo (called by `./run scale` and `./run bench`).

Runs the MPI binary ($MESORHEO_BIN) through mpirun with explicit --bind-to none and
RAYON_NUM_THREADS, repeats each point, and prints Markdown tables (medians) to stdout.

  tools/scale.py --bench              32k-particle DPD benchmark: 1 rank, 2 ranks, 1 rank × 2 threads
                                      (+ LAMMPS side by side with --lammps)
  tools/scale.py [--sizes 1e4,1e5]    strong scaling over sizes, weak scaling at 5e4 per rank
"""
import argparse, json, math, os, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("MESORHEO_BIN", os.path.join(ROOT, "target/mpi/release/mesorheo"))
BENCH_CASE = os.path.join(ROOT, "cases/bench_dpd_32k.toml")


def run(ranks, threads, case, sets=(), steps=None):
    with tempfile.TemporaryDirectory() as out:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe", "--bind-to", "none", BIN, "run", case,
               "--out", out, "-t", str(threads), "-q"]
        for s in sets:
            cmd += ["--set", s]
        if steps:
            cmd += ["--steps", str(steps)]
        env = dict(os.environ, RAYON_NUM_THREADS=str(threads), OMPI_ALLOW_RUN_AS_ROOT="1",
                   OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
        p = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if p.returncode not in (0, 3):
            sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
        with open(os.path.join(out, "summary.json")) as f:
            return json.load(f)


def median_point(ranks, threads, case, repeats, sets=(), steps=None):
    rs = [run(ranks, threads, case, sets, steps) for _ in range(repeats)]
    loop = statistics.median(r["loop_seconds"] for r in rs)
    best = min(rs, key=lambda r: abs(r["loop_seconds"] - loop))
    ph = best["phase_seconds"]
    comm = ph["halo"] + ph["rebuild_comm"]
    return {"ranks": ranks, "threads": threads, "loop": loop, "psps": best["particles"] * best["steps"] / loop,
            "particles": best["particles"], "comm_frac": comm / best["loop_seconds"],
            "neigh_frac": ph["neighbour"] / best["loop_seconds"], "force_frac": ph["forces"] / best["loop_seconds"],
            "rebuilds": ph["rebuilds"], "digest": best["state_digest"],
            "pressure": best["observables"].get("pressure", {}).get("mean")}


def bench(args):
    print("| code | ranks × threads | loop s (median) | particle-steps/s | per core | neighbour | forces | halo+migration | p (steps 20–100) |")
    print("|---|---|---|---|---|---|---|---|---|")
    base = None
    for ranks, threads in [(1, 1), (2, 1), (1, 2)]:
        m = median_point(ranks, threads, BENCH_CASE, args.repeats)
        base = base or m
        print(f"| mesorheo | {ranks} × {threads} | {m['loop']:.3f} | {m['psps']:.3e} | {m['psps']/(ranks*threads):.3e} | "
              f"{100*m['neigh_frac']:.0f} % | {100*m['force_frac']:.0f} % | {100*m['comm_frac']:.0f} % | {m['pressure']:.3f} |")
        assert m["digest"] == base["digest"], "digest differs between decompositions"
    if args.lammps:
        script = os.path.join(ROOT, "benches/lammps/run_lammps.sh")
        env = dict(os.environ, REPEATS=str(args.repeats))
        p = subprocess.run([script], env=env, capture_output=True, text=True)
        for line in p.stdout.splitlines():
            if line.startswith("lammps_median"):
                print(f"<!-- {line} -->")
                kv = dict(x.split("=", 1) for x in line.split()[1:] if "=" in x)
                print(f"| LAMMPS | {kv.get('ranks')} × 1 | {float(kv.get('loop_s', 'nan')):.3f} | {float(kv.get('psps', 'nan')):.3e} | "
                      f"{float(kv.get('psps', 'nan'))/int(kv.get('ranks', 1)):.3e} | {kv.get('neigh_pct', '?')} % | | | {kv.get('press100', '?')} (step 100) |")
        if p.returncode != 0:
            print(f"<!-- LAMMPS failed: {p.stderr[-500:]} -->")


def scale(args):
    sizes = [int(float(s)) for s in args.sizes.split(",")]
    print("### Strong scaling (DPD, ρ = 3, Groot–Warren fluid, skin 0.5)\n")
    print("| particles | ranks × threads | steps | loop s | particle-steps/s | efficiency | halo+migration share |")
    print("|---|---|---|---|---|---|---|")
    rows = []
    for n in sizes:
        side = (n / 3.0) ** (1 / 3)
        steps = max(10, int(3e6 / n))
        sets = [f"box.lengths=[{side:.6f}, {side:.6f}, {side:.6f}]", "particles.lattice=\"random\"",
                "run.equilibration=0", f"run.sample_every={steps}", "diagnostics.blocks=2"]
        base = None
        for ranks, threads in [(1, 1), (2, 1), (1, 2)]:
            m = median_point(ranks, threads, BENCH_CASE, args.repeats, sets + [f"run.steps={2*steps}"])
            base = base or m
            eff = base["loop"] / (m["loop"] * ranks * threads)
            rows.append((n, ranks, threads, eff, m["comm_frac"]))
            print(f"| {m['particles']} | {ranks} × {threads} | {2*steps} | {m['loop']:.3f} | {m['psps']:.3e} | {100*eff:.0f} % | {100*m['comm_frac']:.1f} % |")
    print("\n### Weak scaling (5·10⁴ particles per rank)\n")
    print("| particles | ranks | loop s | efficiency |")
    print("|---|---|---|---|")
    base = None
    for ranks in [1, 2]:
        n = 50000 * ranks
        ly = (50000 / 3.0) ** (1 / 3)
        side_y = ly * ranks
        sets = [f"box.lengths=[{ly:.6f}, {side_y:.6f}, {ly:.6f}]", "particles.lattice=\"random\"",
                "run.equilibration=0", "run.sample_every=50", "diagnostics.blocks=2", "run.steps=100"]
        m = median_point(ranks, 1, BENCH_CASE, args.repeats, sets)
        base = base or m
        print(f"| {m['particles']} | {ranks} | {m['loop']:.3f} | {100*base['loop']/m['loop']:.0f} % |")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 3.5))
        for cfg in [(2, 1), (1, 2)]:
            xs = [r[0] for r in rows if (r[1], r[2]) == cfg]
            ys = [100 * r[3] for r in rows if (r[1], r[2]) == cfg]
            ax.semilogx(xs, ys, "o-", label=f"{cfg[0]} ranks × {cfg[1]} threads")
        ax.axhline(90, color="grey", ls=":")
        ax.set_xlabel("particles"); ax.set_ylabel("strong-scaling efficiency (%)"); ax.legend()
        fig.tight_layout(); fig.savefig(os.path.join(ROOT, "docs/scaling.png"), dpi=120)
        print("\n![strong scaling](scaling.png)")
    except ImportError:
        print("\n(matplotlib not installed: no plot)")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--bench", action="store_true")
    ap.add_argument("--lammps", action="store_true")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--sizes", default="1e4,1e5")
    a = ap.parse_args()
    bench(a) if a.bench else scale(a)
