//! Shared helpers of the integration tests.
#![allow(dead_code)]

use mesorheo::config::{self, LoadedCase};
use std::path::{Path, PathBuf};

/// Parses case text (panics with the case error on bad input: tests own their cases).
pub fn case_from_str(text: &str, name: &str) -> LoadedCase {
    let path = PathBuf::from(name);
    let case = config::parse(text, &path).unwrap_or_else(|e| panic!("{e}"));
    LoadedCase {
        case,
        path,
        source: text.to_owned(),
    }
}

/// Loads a stock case from `cases/`.
pub fn stock_case(name: &str) -> LoadedCase {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name);
    config::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// `text` with `key.path=value` overrides applied by the parser's own `--set` mechanism
/// ([`config::apply_overrides`]): a key that does not exist is refused when the text is
/// parsed, where a string replacement that misses would silently test another case.
/// `reference=[]` drops the references.
pub fn with_overrides(text: &str, overrides: &[&str]) -> String {
    let overrides: Vec<String> = overrides.iter().map(|o| o.to_string()).collect();
    config::apply_overrides(text, &overrides).unwrap_or_else(|e| panic!("{e}"))
}

/// A stock case from `cases/` with overrides ([`with_overrides`]), as text.
pub fn stock_text_with(name: &str, overrides: &[&str]) -> String {
    with_overrides(&stock_text(name), overrides)
}

/// The text of a stock case from `cases/`.
pub fn stock_text(name: &str) -> String {
    std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("cases")
            .join(name),
    )
    .unwrap_or_else(|e| panic!("cases/{name}: {e}"))
}

/// An SPH fluid (Tait, η = 1, kick–drift–kick, Δt = 10⁻⁴) in a periodic box of side 1 with a
/// square lattice of spacing 0.02 and Lucy support `support`; `extra_fluid` is appended to
/// `[fluid]` (it may open a sub-table such as `[fluid.polymer]`).
pub fn sph_periodic_box(viscous_term: &str, support: f64, extra_fluid: &str) -> String {
    format!(
        r#"
dimension = 2
[box]
lengths = [1.0, 1.0]
[particles]
lattice = "cubic"
density = 2500.0
mass = 0.0004
temperature = 0.0
[fluid]
kind = "sph"
kernel = "lucy"
smoothing_length = {support}
sound_speed = 10.0
viscosity = 1.0
equation_of_state = "tait"
viscous_term = "{viscous_term}"
{extra_fluid}
[integrator]
kind = "kick_drift_kick"
dt = 1e-4
[neighbour]
skin = 0.01
[run]
steps = 100
[diagnostics]
observables = ["momentum"]
"#
    )
}

/// Worker threads of a test about physics, not about threads: one. `./run test` runs four
/// tests at a time on two cores (two streams × libtest's two threads), so a second worker per
/// run buys no speed there, only rayon's synchronisation: 15–20 % more CPU for the same run
/// (measured 2026-11-28, `mesorheo run` of the Maxwell shear and the double-Poiseuille DPD
/// cases at `-t 1` and `-t 2`). Every result is bitwise the same on any thread count (the
/// bitwise tests, which keep their own 1–2 threads), so the assertions see the same numbers.
pub const PHYSICS_THREADS: usize = 1;

/// Runs a loaded case on 1 rank × [`PHYSICS_THREADS`] and asserts that it has references and
/// that every one passes (each check printed).
pub fn assert_references_pass(name: &str, loaded: &LoadedCase) {
    let s = mesorheo::driver::run_in_process(loaded, 1, PHYSICS_THREADS, None)
        .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert!(!s.validation.is_empty(), "{name} has no reference");
    for v in &s.validation {
        eprintln!("{name}: {} = {:.3e}", v.name, v.value);
        assert!(v.pass, "{name}: {v:?}");
    }
}

/// The shortened twin of a stock case in `./run test` (issue #40): the stock case with
/// `overrides` (a shorter run), checked against its own references with its own tolerances,
/// except the value references on the observables named in `widened`, which get the tolerance
/// given there. The caller's doc comment says why each is widened (a short window's noise) and
/// which mutation the widened bound still catches; the stock length, with every tolerance as
/// written, is `./run validate stock`'s.
pub fn assert_shortened_references_pass(name: &str, overrides: &[&str], widened: &[(&str, f64)]) {
    let edits: Vec<_> = widened.iter().map(|&(o, t)| (o, None, t)).collect();
    shortened_references_pass(name, overrides, &edits);
}

/// The shortened twin of a stock case whose references depend on the run's window (a
/// time-periodic flow averaged over less than a period): the stock case with `overrides`,
/// with the value references on the observables named in `window` replaced by the value and
/// tolerance given there (the window's own reference; the caller's doc comment says where it
/// comes from, what was measured and which mutation fails it).
pub fn assert_window_references_pass(name: &str, overrides: &[&str], window: &[(&str, f64, f64)]) {
    let edits: Vec<_> = window.iter().map(|&(o, v, t)| (o, Some(v), t)).collect();
    shortened_references_pass(name, overrides, &edits);
}

fn shortened_references_pass(name: &str, overrides: &[&str], edits: &[(&str, Option<f64>, f64)]) {
    let text = stock_text_with(name, overrides);
    let mut loaded = case_from_str(&text, name);
    for (observable, value, tolerance) in edits {
        let mut found = false;
        for r in &mut loaded.case.reference {
            if let config::ReferenceCfg::Value(v) = r
                && v.observable == *observable
            {
                if let Some(value) = value {
                    v.value = *value;
                }
                v.tolerance = *tolerance;
                found = true;
            }
        }
        assert!(found, "{name} has no value reference on {observable}");
    }
    assert_references_pass(
        &format!("{name} (shortened: {})", overrides.join(", ")),
        &loaded,
    );
}

/// Runs `text` on 1–4 in-process ranks × 1–2 threads; `check` sees every summary. Returns, per
/// run, the state digest and the averaged observables (exact reductions, so comparable to the
/// last bit).
pub fn digests_on_1_to_4_ranks(
    text: &str,
    name: &str,
    check: impl Fn(&mesorheo::summary::Summary),
) -> Vec<(usize, usize, String)> {
    let loaded = case_from_str(text, name);
    let mut out = Vec::new();
    for ranks in 1..=4 {
        for threads in 1..=2 {
            let s = mesorheo::driver::run_in_process(&loaded, ranks, threads, None)
                .unwrap_or_else(|e| panic!("{name} on {ranks} ranks × {threads} threads: {e}"));
            check(&s);
            let observables = serde_json::to_string(&s.observables).expect("json");
            out.push((ranks, threads, format!("{} {observables}", s.state_digest)));
        }
    }
    out
}

/// Every run of [`digests_on_1_to_4_ranks`] equals the first (1 rank × 1 thread).
pub fn assert_all_equal(name: &str, d: &[(usize, usize, String)]) {
    for (r, t, x) in d {
        assert_eq!(
            x, &d[0].2,
            "{name}: {r} ranks × {t} threads differs from 1 × 1"
        );
    }
}

/// A small DPD case: `dimension`, cubic box of side `side`, optional shear.
pub fn small_dpd(dimension: usize, side: f64, shear: f64, steps: u64, extra: &str) -> String {
    let lengths = vec![format!("{side}"); dimension].join(", ");
    format!(
        r#"
dimension = {dimension}
seed = 11
[box]
lengths = [{lengths}]
shear_rate = {shear}
[particles]
lattice = "random"
density = 3.0
temperature = 1.0
[fluid]
kind = "dpd"
a = 25.0
gamma = 4.5
kt = 1.0
[integrator]
kind = "groot_warren"
dt = 0.04
lambda = 0.65
[neighbour]
skin = 0.3
[run]
steps = {steps}
sample_every = 1
progress_seconds = 0
{extra}
"#
    )
}

/// A small case of the engine's two-pass test model (the summation gas): `dimension`, cubic
/// box of side `side`, shear rate `shear`, `lattice`, `steps`; `extra` is appended.
pub fn small_gas(
    dimension: usize,
    side: f64,
    shear: f64,
    lattice: &str,
    steps: u64,
    extra: &str,
) -> String {
    let lengths = vec![format!("{side}"); dimension].join(", ");
    format!(
        r#"
dimension = {dimension}
seed = 5
[box]
lengths = [{lengths}]
shear_rate = {shear}
[particles]
lattice = "{lattice}"
density = 4.0
temperature = 0.5
[fluid]
kind = "summation_gas"
smoothing_length = 1.2
sound_speed = 2.0
[integrator]
kind = "groot_warren"
dt = 0.01
[neighbour]
skin = 0.3
[run]
steps = {steps}
sample_every = 5
progress_seconds = 0
[diagnostics]
observables = ["temperature", "momentum"]
{extra}
"#
    )
}

#[cfg(feature = "hdf5")]
/// Every dataset of an HDF5 file with its values (as bit patterns), in path order.
pub fn h5_content(path: &Path) -> Vec<(String, Vec<usize>, Vec<u64>)> {
    fn walk(g: &hdf5::Group, prefix: &str, out: &mut Vec<(String, Vec<usize>, Vec<u64>)>) {
        let mut names = g.member_names().expect("members");
        names.sort();
        for name in names {
            let p = format!("{prefix}/{name}");
            if let Ok(sub) = g.group(&name) {
                walk(&sub, &p, out);
            } else {
                let d = g.dataset(&name).expect("dataset");
                let bits: Vec<u64> = if let Ok(v) = d.read_raw::<f64>() {
                    v.iter().map(|x| x.to_bits()).collect()
                } else if let Ok(v) = d.read_raw::<u64>() {
                    v
                } else {
                    d.read_raw::<i32>()
                        .expect("f64, u64 or i32")
                        .iter()
                        .map(|&x| x as u32 as u64)
                        .collect()
                };
                out.push((p, d.shape(), bits));
            }
        }
    }
    let f = mesorheo::output::h5_options().open(path).expect("open");
    let mut out = Vec::new();
    walk(&f, "", &mut out);
    out
}

/// Says on the uncaptured stderr that a check was skipped, and why: the test harness captures
/// `eprintln!` of a passing test, so a skip reported that way would be silent. (libtest has no
/// "skipped" outcome; the line is what a reader of the test log sees.)
/// The Python of `MESORHEO_PYTHON` for a check that needs one, or `None` after saying on the
/// uncaptured stderr that `what` is skipped and `why`; with `MESORHEO_REQUIRE_PYTHON` set (as
/// `./run test` does) a missing Python fails the test instead.
pub fn python_or_skip(what: &str, why: &str) -> Option<String> {
    let python = std::env::var("MESORHEO_PYTHON").ok();
    if python.is_none() {
        assert!(
            std::env::var("MESORHEO_REQUIRE_PYTHON").is_err(),
            "MESORHEO_PYTHON is not set"
        );
        report_skip(what, why);
    }
    python
}

pub fn report_skip(what: &str, why: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr().lock(), "SKIPPED {what}: {why}");
}

/// Mean and standard error of independent samples.
pub fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Run options of an in-process flow-scene run: `threads`, an output folder, a stop step.
pub fn flow_options(
    threads: usize,
    out: Option<&Path>,
    until: Option<u64>,
) -> mesorheo::driver::RunOptions {
    mesorheo::driver::RunOptions {
        threads,
        steps: None,
        until_step: until,
        out: out.map(Path::to_path_buf),
        max_hours: None,
    }
}

/// Runs a homogeneous-flow case on `ranks` in-process ranks (panics with the run's error).
pub fn run_flow(
    case: &mesorheo::config::FlowCase,
    ranks: usize,
    o: mesorheo::driver::RunOptions,
) -> mesorheo::summary::Summary {
    let case = case.clone();
    mesorheo::driver::in_process(ranks, move |c| {
        mesorheo::driver::run_flow_case(&case, Path::new("flow.toml"), c, &o)
    })
    .unwrap_or_else(|e| panic!("{e}"))
}

/// The instantaneous scalar `name` of a measurement (panics when the case does not record it).
pub fn scalar(m: &mesorheo::sim::Measurement, name: &str) -> f64 {
    m.scalars
        .iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| *v)
        .unwrap_or_else(|| panic!("no {name} in the measurement"))
}
