//! `mesorheo check`: validates a case and prints what it will cost and whether Δt is safe.

use crate::config::{Case, FluidCfg};
use crate::models::dpd::DpdCfg;
use crate::stability::{ball_volume, cfl_limit, dpd_limits_of};

/// Bytes per owned particle (core fields) and per neighbour entry / pair.
const BYTES_CORE: f64 = 8.0 + 4.0 * 8.0 * 3.0 + 4.0 * 3.0;

/// Largest rank count whose slabs are at least cutoff + skin wide.
pub fn max_ranks(case: &Case) -> usize {
    let axis = case.decomposition.axis.index();
    let range = case.cutoff() + case.neighbour.skin;
    (case.domain.lengths[axis] / range).floor().max(1.0) as usize
}

/// Most particles (owned and ghosts) one rank supports: the neighbour list keeps 31-bit
/// indices (the top bit of each entry marks pairs near at the build).
pub const MAX_PARTICLES_PER_RANK: f64 = (crate::neighbour::NEAR_AT_BUILD - 1) as f64;

/// Estimated (owned, ghost) particles per rank on `ranks` ranks: n/ranks owned; ghosts the
/// layers cutoff + skin thick on both slab faces (on one rank, the periodic self-images on
/// every face).
pub fn particles_per_rank(case: &Case, ranks: usize) -> (f64, f64) {
    let (_, n) = case.lattice_counts();
    let range = case.cutoff() + case.neighbour.skin;
    let slab = case.domain.lengths[case.decomposition.axis.index()] / ranks as f64;
    let owned = n as f64 / ranks as f64;
    let ghosts = if ranks == 1 {
        // self-images on every periodic face
        n as f64 * (2.0 * range * case.domain.lengths.iter().map(|l| 1.0 / l).sum::<f64>())
    } else {
        owned * 2.0 * range / slab
    };
    (owned, ghosts)
}

/// Refuses a rank count whose ranks would hold more particles than the neighbour list indexes
/// (before anything is allocated), naming the rank count that fits.
pub fn check_particles_per_rank(case: &Case, ranks: usize) -> Result<(), String> {
    let (owned, ghosts) = particles_per_rank(case, ranks);
    if owned + ghosts < MAX_PARTICLES_PER_RANK {
        return Ok(());
    }
    let fits = (ranks..=max_ranks(case)).find(|&r| {
        let (o, g) = particles_per_rank(case, r);
        o + g < MAX_PARTICLES_PER_RANK
    });
    Err(format!(
        "about {:.3e} particles ({owned:.3e} owned + {ghosts:.3e} ghosts) per rank on {ranks} \
         rank(s): at most 2^31 − 1 = {MAX_PARTICLES_PER_RANK:.0} fit one rank (31-bit neighbour \
         indices); {}",
        owned + ghosts,
        match fits {
            Some(r) => format!("run on at least {r} ranks"),
            None => format!(
                "even the {} ranks the slabs allow are too few: shrink the box or the density",
                max_ranks(case)
            ),
        }
    ))
}

/// Numbers per particle of the fluid model's own fields (a density, a stress, a velocity
/// gradient, …), a state field counted twice for the integrator's half-step copy.
fn model_numbers<const D: usize>(case: &Case) -> f64 {
    crate::sim::build_fluid::<D>(case)
        .fields()
        .iter()
        .map(|f| {
            let copies = if f.flags.checkpointed { 2 } else { 1 };
            (f.kind.width(D) * copies) as f64
        })
        .sum()
}

/// Estimated bytes one rank needs on `ranks` ranks: the particles' core arrays (positions,
/// velocities, forces, ids, …) and the fluid model's fields, the ghosts, the neighbour list
/// (cutoff + skin; SPH adds its full list and the interleaved rows of its lanes, 4 bytes per
/// directed entry each) and the dumbbell ensembles a fluid particle carries. `tests/extremes.rs`
/// compares it with the measured peak of 3·10⁵-particle DPD and SPH runs.
pub fn rank_memory(case: &Case, ranks: usize) -> f64 {
    let dim = case.dimension;
    let (_, n) = case.lattice_counts();
    let volume: f64 = case.domain.lengths.iter().product();
    let density = n as f64 / volume;
    let list_neighbours = density * ball_volume(dim, case.cutoff() + case.neighbour.skin);
    let (owned, ghosts) = particles_per_rank(case, ranks);
    let bytes_entry = 8.0;
    let bytes_pair = 8.0 + (dim as f64 + 4.0) * 8.0;
    let ensembles = match &case.fluid {
        FluidCfg::Sph(s) => s.polymer.as_ref().filter(|p| p.is_ensemble()),
        _ => None,
    };
    let (model, full_lists) = match &case.fluid {
        FluidCfg::Sph(_) => (
            if dim == 2 {
                model_numbers::<2>(case)
            } else {
                model_numbers::<3>(case)
            },
            2.0,
        ),
        _ => (0.0, 0.0),
    };
    owned * (BYTES_CORE + 8.0 * model)
        + ghosts * (8.0 + 2.0 * 8.0 * dim as f64 + 8.0 * model)
        + owned * list_neighbours * (bytes_entry + 0.5 * bytes_pair + full_lists * 4.0)
        + owned * ensembles.map_or(0.0, |p| p.bytes_per_particle(dim))
}

/// Refuses a rank count whose ranks would need more memory than `available` bytes (this node's
/// MemAvailable; no check when unknown), before anything is allocated, naming the rank count
/// that fits or, when no rank count does, the largest box that fits one rank.
pub fn check_rank_memory(case: &Case, ranks: usize, available: Option<f64>) -> Result<(), String> {
    let Some(available) = available else {
        return Ok(());
    };
    let gib = 1024.0 * 1024.0 * 1024.0;
    let need = rank_memory(case, ranks);
    // Leave a tenth for the rest of the process (buffers, output, MPI).
    let budget = 0.9 * available;
    if need <= budget {
        return Ok(());
    }
    let max = max_ranks(case);
    let fits = (ranks..=max).find(|&r| rank_memory(case, r) <= budget);
    // One rank's memory grows like the particle count, i.e. the box volume.
    let one = rank_memory(case, ranks.max(1));
    let scale = (budget / one).powf(1.0 / case.dimension as f64);
    let smaller: Vec<String> = case.domain.lengths[..case.dimension]
        .iter()
        .map(|l| format!("{:.4}", l * scale))
        .collect();
    Err(format!(
        "one rank needs about {:.2} GiB on {ranks} rank(s) but this machine has {:.2} GiB \
         available; {}",
        need / gib,
        available / gib,
        match fits {
            Some(r) => format!(
                "run on at least {r} ranks (with one rank per node like this one), or shrink the \
                 box to about [{}] on {ranks} rank(s)",
                smaller.join(", ")
            ),
            None => format!(
                "even the {max} ranks the slabs allow are too few: shrink the box to about [{}] \
                 (or lower the density)",
                smaller.join(", ")
            ),
        }
    ))
}

/// The report `check` prints.
pub fn report(case: &Case, ranks: usize) -> String {
    let dim = case.dimension;
    let (cells, n) = case.lattice_counts();
    let volume: f64 = case.domain.lengths.iter().product();
    let density = n as f64 / volume;
    let dt = case.integrator.dt();
    let skin = case.neighbour.skin;
    let cutoff = case.cutoff();
    let range = cutoff + skin;
    let neighbours = density * ball_volume(dim, cutoff);
    let list_neighbours = density * ball_volume(dim, range);
    let axis = case.decomposition.axis.index();
    let l_axis = case.domain.lengths[axis];
    let max_ranks = (l_axis / range).floor().max(1.0) as usize;
    let mut s = String::new();
    let mut line = |t: String| {
        s.push_str(&t);
        s.push('\n');
    };
    line(title_line(&case.title));
    line(format!(
        "particles: {n} ({}; lattice cells {:?}), number density {density:.4} (asked {})",
        format!("{:?}", case.particles.lattice).to_lowercase(),
        cells,
        case.particles.density
    ));
    line(format!(
        "neighbours per particle: {:.1} within r_c, {:.1} within r_c + skin (list)",
        neighbours, list_neighbours
    ));
    match &case.fluid {
        FluidCfg::Dpd(d) => {
            dpd_report(case, d, density, &mut line);
            transverse_current_report(case, d, &mut line);
        }
        FluidCfg::Sph(sph) => {
            line(format!(
                "SPH: {} kernel h = {} (support {}), ρ₀ = {}, c₀ = {}, η = {}, {:?} EOS, {:?} \
                 density, {:?} viscous term",
                sph.kernel.name(),
                sph.smoothing_length,
                sph.support(),
                sph.rest_density,
                sph.sound_speed,
                sph.viscosity,
                sph.equation_of_state,
                sph.density,
                sph.viscous_term
            ));
            if sph.derivatives == crate::models::sph::Derivatives::Msph {
                let morris = match sph.viscous_term {
                    crate::models::sph::ViscousTerm::Morris => sph.viscosity,
                    crate::models::sph::ViscousTerm::NestedSummation => {
                        sph.viscosity * sph.morris_share
                    }
                };
                line(format!(
                    "derivatives: MSPH (Zhang–Batra {0}×{0} moment systems, exact for quadratic \
                     fields); Morris (damping) viscosity {morris}",
                    crate::models::sph::msph::unknowns(case.dimension)
                ));
                if morris == 0.0 {
                    line(
                        "note: MSPH derivatives do not damp particle-scale velocity modes (spec \
                         msph-dumbbells.md §5.1); give a Morris viscosity (morris_share ≈ 0.1, \
                         or viscous_term = \"morris\" for the solvent)"
                            .to_string(),
                    );
                }
            } else if sph.kernel == crate::models::sph::kernels::KernelKind::TruncatedGaussian {
                line(
                    "note: the truncated Gaussian has W′(2h) ≠ 0 (pair forces jump as neighbours \
                     cross the support); with pairwise SPH the paper's channel came out 7–99 % \
                     off (docs/validation.md); it is MSPH's kernel: derivatives = \"msph\""
                        .to_string(),
                );
            }
            if sph.derivatives == crate::models::sph::Derivatives::Sph && sph.morris_share > 0.0 {
                line(format!(
                    "viscosity split: {} by the nested summation, {} by Morris's term",
                    sph.viscosity * (1.0 - sph.morris_share),
                    sph.viscosity * sph.morris_share
                ));
            }
            if let Some(poly) = &sph.polymer {
                let gamma = case.domain.shear_rate;
                let de = if gamma != 0.0 {
                    format!(", De = λγ̇ = {}", poly.relaxation_time * gamma.abs())
                } else {
                    String::new()
                };
                if poly.is_ensemble() {
                    line(format!(
                        "dumbbells: {} per fluid particle, spring {:?}, scheme {:?}, {:?} \
                         precision; Kramers stress G(⟨QF(Q)⟩ − I) with G = η_p/λ = {}",
                        poly.per_particle.unwrap_or(0),
                        poly.spring_law(),
                        poly.scheme_or_default(),
                        poly.connector_precision(),
                        poly.modulus()
                    ));
                }
                // FENE dumbbells: the zero-shear polymer viscosity is Gλ b/(b + D + 2).
                let fene = match poly.spring_law() {
                    crate::models::dumbbells::Spring::Fene { b } if poly.is_ensemble() => {
                        b / (b + case.dimension as f64 + 2.0)
                    }
                    _ => 1.0,
                };
                line(format!(
                    "polymer: {:?}{}, η_p = {}, λ = {}, modulus η_p/λ = {}{de}; zero-shear \
                     viscosity η₀ = η + η_p{} = {:.6}, background pressure {}",
                    poly.model,
                    if poly.rotation {
                        ""
                    } else {
                        " (rotation terms off)"
                    },
                    poly.viscosity,
                    poly.relaxation_time,
                    poly.viscosity / poly.relaxation_time,
                    if fene < 1.0 { " b/(b + D + 2)" } else { "" },
                    sph.viscosity + poly.viscosity * fene,
                    sph.background_pressure
                ));
                // The polymer stress passes through two SPH derivatives (G from v, then ∇·τ in
                // pair form); on the initial cubic lattice each scales a linear field by the
                // kernel's lattice sum, which does not tend to 1 as Δ → 0 at fixed r_s/Δ.
                let spacing = case.lattice_spacing();
                // (A support of more than 16 spacings has sums within 10⁻³ of 1 and would cost
                // a long loop.)
                if sph.derivatives == crate::models::sph::Derivatives::Sph
                    && case.particles.lattice == crate::config::Lattice::Cubic
                    && sph.support() / spacing <= 16.0
                {
                    let sum = crate::with_kernel!(
                        sph.kernel,
                        sph.smoothing_length,
                        case.dimension,
                        |k| crate::models::sph::kernels::cubic_lattice_derivative_sum(
                            &k,
                            spacing,
                            case.dimension
                        )
                    );
                    let corrected =
                        sph.velocity_gradient == crate::models::sph::GradientEstimate::Corrected;
                    let factor = if corrected { sum } else { sum * sum };
                    if (factor - 1.0).abs() > 0.01 {
                        line(format!(
                            "  note: on this lattice the SPH derivative of a linear field is \
                             {sum:.4} of the exact one (support {:.2}Δ), and the polymer stress \
                             passes through {}: η_p acts as {factor:.4} η_p and elastic waves \
                             run at {:.4} of √(η_p/(ρ₀λ)) at any Δ (measured, Oldroyd-B start-up \
                             Couette, λ = 0.05, β = 0.1: at Lucy 2.5Δ 1.3 % of U at t = 0.1 even \
                             at Δ = 0.005, at 3Δ 0.06 %; tools/sph_couette_rows.py); Lucy 3Δ \
                             gives 1.0008",
                            sph.support() / spacing,
                            if corrected {
                                "one (its ∇·τ; the corrected G is exact)"
                            } else {
                                "two (G, then ∇·τ)"
                            },
                            factor.sqrt()
                        ));
                    }
                }
                if gamma != 0.0 {
                    use crate::models::sph::maxwell::PolymerModel;
                    // Steady-shear tension: corotational τ_xx = η_p De γ̇/(1 + De²); upper-
                    // convected and Hookean dumbbells 2η_pλγ̇² (FENE less).
                    let de = poly.relaxation_time * gamma.abs();
                    let tension = match poly.model {
                        PolymerModel::CorotationalMaxwell => {
                            poly.viscosity * de * gamma.abs() / (1.0 + de * de)
                        }
                        _ => 2.0 * poly.viscosity * poly.relaxation_time * gamma * gamma,
                    };
                    line(format!(
                        "  steady-shear tension τ_xx ≈ {tension:.4}; background pressure {} = \
                         {:.1} τ_xx",
                        sph.background_pressure,
                        sph.background_pressure / tension
                    ));
                    if sph.background_pressure < 4.0 * tension {
                        line(
                            "  note: below 4 τ_xx the tension feeds the SPH tensile instability \
                             (measured: Oldroyd-B and dumbbells at Wi = 3 with p_b = 1.7 τ_xx drift \
                             to η +6 %, N₁ +10 %; 5 τ_xx holds 0.3 %): raise \
                             fluid.background_pressure"
                                .into(),
                        );
                    }
                    if poly.model == PolymerModel::Dumbbells {
                        // The measured bias of the coupled shear (tools/coupled_bias.py, the
                        // table in docs/validation.md): what a user can expect at these settings.
                        line(format!(
                            "  expected bias of the measured η and N₁ (the momentum flux; 2D \
                             CONNFFESSIT shear, Lucy 3Δ, measured 2026-11-26, docs/validation.md): \
                             Wi ≤ 1, p_b = 5: η +1.5 % with 100 dumbbells per particle, +0.1 % \
                             with 1 000 (the noisy ensembles disorder the particles; p_b = 20 \
                             raises it); Wi = 2–4 with p_b = 5 τ_xx: η within ±2.5 %, N₁ within \
                             ±4.5 %; p_b below 5 τ_xx: errors of 3–17 %. This scene: Wi = {de:.3}, \
                             {} dumbbells per particle, p_b = {:.1} τ_xx",
                            poly.per_particle.unwrap_or(0),
                            sph.background_pressure / tension
                        ));
                    }
                }
            }
            let (binding, _) = crate::stability::sph_binding_limit(sph, case.inclusions.is_some());
            for (name, limit) in crate::stability::sph_limits(sph, case.inclusions.is_some()) {
                line(format!(
                    "time step Δt = {dt}: {name} = {limit:.4e} [{}{}]",
                    if dt <= limit { "ok" } else { "VIOLATED" },
                    if name == binding { ", binding" } else { "" }
                ));
            }
            if let Some(w) = &case.walls {
                let axis = w.axis.index();
                let layers = crate::sim::wall_layer_count(case, axis);
                let (cells, _) = case.lattice_counts();
                let across: usize = (0..case.dimension)
                    .filter(|&d| d != axis)
                    .map(|d| cells[d])
                    .product();
                line(format!(
                    "walls along {}: {layers} boundary rows each side, {} boundary particles in \
                     all (besides the fluid's; {:?}), lower at {:?}, upper at {:?}",
                    ["x", "y", "z"][axis],
                    2 * layers * across,
                    w.treatment,
                    w.lower_velocity,
                    w.upper_velocity
                ));
                // Morris's factor for the first fluid row (d_i = Δ/2) and the deepest image
                // inside the support (d_j ≤ r_s − Δ/2): β = 1 + d_j/d_i ≤ 2r_s/Δ.
                let spacing = case.lattice_spacing();
                let widest = 2.0 * sph.kernel.support_factor() * sph.smoothing_length / spacing;
                let uncapped = (widest + 1e-9).floor() - 1.0;
                if w.treatment == crate::models::sph::WallTreatment::Morris
                    && w.morris_cap < uncapped
                {
                    line(format!(
                        "  note: the cap β ≤ {} clips Morris's images of the first fluid row (β = \
                         1 + d_j/d_i reaches ≈ {widest:.1}): a partial slip (measured in the \
                         paper's channel: +2.6 % Newtonian, +4.5 % UCM at the centre with 1.5); \
                         flat walls keep the factor bounded, so walls.morris_cap = {} removes it",
                        w.morris_cap, uncapped
                    ));
                }
            }
            if let Some(inc) = &case.inclusions {
                let phi = inc.volume_fraction(&case.domain.lengths);
                let shape = if case.dimension == 2 {
                    "discs"
                } else {
                    "spheres"
                };
                line(format!(
                    "inclusions: {} fixed {shape} of radius {}, volume fraction φ = {phi:.5}, \
                     Morris images capped at β = {}; a Newtonian fluid's mean stress over the \
                     fluid is exactly 1/(1 − φ) = {:.5} of ηγ̇{}",
                    inc.centres.len(),
                    inc.radius,
                    inc.morris_cap,
                    1.0 / (1.0 - phi),
                    if case.dimension == 2 {
                        format!(
                            "; dilute composite viscosity η(1 + 3φ) = {:.5} η (fixed discs)",
                            1.0 + 3.0 * phi
                        )
                    } else {
                        String::new()
                    }
                ));
            }
        }
        FluidCfg::SummationGas(g) => {
            let cfl = cfl_limit(g.smoothing_length, g.sound_speed);
            line(format!(
                "summation gas (the engine's two-pass test model): Lucy kernel h = {}, sound \
                 speed c = {}, p = c² ρ",
                g.smoothing_length, g.sound_speed
            ));
            line(format!(
                "time step Δt = {dt}: acoustic limit 0.25 h/c = {cfl:.4e} [{}]",
                if dt < cfl { "ok" } else { "VIOLATED" }
            ));
        }
    }
    let slab = l_axis / ranks as f64;
    line(format!(
        "decomposition: slabs along {}, {ranks} rank(s) → width {slab:.3} (needs ≥ {range:.4}); at most {max_ranks} ranks [{}]",
        ["x", "y", "z"][axis],
        if ranks <= max_ranks {
            "ok"
        } else {
            "TOO MANY RANKS"
        }
    ));
    let (owned, ghosts) = particles_per_rank(case, ranks);
    if let Err(e) = check_particles_per_rank(case, ranks) {
        line(format!("PARTICLES PER RANK: {e}"));
    }
    let ensembles = match &case.fluid {
        FluidCfg::Sph(s) => s.polymer.as_ref().filter(|p| p.is_ensemble()),
        _ => None,
    };
    let mem = rank_memory(case, ranks);
    line(format!(
        "memory per rank ≈ {:.1} MiB ({:.0} owned + {:.0} ghost particles) [{}]",
        mem / 1048576.0,
        owned,
        ghosts,
        match check_rank_memory(case, ranks, crate::flow_scene::available_memory()) {
            Ok(()) => "ok".to_string(),
            Err(e) => format!("DOES NOT FIT: {e}"),
        }
    ));
    let pair_evals = n as f64 * neighbours / 2.0;
    line(format!(
        "cost: {} steps × {n} particles = {:.3e} particle-steps, {:.3e} pair evaluations per step",
        case.run.steps,
        case.run.steps as f64 * n as f64,
        pair_evals
    ));
    if let Some(p) = ensembles {
        // An upper bound: wall and inclusion particles carry none.
        let work = n as f64 * p.per_particle.unwrap_or(0) as f64 * case.run.steps as f64;
        line(format!(
            "dumbbells: ≤ {work:.3e} dumbbell-steps; at ~5·10⁷ per second per core (Hookean, \
             docs/performance.md) about {:.1} core-seconds",
            work / 5e7
        ));
    }
    s
}

/// The DPD lines of the report: parameters, kinetic-theory estimates, time-step limits.
/// What the transverse-current viscosity will resolve: each mode's Newtonian decay time
/// ρ/(η k²) with the kinetic-theory η, against the sampling interval and the longest lag.
fn transverse_current_report(case: &Case, d: &DpdCfg, line: &mut impl FnMut(String)) {
    if !case.wants(crate::config::Observable::TransverseCurrentViscosity) {
        return;
    }
    let Ok(dimension) = crate::dpd_parameters::Dimension::try_from(case.dimension) else {
        return;
    };
    let fluid = crate::dpd_parameters::DpdFluid {
        dimension,
        kt: d.kt,
        number_density: case.particles.density,
        mass: case.particles.mass,
        cutoff: d.cutoff,
        a: d.a,
        conservative_exponent: d.conservative_exponent,
        gamma: d.gamma,
        dissipative_exponent: d.weight_exponent,
    };
    let Ok(prediction) = fluid.predict() else {
        return;
    };
    let diag = &case.diagnostics;
    let eta = prediction.total_viscosity;
    let rho = case.particles.density * case.particles.mass;
    let length = case.domain.lengths[0];
    let interval = diag.transverse_current_every as f64 * case.integrator.dt();
    let decay = |j: usize| {
        let k = std::f64::consts::TAU * j as f64 / length;
        rho / (eta * k * k)
    };
    let modes = diag.transverse_current_modes;
    let slowest = decay(1);
    let fastest = decay(modes);
    let verdict_slow = if diag.transverse_current_time >= 3.0 * slowest {
        "ok"
    } else {
        "SHORT: the slowest mode will not have decayed; raise diagnostics.transverse_current_time"
    };
    let verdict_fast = if fastest >= 2.0 * interval {
        "ok"
    } else {
        "UNDER-RESOLVED: lower diagnostics.transverse_current_every or the modes"
    };
    line(format!(
        "transverse currents: k = 2πj/{length} for j = 1 … {modes}; Newtonian decay ρ/(ηk²) with \
         the kinetic-theory η = {eta:.4}: {slowest:.4} (k₁) … {fastest:.4} (k_{modes}); sampled \
         every {interval:.4} [{verdict_fast}], lags to {} [{verdict_slow}]; the error of η_k₁ \
         falls like √({slowest:.3}/run time)",
        diag.transverse_current_time
    ));
}

fn dpd_report(case: &Case, d: &DpdCfg, density: f64, line: &mut impl FnMut(String)) {
    let dim = case.dimension;
    let m = case.particles.mass;
    let dt = case.integrator.dt();
    let Some(lim) = dpd_limits_of(case) else {
        return;
    };
    let alpha = d.gamma * d.gamma * d.cutoff / (m * d.a.max(f64::MIN_POSITIVE));
    if let Some(physical) = &d.physical
        && let Ok(inputs) = crate::config::dpd_physical::inputs_of(
            physical,
            dim,
            d.kt,
            d.cutoff,
            case.particles.density,
            m,
        )
        && let Ok(mapped) = crate::dpd_parameters::map(&inputs)
    {
        for l in crate::config::dpd_physical::report(&inputs, &mapped) {
            line(l);
        }
    }
    line(format!(
        "DPD: a = {}, γ = {}, k_BT = {}, r_c = {}, s = {}, s̄ = {}, σ = {:.4}, α = γ² r_c/(m a) = \
         {:.3}",
        d.a,
        d.gamma,
        d.kt,
        d.cutoff,
        d.weight_exponent,
        d.conservative_exponent,
        (2.0 * d.gamma * d.kt).sqrt(),
        alpha
    ));
    if dim == 3 && d.weight_exponent == 2.0 && d.conservative_exponent == 1.0 {
        // Kinetic-theory estimate (Groot & Warren 1997, Eq. 33, s = 2) and their EOS for c².
        let rho_m = density * m;
        let eta = 45.0 * d.kt / (4.0 * std::f64::consts::PI * d.gamma * d.cutoff.powi(3))
            + 2.0 * std::f64::consts::PI * d.gamma * density * density * d.cutoff.powi(5) / 1575.0;
        let c2 = d.kt / m + 2.0 * 0.101 * d.a * density * d.cutoff.powi(4) / m;
        line(format!(
            "rough estimates (Groot–Warren kinetic theory, s = 2, no conservative-force or pair \
             correlations): η ≈ {eta:.3} (the a = 25, γ = 4.5, ρ = 3 fluid measures 0.86, 11 % \
             lower: LAMMPS and mesorheo), sound speed c ≈ {:.3}",
            c2.sqrt()
        ));
        let shear = case.domain.shear_rate;
        if shear != 0.0 {
            let ly = case.domain.lengths[1];
            let u = shear.abs() * ly / 2.0;
            line(format!(
                "shear: γ̇ = {shear}, Re = ρ γ̇ L_y²/η ≈ {:.3}, Ma = (γ̇ L_y/2)/c ≈ {:.3}",
                rho_m * shear.abs() * ly * ly / eta,
                u / c2.sqrt()
            ));
        }
    }
    let omega = crate::stability::dpd_mean_field_rate(d, dim, case.particles.density, m);
    let phi = crate::sim::exponential_friction_factor_of(case);
    match phi {
        Some(phi) => line(format!(
            "thermostat: exponential (SETD); ω₀Δt = {:.4} (ω₀ = γΣw_D/(d m) = {omega:.5}), \
             friction and noise variance × φ = (1 − e^{{−ω₀Δt}})/(ω₀Δt) = {phi:.5}: k_BT kept, \
             but the dissipative viscosity is φ η_D ({:.2} % below)",
            omega * dt,
            100.0 * (1.0 - phi)
        )),
        None => line(format!(
            "thermostat: explicit; ω₀Δt = {:.4} (ω₀ = γΣw_D/(d m) = {omega:.5}; the step \
             diverges past 2: thermostat = \"exponential\" integrates it exactly)",
            omega * dt
        )),
    }
    line(format!(
        "time step Δt = {dt}: stability limit ((Δt_C⁻ᵖ + Δt_D⁻ᵖ)^(p′/p) + Δt_F^(−p′))^(−1/p′) = {:.4} \
         [{}] (measured, p = {}, p′ = {}, see docs/validation.md), with the conservative part \
         Δt_C = α/ω_E = {:.4} (cage ω_E = {:.4}), the dissipative part Δt_D = {:.4} \
         (ω_D = γΣw_D/m = {:.4}, c = {:.3}{}) and the free-flight part Δt_F = {} r_c/√(k_BT/m) \
         = {:.4}; Groot–Warren accuracy guide Δt ≤ 0.06 at a = 25 [{}]",
        lim.combined,
        if dt <= lim.combined { "ok" } else { "VIOLATED" },
        crate::stability::dpd_fit::NORM_EXPONENT,
        crate::stability::dpd_fit::FREE_FLIGHT_EXPONENT,
        lim.conservative,
        lim.cage_frequency,
        lim.dissipative,
        lim.friction_rate,
        lim.friction_coefficient,
        if phi.is_some() {
            ", lifted: exponential thermostat"
        } else {
            ""
        },
        if dim == 2 {
            crate::stability::dpd_fit::FREE_FLIGHT_2D
        } else {
            crate::stability::dpd_fit::FREE_FLIGHT_3D
        },
        lim.free_flight,
        if dt <= 0.06 {
            "ok"
        } else {
            "expect k_BT errors > few %"
        }
    ));
}

/// The report `check` prints for a homogeneous-flow scene, and whether it fits this machine
/// on `ranks` ranks (memory of the largest rank's ensembles against MemAvailable here).
pub fn flow_report(case: &crate::config::FlowCase, ranks: usize) -> (String, Result<(), String>) {
    use crate::config::flow::{FlowKind, Precision};
    let p = &case.polymer;
    let params = case.dumbbell_params();
    let n = case.flow.particles;
    let n_d = p.per_particle as u64;
    let dim = case.dimension;
    let lambda = p.relaxation_time;
    let gib = 1024.0 * 1024.0 * 1024.0;
    let per_rank = crate::flow_scene::rank_memory(case, ranks, 0);
    let total = n as f64 * p.bytes_per_particle(dim);
    let mut s = String::new();
    let mut line = |t: String| {
        s.push_str(&t);
        s.push('\n');
    };
    line(title_line(&case.title));
    line(format!(
        "homogeneous flow: {:?}, rate {} ({}D); Weissenberg number Wi = rate × λ = {:.4}",
        case.flow.kind,
        case.flow.rate,
        dim,
        case.flow.rate * lambda
    ));
    if case.flow.kind == FlowKind::UniaxialElongation && case.flow.rate * lambda >= 0.5 {
        line(
            "  note: ε̇λ ≥ 1/2 is beyond the coil–stretch transition: Hookean dumbbells stretch \
             without bound (no steady state); FENE ones saturate"
                .into(),
        );
    }
    line(format!(
        "dumbbells: {n} particles × {n_d} = {:.3e}, spring {:?}, scheme {:?}, λ = {lambda}, G = {}",
        (n * n_d) as f64,
        params.spring,
        params.scheme,
        p.modulus
    ));
    line(format!(
        "time step: Δt = {} = {:.4} λ; {} steps = {:.3} λ; equilibration {} steps; sample every {}",
        params.dt,
        params.dt / lambda,
        case.run.steps,
        case.run.steps as f64 * params.dt / lambda,
        case.run.equilibration,
        case.run.sample_every
    ));
    line(match crate::config::flow::explicit_stability_limit(case) {
        Some(limit) => format!(
            "stability: explicit scheme, Δt < 0.95 × 4λ/(1 + 2λc) = {limit:.4} [{}]",
            if params.dt < limit {
                "ok"
            } else {
                "BEYOND (run.beyond_stability_limits)"
            }
        ),
        None => "stability: semi-implicit scheme, stable at any Δt [ok]".to_string(),
    });
    for w in crate::config::flow::accuracy_warnings(case) {
        line(format!("accuracy: {w} [warning]"));
    }
    line(format!(
        "memory: {:.3} MiB on the largest of {ranks} rank(s), {:.3} MiB in all ({}{})",
        per_rank / (1024.0 * 1024.0),
        total / (1024.0 * 1024.0),
        match p.precision {
            Precision::Double => "double precision",
            Precision::Single => "single precision",
        },
        if p.variance_reduction {
            ", × 2 for the control copies"
        } else {
            ""
        }
    ));
    let work = (n * n_d) as f64 * case.run.steps as f64;
    line(format!(
        "cost: {work:.3e} dumbbell-steps; at ~5·10⁷ dumbbell-steps/s per core (Hookean, \
         docs/performance.md) about {:.1} core-seconds",
        work / 5e7
    ));
    let free = crate::flow_scene::available_memory();
    let verdict = match free {
        Some(free) if per_rank > 0.9 * free => Err(format!(
            "one rank's ensembles need {:.2} GiB but this machine has {:.2} GiB available; use \
             more ranks, fewer dumbbells per particle or polymer.precision = \"single\"",
            per_rank / gib,
            free / gib
        )),
        Some(free) if total > 0.9 * free => {
            line(format!(
                "  note: all ranks together need {:.2} GiB, more than this machine's {:.2} GiB \
                 available: spread them over several nodes",
                total / gib,
                free / gib
            ));
            Ok(())
        }
        _ => Ok(()),
    };
    (s, verdict)
}

/// The first line of every `check` report: the case's title.
fn title_line(title: &str) -> String {
    let title = if title.is_empty() {
        "(untitled)"
    } else {
        title
    };
    format!("case: {title}")
}
