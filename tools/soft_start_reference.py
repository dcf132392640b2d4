#!/usr/bin/env python3
"""An independent implementation of the DPD soft start (src/models/dpd/soft_start.rs), for
tests/dpd_soft_start.rs: all-pairs numpy (no cell list), the same descent:

    F_i  = Σ_j (1 − r_ij/r_c)^s̄ e_ij            (r_ij < r_c, minimum image in a periodic box)
    k    = 2 s̄ N_c / (D r_c),  N_c = n V_D(r_c)
    Δx_i = ½ F_i / k, capped at |Δx_i| ≤ r_c/10, then wrapped into the box

Positions: N uniform points from splitmix64(seed) (the test draws the same), in a cubic box of
side L, D = 2 or 3. Prints JSON: the largest Σ_j (1 − r/r_c)^2 over its mean before and after,
and the relaxed positions.

    python3 tools/soft_start_reference.py D L N SEED SWEEPS [S_BAR]
    python3 tools/soft_start_reference.py --trace D L N SEED   (the ratio after 0, 5, 10, 20,
        30, 50 sweeps, and the pairs closer than 0.2 r_c per particle: docs/theory/dpd_soft_start.md)
"""
import json
import math
import sys

import numpy as np

MASK = (1 << 64) - 1


def splitmix64(state):
    state = (state + 0x9E3779B97F4A7C15) & MASK
    z = state
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return state, (z ^ (z >> 31)) >> 11


def uniform_positions(dim, side, n, seed):
    state, out = seed, []
    for _ in range(n * dim):
        state, bits = splitmix64(state)
        out.append(bits / float(1 << 53) * side)
    return np.array(out).reshape(n, dim)


def pair_vectors(x, side):
    d = x[:, None, :] - x[None, :, :]
    d -= side * np.round(d / side)
    r = np.sqrt((d * d).sum(-1))
    return d, r


def largest_weight_ratio(x, side, rc=1.0, s=2.0):
    _, r = pair_vectors(x, side)
    np.fill_diagonal(r, np.inf)
    w = np.where(r < rc, (1 - np.minimum(r, rc) / rc) ** s, 0.0)
    sums = w.sum(1)
    return float(sums.max() / sums.mean())


def relax(x, side, sweeps, s_bar=1.0, rc=1.0):
    n, dim = x.shape
    ball = math.pi * rc**2 if dim == 2 else 4 / 3 * math.pi * rc**3
    k = 2 * s_bar * (n / side**dim * ball) / (dim * rc)
    for _ in range(sweeps):
        d, r = pair_vectors(x, side)
        np.fill_diagonal(r, np.inf)
        inside = r < rc
        w = np.where(inside, (1 - np.minimum(r, rc) / rc) ** s_bar / np.where(inside, r, 1.0), 0.0)
        f = (w[:, :, None] * d).sum(1)
        step = 0.5 * f / k
        length = np.sqrt((step * step).sum(1))
        scale = np.where(length > 0.1 * rc, 0.1 * rc / np.maximum(length, 1e-300), 1.0)
        x = np.mod(x + scale[:, None] * step, side)
    return x


def close_pairs_per_particle(x, side, within=0.2):
    _, r = pair_vectors(x, side)
    np.fill_diagonal(r, np.inf)
    return float((r < within).sum() / 2 / len(x))


def trace(dim, side, n, seed):
    x = uniform_positions(dim, side, n, seed)
    done = 0
    for sweeps in (0, 5, 10, 20, 30, 50):
        x = relax(x, side, sweeps - done)
        done = sweeps
        print(f"{sweeps:3d} sweeps: largest Σ w_D / mean {largest_weight_ratio(x, side):.3f}, "
              f"pairs closer than 0.2 r_c per particle {close_pairs_per_particle(x, side):.4f}")


def main():
    if sys.argv[1] == "--trace":
        trace(int(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]))
        return
    dim, side, n, seed, sweeps = int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), \
        int(sys.argv[4]), int(sys.argv[5])
    s_bar = float(sys.argv[6]) if len(sys.argv) > 6 else 1.0
    x = uniform_positions(dim, side, n, seed)
    before = largest_weight_ratio(x, side)
    y = relax(x, side, sweeps, s_bar)
    print(json.dumps({"before": before, "after": largest_weight_ratio(y, side),
                      "positions": y.ravel().tolist()}))


if __name__ == "__main__":
    main()
