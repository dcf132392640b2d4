#!/usr/bin/env python3
"""Interleaved A/B of two mesorheo binaries on one case, phase by phase.

Runs A B A B ... (one thread, serial), reads each run's summary.json, and prints per phase the
median of each binary and the median of the pair-by-pair ratios A/B (pairing keeps the ratio
meaningful while the machine's speed drifts). Also prints the digests, which must agree.

    python3 tools/ab_phases.py NEW_BIN OLD_BIN [--runs 7] [--case cases/bench_dpd_32k.toml]

To compare one binary with itself under an environment variable (e.g. MESORHEO_SIMD=portable),
pass a two-line shell wrapper as one of the binaries.
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(binary, case, out):
    subprocess.run([os.path.abspath(binary), "run", case, "--out", out, "--threads", "1", "-q"],
                   check=True, capture_output=True)
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)
    p = s["phase_seconds"]
    return {"loop": s["loop_seconds"], "neighbour": p["neighbour"], "forces": p["forces"],
            "rebuild_comm": p["rebuild_comm"], "digest": s["state_digest"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--runs", type=int, default=7)
    ap.add_argument("--case", default=os.path.join(ROOT, "cases/bench_dpd_32k.toml"))
    args = ap.parse_args()
    results = {"a": [], "b": []}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.runs):
            for side in ("a", "b"):
                results[side].append(run(getattr(args, side), args.case,
                                         os.path.join(tmp, f"{side}{k}")))
    for phase in ("loop", "neighbour", "forces", "rebuild_comm"):
        ma = statistics.median(r[phase] for r in results["a"])
        mb = statistics.median(r[phase] for r in results["b"])
        ratio = statistics.median(x[phase] / y[phase]
                                  for x, y in zip(results["a"], results["b"]))
        print(f"{phase:13s} A {ma:.3f} s  B {mb:.3f} s  median pair ratio A/B {ratio:.3f}")
    digests = {r["digest"] for side in results.values() for r in side}
    print("digests:", ", ".join(sorted(digests)))


if __name__ == "__main__":
    main()
