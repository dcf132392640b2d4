#!/usr/bin/env python3
"""Shear viscosity of a LAMMPS Lees–Edwards run (benches/lammps/in.dpd_shear): reads the
pxy.dat files that fix ave/time wrote (step, T, P_xx, P_yy, P_zz, P_xy every 10 steps) and
prints η = −⟨P_xy⟩/γ̇, N₁ = P_yy − P_xx... as averages with block standard errors.

    tools/lammps_viscosity.py RUN_DIR/pxy.dat [MORE.dat ...] [--rate 0.2] [--blocks 20]

Several files (independent seeds) are pooled as independent blocks. Sign convention: the
pressure tensor P = −σ, so η = −P_xy/γ̇, N₁ = σ_xx − σ_yy = P_yy − P_xx, N₂ = P_zz − P_yy.
"""
import argparse
import math


def read(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            rows.append([float(x) for x in line.split()])
    return rows


def block_means(values, blocks):
    n = len(values) // blocks
    return [sum(values[b * n:(b + 1) * n]) / n for b in range(blocks)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+")
    ap.add_argument("--rate", type=float, default=0.2)
    ap.add_argument("--blocks", type=int, default=20, help="blocks per file")
    args = ap.parse_args()
    series = {"k_BT": lambda r: r[1], "p": lambda r: (r[2] + r[3] + r[4]) / 3,
              "eta": lambda r: -r[5] / args.rate, "N1": lambda r: r[3] - r[2], "N2": lambda r: r[4] - r[3]}
    samples = 0
    means = {k: [] for k in series}
    for path in args.files:
        rows = read(path)
        samples += len(rows)
        for k, f in series.items():
            means[k] += block_means([f(r) for r in rows], args.blocks)
    print(f"{len(args.files)} run(s), {samples} samples, {len(means['eta'])} blocks")
    for k, m in means.items():
        mean = sum(m) / len(m)
        var = sum((x - mean) ** 2 for x in m) / (len(m) - 1)
        print(f"{k} = {mean:.5f} ± {math.sqrt(var / len(m)):.5f}")


if __name__ == "__main__":
    main()
