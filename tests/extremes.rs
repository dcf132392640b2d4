//! Scenes at the edges of what the models allow (issue #18): each either runs to a sane end or
//! is refused with a clear error, never a panic or a silent NaN.
//!
//! - DPD with a = 0 (an ideal gas under the thermostat) and with a huge a (refused at the stock
//!   Δt, naming the conservative force; stable below the limit);
//! - two particles in a box;
//! - slabs exactly one interaction range thick (the most ranks a box allows), bitwise equal to
//!   one rank;
//! - Δt just below, at and just above each DPD and SPH limit that validation enforces;
//! - FENE dumbbells at Wi = 100 with b = 2.01;
//! - a 10⁶-particle scene on one rank against the memory check.

mod common;
use common::{case_from_str, small_dpd, stock_case, with_overrides};
use mesorheo::driver::run_in_process;

fn run(text: &str, ranks: usize) -> mesorheo::summary::Summary {
    run_in_process(&case_from_str(text, "extreme.toml"), ranks, 1, None)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// a = 0: no conservative force, so the fluid is an ideal gas held at k_BT by the thermostat
/// (within 4.5 block errors) with the ideal-gas pressure n k_BT (within 4.5 errors). a = 10⁶ is
/// refused at Δt = 0.04 naming the conservative force, and runs to the end at a tenth of the
/// limit with its momentum conserved (to 10⁻⁶). Its temperature is not k_BT: the random initial positions store ~a per
/// overlapping pair, which the forces release as heat (k_BT ≈ 7·10⁴ after 300 steps, within
/// the heating bound's allowance for a random start).
#[test]
fn dpd_without_repulsion_and_with_a_huge_one() {
    let extra =
        "equilibration = 100\n[diagnostics]\nobservables = [\"temperature\", \"pressure\"]\n";
    // The measured stability limit of this gas is Δt ≈ 0.15 (docs/stability/dpd3_a.csv); at
    // the stock 0.04 its k_BT reads 1.016 ± 0.003 over these 2000 steps, a Δt bias; at 0.01 it
    // is within the error bars.
    let ideal = run(
        &with_overrides(
            &small_dpd(3, 6.0, 0.0, 2000, extra),
            &["fluid.a=0.0", "integrator.dt=0.01"],
        ),
        1,
    );
    let (kt, p) = (
        ideal.observables["temperature"],
        ideal.observables["pressure"],
    );
    assert!((kt.mean - 1.0).abs() < 4.5 * kt.stderr, "{kt:?}");
    assert!(
        (p.mean - 3.0 * kt.mean).abs() < 4.5 * p.stderr,
        "{p:?} vs n k_BT"
    );
    let stiff = with_overrides(&small_dpd(3, 6.0, 0.0, 300, extra), &["fluid.a=1000000.0"]);
    let Err(err) = mesorheo::config::parse_scene(&stiff, std::path::Path::new("stiff.toml")) else {
        panic!("a = 10⁶ at Δt = 0.04 should be refused");
    };
    let err = err.to_string();
    assert!(err.contains("conservative force"), "{err}");
    let loaded = case_from_str(&with_overrides(&stiff, &["fluid.a=25.0"]), "soft.toml");
    let mut case = loaded.case.clone();
    if let mesorheo::config::FluidCfg::Dpd(d) = &mut case.fluid {
        d.a = 1e6;
    }
    let limits = dpd_limits_of_case(&case).expect("a DPD case");
    let dt = 0.1 * limits.combined;
    let text = with_overrides(
        &stiff,
        &[
            &format!("integrator.dt={dt:e}"),
            "diagnostics.observables=[\"temperature\", \"pressure\", \"momentum\"]",
        ],
    );
    let s = run(&text, 1);
    let kt = s.observables["temperature"];
    assert!(s.completed && kt.mean > 0.0, "{kt:?}");
    // Forces of up to 10⁶ cancel pair by pair: the total momentum stays at round-off (a
    // one-sided force, or a pair counted once, would move it by F Δt ≫ 10⁻⁶).
    for axis in ["x", "y", "z"] {
        let p = s.observables[&format!("momentum_{axis}")].mean;
        assert!(p.abs() < 1e-6, "momentum_{axis} = {p} with a = 10⁶");
    }
}

/// Two particles in a 3 × 3 × 3 box (cutoff + skin = 1.3 < L/2): the run completes with finite
/// averages and conserves momentum.
#[test]
fn two_particles() {
    let text = with_overrides(
        &small_dpd(
            3,
            3.0,
            0.0,
            400,
            "equilibration = 100\n[diagnostics]\nobservables = [\"temperature\", \"momentum\"]\n",
        ),
        &["particles.density=0.08"],
    );
    let s = run(&text, 1);
    assert_eq!(s.particles, 2);
    assert!(s.completed && s.observables["temperature"].mean.is_finite());
    assert!(s.observables["momentum_x"].mean.abs() < 1e-9);
}

/// The stock 8³ fluid (cutoff + skin = 1.4) on 5 ranks: slabs of 1.6, the thinnest the box
/// allows, still give the one-rank run's bits; 6 ranks are refused naming 5.
#[test]
fn slabs_one_interaction_range_thick() {
    let mut loaded = stock_case("dpd_equilibrium_3d.toml");
    loaded.case.run.steps = 60;
    loaded.case.run.equilibration = 0;
    assert_eq!(mesorheo::capacity::max_ranks(&loaded.case), 5);
    let one = run_in_process(&loaded, 1, 1, None).expect("1 rank");
    let five = run_in_process(&loaded, 5, 1, None).expect("5 ranks");
    assert_eq!(one.state_digest, five.state_digest);
    let Err(err) = run_in_process(&loaded, 6, 1, None) else {
        panic!("6 ranks should be refused");
    };
    assert!(err.to_string().contains("at most 5"), "{err}");
}

/// Validation refuses Δt strictly beyond each enforced limit and accepts it at and just below:
/// the DPD limit (its dissipative and conservative parts each made the binding one in turn) and the SPH
/// binding limit of the stock Couette case.
#[test]
fn time_steps_at_and_around_each_limit() {
    let parse = |text: &str| {
        mesorheo::config::parse_scene(text, std::path::Path::new("dt.toml"))
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    // Dissipative part binding (large γ), then the conservative part (large a).
    for (fluid, what) in [
        ("a = 25.0\ngamma = 400.0", "dissipative force"),
        ("a = 20000.0\ngamma = 4.5", "conservative force"),
    ] {
        let base = small_dpd(3, 6.0, 0.0, 10, "").replace("a = 25.0\ngamma = 4.5", fluid);
        let case = case_from_str(&with_overrides(&base, &["integrator.dt=1e-6"]), "probe").case;
        let limit = dpd_limits_of_case(&case).expect("a DPD case").combined;
        let at = |dt: f64| parse(&with_overrides(&base, &[&format!("integrator.dt={dt:e}")]));
        if let Err(e) = at(limit * (1.0 - 1e-9)) {
            panic!("{what}: just below: {e}");
        }
        if let Err(e) = at(limit) {
            panic!("{what}: at the limit: {e}");
        }
        let err = at(limit * (1.0 + 1e-9)).expect_err("just above");
        assert!(err.contains(what), "{err}");
    }
    // Without its start-up references, whose times must be multiples of the sampling interval.
    let couette = common::stock_text("sph_couette_2d.toml");
    let couette = couette[..couette.find("[[reference]]").expect("references")].to_owned();
    let case = case_from_str(&couette, "couette").case;
    let mesorheo::config::FluidCfg::Sph(s) = &case.fluid else {
        unreachable!()
    };
    let (name, limit) = mesorheo::models::sph::time_step::sph_binding_limit(s, false);
    let dt_line = couette
        .lines()
        .find(|l| l.trim_start().starts_with("dt ="))
        .expect("a dt line")
        .to_owned();
    let at = |dt: f64| parse(&couette.replace(&dt_line, &format!("dt = {dt:e}")));
    if let Err(e) = at(limit * (1.0 - 1e-9)).and(at(limit)) {
        panic!("{name}: at or just below: {e}");
    }
    let err = at(limit * (1.0 + 1e-9)).expect_err("just above the SPH limit");
    assert!(err.contains(name), "{name}: {err}");
}

/// FENE dumbbells at Wi = 100 with b = 2.01 (almost rigid, almost fully stretched), the
/// extreme of the semi-implicit scheme: ⟨|Q|²⟩, η_p and Ψ₁ against the independent
/// Fokker–Planck solution within 4σ (σ ≤ 1 %). (It used to check |Q|² < b, which the scheme
/// guarantees, and finiteness.) Mutation run: b × 0.95 in the scheme fails ⟨|Q|²⟩.
#[test]
fn fene_at_wi_100_with_b_2_01() {
    let text = common::stock_text("dumbbells_fene_shear_3d.toml");
    // Without the stock references (they are for Wi = 1, b = 50).
    let text = text[..text.find("[[reference]]").expect("references")].to_owned();
    let overrides: Vec<String> = [
        "flow.rate=100.0",
        "polymer.b=2.01",
        "integrator.dt=0.001",
        "run.steps=1500",
        "run.equilibration=500",
        "flow.particles=50",
        "polymer.per_particle=100",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("fene.toml");
    std::fs::write(&path, text).expect("write");
    let loaded = mesorheo::config::load_scene(&path, &overrides).unwrap_or_else(|e| panic!("{e}"));
    let mesorheo::config::CaseScene::HomogeneousFlow(flow) = loaded.scene else {
        panic!("a homogeneous-flow scene");
    };
    let comm = mesorheo::comm::SerialComm::new();
    let s = mesorheo::driver::run_flow_case(
        &flow,
        &path,
        &comm,
        &mesorheo::driver::RunOptions {
            threads: 2,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // The converged Fokker–Planck solution (`python3 tools/fene_fokker_planck.py --dim 3
    // --b 2.01 --wi 100 --converge`: degree 56, changes 1.7·10⁻¹⁰): ⟨|Q|²⟩, η_p/(Gλ),
    // Ψ₁/(Gλ²) (G = 1, λ = 1 here). Measured 2026-11-27: 1.3370 ± 0.0026 (0.8σ), 0.04338 ±
    // 0.00030 (0.6σ), 0.002480 ± 0.000013 (0.7σ).
    for (name, exact) in [
        ("mean_square_connector_length", 1.3347899689),
        ("polymer_viscosity", 0.0432074807),
        ("first_normal_stress_coefficient", 0.0024701605),
    ] {
        let e = s.observables[name];
        assert!(
            e.stderr > 0.0 && e.stderr < 0.01 * exact && (e.mean - exact).abs() < 4.0 * e.stderr,
            "FENE b = 2.01, Wi = 100: {name} = {} ± {} against the Fokker–Planck {exact}",
            e.mean,
            e.stderr
        );
    }
}

/// A 10⁶-particle DPD scene on one rank: about 0.5 GiB, which fits 24 GiB and is refused with
/// 0.25 GiB (naming 3 ranks or more).
#[test]
fn a_million_particles_on_one_rank_against_the_memory_check() {
    let text = small_dpd(3, 69.4, 0.0, 10, "");
    let case = case_from_str(&text, "million").case;
    let (_, n) = case.lattice_counts();
    assert!((990_000..1_010_000).contains(&n), "{n} particles");
    let gib = 1024.0 * 1024.0 * 1024.0;
    let need = mesorheo::capacity::rank_memory(&case, 1);
    assert!(need > 0.1 * gib && need < 2.0 * gib, "{} GiB", need / gib);
    assert!(mesorheo::capacity::check_rank_memory(&case, 1, Some(24.0 * gib)).is_ok());
    let err = mesorheo::capacity::check_rank_memory(&case, 1, Some(0.5 * need / 0.9))
        .expect_err("refused with half the memory it needs");
    assert!(
        err.contains("run on at least 2 ranks") || err.contains("run on at least 3 ranks"),
        "{err}"
    );
}

/// `check`'s memory estimate against what runs take: the peak resident memory (VmHWM, which
/// every run reports in summary.json as `peak_memory_mib`) of a 20-step run of three scenes
/// (DPD 3D, 3.2·10⁵ particles; the SPH benchmark; Maxwell SPH, 9·10⁴ particles), less the peak
/// of the same scene in a box a thousandth the size or less (the binary, the
/// libraries, the threads; each run writes its final checkpoint, whose buffers are part of the
/// peak), against `check::rank_memory` of the large box less the small one, on one thread and
/// on two.
/// The estimate must not fall short on either (`check` would let a run start that does not fit;
/// it keeps a tenth of MemAvailable aside for the rest) and must not exceed 2× (a run refused
/// that needs well under the budget). Two threads take more than one: each worker thread
/// allocates from its own malloc arena, and on one thread the rank's main thread does all the
/// work (`workers::worker_pool`), so one arena serves everything. Measured 2026-11-28 (one
/// thread / two): DPD 3D 1.84× / 1.60×, SPH benchmark 1.93× / 1.90×, Maxwell SPH under
/// Lees–Edwards shear 1.28× / 1.24× (at 3.6·10⁵ particles, the box before 2026-11-28: 1.27×).
/// The peak still grows slowly with the step count (the Maxwell scene at 9·10⁴ particles:
/// 148, 166, 172 MiB after 2, 20, 40 steps), so the 20 steps are not a long run's peak; the
/// estimate's margin covers that. The DPD estimate's per-pair term is the loose one. Without
/// the SPH model's fields and full lists (the estimate before this test) the Maxwell scene's
/// is below 1: it fails.
#[test]
fn check_memory_estimate_covers_the_measured_peak() {
    let stock_case_path = |name: &str| {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("cases")
            .join(name)
    };
    let dir = tempfile::tempdir().expect("temp dir");
    let peak = |case: &str, sets: &[String], tag: &str, threads: &str| -> (f64, f64) {
        let out = dir.path().join(format!("{tag}.t{threads}"));
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_mesorheo"));
        cmd.arg("run")
            .arg(stock_case_path(case))
            .arg("--out")
            .arg(&out)
            .args(["-q", "--no-plots", "-t", threads]);
        for s in sets.iter().chain(&[
            "run.steps=20".to_string(),
            "run.equilibration=0".to_string(),
            "run.sample_every=1".to_string(),
            "diagnostics.blocks=2".to_string(),
        ]) {
            cmd.arg("--set").arg(s);
        }
        let status = cmd.output().expect("run the binary");
        let text = std::fs::read_to_string(out.join("summary.json")).unwrap_or_else(|e| {
            panic!(
                "{tag}: no summary ({e}): {}",
                String::from_utf8_lossy(&status.stderr)
            )
        });
        let summary: serde_json::Value = serde_json::from_str(&text).expect("summary.json");
        let measured = summary["peak_memory_mib"]
            .as_f64()
            .expect("peak_memory_mib");
        let loaded = mesorheo::config::load_with_overrides(&stock_case_path(case), sets)
            .unwrap_or_else(|e| panic!("{e}"));
        let estimate = mesorheo::capacity::rank_memory(&loaded.case, 1) / (1024.0 * 1024.0);
        (measured, estimate)
    };
    let box_of = |l: f64, d: usize| format!("box.lengths=[{}]", vec![l.to_string(); d].join(","));
    let maxwell = |l: f64| {
        vec![
            box_of(l, 2),
            "particles.density=10000.0".into(),
            "particles.mass=1e-4".into(),
            "fluid.smoothing_length=0.03".into(),
            "neighbour.skin=0.005".into(),
            "integrator.dt=1e-4".into(),
        ]
    };
    let scenes: [(&str, &str, Vec<String>, Vec<String>); 3] = [
        (
            "DPD 3D",
            "bench_dpd_32k.toml",
            vec![box_of(47.42, 3)],
            vec![box_of(4.742, 3)],
        ),
        (
            "SPH benchmark",
            "bench_sph_2d.toml",
            vec![box_of(6.0, 2)],
            vec![box_of(0.19, 2)],
        ),
        (
            "Maxwell SPH",
            "maxwell_shear_2d.toml",
            maxwell(3.0),
            maxwell(0.19),
        ),
    ];
    for (name, case, big, small) in scenes {
        for threads in ["1", "2"] {
            let (m_big, e_big) = peak(case, &big, &format!("{case}.big"), threads);
            let (m_small, e_small) = peak(case, &small, &format!("{case}.small"), threads);
            let ratio = (e_big - e_small) / (m_big - m_small);
            eprintln!(
                "{name}, {threads} thread(s): measured {m_big:.1} − {m_small:.1} MiB, estimated \
                 {e_big:.1} − {e_small:.1} MiB: {ratio:.2}×"
            );
            assert!(
                (1.0..=2.0).contains(&ratio),
                "{name}, {threads} thread(s): check's estimate is {ratio:.2}× the measured memory"
            );
        }
    }
}

/// One measured point of a stability map (docs/stability/<map>.csv) with `check`'s limit there.
struct MapPoint {
    /// The map and the value of its second parameter, e.g. `held2_a12_g18 seed=3`.
    label: String,
    largest_stable: f64,
    smallest_unstable: f64,
    /// The `check_limit` column (what the docs' tables print).
    printed: f64,
    /// The library's limit, recomputed here.
    limit: f64,
}

/// Every point of the maps listed in docs/stability/`manifest`, with the library's limit.
fn map_points(manifest: &str) -> (usize, Vec<MapPoint>) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("docs/stability").join(manifest))
        .unwrap_or_else(|e| panic!("docs/stability/{manifest}: {e}"));
    let maps: Vec<Vec<&str>> = text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| l.split('|').map(str::trim).collect())
        .collect();
    let mut points = Vec::new();
    for map in &maps {
        let (name, case) = (map[0], map[1]);
        let fixed: Vec<&str> = map[4].split_whitespace().collect();
        let path = root.join("docs/stability").join(format!("{name}.csv"));
        let text =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
        let col = |key: &str| {
            header
                .iter()
                .position(|h| *h == key)
                .unwrap_or_else(|| panic!("{name}: no column {key}"))
        };
        let (stable, unstable) = (col("largest_stable"), col("smallest_unstable"));
        let printed = col("check_limit");
        for line in lines {
            let cells: Vec<&str> = line.split(',').collect();
            let mut overrides: Vec<String> = fixed.iter().map(|s| s.to_string()).collect();
            overrides.push(format!("{}={}", header[0], cells[0]));
            overrides.push("run.beyond_stability_limits=true".into());
            let loaded = mesorheo::config::load_scene(&root.join("cases").join(case), &overrides)
                .unwrap_or_else(|e| panic!("{name} {overrides:?}: {e}"));
            let mesorheo::config::CaseScene::Particles(c) = loaded.scene else {
                panic!("{name}: a particle scene")
            };
            let parse = |k: usize| cells[k].parse::<f64>().expect("a number");
            points.push(MapPoint {
                label: format!("{name} {}={}", header[0], cells[0]),
                largest_stable: parse(stable),
                smallest_unstable: parse(unstable),
                printed: parse(printed),
                limit: dpd_limits_of_case(&c).expect("DPD").combined,
            });
        }
    }
    (maps.len(), points)
}

/// `check`'s DPD time-step limit against the measured stability maps it was fitted to (issue
/// #18, #40): at every point it refuses the smallest unstable step with the fit's margin and
/// the out-of-sample margin: limit ≤ 0.97 × 0.9 × the first unstable step (0.97: the bisection
/// brackets the boundary to 3 %; 0.9: `SCATTER_MARGIN`, the fixed margin for the seed scatter
/// that the held-out sets found beyond the fitted boundary, up to 1.096 × it; module doc of
/// src/models/dpd/time_step.rs). It accepts at least 80 % of the stable range except where
/// docs/validation.md says it is conservative (at most 316 of the 429 points, none below 36 %:
/// the fit gives 316 and 36.3 %; 178 of them are raw random starts, whose friction part carries
/// the margin for the luckless seed, 62 soft-started random starts and 76 lattice starts, the
/// price of the out-of-sample margin), and it refuses every Δt that blew up in the 1500-step
/// γ × Δt study (docs/studies/dpd_gamma_dt.csv, raw random starts: at γ = 40 that is 0.015,
/// below the 1000-step map's 0.0158). The 429 points include the second, third and fifth
/// held-out sets (20, 22 and 16 maps × seeds 1–3, folded in after each was reported), four 3D
/// lattice maps and 14 soft-started random maps (2026-11-27). The maps are runs of the engine
/// with its blow-up detectors, independent of the formula; the limit is recomputed here from
/// the library, so a change of a coefficient is judged against the measurement, and the
/// `check_limit` column the docs' tables print must be the library's (to 10⁻³;
/// tools/dpd_stability_fit.py, which wrote it, mirrors the library). Mutation (2026-11-27,
/// stab6, evaluated by the fit tool's copy of the formula; no mutant build): SCATTER_MARGIN at
/// 1.0 (the margin dropped) puts 100 points past 0.873 ×, the first in order 2D a = 25,
/// γ = 2, lattice (0.902 × its unstable step); docs/validation.md "Mutations".
#[test]
fn check_refuses_every_measured_unstable_dpd_step() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let (maps, points) = map_points("dpd_maps.txt");
    assert_eq!(maps, 128, "the maps of docs/stability/dpd_maps.txt");
    assert_eq!(points.len(), 429, "the points of docs/stability");
    // The fit's 3 % and the out-of-sample margin (SCATTER_MARGIN = 0.9; doc above).
    let bound = 0.97 * 0.9;
    let (mut conservative, mut worst) = (0, f64::INFINITY);
    // The first point whose printed limit is not the library's (judged after the physics).
    let mut stale: Option<String> = None;
    for p in &points {
        let (s, u, limit) = (p.largest_stable, p.smallest_unstable, p.limit);
        if (p.printed - limit).abs() > 1e-3 * limit && stale.is_none() {
            stale = Some(format!(
                "{}: the CSV's check_limit {} is not the library's {limit:.6e}",
                p.label, p.printed
            ));
        }
        assert!(
            limit <= bound * u,
            "{}: check accepts {limit:.4e}, more than {bound} × the unstable {u:.4e}",
            p.label
        );
        let accepted = limit.min(s) / s;
        worst = worst.min(accepted);
        if accepted < 0.8 {
            conservative += 1;
        }
    }
    assert!(
        conservative <= 316 && worst >= 0.36,
        "{conservative} conservative points, worst {worst:.3}"
    );
    assert!(stale.is_none(), "{}", stale.unwrap_or_default());
    // The γ × Δt study's blow-ups (longer runs than the maps' trials).
    let study = std::fs::read_to_string(root.join("docs/studies/dpd_gamma_dt.csv"))
        .expect("docs/studies/dpd_gamma_dt.csv");
    let mut blowups = 0;
    for line in study.lines().skip(1) {
        let cells: Vec<&str> = line.split(',').collect();
        if cells[2] != "unstable" {
            continue;
        }
        let (gamma, dt) = (cells[0], cells[1].parse::<f64>().expect("Δt"));
        // The study ran the raw random start (before the soft start existed).
        let overrides = [
            format!("fluid.gamma={gamma}"),
            "fluid.soft_start_sweeps=0".to_string(),
            "run.beyond_stability_limits=true".to_string(),
        ];
        let loaded =
            mesorheo::config::load_scene(&root.join("cases/dpd_equilibrium_2d.toml"), &overrides)
                .expect("the study's case");
        let mesorheo::config::CaseScene::Particles(c) = loaded.scene else {
            panic!("a particle scene")
        };
        let limit = dpd_limits_of_case(&c).expect("DPD").combined;
        assert!(
            limit <= bound * dt,
            "γ = {gamma}: check accepts {limit:.4e}, the study blew up at {dt}"
        );
        blowups += 1;
    }
    assert!(blowups >= 3, "{blowups} blow-ups in the study");
}

/// `check`'s DPD limit on the fourth held-out set (issue #40), the 14 maps × seeds 1–3 of
/// docs/stability/dpd_held_out4.txt (raw random starts, `fluid.soft_start_sweeps = 0`, and two
/// lattice maps), never read by tools/dpd_stability_fit.py. A point fails when the limit
/// accepts its measured unstable step (limit ≥ the smallest unstable Δt). Measured 2026-11-27:
/// the limit before the softstart refit accepted 2 of the 42 (3D a = 8, γ = 60 lattice, seeds
/// 2 and 3); the refit, with 3D lattice maps at that point's neighbours (its own runs left
/// out), refuses all 42, so the set is no longer fully out of sample there. It also holds the
/// price of the raw start's margin and of the out-of-sample margin (stab6): of the 42, ≥ 80 %
/// of the stable range is accepted at 3 (measured: 3, worst 38.6 %, median 51 %; 9, 45 %, 58 %
/// before the out-of-sample margin). Mutation (2026-11-27, the fit tool's copy of the formula):
/// the softstart limit with its 3D factor of c₀ back at 1.06 accepts the a = 8, γ = 60 lattice
/// map again (1.070 ×, 1.024 ×).
#[test]
fn check_against_the_fourth_held_out_dpd_stability_maps() {
    let (maps, points) = map_points("dpd_held_out4.txt");
    assert_eq!((maps, points.len()), (14, 42), "the fourth held-out set");
    let verdict = held_out_verdict(&points);
    assert!(
        verdict.accepted_unstable.is_empty(),
        "the held-out points whose measured unstable step check accepts: {:?}",
        verdict.accepted_unstable
    );
    assert!(
        verdict.at_least_80 >= 3 && verdict.worst >= 0.38,
        "{} of 42 points accept ≥ 80 %, worst {:.3}",
        verdict.at_least_80,
        verdict.worst
    );
}

/// `check`'s DPD limit out of sample on the sixth held-out set (issue #40), the 12 maps of
/// docs/stability/dpd_held_out6.txt (39 points: the 2D ideal gas at γ = 12, 22 and 30 over
/// seeds 1–4, weak repulsion a ≤ 4 at γ = 20–70, 2D a = 25 at γ = 90; seven soft-started
/// random maps, two raw random and three lattice maps, 2D and 3D), chosen and committed
/// (5d251c4) before any of them was run and before this limit (the stab6 refit with the
/// out-of-sample margin S = 0.9, dc0877e) existed, never read by tools/dpd_stability_fit.py.
/// A point fails when the limit accepts its measured unstable step (limit ≥ the smallest
/// unstable Δt). Measured 2026-11-27 (maps 20:25–20:38 UTC; the limit evaluated there once,
/// after the refit was committed): **none of the 39 unstable steps is accepted** (largest
/// limit / unstable 0.856, 2D a = 25, γ = 90, seed 2); ≥ 80 % of the stable range is accepted
/// at 7 (worst 40.0 %, a raw 2D ideal-gas start under its margin; median 74 %): the bounds below
/// are those, rounded down. Mutation (2026-11-27, evaluated by the fit tool's copy of the
/// formula on the CSVs, which this file checks against the library to 10⁻³; no mutant build:
/// no time on 2 shared cores): c₀ (IDEAL_GAS_SCALE) 0.937 → 1.1, the ideal-gas friction part
/// loosened by 17 %, accepts 2 points (2D a = 0, ρ = 3, γ = 30, seed 4, 1.026 ×; 2D a = 25,
/// γ = 90, seed 2, 1.007 ×);
/// S back at 1.0 (the margin dropped, the fitted boundary kept) accepts none (0.952 ×): this set
/// alone does not need S (docs/validation.md, "Mutations").
#[test]
fn check_against_the_sixth_held_out_dpd_stability_maps() {
    let (maps, points) = map_points("dpd_held_out6.txt");
    assert_eq!((maps, points.len()), (12, 39), "the sixth held-out set");
    let verdict = held_out_verdict(&points);
    assert!(
        verdict.accepted_unstable.is_empty(),
        "the held-out points whose measured unstable step check accepts: {:?}",
        verdict.accepted_unstable
    );
    assert!(
        verdict.at_least_80 >= 7 && verdict.worst >= 0.39,
        "{} of 39 points accept ≥ 80 %, worst {:.3}",
        verdict.at_least_80,
        verdict.worst
    );
}

/// What a held-out set says about the limit.
struct HeldOutVerdict {
    /// The points whose measured unstable step the limit accepts.
    accepted_unstable: Vec<String>,
    /// Refused points where the limit accepts ≥ 80 % of the stable range.
    at_least_80: usize,
    /// The smallest accepted share of the stable range over the refused points.
    worst: f64,
}

/// Judges every point (printed on stderr).
fn held_out_verdict(points: &[MapPoint]) -> HeldOutVerdict {
    let mut verdict = HeldOutVerdict {
        accepted_unstable: Vec::new(),
        at_least_80: 0,
        worst: f64::INFINITY,
    };
    for p in points {
        let ratio = p.limit / p.smallest_unstable;
        eprintln!(
            "{}: stable {:.4e}, unstable {:.4e}, check {:.4e} ({ratio:.3} × unstable)",
            p.label, p.largest_stable, p.smallest_unstable, p.limit
        );
        if ratio >= 1.0 {
            verdict.accepted_unstable.push(p.label.clone());
            continue;
        }
        let accepted = p.limit.min(p.largest_stable) / p.largest_stable;
        verdict.worst = verdict.worst.min(accepted);
        if accepted >= 0.8 {
            verdict.at_least_80 += 1;
        }
    }
    verdict
}

/// The DPD time-step limits of a case whose fluid is DPD.
fn dpd_limits_of_case(
    case: &mesorheo::config::Case,
) -> Option<mesorheo::models::dpd::time_step::DpdLimits> {
    match &case.fluid {
        mesorheo::config::FluidCfg::Dpd(d) => {
            Some(mesorheo::models::dpd::time_step::dpd_limits_of(d, case))
        }
        _ => None,
    }
}
