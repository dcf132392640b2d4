#!/usr/bin/env python3
r"""Deterministic spectral solver of the FENE (and Hookean) dumbbell Fokker-Planck
equation in steady simple shear, in 2D (disc) and 3D (ball).

Independent of the Brownian-dynamics code of this project; only numpy is used.

Model (non-dimensional: Q in units of sqrt(kT/H), time in units of lambda = zeta/(4H),
b = H Q0^2 / kT)
-----------------------------------------------------------------------------------
    dQ = (kappa.Q - F(Q)/2) dt + dW,        <dW_i dW_j> = delta_ij dt,
    F(Q) = Q / (1 - |Q|^2/b)   (FENE, |Q| < sqrt(b))      or   F(Q) = Q   (Hookean),
    simple shear: kappa_xy = Wi, all other entries 0  (dQ_x gets Wi*Q_y dt).
Stationary Fokker-Planck equation for the density psi(Q):
    0 = -div[(kappa.Q - F/2) psi] + (1/2) lap psi,
backward generator  L*v = (kappa.Q - F/2).grad v + (1/2) lap v.
Kramers stress tau/G = <Q F> - I;  reported:
    eta_p/(G lambda)      = <Q_x F_y> / Wi
    Psi_1/(G lambda^2)    = (<Q_x F_x> - <Q_y F_y>) / Wi^2
    Psi_2/(G lambda^2)    = (<Q_y F_y> - <Q_z F_z>) / Wi^2     (3D)
plus <|Q|^2> and P(|Q| > 0.99 sqrt(b)).

Method (Galerkin / spectral, exact quadrature)
----------------------------------------------
Write psi = w(Q) g(Q) with a radial weight w = (1 - t)^gamma, t = |Q|^2/b (FENE; gamma = b/2
is the equilibrium density) or w = exp(-c|Q|^2/2) (Hookean; c = 1 is the equilibrium).
Then grad w = -e F w with e = 2 gamma/b (FENE) or e = c (Hookean), and the weak form with a
test function v, 0 = int psi L*v dQ, becomes after one integration by parts (no boundary
term since w = 0 on |Q| = sqrt(b), resp. decays)
    a(g, v) = -1/2 int w grad g . grad v + int w g (kappa.Q).grad v
              - (1 - e)/2 int w g F.grad v  = 0.
Trial and test space: polynomials of total degree <= N in Q (g even in Q, and in 3D even
in Q_z, by the symmetry of simple shear).  Basis (orthonormal in L^2(w)):
    phi_{l m k}(Q) = t^(l/2) q_{l,k}(t) Y_{lm}(Q/|Q|),    t = |Q|^2/s  (s = b FENE, 2/c Hookean)
with Y_lm real orthonormal harmonics on the circle/sphere and q_{l,k} the orthonormal
polynomials (Jacobi on [0,1] for FENE, generalised Laguerre for Hookean) of the radial
weight t^(l + d/2 - 1) w(t); l even, l + 2k <= N.  In these coordinates
    y d/dx = n_x n_y (r d/dr) + T,   T = purely angular first-order operator,
    F.grad = (Q.F/|Q|^2) r d/dr,
so every matrix element factorises into (angular integral) x (radial integral).  The
angular integrals use Gauss-Legendre(cos theta) x trapezoid(phi) rules, the radial ones
Gauss-Jacobi (Gauss-Laguerre) rules for the weights t^(d/2-1) w(t) and t^(d/2-1) w/(1-t);
all integrands are polynomials times the rule's weight and the rules are large enough,
so every integral is exact to rounding: there is no quadrature parameter to converge, the
only discretisation parameter is N.  The shear operator couples l only to l, l+-2, so
the matrix is block tridiagonal in l and is solved by block LU (dense numpy solves per
block, one step of iterative refinement).  The constant test function gives 0 = 0; its
equation is replaced by the normalisation int psi = 1.
Moments: <QQ> from the l = 0, 2 coefficients; <QF> directly (exact radial rule for the
weight t^(d/2-1) w/(1-t)).  The discrete solution also satisfies exactly (v = Q_i Q_j is a
test function) <QF>_sym = I + kappa.<QQ> + <QQ>.kappa^T, i.e. eta_p = <Q_y^2>,
Psi_1 = 2<Q_x Q_y>/Wi, Psi_2 = 0 (dumbbells without hydrodynamic interaction); the direct
and identity values agree to rounding.  For the Hookean model every moment of degree <= N
is exact at any N (L* preserves the degree); --selftest checks this against the Gaussian.

Conditioning (important at Wi = 10)
-----------------------------------
With the equilibrium weight, g = psi/w has an enormous dynamic range at high Wi (for b = 50,
Wi = 10 the coefficients reach 1e8 and the condition number 1e13), so results stall at
~1e-6 relative and occasionally jump (non-coercive Galerkin + rounding).  The default
therefore uses gamma = b/2 - j with the largest integer j keeping gamma >= 5 (gamma = 5
for b = 50, gamma = b/2 = 5 for b = 10): psi/w = (1-t)^j x (smooth) is still polynomial,
the condition number drops to ~1e6 and all moments converge spectrally to ~1e-10.  The
converged moments do not depend on gamma (checked to 1e-14 in --selftest).  Hookean:
c = 1/(1 + 2 Wi^2).  The tiny tail probability P(|Q| > 0.99 sqrt b) needs the correct
boundary layer (1-t)^(b/2) of psi in the trial space, so it is computed with gamma = b/2
and its own N sweep (converge_tail); for b = 50, Wi = 10 it converges only slowly
(~1e-19; see --table).

CLI
---
    python tools/fene_fokker_planck.py --dim 3 --b 50 --wi 1 [--degree N] [--hookean]
    python tools/fene_fokker_planck.py --dim 3 --b 50 --wi 1 --converge   # N sweep
    python tools/fene_fokker_planck.py --table      # converged 8-point table (markdown)
    python tools/fene_fokker_planck.py --selftest   # checks, exits non-zero on failure
Importable: steady_shear(dim, b, wi, degree, hookean=False, gamma="auto") -> dict,
            converge(dim, b, wi, rtol=...) -> (result dict, history list),
            converge_tail(dim, b, wi, start) -> (P(|Q|>0.99 sqrt b), converged?, history).
Runtime (one core): --selftest ~6 s, --table ~10 s; 3D N = 48 solves in ~0.3 s.
"""
import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402


# --------------------------------------------------------------------------------------
# Orthonormal polynomials and Gauss rules (Golub-Welsch) for the radial variable t
# --------------------------------------------------------------------------------------
def _recurrence(kind, alpha, beta, n):
    """Three-term recurrence t q_k = a_{k+1} q_{k+1} + c_k q_k + a_k q_{k-1} of the
    orthonormal polynomials for the weight t^beta (1-t)^alpha on [0,1] ('jacobi') or
    t^beta exp(-t) on [0, inf) ('laguerre').  Returns (a[0..n], c[0..n-1], mu0)."""
    k = np.arange(n, dtype=float)
    kk = np.arange(1, n + 1, dtype=float)
    a = np.zeros(n + 1)
    if kind == "jacobi":
        ab = alpha + beta
        with np.errstate(divide="ignore", invalid="ignore"):
            cx = (beta ** 2 - alpha ** 2) / ((2 * k + ab) * (2 * k + ab + 2))
        if n > 0:
            cx[0] = (beta - alpha) / (ab + 2)
        ax = 2.0 / (2 * kk + ab) * np.sqrt(
            kk * (kk + alpha) * (kk + beta) * (kk + ab) / ((2 * kk + ab - 1) * (2 * kk + ab + 1)))
        if n > 0 and abs(ab + 1) < 1e-14:  # (not needed for b > 0, kept for safety)
            ax[0] = 2.0 / (2 + ab) * math.sqrt((1 + alpha) * (1 + beta) / (3 + ab))
        c = (1.0 + cx) / 2.0
        a[1:] = ax / 2.0
        mu0 = math.exp(math.lgamma(alpha + 1) + math.lgamma(beta + 1) - math.lgamma(ab + 2))
    elif kind == "laguerre":
        c = 2 * k + beta + 1
        a[1:] = np.sqrt(kk * (kk + beta))
        mu0 = math.gamma(beta + 1)
    else:
        raise ValueError(kind)
    return a, c, mu0


def _orthopoly(t, n, kind, alpha, beta):
    """Values and t-derivatives of the first n orthonormal polynomials at points t."""
    a, c, mu0 = _recurrence(kind, alpha, beta, n)
    t = np.asarray(t, dtype=float)
    q = np.zeros((t.size, n))
    dq = np.zeros((t.size, n))
    if n == 0:
        return q, dq
    q[:, 0] = 1.0 / math.sqrt(mu0)
    if n > 1:
        q[:, 1] = (t - c[0]) * q[:, 0] / a[1]
        dq[:, 1] = q[:, 0] / a[1]
    for j in range(1, n - 1):
        q[:, j + 1] = ((t - c[j]) * q[:, j] - a[j] * q[:, j - 1]) / a[j + 1]
        dq[:, j + 1] = (q[:, j] + (t - c[j]) * dq[:, j] - a[j] * dq[:, j - 1]) / a[j + 1]
    return q, dq


def _gauss(n, kind, alpha, beta):
    """n-point Gauss rule for the weight t^beta (1-t)^alpha / t^beta e^-t."""
    a, c, mu0 = _recurrence(kind, alpha, beta, n)
    J = np.diag(c[:n]) + np.diag(a[1:n], 1) + np.diag(a[1:n], -1)
    x, V = np.linalg.eigh(J)
    return x, mu0 * V[0, :] ** 2


# --------------------------------------------------------------------------------------
# Radial part
# --------------------------------------------------------------------------------------
class Radial:
    """Radial basis f_{l,k}(t) = t^(l/2) q_{l,k}(t), orthonormal w.r.t. t^(d/2-1) w(t) dt.

    All integrals are written in the measure dmu = t^(d/2-1) w(t) dt dOmega (the constant
    s^(d/2)/2 of r^(d-1) dr = s^(d/2)/2 t^(d/2-1) dt is dropped everywhere: only ratios
    are used)."""

    def __init__(self, dim, b, hookean, degree, gamma=None):
        self.dim, self.b, self.hookean = dim, b, hookean
        self.kind = "laguerre" if hookean else "jacobi"
        if hookean:
            # w = exp(-t), t = c |Q|^2 / 2  (c = gamma, default 1 = equilibrium weight)
            self.c = 1.0 if gamma is None else float(gamma)
            self.s = 2.0 / self.c
            self.alpha = 0.0
        else:
            # w = (1-t)^gamma, t = |Q|^2 / b  (gamma = b/2: equilibrium weight)
            self.s = float(b)
            self.alpha = b / 2.0 if gamma is None else float(gamma)
        self.beta0 = dim / 2.0 - 1.0
        # integrands are polynomials of degree <= N in t (times the weight): N/2+1 nodes
        # suffice; take a generous margin (cost is negligible).
        self.nq = degree // 2 + 8
        self.t, self.W = _gauss(self.nq, self.kind, self.alpha, self.beta0)
        self._cache = {}

    def basis(self, l, nk, t=None):
        """(F, G, U, V) at points t (default: the Gauss nodes):
        F = f = t^(l/2) q,  G = r df/dr = t^(l/2) (l q + 2 t q'),
        U = sqrt(s) df/dr, V = sqrt(s) sqrt(l(l+d-2)) f / r  (for the Dirichlet form)."""
        key = (l, nk) if t is None else None
        if key is not None and key in self._cache:
            return self._cache[key]
        tt = self.t if t is None else np.asarray(t, float)
        q, dq = _orthopoly(tt, nk, self.kind, self.alpha, l + self.beta0)
        th = tt[:, None] ** (l / 2.0)
        F = th * q
        G = th * (l * q + 2 * tt[:, None] * dq)
        if l == 0:
            U = 2.0 * np.sqrt(tt)[:, None] * dq
            V = np.zeros_like(q)
        else:
            tl = tt[:, None] ** ((l - 1) / 2.0)
            U = tl * (l * q + 2 * tt[:, None] * dq)
            V = math.sqrt(l * (l + self.dim - 2)) * tl * q
        out = (F, G, U, V)
        if key is not None:
            self._cache[key] = out
        return out

    def dirichlet(self, l, nk):
        """D[k,k'] = int w f'_k f'_k' + l(l+d-2)/r^2 f_k f_k'  (radial measure)."""
        F, G, U, V = self.basis(l, nk)
        W = self.W[:, None]
        return (U.T @ (W * U) + V.T @ (W * V)) / self.s

    def spring_drift(self, l, nk):
        """P[k,k'] = int w (Q.F/|Q|^2) f_{l,k'} r d/dr f_{l,k}, i.e. with w/(1-t) (FENE)
        or w (Hookean); only used if the weight is not the equilibrium one."""
        if self.hookean:
            F, G, _, _ = self.basis(l, nk)
            return G.T @ (self.W[:, None] * F)
        tf, wf = _gauss(self.nq, "jacobi", self.alpha - 1.0, self.beta0)
        F, G, _, _ = self.basis(l, nk, tf)
        return G.T @ (wf[:, None] * F)

    def shear(self, lt, nkt, lj, nkj):
        """R1[k,k'] = int w f_{lj,k'} r d/dr f_{lt,k};  R2[k,k'] = int w f_{lt,k} f_{lj,k'}."""
        Ft, Gt, _, _ = self.basis(lt, nkt)
        Fj, _, _, _ = self.basis(lj, nkj)
        W = self.W[:, None]
        return Gt.T @ (W * Fj), Ft.T @ (W * Fj)


# --------------------------------------------------------------------------------------
# Angular part: real orthonormal harmonics, even under Q -> -Q (and Q_z -> -Q_z in 3D)
# --------------------------------------------------------------------------------------
def _theta_functions(x, L):
    """Theta_{lm}(x), x = cos(theta), normalised int_{-1}^{1} Theta^2 dx = 1, and
    sin(theta) dTheta/dtheta, for 0 <= m <= l <= L.  Returns dicts keyed by (l, m)."""
    x = np.asarray(x, float)
    sn = np.sqrt(np.maximum(0.0, 1.0 - x * x))
    P, D = {}, {}
    pmm = np.full_like(x, 1.0 / math.sqrt(2.0))
    for m in range(L + 1):
        if m > 0:
            pmm = math.sqrt((2 * m + 1) / (2.0 * m)) * sn * pmm
        P[(m, m)] = pmm
        if m + 1 <= L:
            P[(m + 1, m)] = math.sqrt(2 * m + 3) * x * pmm
        for l in range(m + 2, L + 1):
            P[(l, m)] = math.sqrt((4.0 * l * l - 1) / (l * l - m * m)) * (
                x * P[(l - 1, m)]
                - math.sqrt(((l - 1) ** 2 - m * m) / (4.0 * (l - 1) ** 2 - 1)) * P[(l - 2, m)])
    for (l, m), p in P.items():
        d = l * x * p
        if l > m:
            d = d - math.sqrt((2 * l + 1) * (l * l - m * m) / (2 * l - 1.0)) * P[(l - 1, m)]
        D[(l, m)] = d
    return P, D


def _phi_functions(phi, m, sigma):
    """Orthonormal trigonometric function on [0, 2 pi) and its derivative."""
    if m == 0:
        return np.full_like(phi, 1.0 / math.sqrt(2 * math.pi)), np.zeros_like(phi)
    c = 1.0 / math.sqrt(math.pi)
    if sigma == "c":
        return c * np.cos(m * phi), -c * m * np.sin(m * phi)
    return c * np.sin(m * phi), c * m * np.cos(m * phi)


class Angular:
    """Harmonic list, shear coupling matrices S1[a',a] = int Y_a' n_x n_y Y_a and
    S2[a',a] = int Y_a' T Y_a (T = angular part of y d/dx), and projections of
    1, n_i n_j onto the harmonics."""

    def __init__(self, dim, L):
        self.dim, self.L = dim, L
        harm = []
        if dim == 2:
            for m in range(0, L + 1, 2):
                harm.append((m, m, "c"))
                if m > 0:
                    harm.append((m, m, "s"))
        else:
            for l in range(0, L + 1, 2):
                for m in range(0, l + 1, 2):
                    harm.append((l, m, "c"))
                    if m > 0:
                        harm.append((l, m, "s"))
        self.harm = harm
        self.lvals = np.array([h[0] for h in harm])
        nh = len(harm)
        nphi = 2 * L + 8
        phi = 2 * math.pi * np.arange(nphi) / nphi
        wphi = np.full(nphi, 2 * math.pi / nphi)
        Phi = np.zeros((nphi, nh))
        dPhi = np.zeros((nphi, nh))
        for i, (l, m, sg) in enumerate(harm):
            Phi[:, i], dPhi[:, i] = _phi_functions(phi, m, sg)
        cs, sn = np.cos(phi), np.sin(phi)
        self.sphere_area = 2 * math.pi if dim == 2 else 4 * math.pi

        def pm(A, f, B):
            return A.T @ ((wphi * f)[:, None] * B)

        if dim == 2:
            # n = (cos th, sin th); T Y = -sin^2(th) dY/dth
            self.S1 = pm(Phi, cs * sn, Phi)
            self.S2 = pm(Phi, -sn * sn, dPhi)
            proj = {
                "1": Phi.T @ wphi,
                "xx": Phi.T @ (wphi * cs * cs),
                "yy": Phi.T @ (wphi * sn * sn),
                "xy": Phi.T @ (wphi * cs * sn),
            }
            proj["zz"] = np.zeros(nh)
            self.proj = proj
            self._grid = (phi, wphi, Phi)
        else:
            # Theta_lm (m even) is a polynomial of degree l in x = cos(theta); integrands
            # are of degree <= 2L + 2 (checks: 2N + 2): Gauss-Legendre exact to 2 nth - 1
            nth = L + 4
            x, wx = np.polynomial.legendre.leggauss(nth)
            P, D = _theta_functions(x, L)
            Th = np.column_stack([P[(l, m)] for (l, m, s) in harm])
            dTh = np.column_stack([D[(l, m)] for (l, m, s) in harm])

            def tm(A, f, B):
                return A.T @ ((wx * f)[:, None] * B)

            # n = (sin th cos ph, sin th sin ph, cos th);  n_x n_y = (1-x^2) sin ph cos ph
            # T Y = x sin ph cos ph (sin th dY/dth) - sin^2 ph dY/dph
            Aphi = pm(Phi, sn * cs, Phi)
            self.S1 = tm(Th, 1 - x * x, Th) * Aphi
            self.S2 = tm(Th, x, dTh) * Aphi - tm(Th, np.ones_like(x), Th) * pm(Phi, sn * sn, dPhi)
            thp = {
                "1": (Th.T @ wx) * (Phi.T @ wphi),
                "xx": (Th.T @ (wx * (1 - x * x))) * (Phi.T @ (wphi * cs * cs)),
                "yy": (Th.T @ (wx * (1 - x * x))) * (Phi.T @ (wphi * sn * sn)),
                "zz": (Th.T @ (wx * x * x)) * (Phi.T @ wphi),
                "xy": (Th.T @ (wx * (1 - x * x))) * (Phi.T @ (wphi * sn * cs)),
            }
            self.proj = thp
            self._grid = (x, wx, Th, phi, wphi, Phi)
        # remove rounding noise so that the block structure is exact
        for S in (self.S1, self.S2):
            S[np.abs(S) < 1e-13] = 0.0
        for k in self.proj:
            self.proj[k][np.abs(self.proj[k]) < 1e-13] = 0.0

    def grid(self):
        """Angular quadrature grid: unit vectors n (npts x dim), weights, Y (npts x nh)."""
        if self.dim == 2:
            phi, wphi, Phi = self._grid
            n = np.column_stack([np.cos(phi), np.sin(phi)])
            return n, wphi, Phi
        x, wx, Th, phi, wphi, Phi = self._grid
        X, PH = np.meshgrid(x, phi, indexing="ij")
        st = np.sqrt(1 - X * X)
        n = np.column_stack([(st * np.cos(PH)).ravel(), (st * np.sin(PH)).ravel(), X.ravel()])
        w = (wx[:, None] * wphi[None, :]).ravel()
        Y = (Th[:, None, :] * Phi[None, :, :]).reshape(-1, Th.shape[1])
        return n, w, Y


# --------------------------------------------------------------------------------------
# Assembly and block-tridiagonal solve
# --------------------------------------------------------------------------------------
class Discretisation:
    def __init__(self, dim, b, degree, hookean=False, kmax=None, gamma=None):
        if dim not in (2, 3):
            raise ValueError("dim must be 2 or 3")
        if not hookean and not b > 0:
            raise ValueError("b must be > 0")
        N = int(degree)
        if N < 2:
            raise ValueError("degree must be >= 2")
        N -= N % 2
        self.dim, self.b, self.N, self.hookean = dim, b, N, hookean
        self.gamma = gamma
        self.rad = Radial(dim, b if not hookean else 1.0, hookean, N, gamma=gamma)
        self.ang = Angular(dim, N)
        self.levels = []  # (l, harmonic indices, nk)
        for l in range(0, N + 1, 2):
            idx = np.nonzero(self.ang.lvals == l)[0]
            nk = (N - l) // 2 + 1
            if kmax is not None:
                nk = min(nk, kmax + 1)
            self.levels.append((l, idx, nk))
        self.sizes = [len(idx) * nk for (_, idx, nk) in self.levels]
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes)])
        self.n = int(self.offsets[-1])
        # Wi-independent blocks: Dirichlet (diagonal) and shear parts (per level pair)
        self._dir = []
        self._sh = {}
        nl = len(self.levels)
        for j, (l, idx, nk) in enumerate(self.levels):
            D = self.rad.dirichlet(l, nk)
            # non-equilibrium weight: grad w = -e F w with e = 2 gamma/b (FENE) or
            # e = gamma (Hookean); this adds -(1/2)(1 - e) int w g F.grad v to a(g, v)
            # (absorbed here into the block that is multiplied by -1/2).
            e = None if gamma is None else (gamma if hookean else 2.0 * gamma / b)
            if e is not None and e != 1.0:
                D = D + (1.0 - e) * self.rad.spring_drift(l, nk)
            self._dir.append(np.kron(np.eye(len(idx)), D))
        for jt in range(nl):
            for jj in (jt - 1, jt, jt + 1):
                if 0 <= jj < nl:
                    lt, it, nkt = self.levels[jt]
                    lj, ij, nkj = self.levels[jj]
                    R1, R2 = self.rad.shear(lt, nkt, lj, nkj)
                    s1 = self.ang.S1[np.ix_(ij, it)].T  # [a (test), a' (trial)]
                    s2 = self.ang.S2[np.ix_(ij, it)].T
                    self._sh[(jt, jj)] = np.kron(s1, R1) + np.kron(s2, R2)

    def blocks(self, wi):
        nl = len(self.levels)
        diag = [-0.5 * self._dir[j] + wi * self._sh[(j, j)] for j in range(nl)]
        up = [wi * self._sh[(j, j + 1)] for j in range(nl - 1)]
        lo = [wi * self._sh[(j + 1, j)] for j in range(nl - 1)]
        # normalisation row replaces the (trivial) constant test function: row 0 of level 0
        F0 = self.rad.basis(0, self.levels[0][2])[0]
        Y00 = 1.0 / math.sqrt(self.ang.sphere_area)
        diag[0] = diag[0].copy()
        diag[0][0, :] = Y00 * self.ang.sphere_area * (self.rad.W @ F0)
        if nl > 1:
            up[0] = up[0].copy()
            up[0][0, :] = 0.0
        rhs = [np.zeros(s) for s in self.sizes]
        rhs[0][0] = 1.0
        return diag, up, lo, rhs

    @staticmethod
    def _matvec(diag, up, lo, x):
        nl = len(diag)
        y = [diag[j] @ x[j] for j in range(nl)]
        for j in range(nl - 1):
            y[j] = y[j] + up[j] @ x[j + 1]
            y[j + 1] = y[j + 1] + lo[j] @ x[j]
        return y

    @staticmethod
    def _block_solve(diag, up, lo, rhs):
        nl = len(diag)
        X, yv = [None] * nl, [None] * nl
        for j in range(nl):
            D = diag[j]
            r = rhs[j]
            if j > 0:
                D = D - lo[j - 1] @ X[j - 1]
                r = r - lo[j - 1] @ yv[j - 1]
            if j < nl - 1:
                sol = np.linalg.solve(D, np.column_stack([up[j], r]))
                X[j], yv[j] = sol[:, :-1], sol[:, -1]
            else:
                yv[j] = np.linalg.solve(D, r)
        x = [None] * nl
        x[-1] = yv[-1]
        for j in range(nl - 2, -1, -1):
            x[j] = yv[j] - X[j] @ x[j + 1]
        return x

    def solve(self, wi):
        diag, up, lo, rhs = self.blocks(wi)
        x = self._block_solve(diag, up, lo, rhs)
        # one step of iterative refinement + residual report
        res = [r - a for r, a in zip(rhs, self._matvec(diag, up, lo, x))]
        dx = self._block_solve(diag, up, lo, res)
        x = [a + c for a, c in zip(x, dx)]
        res = [r - a for r, a in zip(rhs, self._matvec(diag, up, lo, x))]
        scale = max(np.abs(d).max() for d in diag) * max(np.abs(v).max() for v in x)
        self.residual = max(np.abs(r).max() for r in res) / scale
        return x

    # ---------------------------------------------------------------- moments
    def moments(self, x, wi):
        dim, rad, ang = self.dim, self.rad, self.ang
        s = rad.s
        # radial integrals of f_{l,k} and of s t f_{l,k}, w.r.t. t^(d/2-1) w dt
        out = {}
        Z = 0.0
        QQ = {k: 0.0 for k in ("xx", "yy", "zz", "xy")}
        tmean = 0.0
        # rule for the weight t^(d/2-1) (1-t)^(b/2-1) for <QF> (FENE)
        if not self.hookean:
            tf, wf = _gauss(rad.nq, "jacobi", rad.alpha - 1.0, rad.beta0)
        QF = {k: 0.0 for k in ("xx", "yy", "zz", "xy")}
        for j, (l, idx, nk) in enumerate(self.levels):
            if l > 2:
                break
            c = x[j].reshape(len(idx), nk)
            F = rad.basis(l, nk)[0]
            I1 = rad.W @ F                    # int f
            It = rad.W @ (s * rad.t[:, None] * F)  # int |Q|^2 f
            if self.hookean:
                Itf = It
            else:
                Ff = rad.basis(l, nk, tf)[0]
                Itf = wf @ (s * tf[:, None] * Ff)  # int |Q|^2 f / (1 - t)
            for ia, a in enumerate(idx):
                Z += ang.proj["1"][a] * (c[ia] @ I1)
                tmean += ang.proj["1"][a] * (c[ia] @ It)
                for kk in QQ:
                    QQ[kk] += ang.proj[kk][a] * (c[ia] @ It)
                    QF[kk] += ang.proj[kk][a] * (c[ia] @ Itf)
        for kk in QQ:
            QQ[kk] /= Z
            QF[kk] /= Z
        out["Q2"] = tmean / Z
        out["QQ"] = QQ
        out["QF"] = QF
        # identity <QF> = I + kappa<QQ> + <QQ>kappa^T  =>  tau_xy = Wi<yy>, N1 = 2Wi<xy>
        if wi != 0:
            out["eta"] = QF["xy"] / wi
            out["psi1"] = (QF["xx"] - QF["yy"]) / wi ** 2
            out["psi2"] = (QF["yy"] - QF["zz"]) / wi ** 2 if dim == 3 else None
            out["eta_identity"] = QQ["yy"]
            out["psi1_identity"] = 2 * QQ["xy"] / wi
        # probability beyond |Q| = 0.99 sqrt(b): only the l = 0 channel contributes
        if not self.hookean:
            tau = 0.99 ** 2
            nfr = rad.nq + 16
            xg, wg = _gauss(nfr, "jacobi", rad.alpha, 0.0)      # weight (1-u)^alpha on [0,1]
            tt = tau + (1 - tau) * xg
            wt = wg * (1 - tau) ** (rad.alpha + 1) * tt ** rad.beta0
            l0, idx0, nk0 = self.levels[0]
            F = rad.basis(0, nk0, tt)[0]
            tail = ang.proj["1"][idx0[0]] * (x[0][:nk0] @ (wt @ F))
            out["frac_099"] = tail / Z
        else:
            out["frac_099"] = None
        out["Z"] = Z
        return out


def default_gamma(b, wi=0.0, hookean=False):
    """Weight parameter used by default (see module docstring, 'Conditioning').

    FENE: w = (1-t)^gamma with gamma = b/2 - j, j = the largest integer keeping gamma >= 5
    (gamma = b/2 for b <= 10; gamma = 5 for b = 50).  b/2 - gamma is an integer, so
    g = psi/w = (1-t)^(b/2-gamma) x (smooth) is still polynomial-friendly, while the
    dynamic range of g (and the condition number) is reduced by many orders of magnitude.
    Hookean: w = exp(-c |Q|^2/2) with c = 1/(1 + 2 Wi^2) (the largest variance of the exact
    Gaussian solution), so that g = psi/w is in L^2(w)."""
    if hookean:
        return 1.0 / (1.0 + 2.0 * wi * wi)
    half = b / 2.0
    return half - math.floor(max(0.0, half - 5.0))


def steady_shear(dim, b, wi, degree, hookean=False, gamma="auto", kmax=None):
    """Solve the stationary Fokker-Planck equation at polynomial degree N = `degree`.

    gamma: "auto" (default_gamma), None (equilibrium weight), or a number.
    Returns a dict with eta (eta_p/(G lambda)), psi1 (Psi_1/(G lambda^2)), psi2 (3D, else
    None), Q2 = <|Q|^2>, frac_099 = P(|Q| > 0.99 sqrt b) (FENE), QQ, QF (second moments
    and <Q F>), eta_identity/psi1_identity (from <QF> = I + kappa<QQ> + <QQ>kappa^T),
    residual (relative residual of the linear solve), n (unknowns), degree, gamma, time."""
    t0 = time.time()
    if isinstance(gamma, str):
        gamma = default_gamma(b, wi, hookean)
    disc = Discretisation(dim, b, degree, hookean=hookean, kmax=kmax, gamma=gamma)
    x = disc.solve(wi)
    out = disc.moments(x, wi)
    out.update(dim=dim, b=b, wi=wi, degree=disc.N, hookean=hookean, n=disc.n, gamma=gamma,
               residual=disc.residual, time=time.time() - t0)
    return out


def _relchange(r, prev, keys):
    return max(abs(r[k] - prev[k]) / max(abs(r[k]), 1e-300) for k in keys)


def converge(dim, b, wi, rtol=1e-5, start=8, step=4, nmax=None, confirm=2, gamma="auto",
             verbose=False, report_rtol=None):
    """Raise N by `step` until eta, psi1 and <Q^2> change by < rtol (relative) between
    successive N, `confirm` times in a row.  Returns (result at the last N, history);
    result["converged"] tells whether the criterion was met, result["N_report"] is the
    first N at which the change fell below report_rtol (default rtol) for good."""
    if nmax is None:
        nmax = 128 if dim == 2 else 80
    if report_rtol is None:
        report_rtol = rtol
    hist, prev, ok, N = [], None, 0, start
    while N <= nmax:
        r = steady_shear(dim, b, wi, N, gamma=gamma)
        r["change"] = _relchange(r, prev, ("eta", "psi1", "Q2")) if prev else float("nan")
        hist.append(r)
        if verbose:
            print("   " + _fmt_row(r), flush=True)
        ok = ok + 1 if (prev is not None and r["change"] < rtol) else 0
        prev = r
        if ok >= confirm:
            break
        N += step
    res = dict(hist[-1])
    res["converged"] = ok >= confirm
    # first N from which all later changes are below report_rtol
    nrep = None
    for i in range(1, len(hist)):
        if all(h["change"] < report_rtol for h in hist[i:]):
            nrep = hist[i]["degree"]
            break
    res["N_report"] = nrep
    return res, hist


def converge_tail(dim, b, wi, start, rtol=1e-2, step=8, nmax=None, confirm=2, verbose=False):
    """P(|Q| > 0.99 sqrt b) from solves with the equilibrium weight (gamma = b/2), which
    carries the correct boundary layer (1-t)^(b/2) (with a reduced gamma the tiny tail is
    swamped by rounding).  Raise N until the relative change is < rtol `confirm` times."""
    if nmax is None:
        nmax = 128 if dim == 2 else 72
    hist, prev, ok, N = [], None, 0, start
    while N <= nmax:
        r = steady_shear(dim, b, wi, N, gamma=None)
        p = r["frac_099"]
        ch = abs(p - prev) / abs(p) if prev is not None and p != 0 else float("nan")
        hist.append((N, p, ch))
        if verbose:
            print("   tail: N=%3d P=%.4e change=%.1e (t=%.1fs)" % (N, p, ch, r["time"]),
                  flush=True)
        ok = ok + 1 if (prev is not None and ch < rtol) else 0
        prev = p
        if ok >= confirm:
            break
        N += step
    return hist[-1][1], ok >= confirm, hist


def _fmt_row(r):
    p2 = "" if r.get("psi2") is None else " psi2=%+.2e" % r["psi2"]
    fr = "" if r.get("frac_099") is None else " P(>0.99)=%.3e" % r["frac_099"]
    ch = r.get("change", float("nan"))
    return ("N=%3d n=%6d eta=%.10f psi1=%.10f%s <Q2>=%.10f%s change=%.1e res=%.1e t=%.1fs"
            % (r["degree"], r["n"], r["eta"], r["psi1"], p2, r["Q2"], fr, ch,
               r["residual"], r["time"]))


# --------------------------------------------------------------------------------------
# Self-test
# --------------------------------------------------------------------------------------
def _gauss_moment(C, powers):
    """E[prod Q_i^p_i] for a zero-mean Gaussian with covariance C (Isserlis, by
    brute-force pairing via the moment generating function derivative)."""
    idx = [i for i, p in enumerate(powers) for _ in range(p)]
    if len(idx) % 2:
        return 0.0

    def rec(lst):
        if not lst:
            return 1.0
        i0 = lst[0]
        tot = 0.0
        for k in range(1, len(lst)):
            rest = lst[1:k] + lst[k + 1:]
            tot += C[i0, lst[k]] * rec(rest)
        return tot
    return rec(idx)


def _grid_expectation(disc, x, funcs):
    """<f(Q)> for callables f by quadrature over the full (t, angle) grid.  Exact for
    polynomial f (integrand polynomial x weight).  Also returns the grid for reuse."""
    rad = disc.rad
    nq = rad.nq + 8
    t, W = _gauss(nq, rad.kind, rad.alpha, rad.beta0)
    n, wa, Y = disc.ang.grid()
    r = np.sqrt(rad.s * t)
    Q = r[:, None, None] * n[None, :, :]          # (nt, na, d)
    g = np.zeros((len(t), len(wa)))
    for j, (l, idx, nk) in enumerate(disc.levels):
        F = rad.basis(l, nk, t)[0]
        c = x[j].reshape(len(idx), nk)
        g += F @ c.T @ Y[:, idx].T
    wts = W[:, None] * wa[None, :] * g
    Z = wts.sum()
    return [float((wts * f(Q)).sum() / Z) for f in funcs]


def _weak_residual(disc, x, wi):
    """Independent check of the discrete equations: max over monomials v = Q^alpha of
    degree 1..N of |int psi L*v| / scale, with L*v computed directly in Cartesian form
    ((kappa Q - F/2).grad v + lap v / 2, F evaluated pointwise)."""
    rad, dim, N = disc.rad, disc.dim, disc.N
    nq = rad.nq + 8
    # weight t^(d/2-1) (1-t)^(b/2-1): psi * (all terms) is a polynomial times this weight
    if disc.hookean:
        t, W = _gauss(nq, "laguerre", 0.0, rad.beta0)
        extra = np.ones_like(t)                   # w itself is the rule's weight
        Fscale = np.ones_like(t)                  # F = Q
    else:
        t, W = _gauss(nq, "jacobi", rad.alpha - 1.0, rad.beta0)
        extra = 1.0 - t                           # w = (1-t) * rule weight
        Fscale = np.ones_like(t)                  # w F = Q * rule weight
    n, wa, Y = disc.ang.grid()
    r = np.sqrt(rad.s * t)
    Q = r[:, None, None] * n[None, :, :]
    g = np.zeros((len(t), len(wa)))
    for j, (l, idx, nk) in enumerate(disc.levels):
        F = rad.basis(l, nk, t)[0]
        c = x[j].reshape(len(idx), nk)
        g += F @ c.T @ Y[:, idx].T
    wpsi = W[:, None] * wa[None, :] * g           # psi/weight-of-rule * rule weights
    import itertools
    worst = 0.0
    for deg in range(1, N + 1):
        for alpha in itertools.product(range(deg + 1), repeat=dim):
            if sum(alpha) != deg:
                continue
            alpha = np.array(alpha)

            def mono(a):
                if np.any(a < 0):
                    return np.zeros(Q.shape[:2]), 0.0
                return np.prod(Q ** a[None, None, :], axis=2), 1.0

            drift = np.zeros(Q.shape[:2])
            scale = np.zeros(Q.shape[:2])
            lap = np.zeros(Q.shape[:2])
            for i in range(dim):
                if alpha[i] == 0:
                    continue
                e = np.zeros(dim, int)
                e[i] = 1
                dv, _ = mono(alpha - e)
                dv = alpha[i] * dv
                # -F_i/2 dv_i
                drift += -0.5 * Fscale[:, None] * Q[:, :, i] * dv
                scale += np.abs(0.5 * Fscale[:, None] * Q[:, :, i] * dv)
                if i == 0:  # kappa_xy: (kappa Q)_x = wi Q_y
                    drift += extra[:, None] * wi * Q[:, :, 1] * dv
                    scale += np.abs(extra[:, None] * wi * Q[:, :, 1] * dv)
                if alpha[i] >= 2:
                    d2, _ = mono(alpha - 2 * e)
                    lap += extra[:, None] * 0.5 * alpha[i] * (alpha[i] - 1) * d2
            val = (wpsi * (drift + lap)).sum()
            sc = (np.abs(wpsi) * (scale + np.abs(lap))).sum()
            worst = max(worst, abs(val) / sc)
    return worst


def selftest():
    t0 = time.time()
    fails = []

    def check(name, val, ref, tol):
        err = abs(val - ref)
        ok = err <= tol
        print("  [%s] %-58s %.12g  (ref %.12g, |err| %.1e, tol %.0e)"
              % ("ok" if ok else "FAIL", name, val, ref, err, tol))
        if not ok:
            fails.append(name)

    print("1. Hookean (F = Q, Gaussian weight, same code path): eta=1, psi1=2, psi2=0 exactly")
    for dim in (2, 3):
        for wi, gam, Ns in ((1.0, None, (2, 8, 16)), (1.0, "auto", (2, 8, 16)),
                            (10.0, "auto", (2, 8, 16))):
            for N in Ns:
                if dim == 3 and N > 12:
                    N = 12
                r = steady_shear(dim, None, wi, N, hookean=True, gamma=gam)
                tag = "Hookean d=%d Wi=%g N=%d c=%.3g" % (dim, wi, N, r["gamma"] or 1.0)
                check(tag + " eta_p", r["eta"], 1.0, 1e-10)
                check(tag + " psi1", r["psi1"], 2.0, 1e-10)
                if dim == 3:
                    check(tag + " psi2", r["psi2"], 0.0, 1e-10)
                check(tag + " <Q^2>/(d+2Wi^2)", r["Q2"] / (dim + 2 * wi ** 2), 1.0, 1e-10)
    print("1b. Hookean: every moment of degree <= N is exact (L* preserves the degree);"
          " vs Gaussian (Isserlis) - exercises all harmonic/radial blocks")
    import itertools
    for dim, N, wi in ((2, 10, 2.0), (3, 8, 2.0)):
        disc = Discretisation(dim, None, N, hookean=True, gamma=0.3)
        x = disc.solve(wi)
        C = np.eye(dim)
        C[0, 0] += 2 * wi ** 2
        C[0, 1] = C[1, 0] = wi
        pw = [p for deg in range(2, N + 1, 2)
              for p in itertools.product(range(deg + 1), repeat=dim) if sum(p) == deg]
        vals = _grid_expectation(disc, x, [lambda Q, p=p: np.prod(Q ** np.array(p), axis=2)
                                           for p in pw])
        worst = max(abs(v - _gauss_moment(C, p)) / _gauss_moment_abs(C, p)
                    for v, p in zip(vals, pw))
        check("Hookean d=%d N=%d Wi=%g: max rel err of %d moments" % (dim, N, wi, len(pw)),
              worst, 0.0, 1e-9)
    print("2. FENE, small Wi: eta_p -> b/(b+d+2); Richardson (Wi=0.01, 0.02) also for"
          " Psi1(0) = 2b^2/((b+d+2)(b+d+4)) [Bird et al. DPL2, 3D]")
    for dim in (2, 3):
        for b in (10.0, 50.0):
            r1 = steady_shear(dim, b, 0.01, 12)
            r2 = steady_shear(dim, b, 0.02, 12)
            ref = b / (b + dim + 2)
            check("FENE d=%d b=%g eta_p(Wi=0.01)" % (dim, b), r1["eta"], ref, 2e-4 * ref)
            check("FENE d=%d b=%g Richardson eta_p(0)" % (dim, b),
                  (4 * r1["eta"] - r2["eta"]) / 3, ref, 1e-7 * ref)
            ref1 = 2 * b * b / ((b + dim + 2) * (b + dim + 4))
            check("FENE d=%d b=%g Richardson psi1(0)" % (dim, b),
                  (4 * r1["psi1"] - r2["psi1"]) / 3, ref1, 1e-7 * ref1)
            check("FENE d=%d b=%g direct <QF> vs identity (eta)" % (dim, b),
                  r1["eta"], r1["eta_identity"], 1e-10)
            if dim == 3:
                check("FENE d=%d b=%g psi2 (=0 for dumbbells)" % (dim, b), r1["psi2"], 0.0, 1e-6)
    print("4. FENE equilibrium (Wi=0): <Q^2> = d b/(b+d+2), P(|Q|>0.99 sqrt b) analytic")
    for dim in (2, 3):
        for b in (10.0, 50.0):
            r = steady_shear(dim, b, 0.0, 8, gamma=None)
            ref = dim * b / (b + dim + 2)
            check("FENE d=%d b=%g <Q^2>_eq" % (dim, b), r["Q2"], ref, 1e-12 * ref)
            r5 = steady_shear(dim, b, 0.0, 16)      # reduced weight: g not constant
            check("FENE d=%d b=%g <Q^2>_eq (gamma=%g, N=16)" % (dim, b, r5["gamma"]), r5["Q2"],
                  ref, 1e-10 * ref)
            # P(t > tau) for t ~ Beta(d/2, b/2+1)
            tau = 0.99 ** 2
            xg, wg = np.polynomial.legendre.leggauss(200)
            tt = tau + (1 - tau) * (xg + 1) / 2
            a, c = dim / 2, b / 2 + 1
            lB = math.lgamma(a) + math.lgamma(c) - math.lgamma(a + c)
            pref = float(np.sum(wg * (1 - tau) / 2 * tt ** (a - 1) * (1 - tt) ** (c - 1))) / math.exp(lB)
            check("FENE d=%d b=%g P(|Q|>0.99 sqrt b)_eq / exact" % (dim, b),
                  r["frac_099"] / pref, 1.0, 1e-9)
    print("5. Discrete equations re-checked independently (Cartesian monomials v, pointwise"
          " F, full grid): max |int psi L*v| / scale")
    for dim, N, b, gam in ((2, 16, 50.0, "auto"), (2, 12, 10.0, None), (3, 12, 10.0, None),
                           (3, 10, 50.0, "auto")):
        disc = Discretisation(dim, b, N, gamma=default_gamma(b) if gam == "auto" else None)
        x = disc.solve(3.0)
        check("FENE d=%d b=%g Wi=3 N=%d gamma=%s weak residual" % (dim, b, N, disc.gamma),
              _weak_residual(disc, x, 3.0), 0.0, 1e-11)
    print("6. Weight independence (converged results with gamma = b/2 and gamma = 5)")
    for dim in (2, 3):
        ra = steady_shear(dim, 50.0, 1.0, 28, gamma=None)
        rb = steady_shear(dim, 50.0, 1.0, 28, gamma=5.0)
        check("FENE d=%d b=50 Wi=1 N=28 eta(gamma=25)-eta(gamma=5)" % dim,
              ra["eta"] - rb["eta"], 0.0, 1e-9)
        check("FENE d=%d b=50 Wi=1 N=28 psi1(gamma=25)-psi1(gamma=5)" % dim,
              ra["psi1"] - rb["psi1"], 0.0, 1e-9)
    dt = time.time() - t0
    print("selftest: %s in %.1f s" % ("FAILED: " + ", ".join(fails) if fails else "all passed", dt))
    return 0 if not fails else 1


def _gauss_moment_abs(C, powers):
    """Scale for relative errors: (deg-1)!! prod_i C_ii^(p_i/2) >= |E[prod Q_i^p_i]|."""
    deg = sum(powers)
    dfac = 1.0
    for k in range(deg - 1, 0, -2):
        dfac *= k
    return dfac * float(np.prod([C[i, i] ** (p / 2.0) for i, p in enumerate(powers)]))


# --------------------------------------------------------------------------------------
TARGETS = [(d, b, wi) for d in (3, 2) for b in (10.0, 50.0) for wi in (1.0, 10.0)]


def table(rtol=1e-8, report_rtol=1e-5, verbose=True, tail_nmax3d=72):
    """Converged 8-point table (main moments to `rtol`; also reports at which N the
    change fell below `report_rtol`), the tail fraction with its own N sweep."""
    rows = []
    t0 = time.time()
    for (d, b, wi) in TARGETS:
        if verbose:
            print("# d=%d b=%g Wi=%g (gamma=%g)" % (d, b, wi, default_gamma(b)), flush=True)
        r, hist = converge(d, b, wi, rtol=rtol, report_rtol=report_rtol, verbose=verbose)
        acc = max(h["change"] for h in hist[-2:])
        p, pok, phist = converge_tail(d, b, wi, start=max(16, r["degree"] - 8),
                                      nmax=128 if d == 2 else tail_nmax3d, verbose=verbose)
        r.update(acc=acc, tail=p, tail_ok=pok, tail_N=phist[-1][0],
                 tail_change=phist[-1][2])
        rows.append(r)
    print()
    print("| d | b | Wi | eta_p/(G lam) | Psi1/(G lam^2) | Psi2/(G lam^2) | <Q^2> | "
          "P(\\|Q\\|>0.99 sqrt b) | N used | N for 1e-5 | est. rel. accuracy |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        tail = "%.3e (N=%d, %s)" % (r["tail"], r["tail_N"],
                                    "rel. change %.0e" % r["tail_change"] if r["tail_ok"]
                                    else "NOT converged, last change %.0e" % r["tail_change"])
        print("| %d | %g | %g | %.9f | %.9f | %s | %.8f | %s | %d | %s | %s |" % (
            r["dim"], r["b"], r["wi"], r["eta"], r["psi1"],
            "-" if r["psi2"] is None else "%.0e" % r["psi2"], r["Q2"], tail,
            r["degree"], r["N_report"], ("%.0e" % r["acc"]) if r["converged"]
            else "NOT converged (%.0e)" % r["acc"]))
    print("\n(total %.1f s)" % (time.time() - t0))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dim", type=int, default=3)
    ap.add_argument("--b", type=float, default=50.0)
    ap.add_argument("--wi", type=float, default=1.0)
    ap.add_argument("--degree", type=int, default=None,
                    help="polynomial degree N (default: raise N until converged)")
    ap.add_argument("--gamma", default="auto",
                    help="weight parameter: 'auto' (default), 'eq' (equilibrium weight) or "
                         "a number (FENE: exponent of (1-|Q|^2/b); Hookean: c in exp(-c Q^2/2))")
    ap.add_argument("--hookean", action="store_true")
    ap.add_argument("--converge", action="store_true", help="print the N sweep")
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--table", action="store_true")
    ap.add_argument("--tail-nmax3d", type=int, default=72,
                    help="largest N of the 3D tail-probability sweep in --table (N=128 takes"
                         " ~80 s per solve)")
    ap.add_argument("--selftest", action="store_true")
    a = ap.parse_args(argv)
    if a.selftest:
        return selftest()
    if a.table:
        table(tail_nmax3d=a.tail_nmax3d)
        return 0
    gam = None if a.gamma == "eq" else ("auto" if a.gamma == "auto" else float(a.gamma))
    tail_note = ""
    if a.hookean:
        r = steady_shear(a.dim, None, a.wi, a.degree or 8, hookean=True, gamma=gam)
    elif a.degree is not None and not a.converge:
        r = steady_shear(a.dim, a.b, a.wi, a.degree, gamma=gam)
        if r["gamma"] is not None and r["gamma"] != a.b / 2:
            # the tail needs the equilibrium weight (see docstring): extra solve
            r["frac_099"] = steady_shear(a.dim, a.b, a.wi, a.degree, gamma=None)["frac_099"]
        tail_note = "  (gamma = b/2 solve at the same N; check its N-convergence)"
    else:
        r, hist = converge(a.dim, a.b, a.wi, rtol=a.rtol, gamma=gam, verbose=a.converge)
        if not r["converged"]:
            print("WARNING: not converged to rtol=%g" % a.rtol)
        p, pok, phist = converge_tail(a.dim, a.b, a.wi, start=max(16, r["degree"] - 8),
                                      nmax=128 if a.dim == 2 else a.tail_nmax3d,
                                      verbose=a.converge)
        r["frac_099"] = p
        tail_note = "  (gamma = b/2, N=%d, %s)" % (
            phist[-1][0], "converged to 1e-2" if pok else
            "NOT converged, last rel. change %.0e" % phist[-1][2])
    print("model      : %s, d=%d, b=%s, Wi=%g, degree N=%d (%d unknowns), weight gamma=%s" % (
        "Hookean" if a.hookean else "FENE", a.dim, "-" if a.hookean else "%g" % a.b, a.wi,
        r["degree"], r["n"], "eq" if r["gamma"] is None else "%g" % r["gamma"]))
    print("eta_p/(G lambda)     = %.10f" % r["eta"])
    print("Psi1/(G lambda^2)    = %.10f" % r["psi1"])
    if r["psi2"] is not None:
        print("Psi2/(G lambda^2)    = %.3e" % r["psi2"])
    print("<|Q|^2>              = %.10f" % r["Q2"])
    if r["frac_099"] is not None:
        print("P(|Q| > 0.99 sqrt b) = %.6e%s" % (r["frac_099"], tail_note))
    print("<QQ> = %s" % {k: float("%.12g" % v) for k, v in r["QQ"].items()})
    print("<QF> = %s" % {k: float("%.12g" % v) for k, v in r["QF"].items()})
    print("identity check: eta=<Q_y^2>=%.12f  psi1=2<Q_xQ_y>/Wi=%.12f" % (
        r["eta_identity"], r["psi1_identity"]))
    print("relative residual %.1e, time %.2f s" % (r["residual"], r["time"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
