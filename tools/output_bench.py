#!/usr/bin/env python3
"""Output benchmark (called by `./run bench --output`): snapshot and checkpoint write time and
bandwidth vs particle count on 1 and 2 ranks (MPI-IO), and the output overhead of a typical run.

Runs the MPI binary ($MESORHEO_BIN) on the 32k benchmark fluid scaled to N particles, writing
one snapshot frame (position, velocity, image) and one checkpoint, and reads the times from the
summary's phase_seconds (snapshots, checkpoints; rank 0, including the id-order redistribution)
and the sizes from the files. Prints Markdown tables (medians of --repeats runs).
"""
import argparse, json, os, statistics, subprocess, sys, tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("MESORHEO_BIN", os.path.join(ROOT, "target/mpi/release/mesorheo"))
CASE = os.path.join(ROOT, "cases/bench_dpd_32k.toml")


def run(ranks, sets, steps):
    with tempfile.TemporaryDirectory(dir=os.environ.get("BENCH_TMP")) as out:
        cmd = ["mpirun", "-n", str(ranks), "--oversubscribe", "--bind-to", "none", BIN, "run", CASE,
               "--out", out, "-t", "1", "-q", "--steps", str(steps)]
        for s in sets:
            cmd += ["--set", s]
        env = dict(os.environ, RAYON_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
                   OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
        p = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if p.returncode not in (0, 3):
            sys.exit(f"failed: {' '.join(cmd)}\n{p.stderr}")
        with open(os.path.join(out, "summary.json")) as f:
            s = json.load(f)
        size = lambda p: os.path.getsize(p) if os.path.exists(p) else 0
        ck = os.path.join(out, "checkpoints")
        s["snapshot_bytes"] = size(os.path.join(out, "snapshots.h5"))
        s["checkpoint_bytes"] = sum(size(os.path.join(ck, f)) for f in os.listdir(ck)) if os.path.isdir(ck) else 0
        return s


def sized(n):
    side = (n / 3.0) ** (1 / 3)
    return [f"box.lengths=[{side:.6f}, {side:.6f}, {side:.6f}]", "particles.lattice=\"random\"", "run.equilibration=0", "run.sample_every=1"]


def io_table(args):
    print("| particles | ranks | snapshot frame s | snapshot MB/s | checkpoint s | checkpoint MB | checkpoint MB/s |")
    print("|---|---|---|---|---|---|---|")
    for n in [int(float(x)) for x in args.sizes.split(",")]:
        for ranks in (1, 2):
            sets = sized(n) + ["output.snapshot_every=10", "output.checkpoint_at_end=true"]
            rs = [run(ranks, sets, 10) for _ in range(args.repeats)]
            snap = statistics.median(r["phase_seconds"]["snapshots"] for r in rs)
            ckpt = statistics.median(r["phase_seconds"]["checkpoints"] for r in rs)
            sb, cb = rs[0]["snapshot_bytes"], rs[0]["checkpoint_bytes"]
            print(f"| {rs[0]['particles']:.0f} | {ranks} | {snap:.3f} | {sb/1e6/snap:.0f} | {ckpt:.3f} | "
                  f"{cb/1e6:.1f} | {cb/1e6/ckpt:.0f} |", flush=True)


def overhead(args):
    print("\n| run (32 000 particles, 1000 steps) | ranks | loop s (median) | output s | overhead |")
    print("|---|---|---|---|---|")
    for ranks in (1, 2):
        base = [run(ranks, ["output.checkpoint_at_end=false"], 1000) for _ in range(args.repeats)]
        out = [run(ranks, ["output.snapshot_every=100", "output.checkpoint_every=500",
                           "output.checkpoint_at_end=false"], 1000) for _ in range(args.repeats)]
        lb = statistics.median(r["loop_seconds"] for r in base)
        lo = statistics.median(r["loop_seconds"] for r in out)
        wo = statistics.median(r["phase_seconds"]["snapshots"] + r["phase_seconds"]["checkpoints"] for r in out)
        print(f"| no output | {ranks} | {lb:.2f} | – | – |")
        print(f"| snapshot / 100 steps + checkpoint / 500 steps | {ranks} | {lo:.2f} | {wo:.3f} | "
              f"{100*(lo/lb-1):+.1f} % (timed writes: {100*wo/lb:.1f} %) |", flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", default="1e4,1e5,1e6")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    io_table(args)
    overhead(args)
