//! The time-step limits of an SPH fluid, which `check` reports and the validation enforces.
//!
//! The acoustic limit is where kick–drift–kick stops being stable for the fastest lattice
//! sound mode (θ = c₀ max|g| Δt ≈ 2 for Lucy at r_s = 2.5Δ, docs/theory/sph_maxwell.md §1.6).
//! The viscous limit of Morris's direct term is measured: the start-up Couette case (Lucy
//! r_s = 2.5Δ, Morris walls with β_max = 2, kick–drift–kick) runs 3000 steps at
//! ν Δt / r_s² = 0.042 and blows up at 0.044 (`cases/sph_couette_2d.toml` with
//! `--set integrator.dt=1.1e-4`). The nested summation's wider stencil damps less at the lattice
//! scale (docs/theory/sph_maxwell.md §1.6); Morris's 0.125 is kept for it (the same case runs at
//! 0.08).

use super::SphCfg;

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
        // Elastic shear waves of speed √(η_p/(ρ₀λ)) travel with the sound
        // (docs/theory/sph_maxwell.md §1.12), and the explicit relaxation needs Δt < λ. The
        // polymer stress is advanced like a velocity-dependent field (not symplectically), so the
        // elastic limit is tighter than the acoustic one. The coefficient is measured
        // (`./run validate maxwell_stability`: maxwell_shear_2d.toml, Lucy 3Δ, η_p = 9.9,
        // bisection on 2000-step runs): the largest stable Δt is 0.38 r_s/√(c₀² + η_p/(ρ₀λ)) at
        // De = 0.0125 and 0.45 at De = 0.05; 0.35 stays 8 % below the worst.
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
