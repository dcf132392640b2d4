#!/usr/bin/env python3
r"""Fixed rigid disc in a Lees–Edwards (sheared-periodic) Stokes cell: an independent reference.

Written from the equations only (numpy, no scipy, nothing from the solver under test).
Derivation and references: docs/theory/stokes_inclusion_cell.md.

Problem
-------
2D incompressible Stokes flow, viscosity η, in a square cell of side L with Lees–Edwards
boundary conditions at shear rate γ̇:

    u(x) = γ̇ (y − L/2) x̂ + u'(x),   u', p periodic on the lattice a1 = (L, 0), a2 = (s, L),

s ∈ [0, L) being the Lees–Edwards offset (quasi-static: the solution depends on s only).
A rigid, fixed, non-rotating disc of radius R at c = (L/2, L/2) with u = 0 on |x − c| = R.
Stress convention: σ_ij = −p δ_ij + η(∂_j u_i + ∂_i u_j); the traction on a surface with unit
normal n is t_i = σ_ij n_j.  So σ_xy is the x-force per length transmitted across a line
y = const (the x-momentum flux across y-planes).

Method: method of fundamental solutions (MFS) with the periodic Stokeslet
------------------------------------------------------------------------
    u(x) = γ̇ (y − L/2) x̂ + U + Σ_k G(x − y_k) · F_k,     Σ_k F_k = F_tot (= 0 in shear),

with M point forces F_k (force on the fluid) at y_k = c + ρR(cos φ_k, sin φ_k) inside the disc,
a free uniform velocity U, and G the doubly periodic Stokeslet with zero cell mean:

    G(x) = (1/(ηA)) Σ_{k ≠ 0} (I − k̂k̂)/k² e^{ik·x},   k = m1 b1 + m2 b2,  a_i·b_j = 2π δ_ij,

(A = L²; the k = 0 mode is absent, i.e. a net force F_tot is balanced by a uniform body force
−F_tot/A = a mean pressure gradient).  It is summed by Ewald/Hasimoto splitting with parameter ξ:

    G = Σ_n G^r(x − x_n) + G^k(x),
    G^r(r) = (1/(4πη)) [ I (½E1(ξ²r²) − e^{−ξ²r²}) + (r r / r²) e^{−ξ²r²} ],
    G^k(x) = (1/(ηA)) Σ_{k≠0} (I − k̂k̂)/k² (1 + k²/(4ξ²)) e^{−k²/(4ξ²)} e^{ik·x}.

The no-slip condition u = 0 is imposed in the least-squares sense at N ≥ M points on |x − c| = R
(the MFS field is smooth there; convergence in M is geometric).

Observables (t = σ·n, n pointing out of the disc into the fluid, t = traction of fluid on disc)
----------------------------------------------------------------------------------------
Because u = 0 on the surface and the MFS continuation inside the disc is a Stokes flow forced
only by the F_k, the divergence theorem gives exactly, for the off-diagonal moments,

    ∮ t_i (x_j − c_j) dS = −Σ_k F_{k,i} (y_{k,j} − c_j)      (i ≠ j).

    torque                T   = ∮ [(x − c_x) t_y − (y − c_y) t_x] dS
    stresslet             S_xy = ½ ∮ [t_x (y − c_y) + t_y (x − c_x)] dS
    Batchelor (1970)      ⟨σ_xy⟩ = η γ̇ + (1/A) ∮ t_x (y − c_y) dS = η γ̇ + S_xy/A − T/(2A)
    η_eff = ⟨σ_xy⟩/γ̇ = η + S_xy/(Aγ̇) [stresslet part] − T/(2Aγ̇) [torque part]

(⟨σ_yx⟩ = ηγ̇ + S_xy/A + T/(2A) is the y-momentum flux across x-planes; the two differ by −T/A.)
The self-test checks these against the traction integrated on the circle and against the
momentum flux through the line y = 0 computed from the velocity gradient of the field.

Dilute limit (isolated disc, Jeffery/Einstein in 2D): T → −2πηR²γ̇, S_xy → 2πηR²γ̇, hence
η_eff → η(1 + 2φ + φ) = η(1 + 3φ), φ = πR²/A.

Usage
-----
    python3 tools/stokes_inclusion_cell.py              # table for R = 0.1, 0.15, 0.2
    python3 tools/stokes_inclusion_cell.py --json       # same, JSON on stdout
    python3 tools/stokes_inclusion_cell.py --selftest   # checks, exit status 1 on failure
    python3 tools/stokes_inclusion_cell.py --radius 0.3 --ns 32   # other radii / s grids
"""
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # modest CPU use: single-threaded BLAS

import argparse
import json
import math
import sys
import time

import numpy as np

EULER_GAMMA = 0.57721566490153286061
EWALD_CUT = 42.0  # real-space terms kept while ξ²r² < 42, k-space while k²/(4ξ²) < 42 (e^-42 ≈ 6e-19)


# --------------------------------------------------------------------------------------------
# Exponential integral E1 (numpy has none)
# --------------------------------------------------------------------------------------------
def expint_e1(x):
    r"""E1(x) = ∫_x^∞ e^{−t}/t dt for x > 0, to ~1e-15 relative.

    x ≤ 2:  E1 = −γ − ln x + Σ_{n≥1} (−1)^{n+1} x^n / (n n!)   (30 terms)
    x > 2:  E1 = e^{−x} / (x + 1 − 1²/(x + 3 − 2²/(x + 5 − 3²/(x + 7 − …))))   (60 levels)
    """
    x = np.asarray(x, dtype=float)
    out = np.empty_like(x)
    lo = x <= 2.0
    if np.any(lo):
        xs = x[lo]
        term = xs.copy()  # x^n / n!
        acc = xs.copy()  # Σ (−1)^{n+1} x^n/(n n!)
        for n in range(2, 31):
            term = term * xs / n
            acc += (-1.0) ** (n + 1) * term / n
        out[lo] = -EULER_GAMMA - np.log(xs) + acc
    hi = ~lo
    if np.any(hi):
        xh = x[hi]
        t = np.zeros_like(xh)
        for k in range(60, 0, -1):
            t = k * k / (xh + 2 * k + 1 - t)
        out[hi] = np.exp(-xh) / (xh + 1.0 - t)
    return out


def expint_e1_quadrature(x, h=0.01):
    r"""Independent E1 for testing: E1(x) = ∫_{−∞}^{∞} e^{−x(1+e^v)} e^v/(1+e^v) dv (t = 1 + e^v),
    trapezoidal rule (exponentially accurate for this analytic, rapidly decaying integrand)."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    v = np.arange(-45.0, math.log(60.0 / x.min()), h)
    ev = np.exp(v)
    f = np.exp(-x[:, None] * (1.0 + ev[None, :])) * (ev / (1.0 + ev))[None, :]
    return h * f.sum(axis=1)


# --------------------------------------------------------------------------------------------
# Doubly periodic Stokeslet on the sheared lattice (Hasimoto/Ewald)
# --------------------------------------------------------------------------------------------
class PeriodicStokeslet:
    r"""G, ∇G and the pressure kernel of the periodic Stokeslet on a1 = (L,0), a2 = (s,L).

    u(x) = G(x)·F, p(x) = P(x)·F for a lattice of point forces F (on the fluid) at the lattice
    points plus a uniform body force −F/A; cell means ⟨u⟩ = 0, ⟨p⟩ = 0.

    Real space (per image, r = x − x_n, E = e^{−ξ²r²}):
        G^r_ij = (1/4πη) [δ_ij g1 + r_i r_j g2],  g1 = ½E1(ξ²r²) − E,  g2 = E/r²
        ∂_l G^r_ij = (1/4πη) [δ_ij r_l g1'/r + (δ_il r_j + δ_jl r_i) g2 + r_i r_j r_l g2'/r],
            g1'/r = E (2ξ² − 1/r²),   g2'/r = −2E (ξ²/r² + 1/r⁴)
        P^r = r E / (2π r²)
    Reciprocal space (sum over half the k-lattice, doubled; q = k²/(4ξ²)):
        G^k = (2/ηA) Σ (I − k̂k̂)(1 + q) e^{−q}/k² cos(k·x)
        ∂_l G^k = −(2/ηA) Σ (I − k̂k̂)(1 + q) e^{−q}/k² k_l sin(k·x)
        P^k = (2/A) Σ k e^{−q}/k² sin(k·x)
    Derivation: 1 − (1 + q)e^{−q} = ∫_0^{a} a' k⁴ e^{−a'k²} da' (a = 1/4ξ²) turns the real-space
    biharmonic kernel into a Gaussian superposition; see the theory note.
    """

    def __init__(self, s, L=1.0, eta=1.0, xi=None, cut=EWALD_CUT):
        self.L, self.s, self.eta = float(L), float(s), float(eta)
        self.A = self.L * self.L
        self.xi = float(xi) if xi is not None else math.sqrt(math.pi) / self.L
        self.lat = np.array([[self.L, 0.0], [self.s, self.L]])  # rows a1, a2
        self.rec = 2.0 * math.pi * np.linalg.inv(self.lat).T  # rows b1, b2
        self.lat_inv = np.linalg.inv(self.lat)
        # Real-space images: after reduction |d| ≤ ½(|a1| + |a2|)
        dmax = 0.5 * (np.linalg.norm(self.lat[0]) + np.linalg.norm(self.lat[1]))
        reach = math.sqrt(cut) / self.xi + dmax
        K = int(math.ceil(reach / (self.L * 0.7))) + 2
        n1, n2 = np.meshgrid(np.arange(-K, K + 1), np.arange(-K, K + 1), indexing="ij")
        pts = n1.ravel()[:, None] * self.lat[0] + n2.ravel()[:, None] * self.lat[1]
        self.images = pts[np.hypot(pts[:, 0], pts[:, 1]) <= reach]
        self.cut = cut
        # Reciprocal vectors, half plane (k and −k paired)
        kc = 2.0 * self.xi * math.sqrt(cut)
        Kk = int(math.ceil(kc / (2.0 * math.pi / self.L) * 1.5)) + 2
        m1, m2 = np.meshgrid(np.arange(0, Kk + 1), np.arange(-Kk, Kk + 1), indexing="ij")
        m1, m2 = m1.ravel(), m2.ravel()
        half = (m1 > 0) | ((m1 == 0) & (m2 > 0))
        kv = m1[half, None] * self.rec[0] + m2[half, None] * self.rec[1]
        k2 = (kv ** 2).sum(axis=1)
        keep = k2 <= kc * kc
        self.kvec, k2 = kv[keep], k2[keep]
        q = k2 / (4.0 * self.xi ** 2)
        w = 2.0 / (self.eta * self.A) * (1.0 + q) * np.exp(-q) / k2
        kx, ky = self.kvec[:, 0], self.kvec[:, 1]
        self.kxx = w * (1.0 - kx * kx / k2)
        self.kxy = w * (-kx * ky / k2)
        self.kyy = w * (1.0 - ky * ky / k2)
        self.kp = 2.0 / self.A * np.exp(-q) / k2

    def reduce(self, d):
        """Map separation vectors into the lattice cell centred on the origin."""
        c = d @ self.lat_inv
        c -= np.round(c)
        return c @ self.lat

    CHUNK = 8192  # separations per block (bounds memory: block × images × 8 B × a few)

    def _blocks(self, fn, d):
        d = np.atleast_2d(np.asarray(d, dtype=float))
        parts = [fn(d[i: i + self.CHUNK]) for i in range(0, d.shape[0], self.CHUNK)]
        if isinstance(parts[0], tuple):
            return tuple(np.concatenate(p) for p in zip(*parts))
        return np.concatenate(parts)

    def G(self, d):
        """Periodic Stokeslet: (Gxx, Gxy, Gyy) arrays for separations d (n, 2)."""
        return self._blocks(self._G, d)

    def gradG(self, d):
        """∂_l G_ij as an array (n, 2, 2, 2) indexed [., i, j, l]."""
        return self._blocks(self._gradG, d)

    def P(self, d):
        """Pressure kernel (n, 2): p = P·F."""
        return self._blocks(self._P, d)

    def _real_space(self, d):
        """Per-image separations r (n, nimg, 2), r² and the mask of retained terms."""
        r = d[:, None, :] - self.images[None, :, :]
        r2 = (r ** 2).sum(axis=2)
        mask = self.xi ** 2 * r2 < self.cut
        return r, r2, mask

    def _G(self, d):
        d = self.reduce(np.atleast_2d(d))
        r, r2, mask = self._real_space(d)
        rm, r2m = r[mask], r2[mask]
        x = self.xi ** 2 * r2m
        E = np.exp(-x)
        g1 = 0.5 * expint_e1(x) - E
        g2 = E / r2m
        c = 1.0 / (4.0 * math.pi * self.eta)
        out = []
        for val in (g1 + rm[:, 0] ** 2 * g2, rm[:, 0] * rm[:, 1] * g2, g1 + rm[:, 1] ** 2 * g2):
            full = np.zeros(r2.shape)
            full[mask] = val
            out.append(c * full.sum(axis=1))
        cosk = np.cos(d @ self.kvec.T)
        out[0] += cosk @ self.kxx
        out[1] += cosk @ self.kxy
        out[2] += cosk @ self.kyy
        return tuple(out)

    def _gradG(self, d):
        d = self.reduce(np.atleast_2d(d))
        r, r2, mask = self._real_space(d)
        rm, r2m = r[mask], r2[mask]
        E = np.exp(-(self.xi ** 2) * r2m)
        g1p = E * (2.0 * self.xi ** 2 - 1.0 / r2m)
        g2 = E / r2m
        g2p = -2.0 * E * (self.xi ** 2 / r2m + 1.0 / r2m ** 2)
        c = 1.0 / (4.0 * math.pi * self.eta)
        n = d.shape[0]
        out = np.zeros((n, 2, 2, 2))
        for i in range(2):
            for j in range(2):
                for l in range(2):
                    val = rm[:, i] * rm[:, j] * rm[:, l] * g2p
                    if i == j:
                        val = val + rm[:, l] * g1p
                    if i == l:
                        val = val + rm[:, j] * g2
                    if j == l:
                        val = val + rm[:, i] * g2
                    full = np.zeros(r2.shape)
                    full[mask] = val
                    out[:, i, j, l] = c * full.sum(axis=1)
        sink = np.sin(d @ self.kvec.T)
        kw = {(0, 0): self.kxx, (0, 1): self.kxy, (1, 0): self.kxy, (1, 1): self.kyy}
        for (i, j), w in kw.items():
            for l in range(2):
                out[:, i, j, l] -= sink @ (w * self.kvec[:, l])
        return out

    def _P(self, d):
        d = self.reduce(np.atleast_2d(d))
        r, r2, mask = self._real_space(d)
        E = np.zeros(r2.shape)
        E[mask] = np.exp(-(self.xi ** 2) * r2[mask]) / r2[mask]
        out = (r * E[:, :, None]).sum(axis=1) / (2.0 * math.pi)
        sink = np.sin(d @ self.kvec.T)
        out += (sink * self.kp) @ self.kvec
        return out


# --------------------------------------------------------------------------------------------
# MFS solution of the cell problem
# --------------------------------------------------------------------------------------------
def default_resolution(R, L=1.0):
    r"""Source radius ρR and number of sources M from the reflection estimate.

    The exterior field continued into the disc is singular only within r* of the centre, where
    r* solves r* = R²/(L − r*) (image of the nearest neighbour's singular set, distance ≥ L):
    r* = (L − √(L² − 4R²))/2.  Sources at ρR = √(r* R) balance the two geometric error rates
    (ρ and r*/(ρR)); M is chosen so that ρ^{M/2} ≈ 1e-16.
    """
    rstar = 0.5 * (L - math.sqrt(max(L * L - 4.0 * R * R, 0.0)))
    rho = min(max(math.sqrt(rstar / R), 0.4), 0.9)
    M = int(math.ceil(1.2 * 37.0 / -math.log(rho)))
    M = max(24, min(M + (M % 2), 400))
    return rho, M


class CellSolution:
    """MFS solution; velocities, gradients, pressure at arbitrary points and the observables."""

    def __init__(self, R, s, L=1.0, eta=1.0, gdot=1.0, M=None, rho=None, oversample=2,
                 xi=None, F_total=(0.0, 0.0), shear=True):
        self.R, self.s, self.L, self.eta = float(R), float(s), float(L), float(eta)
        self.gdot = float(gdot) if shear else 0.0
        rho0, M0 = default_resolution(self.R, self.L)
        self.rho = rho0 if rho is None else float(rho)
        self.M = M0 if M is None else int(M)
        self.N = oversample * self.M
        self.kernel = PeriodicStokeslet(self.s, self.L, self.eta, xi)
        self.A = self.kernel.A
        self.c = np.array([0.5 * self.L, 0.5 * self.L])
        ph = 2.0 * math.pi * np.arange(self.M) / self.M
        self.src = self.c + self.rho * self.R * np.stack([np.cos(ph), np.sin(ph)], axis=1)
        th = 2.0 * math.pi * (np.arange(self.N) + 0.5) / self.N
        self.col = self.c + self.R * np.stack([np.cos(th), np.sin(th)], axis=1)
        self._solve(np.asarray(F_total, dtype=float))

    def background(self, x):
        u = np.zeros_like(x)
        u[:, 0] = self.gdot * (x[:, 1] - 0.5 * self.L)
        return u

    def _solve(self, F_total):
        M, N = self.M, self.N
        d = (self.col[:, None, :] - self.src[None, :, :]).reshape(-1, 2)
        gxx, gxy, gyy = (g.reshape(N, M) for g in self.kernel.G(d))
        # unknowns: F_x (M), F_y (M), U (2); eliminate F_M = F_total − Σ_{k<M} F_k
        Amat = np.zeros((2 * N, 2 * M))
        Amat[:N, :M], Amat[:N, M:] = gxx, gxy
        Amat[N:, :M], Amat[N:, M:] = gxy, gyy
        rhs = -self.background(self.col).T.ravel()
        last_x, last_y = Amat[:, M - 1].copy(), Amat[:, 2 * M - 1].copy()
        rhs = rhs - last_x * F_total[0] - last_y * F_total[1]
        red = np.concatenate([Amat[:, : M - 1] - last_x[:, None],
                              Amat[:, M: 2 * M - 1] - last_y[:, None]], axis=1)
        Uc = np.zeros((2 * N, 2))
        Uc[:N, 0] = 1.0
        Uc[N:, 1] = 1.0
        red = np.concatenate([red, Uc], axis=1)
        # Householder QR least squares (backward stable; LAPACK's SVD-based lstsq is needlessly
        # slow on these exponentially ill-conditioned MFS matrices)
        q, r = np.linalg.qr(red)
        sol = np.linalg.solve(r, q.T @ rhs)
        Fx = np.append(sol[: M - 1], F_total[0] - sol[: M - 1].sum())
        Fy = np.append(sol[M - 1: 2 * M - 2], F_total[1] - sol[M - 1: 2 * M - 2].sum())
        self.F = np.stack([Fx, Fy], axis=1)
        self.U = sol[2 * M - 2:]

    # ---- fields ----------------------------------------------------------------------------
    def velocity(self, x):
        x = np.atleast_2d(x)
        n = x.shape[0]
        d = (x[:, None, :] - self.src[None, :, :]).reshape(-1, 2)
        gxx, gxy, gyy = (g.reshape(n, self.M) for g in self.kernel.G(d))
        Fx, Fy = self.F[:, 0], self.F[:, 1]
        u = np.stack([gxx @ Fx + gxy @ Fy, gxy @ Fx + gyy @ Fy], axis=1)
        return u + self.U + self.background(x)

    def grad_velocity(self, x):
        """(n, 2, 2) array, [., i, l] = ∂_l u_i."""
        x = np.atleast_2d(x)
        n = x.shape[0]
        d = (x[:, None, :] - self.src[None, :, :]).reshape(-1, 2)
        dG = self.kernel.gradG(d).reshape(n, self.M, 2, 2, 2)
        g = np.einsum("nkijl,kj->nil", dG, self.F)
        g[:, 0, 1] += self.gdot
        return g

    def pressure(self, x):
        x = np.atleast_2d(x)
        n = x.shape[0]
        d = (x[:, None, :] - self.src[None, :, :]).reshape(-1, 2)
        P = self.kernel.P(d).reshape(n, self.M, 2)
        return np.einsum("nkj,kj->n", P, self.F)

    def stress(self, x):
        g = self.grad_velocity(x)
        sig = self.eta * (g + np.transpose(g, (0, 2, 1)))
        p = self.pressure(x)
        sig[:, 0, 0] -= p
        sig[:, 1, 1] -= p
        return sig

    # ---- observables ------------------------------------------------------------------------
    def observables(self):
        r"""Moments of the surface traction from the MFS forces (exact for i ≠ j):
        ∮ t_x (y − c_y) dS = −Σ F_x (y_k − c_y),  ∮ t_y (x − c_x) dS = −Σ F_y (x_k − c_x)."""
        dx = self.src - self.c
        txy = -np.sum(self.F[:, 0] * dx[:, 1])  # ∮ t_x (y − c_y)
        tyx = -np.sum(self.F[:, 1] * dx[:, 0])  # ∮ t_y (x − c_x)
        torque = tyx - txy
        stresslet = 0.5 * (txy + tyx)
        g = self.gdot if self.gdot != 0.0 else float("nan")  # η entries undefined without shear
        return {
            "R": self.R, "s": self.s, "phi": math.pi * self.R ** 2 / self.A,
            "torque": torque, "stresslet_xy": stresslet,
            "eta_eff": self.eta + txy / (self.A * g),
            "eta_stresslet_part": stresslet / (self.A * g),
            "eta_torque_part": -0.5 * torque / (self.A * g),
            "sigma_yx_mean": self.eta * self.gdot + (stresslet + 0.5 * torque) / self.A,
            "force": (-self.F.sum(axis=0)).tolist(), "U": self.U.tolist(),
        }

    def boundary_residual(self, n=512):
        th = 2.0 * math.pi * np.arange(n) / n
        x = self.c + self.R * np.stack([np.cos(th), np.sin(th)], axis=1)
        return float(np.abs(self.velocity(x)).max())

    def traction_moments(self, n=256):
        """∮ t_x (y − c_y), ∮ t_y (x − c_x) and ∮ t from the fluid stress on the circle."""
        th = 2.0 * math.pi * np.arange(n) / n
        nv = np.stack([np.cos(th), np.sin(th)], axis=1)
        x = self.c + self.R * nv
        t = np.einsum("nij,nj->ni", self.stress(x), nv)
        w = self.R * 2.0 * math.pi / n
        txy = w * np.sum(t[:, 0] * (x[:, 1] - self.c[1]))
        tyx = w * np.sum(t[:, 1] * (x[:, 0] - self.c[0]))
        return txy, tyx, w * t.sum(axis=0)

    def plane_flux_xy(self, y0=0.0, n=128):
        """(1/L) ∫_0^L σ_xy(x, y0) dx: x-momentum flux across the line y = y0 (a1 is a lattice
        vector for every s, so the integrand is L-periodic: trapezoidal rule)."""
        x = np.stack([self.L * np.arange(n) / n, np.full(n, y0)], axis=1)
        return float(self.stress(x)[:, 0, 1].mean())

    def plane_flux_yx(self, x0=0.0, n=128):
        """(1/L) ∫_0^L σ_yx(x0, y) dy: y-momentum flux across x = x0 (valid for s = 0 only)."""
        assert self.s == 0.0
        x = np.stack([np.full(n, x0), self.L * np.arange(n) / n], axis=1)
        return float(self.stress(x)[:, 1, 0].mean())


def solve(R, s, **kw):
    """Observables of the shear problem at offset s (dict, see CellSolution.observables)."""
    return CellSolution(R, s, **kw).observables()


def s_average(R, ns=16, L=1.0, **kw):
    r"""Uniform average over s ∈ [0, L) by the trapezoidal rule on s_j = jL/ns (spectrally
    accurate: the observables are analytic and L-periodic in s).  Uses the reflection symmetry
    f(s) = f(L − s) (x → −x maps (s, γ̇) to (−s, −γ̇); η_eff and T are even under it), so only
    j = 0 … ns/2 are solved.  Returns (averages, list of per-s results)."""
    assert ns % 2 == 0 and ns >= 2
    rows = [solve(R, L * j / ns, L=L, **kw) for j in range(ns // 2 + 1)]
    keys = ("eta_eff", "eta_stresslet_part", "eta_torque_part", "torque", "stresslet_xy")
    avg = {}
    for key in keys:
        v = np.array([r[key] for r in rows])
        w = np.full(len(v), 2.0)
        w[0] = w[-1] = 1.0
        avg[key] = float(np.dot(w, v) / ns)
    return avg, rows


def square_array_drag(R, L=1.0, eta=1.0, n=128, **kw):
    r"""Hasimoto's problem: fixed square array (s = 0) of discs, flow driven by a mean pressure
    gradient.  Returns D = 4πη U_s / F, U_s the superficial (cell-averaged, disc = 0) velocity
    = flux through the line x = 0 over L, F the force per disc.  Hasimoto (1959), Sangani &
    Acrivos (1982):  D = −½ ln c − 0.738 + c − 0.887 c² + 2.039 c³ + …,  c = πR²/L²."""
    sol = CellSolution(R, 0.0, L=L, eta=eta, shear=False, F_total=(1.0, 0.0), **kw)
    x = np.stack([np.zeros(n), L * np.arange(n) / n], axis=1)
    return 4.0 * math.pi * eta * abs(float(sol.velocity(x)[:, 0].mean()))  # |F| = 1


def cell_table(R, ns=16, L=1.0, eta=1.0, gdot=1.0):
    """The reported quantities for one radius: s-averages (ns-point trapezoid), s = 0, s = L/2,
    and per-s values for s ∈ [0, L/2] (the rest follow from f(s) = f(L − s)).
    surface_residual: max |u|/(γ̇R) on the disc surface (512 points) at s = 0 and s = L/2."""
    if not 0.0 < R < 0.5 * L:
        raise ValueError("need 0 < R < L/2")
    avg, rows = s_average(R, ns, L=L, eta=eta, gdot=gdot)
    at0, athalf = rows[0], rows[-1]
    rho, M = default_resolution(R, L)
    resid = max(CellSolution(R, s, L=L, eta=eta, gdot=gdot).boundary_residual() for s in (0.0, 0.5 * L))
    return {
        "R": R, "phi": math.pi * R * R / (L * L), "ns": ns, "mfs_sources": M, "mfs_rho": rho,
        "surface_residual": resid / (gdot * R),
        "eta_eff_avg": avg["eta_eff"], "eta_stresslet_part_avg": avg["eta_stresslet_part"],
        "eta_torque_part_avg": avg["eta_torque_part"], "torque_avg": avg["torque"],
        "torque_s0": at0["torque"], "eta_eff_s0": at0["eta_eff"],
        "eta_stresslet_part_s0": at0["eta_stresslet_part"], "eta_torque_part_s0": at0["eta_torque_part"],
        "torque_s_half": athalf["torque"], "eta_eff_s_half": athalf["eta_eff"],
        "per_s": [{k: r[k] for k in ("s", "eta_eff", "eta_stresslet_part", "eta_torque_part", "torque")}
                  for r in rows],
    }


# --------------------------------------------------------------------------------------------
# Self-test
# --------------------------------------------------------------------------------------------
class _Checks:
    def __init__(self):
        self.failed = []

    def __call__(self, name, ok, detail):
        print(f"[{'PASS' if ok else 'FAIL'}] {name}: {detail}")
        sys.stdout.flush()
        if not ok:
            self.failed.append(name)


def selftest():
    chk = _Checks()
    t_start, c_start = time.perf_counter(), time.process_time()
    pi = math.pi

    # 0. building blocks ---------------------------------------------------------------------
    x = np.concatenate([np.logspace(-8, 0.3, 40), np.linspace(1.0, 45.0, 120)])
    err = np.max(np.abs(expint_e1(x) / expint_e1_quadrature(x, h=0.05) - 1.0))
    chk("E1: series/continued fraction vs independent quadrature", err < 1e-12,
        f"max rel diff {err:.1e} over x in [1e-8, 45]")

    rng = np.random.default_rng(1)
    d = rng.uniform(-1.5, 1.5, size=(80, 2))
    k = PeriodicStokeslet(0.37)
    d = d[np.hypot(*k.reduce(d).T) > 0.2][:40]  # keep away from the singular lattice points
    ref = k.G(d)
    worst = 0.0
    for f in (0.5, 0.8, 1.5, 2.5):
        other = PeriodicStokeslet(0.37, xi=f * math.sqrt(pi)).G(d)
        worst = max(worst, max(np.abs(a - b).max() for a, b in zip(ref, other)))
    chk("(c) Ewald: periodic Stokeslet independent of splitting xi (xi/sqrt(pi) = 0.5..2.5)",
        worst < 1e-13, f"max |G(xi) - G(sqrt(pi))| = {worst:.1e} (|G| ~ 0.1)")

    lat = k.lat
    shifted = max(np.abs(a - b).max() for a, b in zip(k.G(d), k.G(d + 2 * lat[1] - lat[0])))
    h = 1e-5
    fd = np.stack([(np.stack(k.G(d + h * e)) - np.stack(k.G(d - h * e))) / (2 * h)
                   for e in np.eye(2)], axis=-1)  # [comp(xx,xy,yy), n, l]
    gg = k.gradG(d)
    an = np.stack([gg[:, 0, 0, :], gg[:, 0, 1, :], gg[:, 1, 1, :]])
    div = np.abs(gg[:, 0, 0, 0] + gg[:, 0, 1, 1]).max() + np.abs(gg[:, 1, 0, 0] + gg[:, 1, 1, 1]).max()
    ferr = np.abs(an - fd).max()
    chk("Ewald: lattice periodicity (shift 2a2 - a1), grad G vs finite differences, div G = 0",
        shifted < 1e-13 and ferr < 1e-8 and div < 1e-12,
        f"periodicity {shifted:.1e}, grad-FD {ferr:.1e}, |div| {div:.1e}")

    # 1. (a) convergence in the number of MFS sources --------------------------------------
    R, s = 0.2, 0.3
    base = CellSolution(R, s)
    ob = base.observables()
    lines, diffs = [], []
    for M in (16, 24, 32, 40, 48, 80):
        o = CellSolution(R, s, M=M).observables()
        de, dt = o["eta_eff"] - ob["eta_eff"], o["torque"] - ob["torque"]
        diffs.append(max(abs(de), abs(dt)))
        lines.append(f"M={M}: d_eta={de:+.1e} d_T={dt:+.1e}")
    o3 = CellSolution(R, s, oversample=3).observables()
    dN = max(abs(o3["eta_eff"] - ob["eta_eff"]), abs(o3["torque"] - ob["torque"]))
    orho = CellSolution(R, s, rho=0.6, M=80).observables()
    drho = max(abs(orho["eta_eff"] - ob["eta_eff"]), abs(orho["torque"] - ob["torque"]))
    res = base.boundary_residual()
    chk(f"(a) MFS convergence, R={R}, s={s} (default M={base.M}, rho={base.rho:.3f})",
        diffs[-1] < 1e-12 and diffs[0] > diffs[1] > diffs[2] and dN < 1e-12 and drho < 1e-11 and res < 1e-12,
        "; ".join(lines) + f"; N=3M: {dN:.1e}; rho=0.6,M=80: {drho:.1e}; max|u| on surface {res:.1e}"
        f" -> eta_eff={ob['eta_eff']:.12f}, T={ob['torque']:.12f}")

    R4 = 0.45
    o_lo = CellSolution(R4, s, M=160).observables()
    o_hi = CellSolution(R4, s).observables()
    dd = abs(o_lo["eta_eff"] - o_hi["eta_eff"]) / o_hi["eta_eff"]
    chk(f"(a) MFS convergence near contact, R={R4}: M=160 vs default M={default_resolution(R4)[1]}",
        dd < 1e-9, f"rel diff eta_eff {dd:.1e}, eta_eff={o_hi['eta_eff']:.10f}, T={o_hi['torque']:.10f}")

    # 2. observables: moment formula vs surface traction vs momentum flux -------------------
    for s_ in (0.0, 0.3):
        sol = CellSolution(0.2, s_)
        o = sol.observables()
        txy, tyx, Fs = sol.traction_moments()
        T_tr = tyx - txy
        eta_tr = 1.0 + txy / sol.A
        flux0, flux1 = sol.plane_flux_xy(0.0), sol.plane_flux_xy(0.17)
        e1 = max(abs(eta_tr - o["eta_eff"]), abs(T_tr - o["torque"]), np.abs(Fs).max())
        e2 = max(abs(flux0 - o["eta_eff"]), abs(flux1 - o["eta_eff"]))
        detail = (f"s={s_}: eta_eff moments {o['eta_eff']:.13f}, traction {eta_tr:.13f}, "
                  f"flux y=0 {flux0:.13f}, y=0.17 {flux1:.13f}; T moments {o['torque']:.13f}, "
                  f"traction {T_tr:.13f}; net force {np.abs(Fs).max():.1e}, U {np.abs(o['U']).max():.1e}")
        ok = e1 < 1e-10 and e2 < 1e-10 and np.abs(o["U"]).max() < 1e-12
        if s_ == 0.0:
            fyx = sol.plane_flux_yx(0.0)
            detail += f"; <sigma_yx> flux x=0 {fyx:.13f} vs eta+S/A+T/2A {o['sigma_yx_mean']:.13f}"
            ok = ok and abs(fyx - o["sigma_yx_mean"]) < 1e-10
        chk("Batchelor moments = traction on the circle = x-momentum flux across y-planes", ok, detail)

    # Lees–Edwards: u(x + a2) = u(x) + gdot L x̂,  u(x + a1) = u(x)
    sol = CellSolution(0.15, 0.3)
    pts = np.array([[0.05, 0.1], [0.9, 0.2], [0.3, 0.95]])
    jump2 = sol.velocity(pts + sol.kernel.lat[1]) - sol.velocity(pts)
    jump1 = sol.velocity(pts + sol.kernel.lat[0]) - sol.velocity(pts)
    e = max(np.abs(jump2 - [1.0, 0.0]).max(), np.abs(jump1).max())
    chk("Lees-Edwards images: u(x+a2) - u(x) = (gdot L, 0), u(x+a1) = u(x)", e < 1e-12, f"max err {e:.1e}")

    # symmetry s -> L - s
    a, b = solve(0.2, 0.3), solve(0.2, 0.7)
    e = max(abs(a["eta_eff"] - b["eta_eff"]), abs(a["torque"] - b["torque"]))
    chk("reflection symmetry eta_eff(s) = eta_eff(L-s), T(s) = T(L-s)", e < 1e-12,
        f"s=0.3 vs 0.7: {e:.1e}")

    # scaling: L = 1.7, eta = 1.3, gdot = 0.7 must give eta_eff × eta and T × eta gdot L²
    Ls, es, gs = 1.7, 1.3, 0.7
    c = solve(0.2 * Ls, 0.3 * Ls, L=Ls, eta=es, gdot=gs)
    e = max(abs(c["eta_eff"] - es * a["eta_eff"]), abs(c["torque"] - es * gs * Ls ** 2 * a["torque"]))
    chk("dimensional scaling (L=1.7, eta=1.3, gdot=0.7 vs L=1, eta=1, gdot=1)", e < 1e-12, f"max err {e:.1e}")

    # 3. s-average convergence ---------------------------------------------------------------
    R = 0.2
    avg16, rows = s_average(R, 16)
    vals = np.array([r["eta_eff"] for r in rows])
    tv = np.array([r["torque"] for r in rows])

    def sub_avg(v, ns):
        step = 16 // ns
        w = v[::step]
        return (w[0] + w[-1] + 2.0 * w[1:-1].sum()) / (2 * (len(w) - 1))

    parts = []
    errs = {}
    for ns in (2, 4, 8):
        errs[ns] = max(abs(sub_avg(vals, ns) / avg16["eta_eff"] - 1), abs(sub_avg(tv, ns) / avg16["torque"] - 1))
        parts.append(f"ns={ns}: rel err {errs[ns]:.1e}")
    chk(f"s-average convergence (trapezoid, R={R}); ns=16 avg eta_eff={avg16['eta_eff']:.12f}",
        errs[4] < 1e-4 and errs[8] < 1e-9, "; ".join(parts) + "  -> 4 points suffice for 1e-4")

    # 4. (b) dilute limit --------------------------------------------------------------------
    lines, ok = [], True
    for s_ in (0.0, 0.25, 0.5):
        c2 = []
        for R in (0.005, 0.01, 0.02, 0.04):
            phi = pi * R * R
            o = solve(R, s_)
            T0 = -2.0 * pi * R * R
            c2.append((o["eta_eff"] - 1 - 3 * phi) / phi ** 2)
            lines.append(f"s={s_} R={R}: (eta-1)/phi={(o['eta_eff'] - 1) / phi:.7f} "
                         f"stresslet/phi={o['eta_stresslet_part'] / phi:.7f} torque/phi={o['eta_torque_part'] / phi:.7f} "
                         f"T/T0={o['torque'] / T0:.8f} (eta-1-3phi)/phi^2={c2[-1]:+.5f}")
            ok = ok and abs((o["eta_eff"] - 1) / phi - 3) < 3 * phi and abs(o["torque"] / T0 - 1) < 1.5 * phi
            ok = ok and abs(o["eta_stresslet_part"] / phi - 2) < 2 * phi and abs(o["eta_torque_part"] / phi - 1) < 1.5 * phi
            if s_ == 0.0:
                ok = ok and abs(o["torque"] / T0 * (1 - phi) - 1) < 10 * phi ** 4 + 1e-12
        ok = ok and abs(c2[0] - c2[1]) < abs(c2[2] - c2[3])  # O(phi^2) coefficient converging
    chk("(b) dilute limit: eta_eff -> 1 + 2phi (stresslet) + phi (torque), T -> -2 pi R^2 gdot;"
        " at s=0 T = T0/(1-phi) + O(phi^4)", ok, "\n    " + "\n    ".join(lines))

    # 5. (d) Hasimoto / Sangani–Acrivos square-array drag ----------------------------------
    cs = np.linspace(0.005, 0.08, 8)
    y = np.array([square_array_drag(math.sqrt(c / pi)) + 0.5 * math.log(c) for c in cs])
    coef = np.linalg.lstsq(np.vander(cs, 7, increasing=True), y, rcond=None)[0]
    printed = (-0.738, 1.0, -0.887, 2.039)
    ok = all(abs(cf - p) <= 5e-4 for cf, p in zip(coef, printed))
    chk("(d) square-array drag D = 4 pi eta U/F = -ln(c)/2 - 0.738 + c - 0.887 c^2 + 2.039 c^3"
        " (Hasimoto 1959; Sangani & Acrivos 1982)", ok,
        "fitted coefficients " + ", ".join(f"{cf:+.5f}" for cf in coef[:4]) + " vs printed "
        + ", ".join(f"{p:+.3f}" for p in printed))

    wall, cpu = time.perf_counter() - t_start, time.process_time() - c_start
    print(f"self-test: {len(chk.failed)} failed; wall {wall:.1f} s, cpu {cpu:.1f} s")
    return 0 if not chk.failed else 1


# --------------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------------
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--selftest", action="store_true", help="run the checks (exit 1 on failure)")
    ap.add_argument("--json", action="store_true", help="write the table as JSON to stdout")
    ap.add_argument("--radius", type=float, nargs="+", default=[0.1, 0.15, 0.2], help="disc radii (L = 1)")
    ap.add_argument("--ns", type=int, default=16, help="even number of s points for the s-average")
    ap.add_argument("--per-s", action="store_true", help="also print eta_eff(s), T(s)")
    args = ap.parse_args(argv)
    if args.selftest:
        return selftest()
    t0 = time.perf_counter()
    rows = [cell_table(R, args.ns) for R in args.radius]
    if args.json:
        json.dump({"L": 1.0, "eta": 1.0, "gdot": 1.0, "lattice": "a1=(L,0), a2=(s,L)",
                   "method": "MFS + Ewald periodic Stokeslet (tools/stokes_inclusion_cell.py)",
                   "rows": rows}, sys.stdout, indent=1)
        print()
        return 0
    print(f"Fixed disc in a Lees-Edwards cell: L = 1, eta = 1, gdot = 1; s-average = {args.ns}-point"
          " trapezoid over s in [0, L)")
    hdr = ("R", "phi", "eta_eff<s>", "stresslet<s>", "torque_pt<s>", "T<s>", "T(s=0)", "eta_eff(s=0)")
    print("".join(f"{h:>15s}" for h in hdr))
    for r in rows:
        v = (r["R"], r["phi"], r["eta_eff_avg"], r["eta_stresslet_part_avg"], r["eta_torque_part_avg"],
             r["torque_avg"], r["torque_s0"], r["eta_eff_s0"])
        print(f"{v[0]:15.4f}{v[1]:15.10f}" + "".join(f"{x:15.10f}" for x in v[2:]))
    print("eta_eff = 1 + stresslet + torque_pt;  stresslet = S_xy/(A gdot), torque_pt = -T/(2 A gdot);"
          "  T = torque on the disc (negative: clockwise)")
    if args.per_s:
        for r in rows:
            print(f"R = {r['R']}:        s      eta_eff    stresslet    torque_pt            T")
            for p in r["per_s"]:
                print(f"           {p['s']:8.4f} {p['eta_eff']:12.9f} {p['eta_stresslet_part']:12.9f} "
                      f"{p['eta_torque_part']:12.9f} {p['torque']:12.9f}")
    print(f"({time.perf_counter() - t0:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
