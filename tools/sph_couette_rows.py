#!/usr/bin/env python3
"""Row model of SPH start-up Couette flow of an Oldroyd-B fluid on a perfect square lattice.

The flow is unidirectional and the particles stay on their rows, so the SPH equations of
`src/models/sph/` (Lucy kernel, Morris's viscous term for the solvent, the polymer stress τ_xy
from the velocity-gradient estimate G_xy, its divergence in pair form, Morris's image walls,
kick–drift–kick) reduce to one unknown u_r and one τ_r per lattice row r, coupled through the
kernel's row sums

    A(s) = −Δ² Σ_m (sΔ) W'(ρ)/ρ,   B(s) = Δ² Σ_m W'(ρ)/ρ,   ρ = |(mΔ, sΔ)|,

    G_r      = Σ_s A(s) (u_{r+s} − u_r)                       (Eq. 3.7 × 2, xy component)
    dτ_r/dt  = (η_p G_r − τ_r)/λ                              (upper-convected Maxwell, xy)
    du_r/dt  = Σ_s A(s) (τ_r + τ_{r+s}) + 2ν_s Σ_s B(s) (u_r − u_{r+s})      (ρ = 1)

with rows beyond the walls seen as Morris's images (u_j = U − (d_j/d_i)(u_i − U), β capped)
and, in the momentum equation, τ_j := τ_i (the fluid end's stress), as the code does
(`--walls code`); or as exact odd/even images of the row at the mirror point
(`--walls exact`: u_j = 2U − u(mirror), τ_j = τ(mirror)); or Morris's velocities with the
mirror point's τ (`--walls tau-mirror`). ρ = 1 and no pressure: what it leaves out of SPH is
the compressibility, the density near the walls and the rows' sliding along x.

It reproduces the SPH runs of the Oldroyd-B start-up to 0.1–0.25 % of U (docs/validation.md,
"Elastic start-up Couette"), which separates the SPH error into the bulk operator (`--walls
exact`: the discretisation of the periodic, odd-extended lattice), the wall images and the
lattice sums (Σ_s A(s) sΔ, the derivative of a linear field: 0.9864 at support 2.5Δ, 1.0008 at
3Δ; `--corrected` divides both derivatives by it). The reference is the series of
`analytic::couette_oldroyd_b`, summed here over `--modes` modes.

    python3 tools/sph_couette_rows.py --rows 50 --support 2.5 --cap 2       # the issue's setup
    python3 tools/sph_couette_rows.py --rows 100 --support 3 --cap 6 --walls exact
"""
import argparse
import math


def row_sums(support, spacing):
    """A(s), B(s) of the Lucy kernel of support `support` on a square lattice of spacing
    `spacing` (2D, w₀ = 5/(πh²), W'(r)/r = −12 w₀ (1 − q)²/h²)."""
    h = support
    w0 = 5.0 / (math.pi * h * h)
    reach = int(math.ceil(h / spacing))
    area = spacing * spacing
    a, b = {}, {}
    for s in range(-reach, reach + 1):
        total = 0.0
        for m in range(-reach - 1, reach + 2):
            if m == 0 and s == 0:
                continue
            q = math.hypot(m * spacing, s * spacing) / h
            if q < 1.0:
                total += -12.0 * w0 * (1.0 - q) ** 2 / (h * h)
        a[s] = -area * (s * spacing) * total
        b[s] = area * total
    return a, b


def oldroyd_b_series(y, t, nu_s, nu_p, lam, modes, wall_velocity=1.0, gap=1.0):
    """analytic::couette_oldroyd_b (ρ = 1)."""
    if t <= 0.0:
        return 0.0
    total = wall_velocity * y / gap
    for n in range(1, modes + 1):
        k = n * math.pi / gap
        a0 = 2.0 * wall_velocity * (1 if n % 2 == 0 else -1) / (n * math.pi)
        slope0 = -nu_s * k * k * a0
        b = 1.0 + lam * nu_s * k * k
        c = (nu_s + nu_p) * k * k
        disc = b * b - 4.0 * lam * c
        if disc > 0.0:
            root = math.sqrt(disc)
            sp, sm = (-b + root) / (2 * lam), (-b - root) / (2 * lam)
            cp, cm = (slope0 - sm * a0) / (sp - sm), (sp * a0 - slope0) / (sp - sm)
            amp = cp * math.exp(sp * t) + cm * math.exp(sm * t)
        else:
            mu, om = -b / (2 * lam), math.sqrt(-disc) / (2 * lam)
            amp = math.exp(mu * t) * (a0 * math.cos(om * t) + (slope0 - mu * a0) / om * math.sin(om * t))
        total += amp * math.sin(k * y)
    return total


def simulate(rows, support_over_spacing, nu_s, nu_p, lam, dt, times, cap, walls, corrected):
    """u_r at each of `times` (kick–drift–kick as src/integrators/sph_schemes.rs: the rates at
    the predicted v̂ = v + Δt a, τ̂ = τ + Δt τ̇, then the second half kicks)."""
    spacing = 1.0 / rows
    a, b = row_sums(support_over_spacing * spacing, spacing)
    norm = sum(a[s] * s * spacing for s in a) if corrected else 1.0
    y = [(r + 0.5) * spacing for r in range(rows)]

    def mirror(r):
        return -1 - r if r < 0 else 2 * rows - 1 - r

    def image_velocity(i, r, u):
        wall = 0.0 if r < 0 else 1.0
        if walls == "exact":
            return 2.0 * wall - u[mirror(r)]
        if r < 0:
            di, dj = y[i], -(r + 0.5) * spacing
        else:
            di, dj = 1.0 - y[i], (r + 0.5) * spacing - 1.0
        beta = min(1.0 + dj / max(di, 0.5 * spacing), cap)
        return u[i] - beta * (u[i] - wall)

    def rates(u, tau):
        seen = [{} for _ in range(rows)]
        for i in range(rows):
            for s in a:
                r = i + s
                if s != 0 and not 0 <= r < rows:
                    seen[i][r] = image_velocity(i, r, u)
        dtau = []
        for i in range(rows):
            g = sum(a[s] * ((u[i + s] if 0 <= i + s < rows else seen[i][i + s]) - u[i])
                    for s in a if s != 0)
            dtau.append((nu_p * g / norm - tau[i]) / lam)
        acc = []
        for i in range(rows):
            f = 0.0
            for s in a:
                if s == 0:
                    continue
                r = i + s
                if 0 <= r < rows:
                    tj, uj = tau[r], u[r]
                else:
                    uj = seen[i][r]
                    tj = tau[i] if walls == "code" else tau[mirror(r)]
                f += a[s] * (tau[i] + tj) / norm + 2.0 * nu_s * b[s] * (u[i] - uj)
            acc.append(f)
        return acc, dtau

    u, tau = [0.0] * rows, [0.0] * rows
    acc, dtau = rates(u, tau)
    wanted = {round(t / dt): t for t in times}
    out = {}
    for step in range(1, max(wanted) + 1):
        half_u = [u[i] + 0.5 * dt * acc[i] for i in range(rows)]
        half_tau = [tau[i] + 0.5 * dt * dtau[i] for i in range(rows)]
        acc, dtau = rates([u[i] + dt * acc[i] for i in range(rows)],
                          [tau[i] + dt * dtau[i] for i in range(rows)])
        u = [half_u[i] + 0.5 * dt * acc[i] for i in range(rows)]
        tau = [half_tau[i] + 0.5 * dt * dtau[i] for i in range(rows)]
        if step in wanted:
            out[wanted[step]] = (list(y), list(u))
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rows", type=int, default=50, help="fluid rows across the gap (Δ = 1/rows)")
    p.add_argument("--support", type=float, default=2.5, help="Lucy support / Δ")
    p.add_argument("--lam", type=float, default=0.05, help="relaxation time λ")
    p.add_argument("--beta", type=float, default=0.1, help="η_s/η₀ (η₀ = 1)")
    p.add_argument("--cap", type=float, default=2.0, help="Morris's β_max")
    p.add_argument("--walls", choices=("code", "exact", "tau-mirror"), default="code")
    p.add_argument("--corrected", action="store_true",
                   help="divide both SPH derivatives by the lattice sum Σ A(s) sΔ")
    p.add_argument("--dt", type=float, default=None,
                   help="default 1e-4/2^k, the largest within half the solvent's limit 0.042 r_s²/ν_s")
    p.add_argument("--times", default="0.01,0.02,0.05,0.1,0.2,0.3")
    p.add_argument("--modes", type=int, default=3000)
    o = p.parse_args()
    times = [float(t) for t in o.times.split(",")]
    nu_s, nu_p = o.beta, 1.0 - o.beta
    spacing = 1.0 / o.rows
    dt = o.dt or 1e-4
    while o.dt is None and dt > 0.5 * 0.042 * (o.support * spacing) ** 2 / nu_s:
        dt /= 2
    a, _ = row_sums(o.support * spacing, spacing)
    print(f"rows {o.rows}, support {o.support}Δ (lattice sum {sum(a[s] * s * spacing for s in a):.5f}), "
          f"λ = {o.lam}, β = {o.beta}, cap {o.cap}, walls {o.walls}, corrected {o.corrected}, Δt = {dt:g}")
    for t, (ys, us) in sorted(simulate(o.rows, o.support, nu_s, nu_p, o.lam, dt, times, o.cap,
                                       o.walls, o.corrected).items()):
        errs = [(abs(u - oldroyd_b_series(y, t, nu_s, nu_p, o.lam, o.modes)), y) for y, u in zip(ys, us)]
        e, y = max(errs)
        print(f"t = {t:g}: max |u − u_series| = {100 * e:.3f} % of U (y = {y:.3f})")


if __name__ == "__main__":
    main()
