//! Weakly compressible SPH for Newtonian fluids (`[fluid] kind = "sph"`), with walls of
//! boundary particles (`[walls]`). Ellero 2004, ch. 2, as distilled with its printed errors
//! corrected in docs/theory/sph_maxwell.md §1–§2; notation x_ij = x_i − x_j, v_ij = v_i − v_j,
//! ∇_i W_ij = W'(r_ij) x_ij / r_ij.
//!
//! ```text
//! density, summation (Eq. 2.29)    ρ_i = Σ_j m_j W_ij              (j = i included)
//! density, continuity (Eq. 2.31)   dρ_i/dt = Σ_j m_j v_ij · ∇_i W_ij
//! quadratic EOS (Eq. 2.35)         p = c₀² ρ² / (2 ρ₀)            (p/ρ² = c₀²/(2ρ₀), constant)
//! Tait EOS (Eq. 2.38)              p = (c₀² ρ₀ / 7) ((ρ/ρ₀)⁷ − 1)
//! velocity gradient (Eq. 3.7 × 2)  G_i^{ab} = ∂v^a/∂x^b ≈ Σ_j (m_j/ρ_j)(v_j^a − v_i^a) ∂_b W_ij
//! Newtonian stress (Eq. 2.40)      σ̄_i = η (G_i + G_iᵀ − (2/d) tr G_i I)        (ζ = 0)
//! momentum (Eq. 2.20, corrected)   dv_i^a/dt = Σ_j m_j [(σ̄_i^{ab}/ρ_i² + σ̄_j^{ab}/ρ_j²)
//!                                                 − (p_i/ρ_i² + p_j/ρ_j²) δ^{ab}] ∂_b W_ij + F^a
//! Morris viscosity (alternative)   dv_i/dt += Σ_j m_j (2η/(ρ_i ρ_j)) (x_ij·∇_i W_ij)/(r_ij² + 0.01h²) v_ij
//! ```
//!
//! With `[fluid.polymer]` every particle also carries a polymer stress τ_i ([`maxwell`]),
//! integrated state advanced with the constitutive rate that the velocity-gradient pass forms
//! from G_i; it joins σ̄ in the momentum equation (σ̄_i → σ̄_i + τ_i). Boundary particles advance
//! their own τ from their own G (method B, the λ → 0 limit of the nested summation's wall
//! stress); with Morris's images a fluid–boundary pair uses the fluid particle's τ for both ends
//! (τ_j := τ_i, zero normal gradient, docs/theory/sph_maxwell.md §2.3). With Morris's viscous term
//! the Newtonian stress η(G + Gᵀ − (2/d) tr G I) of a polymer fluid is still formed, for
//! the observables only.
//!
//! Departures from the printed text (docs/theory/sph_maxwell.md §1.2, §1.12, §2.2): the momentum
//! equation contracts the stress with ∂_b W (the thesis prints ∂_a); the wall repulsion is made to
//! repel; the thesis's first-order predictor–corrector is only one of the integrators
//! ([`crate::integrators`]).
//!
//! The "nested summation" is two gather passes: pass 1 estimates G_i and stores σ̄_i, the
//! engine refreshes the ghosts' σ̄, pass 2 forms the momentum equation. Morris's direct term
//! needs no gradient pass. With summation density a density pass comes first; with continuity
//! density ρ is integrated state ([`ParticleModel::integrated_fields`]).
//!
//! Every pair term is exactly antisymmetric (force) or symmetric (density, dρ/dt) under i ↔ j,
//! so momentum is conserved pair by pair, and every sum is exact ([`crate::fixed_sum`]), so
//! the results are the same bits on any number of ranks and threads.
//!
//! # Walls (`[walls]`, thesis method B and Morris's images)
//! Layers of boundary particles continue the lattice beyond the two faces of the wall axis, at
//! least one kernel support thick (default two, so that every boundary particle a fluid
//! particle sees has a complete summation density). They are species of their own
//! ([`crate::species`]): frozen, or moving at the wall velocity; they enter every sum, are
//! never integrated and never counted as fluid. The momentum pass gives them the reactions of
//! their fluid neighbours (pairs of two boundary particles contribute nothing), so the force
//! on a wall's particles is the force the fluid exerts on that wall (the `wall_shear_stress`
//! observable). Their density is summed like the fluid's (or
//! stays ρ₀ under continuity); with the nested summation they carry the stress of their own
//! velocity-gradient estimate. Two treatments of the velocity a fluid particle i sees for a
//! boundary particle j of a wall moving at U:
//!
//! - `layers` (method B): v_j = U;
//! - `morris` (Morris, Fox & Zhu 1997): v_j = U − (d_j/d_i)(v_i − U), i.e. v_i − v_j = β (v_i − U)
//!   with β = min(1 + d_j/d_i, β_max), d_i ≥ Δ/2 the distances from the wall plane
//!   (docs/theory/sph_maxwell.md §2.3).
//!
//! A Lennard-Jones-like repulsion between fluid and boundary particles closer than r₀
//! (docs/theory/sph_maxwell.md §2.2, Eq. 2.47, with the sign that repels),
//! a_i = D [(r₀/r)⁴ − (r₀/r)²] x_ij / r², keeps fluid out of the wall; r₀ defaults to the lattice
//! spacing (the initial fluid–wall distance, where the force vanishes) and D to c₀².

pub mod kernels;
pub mod keys;
mod lanes;
pub mod mirror;
mod momentum_flux;
pub mod msph;
pub mod polymer;
mod spec;
pub mod time_step;
mod validate;

use crate::fixed_sum::Scale;
use crate::models::gather::{
    BATCH, BatchTerms, FullList, GatherKernel, PairBatch, Parity, ScatterBuffers, SymmetricKernel,
    gather, gather_in_lanes, pair_by_pair, scatter,
};
use crate::models::interface::{
    FieldKind, FieldSpec, Integrated, ParticleModel, PassContext, PassOutput, PassSpec,
};
use crate::neighbour::NeighbourList;
use crate::particles::{FieldFlags, Particles};
use crate::simd::Isa;
use crate::species::{Motion, Species};
use crate::with_kernel;
use kernels::{Kernel, KernelKind};
use mirror::{FitFallbacks, MirrorWalls};
pub use momentum_flux::SPH_STRESS_PARTS;
use msph::{Local, MomentKernel, unknowns};
use polymer::{ConstitutiveLaw, PolymerCfg, packed_index, packed_width};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

mod boundaries;
mod config;
mod density;
mod fields;
mod gradient;
mod model;
mod momentum;
mod observables;

use boundaries::*;
pub use config::*;
use density::*;
pub use fields::*;
use gradient::*;
/// The first-order gradient correction's inverse and its singularity guard, shared with the
/// GENERIC polymer particle's corrected conformation gradient.
pub(crate) use gradient::{MIN_CORRECTION_DETERMINANT, determinant_and_inverse};
pub use model::SphModel;
use momentum::*;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::gather::{pair_symmetry, scatter_on};
    use crate::neighbour::NeighbourList;
    use crate::rng::{Purpose, StreamKey};
    use crate::simd::Isa;

    fn cfg(viscous_term: ViscousTerm, density: DensityMethod) -> SphCfg {
        SphCfg {
            kernel: KernelKind::WendlandC2,
            smoothing_length: 0.6,
            rest_density: 1.0,
            sound_speed: 10.0,
            equation_of_state: EquationOfState::Tait,
            density,
            viscosity: 0.3,
            viscous_term,
            body_force: Vec::new(),
            morris_regularisation: 0.01,
            xsph: 0.0,
            background_pressure: 0.0,
            transport_pressure: 0.0,
            velocity_gradient: GradientEstimate::Sph,
            derivatives: Derivatives::Sph,
            morris_share: 0.0,
            polymer: None,
        }
    }

    /// The corrected estimate G_i M_i⁻¹ recovers a linear velocity field v = A x + b exactly
    /// (to round-off) on a random arrangement with random densities, where the plain SPH
    /// estimate is off by several per cent; and the cofactor inverse is an inverse.
    #[test]
    fn corrected_gradient_is_exact_for_a_linear_field_on_a_disordered_arrangement() {
        let key = StreamKey::new(5, Purpose::Test, 4);
        let mut p = random_particles();
        let a: [[f64; 3]; 3] = std::array::from_fn(|r| {
            std::array::from_fn(|c| key.uniform2(2, r as u32, c as u32).0 - 0.5)
        });
        for i in 0..p.n_owned {
            let x = p.pos[i];
            p.vel[i] = std::array::from_fn(|r| 0.3 + (0..3).map(|c| a[r][c] * x[c]).sum::<f64>());
        }
        let density: Vec<f64> = (0..p.n_owned)
            .map(|i| 0.9 + 0.2 * key.uniform2(3, i as u32, 0).0)
            .collect();
        let list = NeighbourList::build(&p, 1.2, 1.2);
        let full = FullList::from_half(&list, p.n_owned);
        let errors = |corrected: bool| -> f64 {
            let width = if corrected { 18 } else { 9 };
            let k = GradientKernel {
                kernel: kernels::WendlandC2::new(0.6, 3),
                // m/ρ ≈ the volume per particle (4³/300), so that M_i ≈ I.
                mass: 0.2,
                density: &density,
                boundaries: Boundaries::default(),
                corrected,
                scales: vec![Scale::covering(1e3); width],
            };
            let mut sums = Vec::new();
            gather(&k, &p, &full, &mut sums).expect("gather");
            if corrected {
                // Particles at the cube's corners see too few neighbours and keep G_i.
                let kept = apply_gradient_correction::<3>(&mut sums, width);
                assert!(kept < p.n_owned / 4, "{kept} of {} kept G_i", p.n_owned);
            }
            // Particles whose whole support (1.2) lies inside the cube of side 4.
            let mut worst: f64 = 0.0;
            for i in (0..p.n_owned).filter(|&i| p.pos[i].iter().all(|&x| (1.2..2.8).contains(&x))) {
                for r in 0..3 {
                    for c in 0..3 {
                        worst = worst.max((sums[i * width + r * 3 + c] - a[r][c]).abs());
                    }
                }
            }
            worst
        };
        let (plain, corrected) = (errors(false), errors(true));
        assert!(
            plain > 0.02,
            "the plain estimate is off by {plain}: the test needs disorder"
        );
        assert!(corrected < 1e-11, "corrected estimate off by {corrected}");
        for m in [
            [[2.0, 0.3, -0.1], [0.5, 1.1, 0.2], [-0.4, 0.7, 0.9]],
            [[1.0, 0.0, 0.0], [0.0, 3.0, 1.0], [0.0, -1.0, 0.5]],
        ] {
            let (det, inv) = determinant_and_inverse(&m);
            assert!(det.abs() > 0.1);
            for r in 0..3 {
                for c in 0..3 {
                    let e: f64 = (0..3).map(|k| m[r][k] * inv[k][c]).sum();
                    assert!((e - f64::from(u8::from(r == c))).abs() < 1e-14, "{m:?}");
                }
            }
        }
        let m2 = [[2.0, 0.3], [0.5, 1.1]];
        let (det, inv) = determinant_and_inverse(&m2);
        assert!((det - 2.05).abs() < 1e-14);
        for r in 0..2 {
            for c in 0..2 {
                let e: f64 = (0..2).map(|k| m2[r][k] * inv[k][c]).sum();
                assert!((e - f64::from(u8::from(r == c))).abs() < 1e-14);
            }
        }
    }

    /// Random particles with random velocities, densities and stresses.
    fn random_particles() -> Particles<3> {
        let key = StreamKey::new(5, Purpose::Test, 2);
        let mut p = Particles::<3>::default();
        for i in 0..300u32 {
            let x = std::array::from_fn(|d| 4.0 * key.uniform2(0, i, d as u32).0);
            let v = std::array::from_fn(|d| key.uniform2(1, i, d as u32).0 - 0.5);
            p.push_owned(u64::from(i), x, v);
        }
        p
    }

    /// The momentum pair term is exactly antisymmetric (both viscous terms, with dρ/dt
    /// symmetric) and the gradient and density terms have the parity their sums need.
    #[test]
    fn pair_terms_have_exact_parity() {
        let key = StreamKey::new(5, Purpose::Test, 3);
        for (viscous, density) in [
            (ViscousTerm::NestedSummation, DensityMethod::Summation),
            (ViscousTerm::Morris, DensityMethod::Continuity),
        ] {
            let mut p = random_particles();
            // Periodic images of the particles near x = 0 (ghosts: rows of the full list
            // reach them only from their owned neighbours' end).
            for i in 0..p.n_owned {
                if p.pos[i][0] < 1.2 {
                    let (g, mut x, v) = (p.gid[i], p.pos[i], p.vel[i]);
                    x[0] += 4.0;
                    p.push_ghost(g, x, v, 0);
                }
            }
            let model_cfg = cfg(viscous, density);
            let mut model = SphModel::<3>::new(&model_cfg, 0.05, &[4.0; 3], 0.2, None, None);
            for spec in model.fields() {
                p.register_field(spec.name, spec.kind.width(3), spec.flags)
                    .expect("new field");
            }
            model.attach(&mut p, false).expect("attach");
            for i in 0..p.len() {
                p.extra[model.density].data[i] = 0.9 + 0.2 * key.uniform2(0, i as u32, 0).0;
                if let Some(s) = model.stress {
                    for c in 0..9 {
                        p.extra[s].data[i * 9 + c] = key.uniform2(1, i as u32, c as u32).0;
                    }
                }
            }
            let list = NeighbourList::build(&p, 1.2, 1.2);
            let density = &p.extra[model.density].data;
            let p_over_rho2: Vec<f64> = density
                .iter()
                .map(|&r| SphCfg::pressure_over_rho2(EquationOfState::Tait, 100.0, 1.0, r))
                .collect();
            let kernel = kernels::WendlandC2::new(0.6, 3);
            let continuity = density_is_continuity(&model_cfg);
            let inv_density: Vec<f64> = density.iter().map(|r| 1.0 / r).collect();
            // σ̄/ρ² per particle, as the pass forms it for the lanes.
            let stress_over_rho2: Option<Vec<f64>> = model.stress.map(|s| {
                p.extra[s]
                    .data
                    .chunks_exact(9)
                    .zip(density)
                    .flat_map(|(s, &rho)| s.iter().map(move |&c| c / (rho * rho)))
                    .collect()
            });
            for regulariser in [0.0036, 0.0] {
                let momentum = MomentumKernel {
                    kernel,
                    mass: 0.05,
                    density,
                    inv_density: &inv_density,
                    p_over_rho2: &p_over_rho2,
                    stress: model.stress.map(|s| p.extra[s].data.as_slice()),
                    stress_over_rho2: stress_over_rho2.as_deref(),
                    polymer: None,
                    two_eta_morris: if viscous == ViscousTerm::Morris {
                        0.6
                    } else {
                        0.0
                    },
                    regulariser,
                    continuity,
                    xsph_eps_mass: 0.0,
                    transport: 0.0,
                    pairwise_stress: true,
                    boundaries: Boundaries::default(),
                    scales: vec![Scale::covering(1e6); 3 + usize::from(continuity)],
                    parities: {
                        let mut parity = vec![Parity::Odd; 3];
                        if continuity {
                            parity.push(Parity::Even);
                        }
                        parity
                    },
                };
                let checked =
                    pair_symmetry(&momentum, &p, &list, momentum.parities()).expect("parity");
                assert!(checked > 1000, "{checked} pairs");
                // Scattered from the half list (in batches, by the vectorised loops where the
                // kernel has them, portable or AVX2), the sums are gather's to the last bit.
                let full = FullList::from_half(&list, p.n_owned);
                let mut gathered = Vec::new();
                gather(&momentum, &p, &full, &mut gathered).expect("gather");
                assert!(gathered.iter().any(|&x| x != 0.0));
                let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                let avx2 = Isa::avx2_for_test("sph scatter: AVX2 against gather");
                for isa in [Some(Isa::PORTABLE), avx2].into_iter().flatten() {
                    let mut scattered = Vec::new();
                    let mut work = ScatterBuffers::default();
                    scatter_on(isa, &momentum, &p, &list, &mut work, &mut scattered)
                        .expect("scatter");
                    assert_eq!(bits(&gathered), bits(&scattered), "{isa:?}");
                }
                // Gathered in lanes along the full rows (the fluid-only scheme: Morris's term
                // with continuity, or the nested summation's stress), by the portable loops
                // and, where the CPU has it, AVX-512: the same bits.
                let avx512 = Isa::avx512();
                if avx512.is_none() {
                    let _ = Isa::avx2_for_test("sph lanes: AVX-512 (only the portable lanes)");
                }
                for isa in [Some(Isa::PORTABLE), avx512].into_iter().flatten() {
                    let mut lanes = Vec::new();
                    assert!(momentum.gather_lanes(isa, &p, full.lanes(), &mut lanes));
                    assert_eq!(bits(&gathered), bits(&lanes), "{isa:?}");
                }
                // Without σ̄/ρ² the nested summation's lanes decline (the pass scatters).
                if momentum.stress.is_some() {
                    let without = MomentumKernel {
                        stress_over_rho2: None,
                        scales: momentum.scales.clone(),
                        parities: momentum.parities.clone(),
                        ..momentum
                    };
                    assert!(!without.gather_lanes(
                        Isa::PORTABLE,
                        &p,
                        full.lanes(),
                        &mut Vec::new()
                    ));
                }
                // A term beyond its scale: the lanes decline, and the scatter names it.
                let narrow = MomentumKernel {
                    scales: vec![Scale::covering(1e-12); momentum.scales.len()],
                    parities: momentum.parities.clone(),
                    ..momentum
                };
                for isa in [Some(Isa::PORTABLE), avx512].into_iter().flatten() {
                    let mut lanes = Vec::new();
                    assert!(!narrow.gather_lanes(isa, &p, full.lanes(), &mut lanes));
                }
            }
            // The velocity-gradient pass (plain and corrected) in its vector lanes, portable
            // and AVX-512, and in the generic lanes: the gather's bits.
            let full = FullList::from_half(&list, p.n_owned);
            let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            for corrected in [false, true] {
                let width = if corrected { 18 } else { 9 };
                let k = GradientKernel {
                    kernel,
                    mass: 0.05,
                    density,
                    boundaries: Boundaries::default(),
                    corrected,
                    scales: vec![Scale::covering(1e3); width],
                };
                let mut gathered = Vec::new();
                gather(&k, &p, &full, &mut gathered).expect("gather");
                assert!(gathered.iter().any(|&x| x != 0.0));
                for isa in [Some(Isa::PORTABLE), Isa::avx2(), Isa::avx512()]
                    .into_iter()
                    .flatten()
                {
                    let mut lanes = Vec::new();
                    assert!(k.gather_lanes(isa, &p, full.lanes(), &mut lanes), "{isa:?}");
                    assert_eq!(bits(&gathered), bits(&lanes), "vector lanes {isa:?}");
                    assert!(gather_in_lanes(isa, &k, &p, &full, &mut lanes), "{isa:?}");
                    assert_eq!(bits(&gathered), bits(&lanes), "generic lanes {isa:?}");
                }
                let narrow = GradientKernel {
                    scales: vec![Scale::covering(1e-9); width],
                    ..k
                };
                assert!(!narrow.gather_lanes(Isa::current(), &p, full.lanes(), &mut Vec::new()));
            }
            let dk = DensityKernel {
                kernel,
                mass: 0.05,
                scales: [Scale::covering(1.0)],
            };
            pair_symmetry(&dk, &p, &list, &[Parity::Even]).expect("even");
        }
    }

    fn density_is_continuity(c: &SphCfg) -> bool {
        c.density == DensityMethod::Continuity
    }

    /// The equations of state: the quadratic one gives p(ρ₀) = ρ₀c₀²/2 and c² = dp/dρ = c₀²
    /// at ρ₀; Tait gives p(ρ₀) = 0 and the same sound speed.
    #[test]
    fn equations_of_state_have_the_stated_sound_speed() {
        for eos in [EquationOfState::Quadratic, EquationOfState::Tait] {
            let mut c = cfg(ViscousTerm::Morris, DensityMethod::Summation);
            c.equation_of_state = eos;
            c.rest_density = 1.3;
            let e = 1e-6;
            let c2 = (c.pressure(1.3 + e) - c.pressure(1.3 - e)) / (2.0 * e);
            assert!((c2 / 100.0 - 1.0).abs() < 1e-8, "{eos:?}: c² = {c2}");
            let p0 = if eos == EquationOfState::Quadratic {
                1.3 * 100.0 / 2.0
            } else {
                0.0
            };
            assert!((c.pressure(1.3) - p0).abs() < 1e-12, "{eos:?}");
        }
    }
}
