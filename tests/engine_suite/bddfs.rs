//! BDDFS (`[polymer] kind = "bddfs"`, issue #45) in homogeneous flows, against references from
//! outside the code under test:
//!
//! - the grid's artificial diffusion: Hookean dumbbells at rest, whose stationary ⟨Q²⟩ has the
//!   closed form D (1 + σ²_grid (1 − ε)²/(4ε)), σ²_grid = ΔQ²/6, ε = Δt/4λ, derived in
//!   `src/models/bddfs.rs` (binning and reconstruction each add ΔQ²/12); measured at three
//!   (n_c, Δt) so that the error's ΔQ²/Δt law is seen (halving Δt doubles it, halving n_c
//!   quadruples it) and the reconstruction-only guess ΔQ²/12 is refuted;
//! - FENE (b = 50, 2D, Wi = 1) in steady shear on a fine grid against the Fokker–Planck solution
//!   of tools/fene_fokker_planck.py (a Galerkin solver, not Brownian dynamics);
//! - bitwise invariance under the rank and thread counts, and N steps ≡ N/2 + checkpoint +
//!   restart on another rank count + N/2 (the histograms are checkpointed).
#![cfg(feature = "hdf5")]

use mesorheo::config::{CaseScene, FlowCase, parse_scene};
use mesorheo::driver::{in_process, restart_case};
use mesorheo::summary::Summary;
use std::path::{Path, PathBuf};

fn case_of(text: &str) -> FlowCase {
    match parse_scene(text, Path::new("bddfs.toml")).unwrap_or_else(|e| panic!("{e}")) {
        CaseScene::HomogeneousFlow(c) => *c,
        CaseScene::Particles(_) => panic!("a [flow] table makes a flow scene"),
    }
}

use crate::common::{flow_options as options, run_flow as run};

/// The observable's mean and standard error (spread of the particles' time averages).
fn observed(s: &Summary, name: &str) -> (f64, f64) {
    let e = &s.observables[name];
    (e.mean, e.stderr)
}

/// Hookean BDDFS at rest in 2D (semi-implicit, λ = 1, grid [−8, 8]², 100 particles × 1000
/// dumbbells, 8λ of equilibration then 12λ of averaging).
fn hookean_rest(cells: usize, dt: f64) -> FlowCase {
    let steps = (20.0 / dt).round() as u64;
    let equilibration = (8.0 / dt).round() as u64;
    case_of(&format!(
        r#"
dimension = 2
seed = 21
[flow]
kind = "rest"
particles = 100
[polymer]
kind = "bddfs"
spring = "hookean"
scheme = "semi_implicit"
relaxation_time = 1.0
per_particle = 1000
cells = {cells}
q_max = 8.0
[integrator]
kind = "brownian_dynamics"
dt = {dt}
[run]
steps = {steps}
equilibration = {equilibration}
sample_every = 2
progress_seconds = 0
"#
    ))
}

/// The grid's artificial diffusion, measured: the stationary ⟨|Q|²⟩ of Hookean BDDFS at rest
/// against its closed form (module docs), at (n_c, Δt) = (64, 0.1), (64, 0.05) and (32, 0.1):
/// ΔQ = 0.25 and 0.5, excess per component 0.0990, 0.2032 and 0.3961 (×2 in ⟨|Q|²⟩), so the
/// ΔQ²/Δt law shows as ×2.05 for Δt/2 and ×4 for n_c/2. Each tolerance is 5 standard errors of
/// the run (the spread of 100 independent particles' time averages; ~0.003 here, against
/// excesses of 0.2–0.8): the closed form is exact up to Sheppard's remainder, ~e^(−2π²a²/ΔQ²)
/// ≤ 10⁻³ of the excess for the step's noise width a = 0.31 (no other tolerance is needed).
/// The guess ΔQ²/12 (the reconstruction alone) is 30–140 standard errors away and refused.
///
/// Mutations that fail it: reconstruction at the cell centre (`lower + ½ΔQ`, no jitter: only
/// the binning's ΔQ²/12 remains; run through the CLI on this case: ⟨Q²⟩ = 2.0959 ± 0.0023 at
/// n_c = 64, Δt = 0.1, −43σ); offsets on [0, 1] + ½ (the text's "unit square" misread, the mean
/// drifts by ΔQ/2 a step; not run on this test).
#[test]
fn hookean_grid_diffusion_is_dq2_over_6_per_step_and_grows_as_dq2_over_dt() {
    let mut excesses = Vec::new();
    for (cells, dt) in [(64usize, 0.1), (64, 0.05), (32, 0.1)] {
        let case = hookean_rest(cells, dt);
        let s = run(
            &case,
            1,
            options(crate::common::PHYSICS_THREADS, None, None),
        );
        assert!(s.completed);
        let (q2, se) = observed(&s, "mean_square_connector_length");
        let grid = case.polymer.histogram_grid().expect("bddfs");
        let excess = mesorheo::models::bddfs::hookean_rest_excess(&grid, dt, 1.0);
        let want = 2.0 * (1.0 + excess);
        assert!(
            (q2 - want).abs() < 5.0 * se,
            "n_c = {cells}, Δt = {dt}: ⟨Q²⟩ = {q2:.5} ± {se:.5}, derived {want:.5} \
             (excess {excess:.5} per component)"
        );
        // The reconstruction-only guess ΔQ²/12 predicts half the excess.
        let half = 2.0 * (1.0 + 0.5 * excess);
        assert!(
            (q2 - half).abs() > 5.0 * se,
            "n_c = {cells}, Δt = {dt}: ⟨Q²⟩ = {q2:.5} does not tell ΔQ²/6 from ΔQ²/12"
        );
        eprintln!(
            "BDDFS Hookean rest n_c = {cells} Δt = {dt}: ⟨Q²⟩ = {q2:.5} ± {se:.5}, \
             derived {want:.5}"
        );
        excesses.push((q2 / 2.0 - 1.0, se / 2.0));
    }
    // The law itself, from the measured excesses: Δt/2 doubles it (×(1 − ε/2)²/(1 − ε)²·2 =
    // 2.052), n_c/2 quadruples it; each ratio within 5 of its propagated standard errors.
    let ratio = |a: (f64, f64), b: (f64, f64)| {
        let r = a.0 / b.0;
        (r, r * ((a.1 / a.0).powi(2) + (b.1 / b.0).powi(2)).sqrt())
    };
    let (dt_ratio, dt_se) = ratio(excesses[1], excesses[0]);
    let (dq_ratio, dq_se) = ratio(excesses[2], excesses[0]);
    let dt_want = 0.9875f64.powi(2) / 0.05 / (0.975f64.powi(2) / 0.1);
    assert!(
        (dt_ratio - dt_want).abs() < 5.0 * dt_se,
        "Δt/2: ×{dt_ratio:.3} ± {dt_se:.3}"
    );
    assert!(
        (dq_ratio - 4.0).abs() < 5.0 * dq_se,
        "n_c/2: ×{dq_ratio:.3} ± {dq_se:.3}"
    );
}

/// FENE b = 50 in 2D steady shear at Wi = 1 on a fine grid against the Fokker–Planck solution
/// (`tools/fene_fokker_planck.py --dim 2 --b 50 --wi 1`: η_p = 0.8817451 Gλ,
/// Ψ₁ = 1.4742488 Gλ², ⟨|Q|²⟩ = 3.0061869). n_c = 2000 (ΔQ = 0.00707) at Δt = 0.01 keeps the
/// grid's bias r = λΔQ²/(6Δt) = 0.08 % below a fifth of the statistical error (100 particles ×
/// 500 dumbbells, 5λ of start-up then 10λ: ~0.5 % on η_p and Ψ₁, 0.25 % on ⟨|Q|²⟩), and the
/// semi-implicit scheme's O(Δt²) bias is below 0.1 % (tests/engine_suite/dumbbell_rheology.rs).
/// Tolerance: 5 standard errors of the run, plus 0.2 % for those two biases.
///
/// Mutation that fails it (run through the CLI on this case): offsets on [0, 1] + ½ instead of
/// [−½, ½] (every connector moves by ΔQ/2 per axis and step): η_p = 1.861 ± 0.006, +111 %.
#[test]
fn fene_shear_on_a_fine_grid_matches_the_fokker_planck_solution() {
    let case = case_of(
        r#"
dimension = 2
seed = 8
[flow]
kind = "simple_shear"
rate = 1.0
particles = 100
[polymer]
kind = "bddfs"
spring = "fene"
b = 50.0
relaxation_time = 1.0
per_particle = 500
cells = 2000
[integrator]
kind = "brownian_dynamics"
dt = 0.01
[run]
steps = 1500
equilibration = 500
sample_every = 5
progress_seconds = 0
"#,
    );
    let s = run(
        &case,
        1,
        options(crate::common::PHYSICS_THREADS, None, None),
    );
    assert!(s.completed);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    for (name, want) in [
        ("polymer_viscosity", 0.8817451196),
        ("first_normal_stress_coefficient", 1.4742487717),
        ("mean_square_connector_length", 3.0061868757),
    ] {
        let (got, se) = observed(&s, name);
        eprintln!("BDDFS FENE Wi = 1 n_c = 2000: {name} = {got:.5} ± {se:.5} (FP {want:.5})");
        assert!(
            (got - want).abs() < 5.0 * se + 0.002 * want,
            "{name}: {got:.5} ± {se:.5}, Fokker–Planck {want:.5}"
        );
    }
}

/// A small BDDFS scene that exercises clipping: Hookean shear reversal at Wi = 2 on the grid
/// [−5, 5]² with 24 cells per axis (connectors beyond 5 are counted into boundary cells).
fn small(steps: u64) -> FlowCase {
    case_of(&format!(
        r#"
dimension = 2
seed = 5
[flow]
kind = "shear_reversal"
rate = 2.0
reverse_at = 0.3
particles = 37
[polymer]
kind = "bddfs"
spring = "hookean"
relaxation_time = 1.0
per_particle = 64
cells = 24
q_max = 5.0
[integrator]
kind = "brownian_dynamics"
dt = 0.01
[run]
steps = {steps}
equilibration = 10
sample_every = 5
progress_seconds = 0
"#
    ))
}

fn observable_bits(s: &Summary) -> Vec<(String, u64, u64)> {
    s.observables
        .iter()
        .map(|(k, e)| (k.clone(), e.mean.to_bits(), e.stderr.to_bits()))
        .collect()
}

/// The histograms (digest) and every averaged observable are bitwise the same on 1–3 ranks ×
/// 1–2 threads. Mutation that fails it (run): the reconstruction stream keyed by the worker
/// thread's index as well as the global id (the digest differs at 3 ranks × 2 threads).
#[test]
fn bddfs_is_bitwise_identical_on_any_rank_and_thread_count() {
    let case = small(60);
    let reference = run(&case, 1, options(1, None, None));
    assert!(reference.observables.contains_key("polymer_viscosity"));
    for (ranks, threads) in [(1, 2), (2, 1), (3, 2)] {
        let s = run(&case, ranks, options(threads, None, None));
        assert_eq!(
            s.state_digest, reference.state_digest,
            "{ranks} ranks × {threads} threads"
        );
        assert_eq!(observable_bits(&s), observable_bits(&reference));
    }
}

/// 80 steps ≡ 40 + checkpoint + restart on another rank count + 40, bitwise (digest and
/// averages): the histograms are checkpointed (`/ensembles/histograms`) and nothing else is
/// needed to continue. Mutation that should fail it (not run): the reader keeps the rows' zero
/// padding (the digest hashes the rows, so it would differ).
#[test]
fn bddfs_restart_is_bitwise_on_other_rank_counts() {
    let case = small(80);
    let whole = run(&case, 1, options(1, None, None));
    for (first, second) in [(1, 2), (3, 1)] {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().to_path_buf();
        let half = run(&case, first, options(1, Some(&out), Some(40)));
        assert!(!half.completed);
        let ck = PathBuf::from(half.last_checkpoint.expect("checkpoint written"));
        let info = mesorheo::output::info::describe(&ck).expect("info");
        assert!(info.contains("/ensembles/histograms"), "{info}");
        let o = out.clone();
        let rest = in_process(second, move |c| {
            restart_case(&o.join("checkpoints"), c, &options(1, Some(&o), None))
        })
        .unwrap_or_else(|e| panic!("{e}"));
        assert!(rest.completed);
        assert_eq!(rest.steps, 80);
        assert_eq!(rest.state_digest, whole.state_digest, "{first}→{second}");
        assert_eq!(observable_bits(&rest), observable_bits(&whole));
    }
}
