//! DPD physics against known answers: the thermostat (fluctuation–dissipation), the pressure of
//! the Groot–Warren fluid, momentum conservation, and the linear profile of Lees–Edwards shear.
//! Each stock scene carries its `[[reference]]` checks; here they must all pass.

use crate::common;
use common::{case_from_str, small_dpd, stock_case, stock_text_with, with_overrides};
use mesorheo::comm::SerialComm;
use mesorheo::driver::run_in_process;
use mesorheo::facade::Engine;
use mesorheo::sim::Simulation;

fn assert_validations_pass(name: &str, ranks: usize, threads: usize) {
    let loaded = stock_case(name);
    let s = run_in_process(&loaded, ranks, threads, None).unwrap_or_else(|e| panic!("{e}"));
    assert!(!s.validation.is_empty(), "{name} carries no reference");
    for v in &s.validation {
        assert!(
            v.pass,
            "{name}: {} — {} = {} > tolerance {}",
            v.name, v.metric, v.value, v.tolerance
        );
    }
}

/// k_BT within 1.4 % and p within 0.2 % of LAMMPS's time average 23.693 ± 0.003 at ρ = 3,
/// a = 25, γ = 4.5 (Δt = 0.04, λ = 0.65; 3D); thermostat and momentum in 2D. A conservative force
/// 1 % too strong moves p by ~+1 % and fails.
#[test]
fn equilibrium_temperature_and_pressure_match_references() {
    assert_validations_pass("dpd_equilibrium_3d.toml", 1, 2);
    assert_validations_pass("dpd_equilibrium_2d.toml", 2, 1);
}

/// The 32 000-particle benchmark fluid (LAMMPS's bench/in.dpd): its pressure over steps 20–100
/// within 1 % of LAMMPS's printed 23.86 (a few seconds; every stock case under a minute runs its
/// references in `./run test`).
#[test]
fn benchmark_fluid_pressure_matches_lammps() {
    assert_validations_pass("bench_dpd_32k.toml", 1, 2);
}

/// Linear profile through the Lees–Edwards plane (no kink), thermostat, momentum: 2D on 2 ranks.
#[test]
fn lees_edwards_shear_profile_is_linear_through_the_plane() {
    assert_validations_pass("dpd_shear_2d.toml", 2, 1);
}

/// The 3D Lees–Edwards fluid: its shear viscosity against LAMMPS's on the same fluid
/// (0.859 ± 0.006; within 13 %, 4.4 combined standard errors), the profile, the thermostat and
/// the peculiar momentum. Fails with the dissipative and random virial left out of the stress
/// (η = 0.695) or with the sign of P_xy flipped.
#[test]
fn lees_edwards_viscosity_matches_lammps_in_3d() {
    assert_validations_pass("dpd_shear_3d.toml", 1, 2);
}

/// Total (peculiar) momentum stays at its initial value to round-off, with and without shear.
#[test]
fn momentum_is_conserved_to_round_off() {
    for (dim, shear) in [(3usize, 0.0), (3, 0.5), (2, 0.5)] {
        let text = small_dpd(
            dim,
            6.0,
            shear,
            10,
            "[diagnostics]\nobservables = [\"momentum\"]\n",
        );
        let loaded = case_from_str(&text, "momentum");
        let comm = SerialComm::new();
        let worst = if dim == 3 {
            let mut sim = Simulation::<3>::new(&loaded.case, &comm, 1).expect("setup");
            drift(&mut sim)
        } else {
            let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("setup");
            drift(&mut sim)
        };
        // ~600 particles with |m v| ~ 1: round-off of the sum is ~1e-13.
        assert!(
            worst < 1e-10,
            "{dim}D shear {shear}: momentum drift {worst}"
        );
    }
}

fn drift<const D: usize>(sim: &mut Simulation<D>) -> f64
where
    for<'c> Simulation<'c, D>: Engine<'c, D>,
{
    let p0: Vec<f64> = sim.measure().scalars.iter().map(|(_, v)| *v).collect();
    let mut worst = 0.0f64;
    for _ in 0..20 {
        sim.run_steps(25).expect("steps");
        let p: Vec<f64> = sim.measure().scalars.iter().map(|(_, v)| *v).collect();
        for (a, b) in p.iter().zip(&p0) {
            worst = worst.max((a - b).abs());
        }
    }
    worst
}

/// Forces sum to zero exactly for owned–owned pairs; with images, to round-off.
#[test]
fn forces_sum_to_zero() {
    let loaded = case_from_str(&small_dpd(3, 6.0, 0.4, 10, ""), "forces");
    let comm = SerialComm::new();
    let sim = Simulation::<3>::new(&loaded.case, &comm, 2).expect("setup");
    let mut total = [0.0f64; 3];
    let mut scale = 0.0f64;
    for f in &sim.particles.force[..sim.particles.n_owned] {
        for d in 0..3 {
            total[d] += f[d];
            scale = scale.max(f[d].abs());
        }
    }
    for t in total {
        assert!(
            t.abs() < 1e-11 * scale * sim.particles.n_owned as f64,
            "{total:?}"
        );
    }
}

/// A blown-up run (here: a repulsion far beyond anything the validated time step allows,
/// injected past the case validation) stops with a clear error instead of producing garbage.
#[test]
fn an_exploding_force_is_reported_not_accumulated() {
    let mut loaded = case_from_str(&small_dpd(3, 6.0, 0.0, 10, ""), "explode");
    let mesorheo::config::FluidCfg::Dpd(d) = &mut loaded.case.fluid else {
        panic!("a DPD case");
    };
    d.a = 1e12;
    let comm = SerialComm::new();
    let err = match Simulation::<3>::new(&loaded.case, &comm, 1) {
        Ok(_) => panic!("a 1e12 repulsion must be refused"),
        Err(e) => e,
    };
    assert!(
        err.unstable()
            .is_some_and(|u| u.quantity == mesorheo::error::Quantity::PairForce),
        "{err}"
    );
}

/// Blow-up detection (issue #18): a particle whose position becomes NaN is caught at the next
/// step's displacement check, on every rank alike, with a diagnosis naming it (`f64::max`
/// alone would skip the NaN and let the run go on); a particle thrown beyond the list's reach
/// is named with its displacement. Both say "the run is unstable", on which `mesorheo run`
/// exits with code 4. Fails if NaN displacements are dropped again (the step then succeeds).
#[test]
fn a_non_finite_or_runaway_particle_is_named() {
    let loaded = case_from_str(&small_dpd(3, 6.0, 0.0, 10, ""), "nan");
    let comm = SerialComm::new();
    for (poison, expect) in [
        (f64::NAN, "has a position that is not finite"),
        (0.0, "(more than cutoff + skin"),
    ] {
        let mut sim =
            Simulation::<3>::new(&loaded.case, &comm, 1).unwrap_or_else(|e| panic!("{e}"));
        sim.advance().expect("a good step");
        let k = (0..sim.particles.n_owned)
            .find(|&k| sim.particles.gid[k] == 17)
            .expect("particle 17 is owned");
        // A NaN position, or a kick of 30 per step along x (the list reaches 1.3).
        sim.particles.pos[k][0] += poison;
        if poison.is_finite() {
            sim.particles.vel[k][0] += 30.0 / 0.04;
        }
        let err = sim.advance().expect_err("the blow-up is caught");
        assert!(
            err.to_string().contains("particle 17")
                && err.to_string().contains(expect)
                && err.unstable().is_some(),
            "{err}"
        );
    }
}

/// Blow-up detection (issue #18), runaway energy: a DPD particle kicked to a peculiar kinetic
/// energy beyond RUNAWAY_KT + a n_c (here 100 + 25 × 4π/3 × 3 ≈ 416 k_BT) while still within the
/// lists' reach (v = 30: 1.2 per step of 0.04, below cutoff + skin = 1.3) is stopped at the
/// next step, named, with its energy. Fails if the energy check is dropped (that step then
/// succeeds) or measured without the mass, or against the thermal bound alone on the
/// violent random start of a = 10⁶ (tests/extremes.rs, which must complete).
#[test]
fn a_particle_with_a_runaway_kinetic_energy_is_named() {
    let loaded = case_from_str(&small_dpd(3, 6.0, 0.0, 10, ""), "hot");
    let comm = SerialComm::new();
    let mut sim = Simulation::<3>::new(&loaded.case, &comm, 1).unwrap_or_else(|e| panic!("{e}"));
    sim.advance().expect("a good step");
    let k = (0..sim.particles.n_owned)
        .find(|&k| sim.particles.gid[k] == 23)
        .expect("particle 23 is owned");
    sim.particles.vel[k] = [30.0, 0.0, 0.0];
    let err = sim.advance().expect_err("the runaway is caught");
    assert!(
        err.to_string().contains("particle 23")
            && err.to_string().contains("peculiar kinetic energy")
            && err.unstable().is_some(),
        "{err}"
    );
    let bound = match &loaded.case.fluid {
        mesorheo::config::FluidCfg::Dpd(d) => {
            mesorheo::models::dpd::spec::runaway_energy_in_kt(d, 3, 3.0)
        }
        _ => unreachable!(),
    };
    assert!((bound - (100.0 + 25.0 * 4.0 * std::f64::consts::PI)).abs() < 1e-9);
}

/// Blow-up detection (issue #18), heating: a thermostatted fluid whose kinetic temperature has
/// passed its heating bound stops at the next sample with a diagnosis naming the temperature;
/// 10 % below the bound it samples on. The bound is 2 k_BT plus the overlap energy of a random
/// start, (2/D)(n/2)∫φ dV = n a π/45 = 5.236 k_BT for the 3D a = 25, ρ = 3 fluid (by hand),
/// decaying as e^{−ω₀t/2}, ω₀ = γ n (8π/60)/3 = 1.885: at t = 0.04 (one step) 2 + 5.236 ×
/// e^{−0.0377} = 7.042. The velocities are scaled by √(T/T₀), so the measured temperature is
/// known to round-off. Fails if the heating check is dropped (the hot sample succeeds), if its
/// bound drops the start's allowance (0.9 × 7.042 is then stopped) or keeps it undecayed.
#[test]
fn a_fluid_heating_past_its_bound_is_stopped() {
    let loaded = case_from_str(&small_dpd(3, 6.0, 0.0, 10, ""), "heating");
    let mesorheo::config::FluidCfg::Dpd(dpd) = &loaded.case.fluid else {
        unreachable!()
    };
    let bound = |t: f64| mesorheo::models::dpd::spec::heating_bound_in_kt(dpd, 3, 3.0, 1.0, t);
    let omega0 = 4.5 * 3.0 * 8.0 * std::f64::consts::PI / 60.0 / 3.0;
    let start = 3.0 * 25.0 * std::f64::consts::PI / 45.0;
    assert!((bound(0.0) - 2.0 - start).abs() < 1e-12, "{}", bound(0.0));
    assert!((bound(0.04) - 2.0 - start * (-0.5 * omega0 * 0.04).exp()).abs() < 1e-12);
    assert!((bound(100.0) - 2.0).abs() < 1e-12, "{}", bound(100.0));
    let comm = SerialComm::new();
    let mut sim = Simulation::<3>::new(&loaded.case, &comm, 1).unwrap_or_else(|e| panic!("{e}"));
    sim.advance().expect("a good step");
    let t0 = sim.measure().kinetic_temperature;
    assert!(t0 > 0.5 && t0 < 2.0, "k_BT after one step {t0}");
    let limit = bound(sim.time());
    for (target, stops) in [(0.9 * limit, false), (1.1 * limit, true)] {
        let scale = (target / sim.measure().kinetic_temperature).sqrt();
        for v in sim.particles.vel[..sim.particles.n_owned].iter_mut() {
            v.iter_mut().for_each(|c| *c *= scale);
        }
        let t = sim.measure().kinetic_temperature;
        assert!((t - target).abs() < 1e-9, "scaled to {t}");
        match sim.sample() {
            Ok(()) => assert!(!stops, "k_BT = {t} passed the heating check ({limit})"),
            Err(e) => {
                assert!(stops, "k_BT = {t} stopped: {e}");
                assert!(
                    e.to_string().contains(&format!(
                        "kinetic temperature is {t:.4} k_BT, beyond {limit:.4}"
                    )) && e.unstable().is_some(),
                    "{e}"
                );
            }
        }
    }
}

/// The profile-unbiased temperature removes the whole linear shear profile, including its
/// variation inside a bin: a lattice moving exactly with u_x = γ̇ (y − L_y/2) at k_BT = 0 reads
/// k_BT = 0 and no kinetic normal stress (a constant bin mean would read m γ̇² Δ² / (12 D) ≈
/// 0.042 here).
#[test]
fn a_pure_shear_flow_has_zero_temperature_and_no_kinetic_normal_stress() {
    let text = with_overrides(
        &small_dpd(
            2,
            8.0,
            0.5,
            10,
            "[diagnostics]\nobservables = [\"temperature\", \"stress\"]\nprofile_bins = 4\n",
        ),
        &["particles.lattice=\"cubic\"", "particles.temperature=0.0"],
    );
    let loaded = case_from_str(&text, "pure_shear");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("setup");
    let m = sim.measure();
    let get = |k: &str| m.scalars.iter().find(|(n, _)| n == k).expect(k).1;
    assert!(get("temperature").abs() < 1e-12, "{}", get("temperature"));
    assert!(
        get("stress_kinetic_xx").abs() < 1e-12,
        "{}",
        get("stress_kinetic_xx")
    );
}

/// The transverse currents obey equipartition, C⊥(k, 0) = (k²/N)⟨|J⊥(k)|²⟩ = k² k_BT/m, at
/// every mode within 4.5 jackknife errors (the block spread of a 6³ Groot–Warren fluid; the
/// Δt bias of k_BT at Δt = 0.04 is ≈ +0.5 %, well inside; the errors are 2–6 %, the slow
/// modes' largest). Mutations that fail: dropping the k² (modes 2 and 3: factors 4.4 and 9.9),
/// normalising by the particles of one rank or by the D(D − 1) pairs
/// twice, a phase e^{ikx} with L off by one lattice cell. The 2-rank run gives the same bits.
#[test]
fn transverse_currents_obey_equipartition_and_are_rank_invariant() {
    let text = small_dpd(
        3,
        6.0,
        0.0,
        4000,
        "equilibration = 100\n[diagnostics]\nobservables = [\"temperature\", \
         \"transverse_current_viscosity\"]\nblocks = 10\ntransverse_current_modes = 3\n\
         transverse_current_every = 1\ntransverse_current_time = 3.0\n",
    );
    let loaded = case_from_str(&text, "tcaf.toml");
    let mut digests = Vec::new();
    for ranks in [1, 2] {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().to_path_buf();
        let l = loaded.clone();
        let o = out.clone();
        let s = mesorheo::driver::in_process(ranks, move |c| {
            mesorheo::driver::run_case(
                &l,
                c,
                &mesorheo::driver::RunOptions {
                    threads: 1,
                    steps: None,
                    until_step: None,
                    out: Some(o.clone()),
                    max_hours: None,
                },
            )
        })
        .expect("run");
        digests.push((
            s.state_digest.clone(),
            s.observables["transverse_current_viscosity_k1"]
                .mean
                .to_bits(),
        ));
        let csv = std::fs::read_to_string(out.join("transverse_current.csv")).expect("csv");
        let mut seen = std::collections::BTreeSet::new();
        for line in csv.lines().skip(1) {
            let f: Vec<f64> = line
                .split(',')
                .map(|x| x.parse().expect("number"))
                .collect();
            let (mode, k, c0, se, expected) = (f[0] as usize, f[1], f[6], f[7], f[8]);
            if !seen.insert(mode) {
                continue;
            }
            let kt = s.observables["temperature"].mean;
            let want = k * k * kt;
            assert!(
                (expected - k * k).abs() < 1e-9 * k * k,
                "{expected} vs k² = {}",
                k * k
            );
            assert!(
                (c0 - want).abs() < 4.5 * se && se < 0.1 * want,
                "mode {mode}: C⊥(k, 0) = {c0} ± {se}, k² k_BT/m = {want}"
            );
        }
        assert_eq!(seen.len(), 3);
    }
    assert_eq!(digests[0], digests[1], "1 and 2 ranks differ");
}

/// The profile-unbiased k_BT under shear does not depend on how finely the streaming profile
/// is binned: 10 particles per bin (30 bins) and 60 (5 bins), on the same trajectory (the same
/// seed; only the estimator differs), agree within 0.004. Measured 2026-11-25: 1.00290 and
/// 1.00309 (difference 0.0002; each ± 0.0075 of trajectory noise, which the difference does not
/// carry). Dividing Σ m V² by D(N − bins) instead of by the degrees of freedom the interpolated
/// bin means leave (the estimator before 2026-11-25) gave 1.0224 and 1.0059: a difference of
/// 0.0165, which fails.
#[test]
fn sheared_temperature_does_not_depend_on_the_bin_count() {
    let text = |bins: usize| {
        with_overrides(
            &small_dpd(
                2,
                10.0,
                0.05,
                5000,
                &format!(
                    "equilibration = 200\n[diagnostics]\nobservables = [\"temperature\"]\n\
                     profile_bins = {bins}\n"
                ),
            ),
            &["integrator.dt=0.02"],
        )
    };
    let kt = |bins: usize| {
        let s = run_in_process(
            &case_from_str(&text(bins), "kt.toml"),
            1,
            crate::common::PHYSICS_THREADS,
            None,
        )
        .unwrap_or_else(|e| panic!("{e}"));
        s.observables["temperature"]
    };
    let (fine, coarse) = (kt(30), kt(5));
    assert!(
        (fine.mean - coarse.mean).abs() < 0.004 && (fine.mean - 1.0).abs() < 4.5 * fine.stderr,
        "30 bins: {fine:?}, 5 bins: {coarse:?}"
    );
}

/// Nguyen's low-mass Couette fluid (Table 3.1: 2D 10 × 10, n = 10, m = 0.01, r_c = 1.6, η = 100,
/// α = 10; Lees–Edwards γ̇ = 0.2) at Δt = 5·10⁻⁴, where ω₀Δt = 4.1: the explicit step diverges
/// (the thesis's too), the exponential thermostat keeps k_BT = 1 within 4.5 block errors
/// (measured 1.0000 ± 0.0008 over t = 2.5; the thesis's SETD read 0.49 here). The reference is
/// the input k_BT (fluctuation–dissipation), not the code. Mutations: noise scaled by φ instead
/// of √φ reads k_BT ≈ φ = 0.24; no factor at all diverges like the explicit step.
#[test]
fn exponential_thermostat_keeps_k_bt_where_the_explicit_step_diverges() {
    let text = |thermostat: &str| {
        format!(
            "dimension = 2\nseed = 12\n[box]\nlengths = [10.0, 10.0]\nshear_rate = 0.2\n\
             [particles]\nlattice = \"random\"\ndensity = 10.0\nmass = 0.01\ntemperature = 1.0\n\
             velocity_profile = \"shear\"\n[fluid]\nkind = \"dpd\"\nkt = 1.0\ncutoff = 1.6\n\
             [fluid.physical]\nviscosity = 100.0\ntime_scale_ratio = 10.0\n[integrator]\n\
             kind = \"groot_warren\"\ndt = 5e-4\nthermostat = \"{thermostat}\"\n[neighbour]\n\
             skin = 0.3\n[run]\nsteps = 5000\nequilibration = 500\nsample_every = 5\n\
             beyond_stability_limits = true\n[diagnostics]\nobservables = [\"temperature\"]\n\
             profile_bins = 100\nblocks = 20\n"
        )
    };
    let exponential = run_in_process(
        &case_from_str(&text("exponential"), "setd.toml"),
        1,
        2,
        None,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let kt = exponential.observables["temperature"];
    assert!(
        kt.stderr < 0.002 && (kt.mean - 1.0).abs() < 4.5 * kt.stderr,
        "exponential thermostat at ω₀Δt = 4.1: k_BT = {kt:?}"
    );
    let explicit = run_in_process(&case_from_str(&text("explicit"), "vv.toml"), 1, 2, None);
    assert!(
        explicit.is_err() || !explicit.as_ref().is_ok_and(|s| s.completed),
        "the explicit step at ω₀Δt = 4.1 should diverge"
    );
}

/// The reverse Poiseuille flow (the n = 4 level of Nguyen's §3.4: 20 × 20, n = 4, m = 2, g = ±1, the
/// stock case shortened to t = 23, sampled after t = 8; 11 500 steps, 49 s on one thread).
///
/// 1. The binned shear stress against the momentum balance alone, τ_xy = ρ g (L_y/4 − |s|),
///    τ_max = 40, which holds whatever the viscosity: every bin within 4.5 of its block errors
///    (20 blocks), and the bins averaging to the box's −P_xy (the segment shares sum to one
///    pair's whole virial). The block errors must be below 1.5 (3.75 % of τ_max; the largest
///    is 1.12 on this window, 2026-11-28: the guard leaves room for the ±16 % scatter of a
///    20-block error estimate). Mutation run: the dissipative and random parts left out of the
///    binned pair stress give τ = −0.37 ± 0.03 against −36 in the first bin (this fluid's stress
///    is almost all dissipative) and fail by more than 20 block errors.
/// 2. The mapped viscosity (issue #40: the decisive check of the physical-parameter mapping,
///    which the stress cannot see): the binned u_x(y) projected on the start-up solution of
///    ∂u/∂t = ν ∂²u/∂y² + g(y) from rest with the case's η = 30 (its Fourier series, written
///    here: square-wave force, modes k_n = 2πn/L_y, n odd, each relaxing as e^{−νk_n²t},
///    averaged over the sampling window and over each bin). The amplitude A = Σu φ/Σφ² is
///    η_input/η_fluid at steady state (a box-mean drift drops out: φ is odd). Measured here
///    (2026-11-28) A = 1.0018 ± 0.0011. Bound: |A − 1| < 2 %, the accuracy of the kinetic-theory
///    mapping (the n = 8 stock case at t = 300 measured 1.4 % above); a 5 % error of the
///    mapping must fail either way. Mutation runs (2026-11-28, `fluid.physical.viscosity` set
///    to 31.5 resp. 28.5 while the analysis keeps η = 30, which is γ mapped from 1.05 η resp.
///    0.95 η): A = 0.9699 ± 0.0012 and 1.0600 ± 0.0016, both fail (by 8σ and 33σ).
///    Not understood yet: the same run to t = 38 gave A = 1.0189 ± 0.0014, so the amplitude
///    still moves after t = 23 by more than its error bar, and the mutations move it by
///    −3.2 % and +5.8 % rather than ∓4.8 % and +5.3 %.
#[test]
fn double_poiseuille_shear_stress_follows_the_momentum_balance() {
    let (steps, equilibration) = (11_500_u32, 4000_u32);
    let text = stock_text_with(
        "dpd_double_poiseuille_2d_n4.toml",
        &[
            &format!("run.steps={steps}"),
            &format!("run.equilibration={equilibration}"),
            "diagnostics.observables=[\"temperature\", \"velocity_profile\", \"shear_stress_profile\", \"stress\"]",
            "diagnostics.blocks=20",
        ],
    );
    let s = run_in_process(
        &case_from_str(&text, "dp_stress.toml"),
        1,
        crate::common::PHYSICS_THREADS,
        None,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let profile = &s.shear_stress_profile;
    assert_eq!(profile.len(), 20);
    let worst = profile.iter().map(|p| p.stderr).fold(0.0, f64::max);
    eprintln!("reverse Poiseuille: the largest block error of a τ_xy bin is {worst:.3}");
    for p in profile {
        assert!(
            p.stderr < 1.5 && (p.mean - p.expected).abs() < 4.5 * p.stderr,
            "τ_xy at y = {}: {} ± {} against {}",
            p.y,
            p.mean,
            p.stderr,
            p.expected
        );
    }
    let mean = profile.iter().map(|p| p.mean).sum::<f64>() / 20.0;
    let total = s.observables["stress_total_xy"].mean;
    assert!(
        (mean + total).abs() < 1e-9 * 40.0,
        "bins {mean} vs −P_xy {}",
        -total
    );
    // 2. The viscosity the mapping promises, from the velocity profile.
    // ρ is the mass density n m = 4 × 2 (the n = 4 level keeps Nguyen's ρ = 8).
    let (ly, rho, g, eta, dt) = (20.0, 8.0, 1.0, 30.0, 0.002);
    let (t1, t2) = (f64::from(equilibration) * dt, f64::from(steps) * dt);
    let u = &s.velocity_profile;
    assert_eq!(u.len(), 20);
    let (mut num, mut den, mut var) = (0.0, 0.0, 0.0);
    for (i, bin) in u.iter().enumerate() {
        let (s0, s1) = (i as f64 - 10.0, i as f64 - 9.0); // s = y − L_y/2 over the bin
        let phi = reverse_poiseuille_startup_bin(s0, s1, t1, t2, ly, rho, g, eta);
        num += bin.mean * phi;
        den += phi * phi;
        var += (bin.stderr * phi).powi(2);
    }
    let (amplitude, error) = (num / den, var.sqrt() / den);
    eprintln!("reverse Poiseuille: amplitude η_input/η_fluid = {amplitude:.4} ± {error:.4}");
    assert!(
        error < 0.01 && (amplitude - 1.0).abs() < 0.02,
        "the velocity profile is {amplitude:.4} ± {error:.4} × the one of η = {eta}: the fluid's \
         viscosity is {:.2}",
        eta / amplitude
    );
}

/// Bin mean over s ∈ [s0, s1] and time mean over [t1, t2] of the reverse Poiseuille start-up
/// from rest: force +g for s > 0, −g for s < 0 (period L), u = Σ_{n odd} 4g/(πnνk_n²)
/// (1 − e^{−νk_n²t}) sin(k_n s), k_n = 2πn/L, ν = η/ρ; its steady state is
/// ρ g s (L/2 − |s|)/(2η).
#[allow(clippy::too_many_arguments)]
fn reverse_poiseuille_startup_bin(
    s0: f64,
    s1: f64,
    t1: f64,
    t2: f64,
    l: f64,
    rho: f64,
    g: f64,
    eta: f64,
) -> f64 {
    let nu = eta / rho;
    let mut sum = 0.0;
    for n in (1..20_001).step_by(2) {
        let k = 2.0 * std::f64::consts::PI * n as f64 / l;
        let rate = nu * k * k;
        let time = 1.0 - ((-rate * t1).exp() - (-rate * t2).exp()) / (rate * (t2 - t1));
        let space = ((k * s0).cos() - (k * s1).cos()) / (k * (s1 - s0));
        sum += 4.0 * g / (std::f64::consts::PI * n as f64 * rate) * time * space;
    }
    sum
}
