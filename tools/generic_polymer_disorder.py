#!/usr/bin/env python3
"""Particle disorder of a Lees–Edwards run: velocity fluctuations about the imposed profile.

Reads the H5MD snapshots of a 2D sheared run (`output.snapshot_every > 0`, fields position and
velocity) and prints, per frame, the rms of u = v − γ̇(y − L/2) x̂ and the fraction of Σ|û_k|²
in shells of |m| (k = 2πm/L; white particle noise spreads over all shells, |m| ≥ 8 holds
≈ 3 of it for 400 particles because the shells alias), then the mean profile ⟨v_x⟩(y) with
the rms of u_x and v_y per bin over the last two thirds of the frames.
Used for docs/validation.md ("GENERIC polymer fluid particle", the T1 diagnosis).

    python3 tools/generic_polymer_disorder.py OUT/snapshots.h5 BOX_LENGTH SHEAR_RATE
"""
import sys

import h5py
import numpy as np


def main():
    path, box, shear = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    f = h5py.File(path, "r")
    group = f["particles"][list(f["particles"].keys())[0]]
    pos = group["position/value"][:]
    vel = group["velocity/value"][:]
    time = group["position/time"][:]
    m = np.arange(-20, 21)
    mx, my = np.meshgrid(m, m, indexing="ij")
    kk = np.hypot(mx.ravel(), my.ravel())
    shells = [(0.5, 1.5), (1.5, 3.5), (3.5, 7.5), (7.5, 20.5)]
    for n in range(len(time)):
        x = pos[n] % box
        u = vel[n].copy()
        u[:, 0] -= shear * (x[:, 1] - box / 2)
        phase = np.exp(-2j * np.pi * (np.outer(x[:, 0], mx.ravel()) + np.outer(x[:, 1], my.ravel())) / box)
        energy = np.abs((u[:, 0:1] * phase).mean(0)) ** 2 + np.abs((u[:, 1:2] * phase).mean(0)) ** 2
        total = (u**2).sum(1).mean()
        parts = " ".join(f"[{a},{b}):{energy[(kk >= a) & (kk < b)].sum() / total:.3f}" for a, b in shells)
        print(f"t = {time[n]:.2f}  u_rms = {np.sqrt(total):.3e}  |m| shells {parts}")
    bins = 10
    acc = np.zeros((bins, 4))
    count = np.zeros(bins)
    for n in range(len(time) // 3, len(time)):
        x = pos[n] % box
        v = vel[n]
        b = np.minimum((x[:, 1] / box * bins).astype(int), bins - 1)
        ux = v[:, 0] - shear * (x[:, 1] - box / 2)
        for k in range(bins):
            s = b == k
            count[k] += s.sum()
            acc[k] += [ux[s].sum(), (ux[s] ** 2).sum(), (v[s, 1] ** 2).sum(), v[s, 0].sum()]
    for k in range(bins):
        mean = acc[k] / count[k]
        y = (k + 0.5) / bins * box
        print(
            f"y = {y:.3f}  <v_x> = {mean[3]:+.4f} (profile {shear * (y - box / 2):+.4f})  "
            f"u_x rms = {np.sqrt(mean[1] - mean[0] ** 2):.4f}  v_y rms = {np.sqrt(mean[2]):.4f}"
        )


if __name__ == "__main__":
    main()
