//! Time-step limits that `check` reports and the validation enforces.
//!
//! DPD (explicit in the velocity-dependent dissipative force):
//!
//! ```text
//! Σ_j w_D(r_ij) ≈ n ∫ w_D dV = n 4π r_c³ · 2 / ((s+1)(s+2)(s+3))     (3D)
//!                            = n 2π r_c² / ((s+1)(s+2))               (2D)
//! Δt_D = m / (γ Σ_j w_D)          relaxation of the relative velocity in one step
//! ω²   = (a / r_c) N_c / (D m),   N_c = n V_D(r_c) neighbours,   Δt_C = 2 / ω  (Verlet)
//! ```
//!
//! Δt_D is the step at which the explicit update over-corrects the relative velocity of a
//! particle and its neighbourhood; beyond Δt_C the conservative oscillation of a particle in
//! its cage is unstable under velocity Verlet. Groot & Warren (1997) recommend Δt ≈ 0.04–0.06 at
//! a = 25, γ = 4.5, ρ = 3 for k_BT within a few per cent: that accuracy limit is reported, not
//! enforced (see the k_BT-vs-Δt curve in docs/validation.md).
//!
//! SPH (the summation gas): the acoustic CFL limit Δt < 0.25 h / c (Monaghan 1992; spec
//! `sph-maxwell.md` §1).
//!
//! SPH (`kind = "sph"`, spec `sph-maxwell.md` §1.12), with r_s the kernel support:
//!
//! ```text
//! acoustic (CFL, the thesis's criterion)   Δt ≤ r_s / c₀
//! viscous, nested summation               Δt ≤ 0.125 r_s² ρ₀ / η     (Morris et al.'s criterion)
//! viscous, Morris's term                   Δt ≤ 0.042 r_s² ρ₀ / η     (measured, below)
//! force (Monaghan; the thesis's h/|F| is
//!        dimensionally wrong)              Δt ≤ 0.25 √(r_s / |F|)     (F the body force)
//! ```
//!
//! The acoustic limit is where kick–drift–kick stops being stable for the fastest lattice
//! sound mode (θ = c₀ max|g| Δt ≈ 2 for Lucy at r_s = 2.5Δ, spec §1.6). The viscous limit of
//! Morris's direct term is measured: the start-up Couette case (Lucy r_s = 2.5Δ, Morris walls
//! with β_max = 2, kick–drift–kick) runs 3000 steps at ν Δt / r_s² = 0.042 and blows up at
//! 0.044 (`cases/sph_couette_2d.toml` with `--set integrator.dt=1.1e-4`). The nested
//! summation's wider stencil damps less at the lattice scale (spec §1.6); Morris's 0.125 is
//! kept for it (the same case runs at 0.08).

use crate::models::dpd::DpdCfg;
use crate::models::sph::SphCfg;

/// Time-step limits of a DPD case.
#[derive(Clone, Copy, Debug)]
pub struct DpdLimits {
    /// Expected neighbours inside the cutoff.
    pub neighbours: f64,
    /// Σ_j w_D at the mean density.
    pub sum_wd: f64,
    /// Dissipative stability limit Δt_D.
    pub dissipative: f64,
    /// Conservative (Verlet) stability limit Δt_C.
    pub conservative: f64,
}

/// Volume of the D-ball of radius r.
pub fn ball_volume(dimension: usize, r: f64) -> f64 {
    if dimension == 2 {
        std::f64::consts::PI * r * r
    } else {
        4.0 / 3.0 * std::f64::consts::PI * r * r * r
    }
}

/// The acoustic (CFL) limit 0.25 h / c of an SPH fluid with smoothing length h and sound
/// speed c.
pub fn cfl_limit(smoothing_length: f64, sound_speed: f64) -> f64 {
    0.25 * smoothing_length / sound_speed
}

/// Limits for the DPD fluid `d` in `dimension` dimensions at number density `n` and particle
/// mass `m`.
pub fn dpd_limits(d: &DpdCfg, dimension: usize, n: f64, m: f64) -> DpdLimits {
    let s = d.weight_exponent;
    let rc = d.cutoff;
    let dim = dimension;
    let sum_wd = if dim == 2 {
        n * 2.0 * std::f64::consts::PI * rc * rc / ((s + 1.0) * (s + 2.0))
    } else {
        n * 4.0 * std::f64::consts::PI * rc.powi(3) * 2.0 / ((s + 1.0) * (s + 2.0) * (s + 3.0))
    };
    let neighbours = n * ball_volume(dim, rc);
    // The conservative force a (1 − r/r_c)^s̄ stiffens as a s̄/r_c near contact.
    let omega2 = d.a * d.conservative_exponent / rc * neighbours / (dim as f64 * m);
    DpdLimits {
        neighbours,
        sum_wd,
        dissipative: m / (d.gamma * sum_wd),
        conservative: if omega2 > 0.0 {
            2.0 / omega2.sqrt()
        } else {
            f64::INFINITY
        },
    }
}

/// The mean-field rate of the DPD friction, ω₀ = γ n [w_D]/(d m) = γ Σ_j w_D/(d m) (spec
/// `dpd-physical-parameters.md` §10 A7): the velocity of a particle among neighbours at rest
/// relaxes as e^{−ω₀t}.
pub fn dpd_mean_field_rate(d: &DpdCfg, dimension: usize, n: f64, m: f64) -> f64 {
    d.gamma * dpd_limits(d, dimension, n, m).sum_wd / (dimension as f64 * m)
}

/// Time-step limits of an SPH fluid, each with its name.
pub fn sph_limits(s: &SphCfg, inclusions: bool) -> Vec<(&'static str, f64)> {
    let support = s.support();
    let mut limits = vec![("acoustic (CFL) r_s/c₀", support / s.sound_speed)];
    if s.viscosity > 0.0 {
        let (name, c) = match s.viscous_term {
            crate::models::sph::ViscousTerm::NestedSummation => ("viscous 0.125 r_s² ρ₀/η", 0.125),
            // Morris's images of an inclusion couple a fluid particle to the surface β ≤ β_max
            // times more strongly than a fluid neighbour; the coefficient is measured (quintic,
            // Δ = 0.02, R = 0.2, β_max = 1.5, XSPH ε = 1: Δt at 0.62 × 0.042 r_s²ρ₀/η runs
            // 10⁴ steps, at 0.68× blows up within 500).
            crate::models::sph::ViscousTerm::Morris if inclusions => {
                ("viscous (inclusions) 0.025 r_s² ρ₀/η", 0.025)
            }
            crate::models::sph::ViscousTerm::Morris => ("viscous 0.042 r_s² ρ₀/η", 0.042),
        };
        limits.push((name, c * support * support * s.rest_density / s.viscosity));
    }
    if let Some(poly) = &s.polymer {
        // Elastic shear waves of speed √(η_p/(ρ₀λ)) travel with the sound (spec §1.12), and the
        // explicit relaxation needs Δt < λ. The polymer stress is advanced like a velocity-
        // dependent field (not symplectically), so the elastic limit is tighter than the
        // acoustic one. The coefficient is measured (`./run validate maxwell_stability`:
        // maxwell_shear_2d.toml, Lucy 3Δ, η_p = 9.9, bisection on 2000-step runs): the largest
        // stable Δt is 0.38 r_s/√(c₀² + η_p/(ρ₀λ)) at De = 0.0125 and 0.45 at De = 0.05; 0.35
        // stays 8 % below the worst.
        let elastic = poly.viscosity / (s.rest_density * poly.relaxation_time);
        limits.push((
            "elastic wave 0.35 r_s/√(c₀² + η_p/(ρ₀λ))",
            0.35 * support / (s.sound_speed * s.sound_speed + elastic).sqrt(),
        ));
        limits.push(("relaxation λ", poly.relaxation_time));
    }
    let force = s.body_force.iter().map(|f| f * f).sum::<f64>().sqrt();
    if force > 0.0 {
        limits.push((
            "body force 0.25 √(r_s/|F|)",
            0.25 * (support / force).sqrt(),
        ));
    }
    limits
}

/// The binding (smallest) SPH limit.
pub fn sph_binding_limit(s: &SphCfg, inclusions: bool) -> (&'static str, f64) {
    sph_limits(s, inclusions)
        .into_iter()
        .fold(
            ("none", f64::INFINITY),
            |a, b| if b.1 < a.1 { b } else { a },
        )
}
