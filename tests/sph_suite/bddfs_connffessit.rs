//! BDDFS carried by every SPH particle (`[fluid.polymer] model = "bddfs"`, issue #45): each
//! fluid particle keeps a sparse histogram of its N_d connectors and regenerates them every
//! step, advancing them with its own velocity gradient; their Kramers stress drives the fluid.
//!
//! - The coupled Lees–Edwards shear with BDDFS per particle gives the η and N₁ of the same
//!   flow with explicit dumbbells (same N_d, same seed), within error bars computed from the
//!   two runs, after the grid's own predicted excess r = λΔQ²/(6Δt) (Hookean: the conformation
//!   scales by 1 + r, docs/theory/polymer_particle_and_bddfs.md §2.4).
//! - The coupled run is the same bits on 1–4 ranks × 1–2 threads, and on 1 and 2 ranks across
//!   the migrations of 1 000 steps (histograms and their stress migrate with their particle).
//! - Restart continuity: `tests/engine_suite/restart.rs`.

use crate::common;
use common::{assert_all_equal, case_from_str, digests_on_1_to_4_ranks, stock_text_with};
use mesorheo::comm::SerialComm;
use mesorheo::diagnostics::integrated_autocorrelation_time;
use mesorheo::facade::Engine;
use mesorheo::models::dumbbell_ensemble::HISTOGRAMS;
use mesorheo::sim::Simulation;

/// The steady-shear series of `case` (a stock case) shortened to 6 000 steps (9λ), sampled
/// every 10 steps from step 2 000 (3λ): (η, N₁) of the particles' mean polymer stress
/// ("constitutive"), η of the momentum flux, and the ensemble bytes per particle.
fn shear_series(case: &str, overrides: &[&str]) -> ([Vec<f64>; 3], f64) {
    let mut all = vec![
        "reference=[]",
        "run.steps=6000",
        "run.equilibration=2000",
        "run.sample_every=10",
    ];
    all.extend_from_slice(overrides);
    let loaded = case_from_str(&stock_text_with(case, &all), case);
    let comm = SerialComm::new();
    let mut sim =
        Simulation::<2>::new(&loaded.case, &comm, crate::common::PHYSICS_THREADS).expect("set up");
    let mut series: [Vec<f64>; 3] = Default::default();
    while sim.step < 6000 {
        sim.advance().expect("a stable step");
        if sim.is_sample_step() {
            let m = sim.measure();
            series[0].push(common::scalar(&m, "viscosity_constitutive"));
            series[1].push(common::scalar(
                &m,
                "first_normal_stress_difference_constitutive",
            ));
            series[2].push(common::scalar(&m, "viscosity"));
        }
    }
    let bytes = sim.ensemble_bytes_per_particle().expect("ensembles");
    (series, bytes)
}

/// Mean and its standard error √(2 τ_int s²/n) (τ_int: the integrated autocorrelation time in
/// samples; the series are correlated over ~50 samples here).
fn mean_with_error(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let tau = integrated_autocorrelation_time(v);
    (mean, (2.0 * tau * var / n).sqrt())
}

/// The coupled shear at Wi = 1 (`cases/connffessit_shear_2d.toml` and its BDDFS twin
/// `cases/bddfs_connffessit_shear_2d.toml`: 400 particles × 100 Hookean dumbbells, Δt =
/// 1.5·10⁻³λ, n_c = 8 000 over [−12, 12]², so r = λΔQ²/(6Δt) = 10⁻³): BDDFS's η and N₁ (of the
/// particles' stress and of the momentum flux) against the explicit dumbbells', the same
/// seed. The two runs are independent samples (BDDFS draws other numbers), so the difference,
/// less the predicted grid excess (r of the polymer part), must lie within 4.5 σ of the
/// combined error bars (σ from each run's autocorrelation time; 4.5σ: a false alarm 1 in
/// 10⁵ per quantity). Memory: explicit dumbbells N_d × D × 8 = 1 600 B per particle; the
/// histograms at most 800 B.
#[test]
fn coupled_bddfs_shear_matches_explicit_dumbbells_within_error_bars() {
    // The explicit twin at the BDDFS case's own settings (Lucy 3Δ, p_b = 5, no transport
    // velocity), pinned so that a change of the explicit stock case does not move it.
    let (bd, bd_bytes) = shear_series(
        "connffessit_shear_2d.toml",
        &[
            "fluid.smoothing_length=0.15",
            "fluid.background_pressure=5.0",
            "fluid.transport_pressure=0.0",
        ],
    );
    let (bddfs, bddfs_bytes) = shear_series("bddfs_connffessit_shear_2d.toml", &[]);
    let r = 1e-3; // λΔQ²/(6Δt), ΔQ = 24/8000, Δt = 1.5e-3
    let g_lambda = 0.5; // η_p = Gλ
    eprintln!("ensemble bytes per particle: BD {bd_bytes}, BDDFS {bddfs_bytes}");
    assert_eq!(bd_bytes, 1600.0);
    assert!(
        bddfs_bytes > 0.0 && bddfs_bytes <= 800.0,
        "BDDFS {bddfs_bytes} B per particle"
    );
    for (k, name) in ["η (constitutive)", "N₁ (constitutive)", "η (momentum flux)"]
        .iter()
        .enumerate()
    {
        let (a, sa) = mean_with_error(&bd[k]);
        let (b, sb) = mean_with_error(&bddfs[k]);
        // The grid's excess: the polymer part × r (η_p = Gλ for η, all of N₁).
        let excess = if k == 1 { r * a } else { r * g_lambda };
        let sigma = (sa * sa + sb * sb).sqrt();
        let z = (b - a - excess) / sigma;
        eprintln!(
            "{name}: BD {a:.5} ± {sa:.1e}, BDDFS {b:.5} ± {sb:.1e}; difference {:+.3} % of the \
             polymer part ({z:+.2} σ, grid excess {excess:.1e} removed)",
            100.0 * (b - a) / if k == 1 { a } else { g_lambda }
        );
        assert!(z.abs() < 4.5, "{name}: BDDFS off BD by {z:+.2} σ");
    }
}

/// 80 steps of the coupled shear with 8 dumbbells per particle: the same digest and
/// observables on 1–4 ranks × 1–2 threads; another seed changes them (the keys reach the
/// histograms).
#[test]
fn coupled_bddfs_is_bitwise_on_1_to_4_ranks_and_1_2_threads() {
    let text = stock_text_with(
        "bddfs_connffessit_shear_2d.toml",
        &[
            "reference=[]",
            "run.steps=80",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
        ],
    );
    let d = digests_on_1_to_4_ranks(&text, "bddfs connffessit", |s| {
        assert_eq!(s.steps, 80);
        let bytes = s.ensemble_bytes_per_particle.expect("ensemble bytes");
        assert!(bytes > 0.0 && bytes <= 64.0, "{bytes} B for 8 dumbbells");
    });
    assert_all_equal("bddfs connffessit", &d);
    let other = common::with_overrides(&text, &["seed=4"]);
    let loaded = case_from_str(&other, "other seed");
    let s = mesorheo::driver::run_in_process(&loaded, 1, 1, None).expect("run");
    assert_ne!(
        format!(
            "{} {}",
            s.state_digest,
            serde_json::to_string(&s.observables).unwrap()
        ),
        d[0].2
    );
}

/// Histograms and their stress migrate with their particle: 1 000 steps, in which particles
/// cross the slab faces of 2 ranks, are the same bits on 1 and 2 ranks; every fluid particle
/// still holds its 8 dumbbells.
#[test]
fn coupled_bddfs_is_bitwise_on_1_and_2_ranks_across_migrations() {
    let text = stock_text_with(
        "bddfs_connffessit_shear_2d.toml",
        &[
            "reference=[]",
            "run.steps=1000",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
        ],
    );
    let loaded = case_from_str(&text, "bddfs migrations");
    let digest = |ranks: usize| {
        mesorheo::driver::run_in_process(&loaded, ranks, 1, None)
            .unwrap_or_else(|e| panic!("{ranks} ranks: {e}"))
            .state_digest
    };
    assert_eq!(digest(2), digest(1));
    let comm = SerialComm::new();
    let sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    let p = &sim.particles;
    let k = (p.var.iter().position(|f| f.name == HISTOGRAMS)).expect("histograms");
    let rows = p.var[k].data.words().expect("words");
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(
            mesorheo::models::bddfs::dumbbell_count(row),
            8,
            "particle {i}"
        );
    }
    assert_eq!(sim.dumbbell_count(), Some(8 * 400));
}
