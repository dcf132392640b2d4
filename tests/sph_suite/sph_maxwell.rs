//! Viscoelastic SPH (`[fluid.polymer]`) against analytic solutions and the engine's invariants:
//!
//! - a small-amplitude shear wave of a Maxwell fluid in a periodic box oscillates and decays as
//!   the linearised Maxwell solution (the polymer stress's coupling into the momentum equation);
//! - the stock Lees–Edwards steady shear (η, N₁ of the corotational Jeffreys fluid at De = 1)
//!   and channel relaxation (the linear variant against the corrected initial-value solution)
//!   pass their references;
//! - a walled channel and a Lees–Edwards box of Maxwell fluid give the same bits on 1–4 ranks
//!   × 1–2 threads, and across a restart (the polymer stress and its rate are checkpointed).
//!
//! The constitutive update itself (start-up of simple shear against the analytic solution, the
//! thesis's printed sign failing it) is a unit test of `models::sph::maxwell`.

use crate::common;
use common::{
    assert_all_equal, assert_references_pass, assert_shortened_references_pass, case_from_str,
    digests_on_1_to_4_ranks, sph_periodic_box, stock_case, stock_text, with_overrides,
};
use mesorheo::analytic::relaxation;
use mesorheo::comm::SerialComm;
use mesorheo::facade::Engine;
use mesorheo::sim::Simulation;

/// A periodic box of side 1, square lattice of spacing 0.02, Lucy support 0.06, Tait EOS,
/// no Newtonian viscosity, a polymer of viscosity 1 and relaxation time `lambda`; `extra` is
/// appended to `[box]`.
fn maxwell_box(lambda: f64, rotation: bool, extra: &str) -> String {
    let polymer = format!(
        "[fluid.polymer]\nmodel = \"corotational_maxwell\"\nviscosity = 1.0\n\
         relaxation_time = {lambda}\nrotation = {rotation}"
    );
    sph_periodic_box("nested_summation", 0.06, &polymer)
        .replacen("viscosity = 1.0", "viscosity = 0.0", 1)
        .replace(
            "lengths = [1.0, 1.0]",
            &format!("lengths = [1.0, 1.0]\n{extra}"),
        )
}

/// u_x = A sin(2πy) in a Maxwell fluid (η_p = 1, λ = 0.05, τ = 0 at t = 0): the projected
/// amplitude follows the linearised solution a(t) = A e^{−t/(2λ)}[cos ωt + sin(ωt)/(2λω)],
/// ω = √(νk²/λ − 1/(4λ²)) = 26.3, through a full oscillation (it changes sign at t ≈ 0.066).
/// A = 0.01 keeps the rotation terms and advection below 10⁻³ of the signal. The SPH operator
/// τ ← G, ∇·τ smooths twice, which lowers the effective νk² by ~2 % at kh = 0.38 (the Newtonian
/// nested summation measured −2.0 % in tests/sph_suite/sph_channel.rs), so ω by ~1 %. Measured: worst
/// 1.29 % of A (t = 0.07, near the zero crossing). The bound, 1.5 % of A at every sampled time,
/// fails a coupling off by 5 % (measured: the polymer term × 0.95 gives 4.6 %), the polymer
/// stress left out of the momentum equation (the wave then just stands), or the sign of the
/// stress's divergence flipped (it then grows).
#[test]
fn maxwell_shear_wave_follows_the_linear_solution() {
    let loaded = case_from_str(&maxwell_box(0.05, true, ""), "wave.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    let (amp, k) = (0.01, 2.0 * std::f64::consts::PI);
    for i in 0..sim.particles.n_owned {
        let y = sim.particles.pos[i][1];
        sim.particles.vel[i] = [amp * (k * y).sin(), 0.0];
    }
    sim.jump_to_step(0).expect("forces");
    let mut worst: f64 = 0.0;
    for block in 1..=12 {
        sim.run_steps(100).expect("run");
        let t = block as f64 * 100.0 * 1e-4;
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..sim.particles.n_owned {
            let s = (k * sim.particles.pos[i][1]).sin();
            num += sim.particles.vel[i][0] * s;
            den += s * s;
        }
        let got = num / den;
        // relaxation() is written for sin(πy/L): L = 1/2 gives k = 2π.
        let want = relaxation(t, amp, 0.5, 1.0, 0.0, Some((1.0, 0.05)));
        let err = (got - want).abs() / amp;
        eprintln!("t = {t:.2}: amplitude {got:+.6e}, exact {want:+.6e}, error {err:.2e} of A");
        worst = worst.max(err);
    }
    assert!(worst < 0.015, "worst error {worst:.3e} of A");
}

// The stock viscoelastic cases pass their references, one test each (they run in parallel).

/// `maxwell_shear_2d` shortened to 9 000 of its 16 000 steps (7 λ of start-up, t ∈ [7, 9]
/// averaged): the particles' own η and N₁ within the case's 0.2 % (measured 2026-11-28:
/// +0.09 %, +0.02 %; after 4 λ the start-up's oscillation is still there: −0.76 %, +1.36 %),
/// τ traceless, momentum conserved. The momentum-flux η and N₁ need the case's whole window
/// t ∈ [8, 16] for its 0.4 % and 1 % (the pressure's slow oscillation: on t ∈ [7, 9] they read
/// −0.90 ± 0.40 % and −2.46 ± 0.42 %), so here their bounds are 3 % and 5 %, which still fail
/// the polymer term dropped from the momentum equation (the flux η falls to η_s, −98 %) or its
/// sign flipped; the case's own bounds are `./run validate stock`'s.
#[test]
fn stock_maxwell_shear_passes_its_references() {
    assert_shortened_references_pass(
        "maxwell_shear_2d.toml",
        &["run.steps=9000", "run.equilibration=7000"],
        &[
            ("viscosity", 0.03),
            ("first_normal_stress_difference", 0.05),
        ],
    );
}

/// `maxwell_channel_relaxation_2d`: the relaxation profile within 2 % of the amplitude at every
/// bin and time.
#[test]
fn stock_maxwell_channel_relaxation_passes_its_references() {
    let name = "maxwell_channel_relaxation_2d.toml";
    assert_references_pass(name, &stock_case(name));
}

/// `fene_p_shear_2d` shortened to 5 000 of its 16 000 steps (4 λ of start-up, t ∈ [4, 5]
/// averaged; Z = 1.56 at Wi = 1, so the start-up decays as e^{−Zt/λ}): the particles' own η and
/// N₁ against the closed form within the case's 0.6 % (measured 2026-11-28: +0.17 %, +0.27 %).
/// The momentum-flux η and N₁ get 3 % and 5 % instead of the case's 1.5 % and 3 % (on this
/// window they read +0.07 ± 0.55 % and +2.76 ± 0.94 %; the whole window is
/// `./run validate stock`'s), which still fail the polymer term dropped from the momentum
/// equation or its sign flipped. Mutation: Z = 1 + tr τ/(G_p b), without the D (η +24 %,
/// N₁ +53 %).
#[test]
fn stock_fene_p_shear_passes_its_references() {
    assert_shortened_references_pass(
        "fene_p_shear_2d.toml",
        &["run.steps=5000", "run.equilibration=4000"],
        &[
            ("viscosity", 0.03),
            ("first_normal_stress_difference", 0.05),
        ],
    );
}

/// A Lees–Edwards box and a walled channel of Maxwell fluid (the wall particles advance their
/// own polymer stress; Morris images mirror it) give the same bits on 1–4 ranks × 1–2 threads.
#[test]
fn maxwell_fluid_is_bitwise_rank_invariant() {
    let sheared = with_overrides(
        &maxwell_box(0.5, true, "shear_rate = 1.0"),
        &[
            "diagnostics.observables=[\"momentum\", \"viscosity\", \"polymer_stress_trace\"]",
            "run.steps=60",
            "run.sample_every=5",
        ],
    );
    let d = digests_on_1_to_4_ranks(&sheared, "le.toml", |_| {});
    assert_all_equal("Lees–Edwards Maxwell", &d);
    for treatment in ["layers", "morris"] {
        let channel = with_overrides(
            &maxwell_box(0.1, false, "boundaries = [\"periodic\", \"wall\"]"),
            &[
                "particles.velocity_profile=\"half_sine\"",
                "run.steps=60",
                "run.sample_every=5",
                &format!("walls.treatment=\"{treatment}\""),
                "decomposition.axis=\"y\"",
            ],
        );
        let d = digests_on_1_to_4_ranks(&channel, "channel.toml", |_| {});
        assert_all_equal(&format!("channel, {treatment}"), &d);
    }
}

/// The Newtonian limit λ → 0: the stock start-up Couette (`cases/sph_couette_2d.toml`, η = 1)
/// with its viscosity carried by a corotational Maxwell polymer instead (η_p = 0.99, λ = 10⁻³,
/// De = λU/L = 10⁻³, and the 1 % Morris solvent every Maxwell scene needs) reproduces the
/// Newtonian SPH run's profiles within 1 % of U from t = 0.05 = 50λ on (measured 0.61, 0.50,
/// 0.28, 0.16 % at t = 0.05, 0.1, 0.2, 0.3; before it the elastic start-up, whose waves
/// √(η_p/ρλ) = 31 cross the gap, and the two-pass stress's lattice-scale zigzag give 2.4 % at
/// t = 0.01). Its own reference, now the Oldroyd-B start-up series (`couette_oldroyd_b`, which
/// tends to the Newtonian series with ν₀), is met within 1.5 % of U from t = 0.05 on (measured
/// 1.22 … 0.34 %; the Newtonian SPH run is itself 0.53 % below its series at t = 0.05).
/// Mutation: the polymer's (2η_p/λ) D̄ term × 0.9 (run): 3.1 % from the Newtonian run at
/// t = 0.05, and 3.7 % from the series.
#[test]
fn maxwell_fluid_tends_to_the_newtonian_one_as_lambda_vanishes() {
    let newtonian = stock_text("sph_couette_2d.toml");
    let maxwell = with_overrides(
        &newtonian,
        &[
            "fluid.viscosity=0.01",
            "fluid.polymer.model=\"corotational_maxwell\"",
            "fluid.polymer.viscosity=0.99",
            "fluid.polymer.relaxation_time=0.001",
        ],
    );
    assert_ne!(
        maxwell, newtonian,
        "the stock Couette case changed its layout"
    );
    let run = |text: &str, name: &str| {
        mesorheo::driver::run_in_process(
            &case_from_str(text, name),
            1,
            crate::common::PHYSICS_THREADS,
            None,
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"))
    };
    let (n, m) = (run(&newtonian, "newtonian"), run(&maxwell, "maxwell"));
    assert_eq!(n.validation.len(), m.validation.len());
    for (vn, vm) in n.validation.iter().zip(&m.validation) {
        let t: f64 = vm
            .name
            .rsplit("t = ")
            .next()
            .and_then(|s| s.parse().ok())
            .expect("t");
        let apart = vn
            .profile
            .iter()
            .zip(&vm.profile)
            .map(|(a, b)| (a[1] - b[1]).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "t = {t}: |u_Maxwell − u_Newtonian| ≤ {apart:.4} U; against the Oldroyd-B series {:.4} U",
            vm.value
        );
        if t >= 0.05 {
            assert!(
                apart < 0.01,
                "t = {t}: the Maxwell run is {apart} U from the Newtonian one"
            );
            assert!(vm.value < 0.015, "t = {t}: {vm:?}");
        }
    }
}

/// Elastic start-up Couette flow of an Oldroyd-B fluid (`cases/maxwell_couette_startup_2d.toml`:
/// upper-convected Maxwell polymer, λ = 0.05, β = η_s/η₀ = 0.1, Δ = 0.01, Lucy 3Δ, Morris walls
/// with β_max = 6) against the Oldroyd-B series `couette_oldroyd_b`, within 1 % of U in every
/// one of the 100 bins at t = 0.04, 0.05, 0.1, 0.2, 0.3 (measured 0.71, 0.59, 0.29, 0.15,
/// 0.16 %). The elastic wave (speed √(η_p/ρλ) = 4.24) crosses the gap by t ≈ 0.24 and
/// reflects, so the listed times see it leave the moving wall, cross, and come back. The case's
/// last time, t = 0.5 (0.20 %), is left to `./run validate stock` (issue #40, CI time: the run
/// to t = 0.3 is 1 500 of the 2 500 steps).
/// Mutations (run; the test stops at the first time that fails): the polymer's (2η_p/λ) D term
/// × 0.97 in the upper-convected rate (what the lattice sums of Lucy 2.5Δ do to η_p): 1.87 % at
/// t = 0.04; Morris's wall images carrying the boundary particle's own τ instead of the fluid
/// end's (method B's wall stress): 2.45 % at t = 0.04, in the wall row.
#[test]
fn oldroyd_b_start_up_couette_follows_the_series() {
    let name = "maxwell_couette_startup_2d.toml";
    let times = "times = [0.04, 0.05, 0.1, 0.2, 0.3, 0.5]";
    let text = stock_text(name);
    assert!(text.contains(times), "{name}: `{times}` not in the case");
    let text = with_overrides(
        &text.replace(times, "times = [0.04, 0.05, 0.1, 0.2, 0.3]"),
        &["run.steps=1500"],
    );
    let s = mesorheo::driver::run_in_process(
        &case_from_str(&text, name),
        1,
        crate::common::PHYSICS_THREADS,
        None,
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(s.validation.len(), 5, "{name}: one check per listed time");
    for v in &s.validation {
        let worst = v
            .profile
            .iter()
            .max_by(|a, b| (a[1] - a[2]).abs().total_cmp(&(b[1] - b[2]).abs()))
            .expect("a profile");
        eprintln!(
            "{}: {:.3} % of U (worst bin y = {:.3}: u = {:.4}, series {:.4})",
            v.name,
            100.0 * v.value,
            worst[0],
            worst[1],
            worst[2]
        );
        assert!(v.pass, "{name}: {v:?}");
    }
}
