//! SPH against analytic solutions, exact invariants and the engine's determinism:
//!
//! - a shear wave in a periodic box decays at exp(−νk²t) (the bulk viscous operators);
//! - Morris's wall images keep steady Couette flow linear (to 10⁻⁵); method B's layers slip;
//! - every integrator has its order in time on both start-up flows (2, or 1 for the thesis's
//!   scheme as printed);
//! - the stock start-up Couette and (the early part of) Poiseuille cases pass their series
//!   references (src/analytic.rs, checked against the tables of
//!   docs/theory/sph_maxwell.md §3);
//! - total momentum of a periodic box is conserved to round-off (antisymmetric pair terms);
//! - a walled channel gives the same bits on 1–4 ranks × 1–2 threads, cut across or along it;
//! - the Poiseuille start-up in 3D (periodic in z) agrees with 2D and with the series;
//! - XSPH moves particles by the smoothed velocity difference; the density profile of a fluid
//!   at rest under gravity is hydrostatic; the wall shear stress follows the start-up series;
//! - the wall repulsion alone stops a row of fluid thrown at the wall before the wall plane.

use crate::common;
use common::{
    assert_all_equal, assert_references_pass, case_from_str, digests_on_1_to_4_ranks,
    sph_periodic_box as periodic_box, stock_case, with_overrides,
};
use mesorheo::comm::SerialComm;
use mesorheo::driver::run_in_process;
use mesorheo::facade::Engine;
use mesorheo::sim::Simulation;

/// A channel between walls at y = 0 and y = 1 (Δ = 0.02, Lucy support 2.5Δ), the upper wall
/// at `upper` along x.
fn channel(viscous_term: &str, treatment: &str, upper: f64) -> String {
    with_overrides(
        &periodic_box(viscous_term, 0.05, ""),
        &[
            "box.boundaries=[\"periodic\", \"wall\"]",
            "diagnostics.observables=[\"momentum\", \"wall_shear_stress\"]",
            &format!("walls.upper_velocity=[{upper}, 0.0]"),
            &format!("walls.treatment=\"{treatment}\""),
            "walls.morris_cap=2.0",
        ],
    )
}

/// Sets every fluid particle's velocity to `u(y)` along x, then rebuilds the ghosts (they
/// carry the new velocities) and recomputes the forces.
fn set_velocity(sim: &mut Simulation<'_, 2>, u: impl Fn(f64) -> f64) {
    for i in 0..sim.particles.n_owned {
        if sim.particles.species_of(i) == 0 {
            let y = sim.particles.pos[i][1];
            sim.particles.vel[i] = [u(y), 0.0];
        }
    }
    sim.jump_to_step(0).expect("forces");
}

/// The instantaneous `wall_shear_stress` of the lower and upper walls.
fn wall_shear_stresses(sim: &mut Simulation<'_, 2>) -> (f64, f64) {
    let m = sim.measure();
    (
        common::scalar(&m, "wall_shear_stress_lower"),
        common::scalar(&m, "wall_shear_stress_upper"),
    )
}

/// u_x = A sin(2πy) decays as exp(−νk²t). At Lucy support 3Δ the lattice sum of the Laplacian
/// is 1.0008 of its continuum value (2.5Δ: 0.986); what remains is the kernel's smoothing
/// error, O((kh)²) with kh = 0.38, once for Morris's operator and twice for the nested
/// summation (two smoothed derivatives). Measured: Morris −0.8 %, nested summation −2.0 %;
/// the bounds are 1.2 % and 2.5 %. Fails with Morris's 0.01h² regularisation put back (−5 %),
/// or with the factor 2 of 2η dropped, or with the traceless part of σ̄ mis-signed.
#[test]
fn shear_wave_decays_at_the_viscous_rate() {
    for term in ["morris", "nested_summation"] {
        let loaded = case_from_str(&periodic_box(term, 0.06, ""), "wave.toml");
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
        let k = 2.0 * std::f64::consts::PI;
        let amp = 0.01;
        set_velocity(&mut sim, |y| amp * (k * y).sin());
        let steps = 200;
        sim.run_steps(steps).expect("run");
        let t = steps as f64 * 1e-4;
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..sim.particles.n_owned {
            let s = (k * sim.particles.pos[i][1]).sin();
            num += sim.particles.vel[i][0] * s;
            den += s * s;
        }
        let rate = -(num / den / amp).ln() / t;
        let want = k * k;
        eprintln!("{term}: decay rate {rate:.4} vs νk² = {want:.4}");
        let bound = if term == "morris" { 0.012 } else { 0.025 };
        assert!(
            (rate / want - 1.0).abs() < bound,
            "{term}: rate {rate} vs {want}"
        );
    }
}

/// Steady Couette flow u = y: Morris's image velocities, uncapped (β_max = 6, the largest β the
/// floor d_i ≥ Δ/2 allows at support 2.5Δ), reproduce it to 10⁻⁴ (measured 10⁻⁵ after 1000
/// steps; linear extrapolation is exact for a linear profile); method B's layers, which give the
/// boundary particles the wall velocity, slip by about 1 % of U at the wall rows (measured
/// 1.1 %), the first-order error the thesis's method carries. Fails if the extrapolation sign
/// or the wall planes are wrong, or β is capped at 1.5 (4·10⁻³). Also the wall shear stress
/// observable: ±ηU/L on the two walls.
#[test]
fn morris_images_keep_steady_couette_flow_linear() {
    for (treatment, lo, hi) in [("morris", 0.0, 1e-4), ("layers", 0.005, 0.02)] {
        let text = with_overrides(
            &channel("morris", treatment, 1.0),
            &["walls.morris_cap=6.0"],
        );
        let loaded = case_from_str(&text, "couette.toml");
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
        set_velocity(&mut sim, |y| y);
        sim.run_steps(1000).expect("run");
        let worst = (0..sim.particles.n_owned)
            .filter(|&i| sim.particles.species_of(i) == 0)
            .map(|i| (sim.particles.vel[i][0] - sim.particles.pos[i][1]).abs())
            .fold(0.0, f64::max);
        eprintln!("{treatment}: max |u − y| = {worst:.3e}");
        assert!(worst >= lo && worst < hi, "{treatment}: {worst}");
        if treatment == "morris" {
            let (lower, upper) = wall_shear_stresses(&mut sim);
            eprintln!("wall shear stress: lower {lower:.5}, upper {upper:.5} (η U / L = 1)");
            // The fluid drags the lower wall along +x and holds the upper one back with
            // η U / L = 1, less the lattice deficit of the viscous operator at support 2.5Δ
            // (−Σ_n W′(|n|Δ)/|n|Δ · n_y² Δ⁴ = 0.9864 of its continuum value, computed apart):
            // measured 0.9852. In the steady state the two walls balance to round-off.
            assert!((lower - 1.0).abs() < 0.02, "lower wall {lower}");
            assert!(
                (lower + upper).abs() < 1e-9,
                "walls {lower} and {upper} do not balance"
            );
        }
    }
}

/// The stock start-up cases pass their own series references at every listed time (Couette
/// to t = 0.3; Poiseuille's early transient to t = 0.4 here, the whole run to the steady state
/// under `./run validate sph`).
#[test]
fn stock_startup_cases_pass_their_references() {
    for (name, steps) in [
        ("sph_couette_2d.toml", None),
        ("sph_poiseuille_2d.toml", Some(4000)),
    ] {
        let mut loaded = stock_case(name);
        if let Some(s) = steps {
            loaded.case.run.steps = s;
            for r in &mut loaded.case.reference {
                if let mesorheo::config::ReferenceCfg::StartupProfile(sp) = r {
                    sp.times.retain(|&t| t <= 0.4 + 1e-9);
                }
            }
        }
        assert_references_pass(name, &loaded);
    }
}

/// Σ m v of a periodic box with a random velocity field stays at its initial value to
/// round-off, for both viscous terms and both density methods (the pair terms are
/// antisymmetric to the last bit; the exact sums round once per particle). Fails if a pair
/// term loses its antisymmetry (e.g. p_i/ρ_i² alone instead of p_i/ρ_i² + p_j/ρ_j²).
#[test]
fn momentum_is_conserved_to_round_off() {
    for (term, density) in [("morris", "continuity"), ("nested_summation", "summation")] {
        let text = periodic_box(term, 0.05, &format!("density = \"{density}\""));
        let loaded = case_from_str(&text, "box.toml");
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
        for i in 0..sim.particles.n_owned {
            let g = sim.particles.gid[i] as f64;
            sim.particles.vel[i] = [0.1 * (1.7 * g).sin(), 0.1 * (2.3 * g).cos()];
        }
        sim.jump_to_step(0).expect("forces");
        let momentum = |sim: &Simulation<'_, 2>| {
            let mut p = [0.0f64; 2];
            for v in &sim.particles.vel[..sim.particles.n_owned] {
                p[0] += v[0];
                p[1] += v[1];
            }
            p
        };
        let before = momentum(&sim);
        sim.run_steps(200).expect("run");
        let after = momentum(&sim);
        for d in 0..2 {
            // 2500 velocities of 0.1, each rounded at 1e-17 per step: 1e-11 is round-off.
            assert!(
                (after[d] - before[d]).abs() < 1e-11,
                "{term}/{density}: momentum {d} {} → {}",
                before[d],
                after[d]
            );
        }
    }
}

/// A walled Couette channel: the same bits on 1–4 ranks × 1–2 threads, with slabs cut across
/// the channel (along x: every slab holds both walls) and along it (along y: the walls live on
/// the first and last ranks), for the thesis's scheme and for continuity density with Heun.
#[test]
fn walled_channel_is_bitwise_identical_on_1_to_4_ranks() {
    for (term, axis, extra) in [
        ("nested_summation", "x", ""),
        ("morris", "y", "fluid.density=\"continuity\""),
    ] {
        let mut overrides = vec![format!("decomposition.axis=\"{axis}\"")];
        if !extra.is_empty() {
            overrides.extend([extra.to_string(), "integrator.kind=\"heun\"".to_string()]);
        }
        let overrides: Vec<&str> = overrides.iter().map(String::as_str).collect();
        let text = with_overrides(&channel(term, "morris", 1.0), &overrides);
        let d = digests_on_1_to_4_ranks(&text, "channel.toml", |_| {});
        assert_all_equal(&format!("{term} along {axis}"), &d);
    }
}

/// The fluid-only weakly compressible scheme (Morris's term, continuity density: on a CPU with
/// AVX-512 its momentum sums are gathered in lanes, `src/models/sph/lanes.rs`) in a sheared
/// Lees–Edwards box: the same bits on 1–4 ranks × 1–2 threads, with the images' velocity
/// shift in the rows. Fails if a lane's row loses or repeats a neighbour (a padding entry that
/// is another particle), or if the lanes' terms round differently from the scatter's.
#[test]
fn fluid_only_scheme_is_bitwise_identical_on_1_to_4_ranks() {
    let text = with_overrides(
        &periodic_box("morris", 0.05, "density = \"continuity\""),
        &["box.shear_rate=1.0", "run.steps=60", "run.sample_every=5"],
    );
    let d = digests_on_1_to_4_ranks(&text, "le.toml", |_| {});
    assert_all_equal("fluid-only Lees–Edwards box", &d);
}

/// The fluid velocities at t = 0.01 (ordered by particle id) of start-up Couette flow (upper
/// wall at U = 1) or of start-up Poiseuille flow (walls at rest, body force 1 along x), stepped
/// with `integrator` at Δt = `dt`.
fn startup_velocities_at(poiseuille: bool, integrator: &str, dt: f64) -> Vec<[f64; 2]> {
    let t_end = 0.01;
    let mut overrides = vec![
        format!("integrator.kind=\"{integrator}\""),
        format!("integrator.dt={dt:e}"),
    ];
    if poiseuille {
        overrides.extend([
            "fluid.viscosity=0.125".into(),
            "fluid.body_force=[1.0, 0.0]".into(),
        ]);
    }
    let overrides: Vec<&str> = overrides.iter().map(String::as_str).collect();
    let text = with_overrides(
        &channel("morris", "morris", if poiseuille { 0.0 } else { 1.0 }),
        &overrides,
    );
    let loaded = case_from_str(&text, "startup.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    let steps = (t_end / dt).round() as u64;
    sim.run_steps(steps).expect("run");
    let p = &sim.particles;
    let mut fluid: Vec<(u64, [f64; 2])> = (0..p.n_owned)
        .filter(|&i| p.species_of(i) == 0)
        .map(|i| (p.gid[i], p.vel[i]))
        .collect();
    fluid.sort_by_key(|&(g, _)| g);
    fluid.into_iter().map(|(_, v)| v).collect()
}

/// The order in time of each integrator on the SPH start-up flows themselves (walls moving or
/// a body force, velocity-dependent forces), from the self-convergence of the velocities at
/// t = 0.01 with Δt = 10⁻⁴, 5·10⁻⁵, 2.5·10⁻⁵:
/// p = log₂(max|u_Δt − u_Δt/2| / max|u_Δt/2 − u_Δt/4|). Second order for kick–drift–kick,
/// Heun and midpoint; first order for the thesis's predictor–corrector as printed (its
/// erratum). Fails if Heun's predictor goes half a step (c = ½ with the trapezoidal
/// corrector: the thesis's scheme). Measured at t = 0.01 (2026-11-28): Couette 2.010, 2.019,
/// 2.019, 1.000; Poiseuille 2.006, 2.014, 2.014, 1.002 (at t = 0.02, where the test ran until
/// then at twice the cost, Couette 2.005, 2.009, 2.009, 1.000). Δt = 2·10⁻⁴ is beyond the
/// case's stability limit, so the ladder cannot start coarser.
#[test]
fn integrators_have_their_order_in_time_on_the_startup_flows() {
    for poiseuille in [false, true] {
        for (integrator, want) in [
            ("kick_drift_kick", 2.0),
            ("heun", 2.0),
            ("midpoint", 2.0),
            ("thesis_predictor_corrector", 1.0),
        ] {
            let runs: Vec<Vec<[f64; 2]>> = [1e-4, 5e-5, 2.5e-5]
                .iter()
                .map(|&dt| startup_velocities_at(poiseuille, integrator, dt))
                .collect();
            let diff = |a: &[[f64; 2]], b: &[[f64; 2]]| {
                a.iter()
                    .zip(b)
                    .map(|(u, v)| (u[0] - v[0]).abs().max((u[1] - v[1]).abs()))
                    .fold(0.0, f64::max)
            };
            let (e1, e2) = (diff(&runs[0], &runs[1]), diff(&runs[1], &runs[2]));
            let order = (e1 / e2).log2();
            let flow = if poiseuille { "Poiseuille" } else { "Couette" };
            eprintln!(
                "{flow}, {integrator}: |u(Δt) − u(Δt/2)| = {e1:.3e}, then {e2:.3e}: order {order:.3}"
            );
            // Measured within 0.02 of the target (above): 0.1 is the asymptotic regime's slack.
            assert!(
                (order - want).abs() < 0.1,
                "{flow}, {integrator}: order {order}"
            );
        }
    }
}

/// Row-averaged u_x(y) of the fluid (rows of the lattice, spacing `delta` from y = Δ/2).
fn row_profile<const D: usize>(sim: &Simulation<'_, D>, delta: f64) -> Vec<f64> {
    let rows = (1.0 / delta).round() as usize;
    let (mut sum, mut count) = (vec![0.0; rows], vec![0usize; rows]);
    let p = &sim.particles;
    for i in (0..p.n_owned).filter(|&i| p.species_of(i) == 0) {
        let row = ((p.pos[i][1] / delta).floor() as usize).min(rows - 1);
        sum[row] += p.vel[i][0];
        count[row] += 1;
    }
    sum.iter().zip(&count).map(|(s, &c)| s / c as f64).collect()
}

/// The stock Poiseuille problem (walls at rest, F = 1, ν = 0.125, Lucy support 3Δ, Morris
/// walls) at Δ = 0.04 to t = 0.4, in 2D and in 3D (periodic in z over 8 layers): both rows
/// profiles against the corrected series (docs/theory/sph_maxwell.md §3 T2) and against each other,
/// relative to the steady centre velocity 1. Measured: 2D 0.67 %, 3D 0.52 %, apart 0.17 %;
/// the bounds (1 % against the series, the tolerance; 0.5 % between them) fail if the 3D
/// kernel's normalisation is off by 5 % (105 → 100 in Lucy's 3D constant: 3D error 1.11 %).
#[test]
fn poiseuille_in_3d_agrees_with_2d() {
    let delta: f64 = 0.04;
    let (t, dt): (f64, f64) = (0.4, 4e-4);
    let base = stock_case("sph_poiseuille_2d.toml");
    let mut profiles = Vec::new();
    for dimension in [2i32, 3] {
        let per_side = (1.0 / delta).round();
        let mut overrides = vec![
            format!("particles.density={:.1}", per_side.powi(dimension)),
            format!("particles.mass={:e}", delta.powi(dimension)),
            format!("fluid.smoothing_length={}", 3.0 * delta),
            format!("integrator.dt={dt:e}"),
            format!("run.steps={}", (t / dt).round()),
            format!("neighbour.skin={}", delta / 2.0),
            // No references (the test compares itself).
            "reference=[]".to_string(),
        ];
        if dimension == 3 {
            overrides.extend([
                "dimension=3".to_string(),
                format!("box.lengths=[1.0, 1.0, {}]", 8.0 * delta),
                "box.boundaries=[\"periodic\", \"wall\", \"periodic\"]".to_string(),
                "fluid.body_force=[1.0, 0.0, 0.0]".to_string(),
            ]);
        }
        let overrides: Vec<&str> = overrides.iter().map(String::as_str).collect();
        let text = with_overrides(&base.source, &overrides);
        let loaded = case_from_str(&text, "poiseuille.toml");
        let comm = SerialComm::new();
        let series: Vec<f64> = (0..(1.0 / delta).round() as usize)
            .map(|k| mesorheo::analytic::poiseuille((k as f64 + 0.5) * delta, t, 1.0, 1.0, 0.125))
            .collect();
        let profile = if dimension == 2 {
            let mut sim = Simulation::<2>::new(&loaded.case, &comm, crate::common::PHYSICS_THREADS)
                .expect("set up");
            sim.run_steps((t / dt).round() as u64).expect("run");
            row_profile(&sim, delta)
        } else {
            let mut sim = Simulation::<3>::new(&loaded.case, &comm, crate::common::PHYSICS_THREADS)
                .expect("set up");
            sim.run_steps((t / dt).round() as u64).expect("run");
            row_profile(&sim, delta)
        };
        let error = profile
            .iter()
            .zip(&series)
            .map(|(u, s)| (u - s).abs())
            .fold(0.0, f64::max);
        eprintln!("{dimension}D: max |u − series| = {error:.4} at t = {t}");
        assert!(error < 0.01, "{dimension}D: {error}");
        profiles.push(profile);
    }
    let apart = profiles[0]
        .iter()
        .zip(&profiles[1])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!("max |u_3D − u_2D| = {apart:.4}");
    assert!(apart < 0.005, "2D and 3D differ by {apart}");
}

/// XSPH: after a force evaluation every fluid particle holds the drift correction
/// c_i = ε Σ_j (m/ρ̄_ij)(v_j − v_i) W(r_ij), ρ̄_ij = (ρ_i + ρ_j)/2, here against that sum done
/// directly over all pairs (minimum image) for a shear wave u_x = 0.01 sin(2πy) on a
/// continuity density perturbed by 10 %; the next drift moves each particle by
/// Δt (v½ + c). Agreement to 1e-12 of the largest correction (the sums differ in order only).
/// Fails with the sign of the correction flipped, or with ρ_i in place of ρ̄_ij.
#[test]
fn xsph_correction_is_the_smoothed_velocity_difference() {
    let eps = 0.5;
    let text = periodic_box(
        "morris",
        0.05,
        &format!("density = \"continuity\"\nxsph = {eps}"),
    );
    let loaded = case_from_str(&text, "xsph.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    let rho = sim.particles.extra_index("density").expect("density");
    let xsph = sim
        .particles
        .extra_index("xsph_correction")
        .expect("the correction field");
    for i in 0..sim.particles.n_owned {
        let x = sim.particles.pos[i][0];
        sim.particles.extra[rho].data[i] = 1.0 + 0.1 * (2.0 * std::f64::consts::PI * x).sin();
    }
    set_velocity(&mut sim, |y| 0.01 * (2.0 * std::f64::consts::PI * y).sin());
    let p = &sim.particles;
    let n = p.n_owned;
    let (mass, support) = (0.0004, 0.05);
    let lucy = |r: f64| {
        let q = r / support;
        if q >= 1.0 {
            0.0
        } else {
            5.0 / (std::f64::consts::PI * support * support) * (1.0 + 3.0 * q) * (1.0 - q).powi(3)
        }
    };
    let mut worst: f64 = 0.0;
    let mut largest: f64 = 0.0;
    for i in 0..n {
        let mut want = [0.0; 2];
        for j in 0..n {
            if j == i {
                continue;
            }
            let mut r2 = 0.0;
            for d in 0..2 {
                let mut x = p.pos[i][d] - p.pos[j][d];
                x -= x.round(); // minimum image in the unit box
                r2 += x * x;
            }
            let w = lucy(r2.sqrt());
            if w == 0.0 {
                continue;
            }
            let rho_bar = 0.5 * (p.extra[rho].data[i] + p.extra[rho].data[j]);
            for (d, c) in want.iter_mut().enumerate() {
                *c += eps * mass / rho_bar * (p.vel[j][d] - p.vel[i][d]) * w;
            }
        }
        for (d, c) in want.iter().enumerate() {
            let got = p.extra[xsph].data[i * 2 + d];
            worst = worst.max((got - c).abs());
            largest = largest.max(c.abs());
        }
    }
    eprintln!("XSPH correction: largest {largest:.3e}, worst difference {worst:.3e}");
    assert!(largest > 1e-5, "the correction vanished: {largest}");
    assert!(worst < 1e-12 * largest, "worst {worst} of {largest}");
    // The drift: r ← r + Δt (v + Δt a / 2 + c), particle by particle.
    let before: Vec<(u64, [f64; 2], [f64; 2])> = (0..n)
        .map(|i| {
            let (v, f, c) = (
                p.vel[i],
                p.force[i],
                [p.extra[xsph].data[2 * i], p.extra[xsph].data[2 * i + 1]],
            );
            let dt = 1e-4;
            let step: [f64; 2] =
                std::array::from_fn(|d| dt * (v[d] + 0.5 * dt * (f[d] / mass) + c[d]));
            (p.gid[i], p.pos[i], step)
        })
        .collect();
    sim.run_steps(1).expect("step");
    let p = &sim.particles;
    let index: std::collections::HashMap<u64, usize> =
        (0..p.n_owned).map(|i| (p.gid[i], i)).collect();
    for (gid, x0, step) in before {
        let x1 = p.pos[index[&gid]];
        for d in 0..2 {
            let mut moved = x1[d] - x0[d];
            moved -= moved.round();
            assert!(
                (moved - step[d]).abs() < 1e-15,
                "particle {gid}: moved {moved}, expected {}",
                step[d]
            );
        }
    }
}

/// Hydrostatic equilibrium under gravity g along −y between walls at rest: the Tait fluid's
/// density obeys dp/dy = −ρg with p = (c₀²ρ₀/7)((ρ/ρ₀)⁷ − 1), i.e. ρ⁶ = ρ_b⁶ − 6gρ₀⁶y/c₀².
/// The `density_profile` observable (time-averaged over t ∈ [0.5, 1], after the acoustic
/// transient has decayed) against that profile, the constant ρ_b fitted by the mean over
/// the interior bins, four supports (0.2) from either wall: within three supports of a wall
/// the density layers by ±0.3 % (measured; the continuity density next to the boundary
/// particles). Measured: worst deviation 1.2 % of the 0.6 % density drop across the interior
/// (standard errors 1–3·10⁻⁵, i.e. 0.2–0.5 % of the drop, on correlated samples); bound 3 %.
/// Fails if the profile bins along x instead of y (flat), or with the sign of g.
#[test]
fn density_profile_is_hydrostatic_under_gravity() {
    let (g, c0) = (1.0, 10.0);
    let text = with_overrides(
        &channel("morris", "morris", 0.0),
        &[
            &format!("fluid.body_force=[0.0, {}]", -g),
            "fluid.density=\"continuity\"",
            "run.steps=10000",
            "run.equilibration=5000",
            "run.sample_every=50",
            "diagnostics.observables=[\"density_profile\"]",
            "diagnostics.profile_bins=50",
        ],
    );
    let loaded = case_from_str(&text, "hydrostatic.toml");
    let s = run_in_process(&loaded, 1, crate::common::PHYSICS_THREADS, None).expect("run");
    let profile = &s.density_profile;
    assert_eq!(profile.len(), 50);
    let interior: Vec<_> = profile.iter().filter(|b| b.y > 0.2 && b.y < 0.8).collect();
    let shape = |y: f64, rho_b6: f64| (rho_b6 - 6.0 * g * y / (c0 * c0)).powf(1.0 / 6.0);
    // ρ_b⁶ such that the interior mean matches (the profile is nearly linear: one Newton step
    // from ρ_b = 1 is exact to 1e-8).
    let mean = interior.iter().map(|b| b.mean).sum::<f64>() / interior.len() as f64;
    let model_mean = |rho_b6: f64| {
        interior.iter().map(|b| shape(b.y, rho_b6)).sum::<f64>() / interior.len() as f64
    };
    let mut rho_b6 = 1.0;
    for _ in 0..3 {
        let d = 1e-6;
        let slope = (model_mean(rho_b6 + d) - model_mean(rho_b6)) / d;
        rho_b6 -= (model_mean(rho_b6) - mean) / slope;
    }
    let mut worst: f64 = 0.0;
    for b in &interior {
        let want = shape(b.y, rho_b6);
        eprintln!(
            "y = {:.2}: ρ = {:.6} ± {:.1e}, hydrostatic {want:.6}",
            b.y, b.mean, b.stderr
        );
        worst = worst.max((b.mean - want).abs());
    }
    let drop = shape(0.2, rho_b6) - shape(0.8, rho_b6);
    eprintln!("worst deviation {worst:.2e} of a drop of {drop:.2e} across the interior");
    assert!(
        worst < 0.03 * drop,
        "worst {worst} against a drop of {drop}"
    );
}

/// The `wall_shear_stress` observable during start-up Couette flow (η = 1, U = 1, L = 1)
/// against the series: the fluid pulls the lower wall with η ∂u/∂y(0, t) =
/// ηU/L (1 + 2 Σ (−1)ⁿ e^(−n²π²νt/L²)) and holds the upper one back with −η ∂u/∂y(L, t) =
/// −ηU/L (1 + 2 Σ e^(−n²π²νt/L²)) (the derivative of `analytic::couette`, checked here by
/// finite differences). Measured at t = 0.05, 0.1, 0.2, 0.3: lower 0.0315, 0.279, 0.702,
/// 0.875 against 0.0340, 0.293, 0.723, 0.897; upper −2.503, −1.770, −1.270, −1.094 against
/// −2.523, −1.784, −1.279, −1.104: within 2.2 % of ηU/L (the steady deficit is the 1.4 %
/// lattice sum of the viscous operator at 2.5Δ, the rest the near-wall gradient); bound 3 %.
/// Fails with the two walls' stresses swapped (worst deviation 2.55 ηU/L, run).
#[test]
fn wall_shear_stress_follows_the_startup_series() {
    let text = channel("morris", "morris", 1.0);
    let loaded = case_from_str(&text, "couette.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    let nu = 1.0;
    let slope = |t: f64, at_top: bool| {
        let mut s = 1.0;
        for n in 1..200 {
            let sign = if at_top || n % 2 == 0 { 1.0 } else { -1.0 };
            s += 2.0 * sign * (-(n as f64 * std::f64::consts::PI).powi(2) * nu * t).exp();
        }
        s
    };
    let mut done = 0u64;
    let mut worst: f64 = 0.0;
    for t in [0.05, 0.1, 0.2, 0.3] {
        // The closed form against the series it differentiates.
        for (y, top) in [(0.0, false), (1.0, true)] {
            let h = 1e-5;
            let (a, b) = if top { (y - h, y) } else { (y, y + h) };
            let fd = (mesorheo::analytic::couette(b, t, 1.0, 1.0, nu)
                - mesorheo::analytic::couette(a, t, 1.0, 1.0, nu))
                / h;
            assert!(
                (fd - slope(t, top)).abs() < 1e-3,
                "t = {t}: {fd} vs {}",
                slope(t, top)
            );
        }
        let steps = (t / 1e-4_f64).round() as u64;
        sim.run_steps(steps - done).expect("run");
        done = steps;
        let (lower, upper) = wall_shear_stresses(&mut sim);
        let (want_lower, want_upper) = (slope(t, false), -slope(t, true));
        eprintln!(
            "t = {t}: lower {lower:.4} (series {want_lower:.4}), upper {upper:.4} (series {want_upper:.4})"
        );
        worst = worst
            .max((lower - want_lower).abs())
            .max((upper - want_upper).abs());
    }
    assert!(worst < 0.03, "worst deviation {worst} of ηU/L");
}

/// The closest approach to the lower wall plane of the first fluid row thrown at the wall at
/// speed `speed`, with pressure and viscosity negligible (c₀ = 10⁻³, η = 0), so that only the
/// wall's repulsion (strength `strength`, range Δ) can stop it.
fn closest_approach(speed: f64, strength: f64) -> f64 {
    let text = with_overrides(
        &channel("morris", "morris", 0.0),
        &[
            "fluid.sound_speed=0.001",
            "fluid.viscosity=0.0",
            &format!("walls.repulsion_strength={strength:e}"),
        ],
    );
    let loaded = case_from_str(&text, "thrown.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    for i in 0..sim.particles.n_owned {
        if sim.particles.species_of(i) == 0 && sim.particles.pos[i][1] < 0.02 {
            sim.particles.vel[i] = [0.0, -speed];
        }
    }
    sim.jump_to_step(0).expect("forces");
    let mut closest = f64::INFINITY;
    for _ in 0..400 {
        sim.run_steps(1).expect("run");
        let p = &sim.particles;
        for i in (0..p.n_owned).filter(|&i| p.species_of(i) == 0) {
            closest = closest.min(p.pos[i][1]);
        }
    }
    closest
}

/// No fluid particle reaches the wall plane: the first row thrown at the lower wall at speed 1
/// (from y = Δ/2 = 0.01) is stopped by the repulsion alone (pressure and viscosity switched
/// off), strength D = 1. Measured: closest approach 0.0029 (bound 0.002); with D = 10⁻¹² the
/// row reaches the plane (0, where the engine's last-resort reflection catches it). This test
/// found the repulsion m_j = 4·10⁻⁴ times too weak (multiplied by m_i m_j like the pair
/// terms, although Eq. 2.48 adds it as an acceleration): the row then reached the plane too.
#[test]
fn the_wall_repulsion_keeps_fluid_particles_off_the_wall_plane() {
    let held = closest_approach(1.0, 1.0);
    let unheld = closest_approach(1.0, 1e-12);
    eprintln!("closest approach: {held:.5} with the repulsion, {unheld:.5} without");
    assert!(held > 0.002, "the repulsion let the row reach y = {held}");
    assert!(
        unheld < 1e-3,
        "without repulsion the row still stopped at {unheld}"
    );
}

/// Blow-up detection (issue #18), SPH density: a fluid particle whose (continuity) density has
/// gone negative is stopped at the next momentum pass, before the equation of state turns it
/// into a pressure, naming the particle and its density. Fails if the check is dropped (the
/// step then succeeds with a negative density in the sums).
#[test]
fn a_negative_density_is_stopped_and_named() {
    let text = periodic_box("morris", 0.05, "density = \"continuity\"");
    let loaded = case_from_str(&text, "box.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    sim.advance().expect("a good step");
    let rho = sim
        .particles
        .extra_index(mesorheo::models::sph::DENSITY)
        .expect("a density field");
    let k = (0..sim.particles.n_owned)
        .find(|&k| sim.particles.gid[k] == 31)
        .expect("particle 31 is owned");
    sim.particles.extra[rho].data[k] = -0.5;
    let err = sim.advance().expect_err("the negative density is caught");
    assert!(
        err.to_string().contains("particle 31")
            && err.to_string().contains("density ρ = -")
            && err.unstable().is_some(),
        "{err}"
    );
}
