//! `mesorheo study SWEEP.toml`: the speed/accuracy trade of a case, measured.
//!
//! A sweep file names a case, the knobs to vary (any case key, with a list of values each), the
//! observables whose error is measured and, for each, its reference:
//!
//! ```toml
//! title = "FENE dumbbells at Wi = 1: dumbbells per particle × time step"
//! case = "../cases/dumbbells_fene_shear_3d.toml"   # relative to the sweep file
//! threads = 1                                      # per run (ranks = 1 by default)
//! set = ["run.steps=1500"]                         # fixed overrides of every point
//! target = 0.01                                    # default of --target
//!
//! [[knob]]
//! key = "polymer.per_particle"
//! values = [20, 100, 500]
//!
//! [[knob]]
//! key = "integrator.dt"
//! values = [0.04, 0.02, 0.01]
//!
//! [[observable]]
//! name = "polymer_viscosity"
//! value = 0.867474           # an analytic or published value (optional value_stderr)
//! # reference = "converged"  # or: the most expensive point
//! # reference = "richardson" # or: Richardson extrapolation in integrator.dt (order = 1 or 2)
//! ```
//!
//! A knob value may be a table, a *bundle* of case keys set together; the knob's `key` then only
//! names its column. So plain Brownian dynamics and BDDFS grids share one sweep, and N_d varies
//! at a fixed total of dumbbells:
//!
//! ```toml
//! [[knob]]
//! key = "method"
//! values = [{ polymer = { kind = "dumbbells" } }, { polymer = { kind = "bddfs", cells = 200 } }]
//! [[knob]]
//! key = "ensemble"
//! values = [{ "flow.particles" = 200, "polymer.per_particle" = 1000 },
//!           { "flow.particles" = 20, "polymer.per_particle" = 10000 }]
//! ```
//!
//! Every point of the Cartesian product of the knobs is an ordinary `mesorheo run` (a child
//! process, under `mpirun` when `ranks > 1`) in `OUT/points/NNN/`. A point whose `point.json`
//! records the same overrides is not run again, so an interrupted study resumes where it
//! stopped. A point the case validation refuses (say a Δt beyond `check`'s limit) or that blows
//! up (exit code 4) is recorded as such, not fatal.
//!
//! For every point and observable, with the estimate A ± σ and the reference A* ± σ*:
//! - error e = |A − A*| (divided by |A*| for the default `metric = "relative"`);
//! - statistical error s = √(σ² + σ*²) (same scaling): what more samples would shrink;
//! - systematic error √(max(0, e² − s²)): the part of e that the sampling noise does not
//!   explain, i.e. what a smaller Δt, a finer resolution or a better scheme would shrink.
//!
//! The study's error of a point is the largest e over its observables; its cost is the CPU
//! seconds (user + system) of the run's processes, all ranks and threads, measured by the study
//! around the child (`getrusage(RUSAGE_CHILDREN)`), so that a point does not look dearer because
//! something else ran beside it (for a point finished by an older version: wall × ranks ×
//! threads). A point is on the Pareto front when no other
//! point is both cheaper and more accurate. Its memory is the stored ensemble bytes per
//! particle the run reports (summary.json `ensemble_bytes_per_particle`: the connectors of
//! plain dumbbells, the occupied histogram cells of BDDFS), with its own memory/error front
//! (CSV `pareto_memory`) and the leanest point that meets the target. The recommendation for a target tolerance τ is the
//! cheapest point whose every observable has e + 2s ≤ τ (its true error is below τ with about
//! 95 % confidence), so a point that is accurate only by luck of its noise is not picked.
//!
//! Richardson extrapolation, for `reference = "richardson"`: among the points that share the
//! other knob values of the most expensive point, the two smallest steps h₁ < h₂ give
//! A* = A₁ + (A₁ − A₂)/((h₂/h₁)^p − 1) for a scheme of weak order p, with
//! σ*² = (1 + c)² σ₁² + c² σ₂², c = 1/((h₂/h₁)^p − 1).

use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The sweep file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepFile {
    #[serde(default)]
    title: String,
    case: PathBuf,
    #[serde(default = "one")]
    ranks: usize,
    #[serde(default = "one")]
    threads: usize,
    #[serde(default)]
    set: Vec<String>,
    #[serde(default)]
    target: Option<f64>,
    #[serde(default)]
    launcher: Option<String>,
    #[serde(default)]
    keep_time: Option<bool>,
    #[serde(default)]
    knob: Vec<KnobFile>,
    #[serde(default)]
    observable: Vec<ObservableFile>,
}

fn one() -> usize {
    1
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct KnobFile {
    key: String,
    values: Vec<toml::Value>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ObservableFile {
    name: String,
    #[serde(default)]
    value: Option<f64>,
    #[serde(default)]
    value_stderr: Option<f64>,
    #[serde(default)]
    reference: Option<String>,
    #[serde(default)]
    knob: Option<String>,
    #[serde(default)]
    order: Option<f64>,
    #[serde(default)]
    metric: Option<String>,
}

/// What an observable's error is measured against.
#[derive(Clone, Debug, PartialEq)]
pub enum Reference {
    /// An analytic or published value ± its own standard error.
    Value { value: f64, stderr: f64 },
    /// The most expensive completed point.
    Converged,
    /// Richardson extrapolation to zero of the knob `knob` for a scheme of order `order`.
    Richardson { knob: String, order: f64 },
}

/// One observable of a study.
#[derive(Clone, Debug)]
pub struct ObservableSpec {
    /// Name in summary.json's `observables`.
    pub name: String,
    pub reference: Reference,
    /// Relative (|A − A*|/|A*|) or absolute error.
    pub relative: bool,
}

/// A knob: a case key and its values (TOML text, as given to `--set`).
///
/// A value may instead be a table of several case keys set together (a "bundle"), e.g.
/// `{ polymer = { kind = "bddfs", cells = 200 } }` or `{ "flow.particles" = 20,
/// "polymer.per_particle" = 10000 }`: its entries, flattened to dotted keys, are the point's
/// overrides, and the knob's `key` only names its column (so plain Brownian dynamics and BDDFS
/// at several grids can share one sweep, and N_d can vary at a fixed total of dumbbells).
#[derive(Clone, Debug)]
pub struct Knob {
    pub key: String,
    /// Per value, its label in the CSV, the plot and the recommendation (the TOML text of a
    /// plain value; `cells=200 kind=bddfs` for a bundle: its entries in key order, keys
    /// shortened to their last part).
    pub values: Vec<String>,
    /// Per value, the `key=value` overrides it sets.
    pub settings: Vec<Vec<String>>,
}

/// A bundle's entries as (dotted key, TOML text), nested tables flattened in order.
fn flatten_bundle(prefix: &str, table: &toml::Table, out: &mut Vec<(String, String)>) {
    for (k, v) in table {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(t) => flatten_bundle(&key, t, out),
            other => out.push((key, toml_text(other))),
        }
    }
}

/// A validated sweep.
#[derive(Clone, Debug)]
pub struct Sweep {
    pub title: String,
    /// The case file, resolved against the sweep file's folder.
    pub case: PathBuf,
    pub ranks: usize,
    pub threads: usize,
    /// Overrides applied to every point.
    pub set: Vec<String>,
    pub target: Option<f64>,
    /// Command prefix for ranks > 1, `{ranks}` replaced (default `mpirun -n {ranks}`).
    pub launcher: String,
    /// Scale run.steps, run.equilibration and run.sample_every by Δt₀/Δt, so that every point
    /// covers the same simulated time (default: on when integrator.dt is a knob).
    pub keep_time: bool,
    pub knobs: Vec<Knob>,
    pub observables: Vec<ObservableSpec>,
}

/// The time-step key, whose points keep the simulated time (see [`Sweep::keep_time`]).
pub const DT_KEY: &str = "integrator.dt";

/// Upper bound of the points in one sweep (a typo like `values = [..1000 entries..]` is caught
/// before hours are spent).
pub const MAX_POINTS: usize = 10_000;

/// Reads and validates a sweep file. Errors name the file and what would be valid.
pub fn load_sweep(path: &Path) -> Result<Sweep, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read the sweep file: {e}", path.display()))?;
    let here = path.parent().unwrap_or(Path::new("."));
    parse_sweep(&text, here).map_err(|e| format!("{}: {e}", path.display()))
}

fn toml_text(v: &toml::Value) -> String {
    match v {
        // A bare string is what `--set key=value` reads as a string, and what a folder name
        // shows best.
        toml::Value::String(s) => format!("\"{s}\""),
        other => other.to_string(),
    }
}

/// Parses sweep text; `here` is the folder relative paths are resolved against.
pub fn parse_sweep(text: &str, here: &Path) -> Result<Sweep, String> {
    let de = toml::Deserializer::parse(text).map_err(|e| format!("invalid TOML: {e}"))?;
    let file: SweepFile = serde_path_to_error::deserialize(de).map_err(|e| {
        format!(
            "at `{}`: {} (valid keys: title, case, ranks, threads, set, target, launcher, \
             keep_time, [[knob]] key/values, [[observable]] name/value/value_stderr/reference/knob/order/\
             metric)",
            e.path(),
            e.inner().message()
        )
    })?;
    if file.ranks == 0 || file.threads == 0 {
        return Err(format!(
            "ranks = {}, threads = {}: both must be ≥ 1",
            file.ranks, file.threads
        ));
    }
    let case = here.join(&file.case);
    if !case.is_file() {
        return Err(format!(
            "case = {:?}: no such file (resolved to {}; paths are relative to the sweep file)",
            file.case.display().to_string(),
            case.display()
        ));
    }
    if let Some(t) = file.target
        && !(t.is_finite() && t > 0.0)
    {
        return Err(format!("target = {t}: must be a positive tolerance"));
    }
    for s in &file.set {
        if !s.contains('=') {
            return Err(format!("set = [{s:?}]: expected \"key=value\" entries"));
        }
    }
    if file.knob.is_empty() {
        return Err("no [[knob]]: name at least one case key to vary, e.g. \
                    [[knob]] key = \"integrator.dt\" values = [0.02, 0.01]"
            .into());
    }
    let mut knobs = Vec::new();
    for (i, k) in file.knob.iter().enumerate() {
        if k.key.trim().is_empty() || k.key.contains('=') {
            return Err(format!(
                "knob[{i}].key = {:?}: give a case key such as \"integrator.dt\"",
                k.key
            ));
        }
        if k.values.is_empty() {
            return Err(format!("knob[{i}] ({}): values is empty", k.key));
        }
        if knobs.iter().any(|o: &Knob| o.key == k.key) {
            return Err(format!("knob[{i}]: the key {} is varied twice", k.key));
        }
        let mut values = Vec::new();
        let mut settings = Vec::new();
        for (j, v) in k.values.iter().enumerate() {
            if let toml::Value::Table(t) = v {
                let mut entries = Vec::new();
                flatten_bundle("", t, &mut entries);
                if entries.is_empty() {
                    return Err(format!(
                        "knob[{i}] ({}): value {j} is an empty table; a bundle sets case keys, \
                         e.g. {{ polymer = {{ kind = \"bddfs\", cells = 200 }} }}",
                        k.key
                    ));
                }
                values.push(
                    entries
                        .iter()
                        .map(|(key, v)| {
                            let short = key.rsplit('.').next().unwrap_or(key);
                            format!("{short}={}", v.trim_matches('"'))
                        })
                        .collect::<Vec<_>>()
                        .join(" "),
                );
                settings.push(
                    entries
                        .iter()
                        .map(|(key, v)| format!("{key}={v}"))
                        .collect(),
                );
            } else {
                let text = toml_text(v);
                settings.push(vec![format!("{}={text}", k.key)]);
                values.push(text);
            }
        }
        knobs.push(Knob {
            key: k.key.clone(),
            values,
            settings,
        });
    }
    let count = knobs
        .iter()
        .try_fold(1usize, |n, k| n.checked_mul(k.values.len()))
        .unwrap_or(usize::MAX);
    if count > MAX_POINTS {
        return Err(format!(
            "the knobs make {count} points; at most {MAX_POINTS} (split the sweep)"
        ));
    }
    if file.observable.is_empty() {
        return Err(
            "no [[observable]]: name at least one observable of summary.json with its \
                    reference (value = …, or reference = \"converged\" / \"richardson\")"
                .into(),
        );
    }
    let mut observables = Vec::new();
    for (i, o) in file.observable.iter().enumerate() {
        let at = format!("observable[{i}] ({})", o.name);
        let reference = match (o.value, o.reference.as_deref()) {
            (Some(v), None) => {
                let stderr = o.value_stderr.unwrap_or(0.0);
                if !(v.is_finite() && stderr.is_finite() && stderr >= 0.0) {
                    return Err(format!(
                        "{at}: value = {v} ± {stderr}: need a finite value and stderr ≥ 0"
                    ));
                }
                Reference::Value { value: v, stderr }
            }
            (None, Some("converged")) => Reference::Converged,
            (None, Some("richardson")) => {
                let knob = o.knob.clone().unwrap_or_else(|| "integrator.dt".into());
                let Some(k) = knobs.iter().find(|k| k.key == knob) else {
                    return Err(format!(
                        "{at}: Richardson extrapolation in {knob}, which is not a knob of this \
                         sweep"
                    ));
                };
                let numeric = k.values.iter().filter(|v| v.parse::<f64>().is_ok()).count();
                if numeric < 2 {
                    return Err(format!(
                        "{at}: Richardson extrapolation needs at least two numeric values of \
                         {knob}"
                    ));
                }
                let order = o.order.unwrap_or(1.0);
                if !(order.is_finite() && order > 0.0) {
                    return Err(format!("{at}: order = {order}: must be > 0 (1 or 2)"));
                }
                Reference::Richardson { knob, order }
            }
            (Some(_), Some(_)) => {
                return Err(format!("{at}: give either value or reference, not both"));
            }
            (None, Some(other)) => {
                return Err(format!(
                    "{at}: reference = {other:?}; valid: \"converged\" (the most expensive \
                     point), \"richardson\" (in integrator.dt), or a number as value = …"
                ));
            }
            (None, None) => {
                return Err(format!(
                    "{at}: no reference: give value = … (analytic or published), or \
                     reference = \"converged\" or \"richardson\""
                ));
            }
        };
        if o.value.is_none() && o.value_stderr.is_some() {
            return Err(format!("{at}: value_stderr without value"));
        }
        let relative = match o.metric.as_deref() {
            None | Some("relative") => true,
            Some("absolute") => false,
            Some(m) => {
                return Err(format!(
                    "{at}: metric = {m:?}; valid: \"relative\", \"absolute\""
                ));
            }
        };
        if relative && matches!(reference, Reference::Value { value, .. } if value == 0.0) {
            return Err(format!(
                "{at}: a relative error against 0 is undefined; use metric = \"absolute\""
            ));
        }
        observables.push(ObservableSpec {
            name: o.name.clone(),
            reference,
            relative,
        });
    }
    Ok(Sweep {
        title: file.title,
        case,
        ranks: file.ranks,
        threads: file.threads,
        set: file.set,
        target: file.target,
        launcher: file
            .launcher
            .unwrap_or_else(|| "mpirun -n {ranks}".to_string()),
        keep_time: file
            .keep_time
            .unwrap_or(knobs.iter().any(|k| k.key == DT_KEY)),
        knobs,
        observables,
    })
}

/// The points of a sweep: the Cartesian product of the knob values (the first knob varies
/// slowest), each as its list of `key=value` overrides (a bundle contributes all of its keys).
pub fn points(sweep: &Sweep) -> Vec<Vec<String>> {
    point_values(sweep)
        .into_iter()
        .map(|p| {
            p.iter()
                .enumerate()
                .flat_map(|(k, &j)| sweep.knobs[k].settings[j].iter().cloned())
                .collect()
        })
        .collect()
}

/// The points of a sweep as the index of each knob's value, in the order of [`points`].
pub fn point_values(sweep: &Sweep) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = vec![Vec::new()];
    for k in &sweep.knobs {
        out = out
            .into_iter()
            .flat_map(|p| {
                (0..k.values.len()).map(move |j| {
                    let mut q = p.clone();
                    q.push(j);
                    q
                })
            })
            .collect();
    }
    out
}

/// A point's overrides: the sweep's `set`, its knob values and, with `keep_time`, the run
/// lengths scaled by Δt₀/Δt (`base` is the case's Δt₀ and run lengths under `set`).
pub fn point_overrides(
    sweep: &Sweep,
    base: Option<(f64, &crate::config::RunCfg)>,
    knob_overrides: &[String],
) -> Vec<String> {
    let mut all = sweep.set.clone();
    all.extend(knob_overrides.iter().cloned());
    let dt = knob_overrides.iter().find_map(|o| {
        o.strip_prefix(DT_KEY)?
            .strip_prefix('=')?
            .parse::<f64>()
            .ok()
    });
    if let (true, Some((dt0, run)), Some(dt)) = (sweep.keep_time, base, dt)
        && dt > 0.0
    {
        let scale = dt0 / dt;
        let varied = |key: &str| {
            let prefix = format!("{key}=");
            sweep.knobs.iter().any(|k| k.key == key)
                || knob_overrides.iter().any(|o| o.starts_with(&prefix))
        };
        let scaled = |n: u64| (n as f64 * scale).round() as u64;
        for (key, value) in [
            ("run.steps", scaled(run.steps).max(1)),
            ("run.equilibration", scaled(run.equilibration)),
            ("run.sample_every", scaled(run.sample_every).max(1)),
        ] {
            if !varied(key) {
                all.push(format!("{key}={value}"));
            }
        }
    }
    all
}

mod analysis;
mod report;
use report::plot;
mod run;
pub use analysis::*;
pub use run::*;

#[cfg(test)]
mod tests {
    use super::*;

    fn sweep(text: &str) -> Result<Sweep, String> {
        let here = Path::new(env!("CARGO_MANIFEST_DIR")).join("studies");
        parse_sweep(text, &here)
    }

    const BASE: &str = r#"
        case = "../cases/dumbbells_hookean_shear_3d.toml"
        [[knob]]
        key = "integrator.dt"
        values = [0.04, 0.02, 0.01]
        [[knob]]
        key = "polymer.per_particle"
        values = [10, 100]
        [[observable]]
        name = "polymer_viscosity"
        reference = "richardson"
        order = 2
    "#;

    #[test]
    fn the_points_are_the_product_of_the_knobs_first_knob_slowest() {
        let s = sweep(BASE).unwrap();
        let p = points(&s);
        assert_eq!(p.len(), 6);
        assert_eq!(p[0], ["integrator.dt=0.04", "polymer.per_particle=10"]);
        assert_eq!(p[1], ["integrator.dt=0.04", "polymer.per_particle=100"]);
        assert_eq!(p[5], ["integrator.dt=0.01", "polymer.per_particle=100"]);
        assert!(s.keep_time, "on by default when Δt is a knob");
    }

    #[test]
    fn keep_time_scales_the_run_lengths_by_dt0_over_dt() {
        let s = sweep(BASE).unwrap();
        let run = crate::config::RunCfg {
            steps: 1000,
            equilibration: 200,
            sample_every: 10,
            progress_seconds: 10.0,
            beyond_stability_limits: false,
        };
        let o = point_overrides(&s, Some((0.01, &run)), &["integrator.dt=0.04".into()]);
        assert_eq!(
            o,
            [
                "integrator.dt=0.04",
                "run.steps=250",
                "run.equilibration=50",
                "run.sample_every=3"
            ]
        );
    }

    #[test]
    fn bad_sweeps_are_refused_with_what_is_valid() {
        let cases = [
            (
                BASE.replace("order = 2", "order = 2\nfoo = 1"),
                "unknown field",
            ),
            (
                BASE.replace("reference = \"richardson\"", "reference = \"best\""),
                "valid",
            ),
            (
                BASE.replace("reference = \"richardson\"\n", ""),
                "no reference",
            ),
            (BASE.replace("integrator.dt", "run.steps"), "not a knob"),
            (
                BASE.replace("dumbbells_hookean", "nonexistent"),
                "no such file",
            ),
            (BASE.replace("values = [10, 100]", "values = []"), "empty"),
        ];
        for (text, expect) in cases {
            let e = sweep(&text).unwrap_err();
            assert!(e.contains(expect), "{expect:?} not in {e:?}");
        }
    }

    fn result(dt: f64, mean: f64, stderr: f64, wall: f64) -> PointResult {
        PointResult {
            knob_values: vec![dt.to_string()],
            status: Status::Done {
                values: vec![(mean, stderr)],
                wall_seconds: wall,
                cpu_seconds: None,
                bytes_per_particle: None,
            },
        }
    }

    /// Plain Brownian dynamics and BDDFS in one sweep: a bundle sets several keys as one knob
    /// value, labelled by its entries.
    #[test]
    fn a_bundle_value_sets_several_keys_and_is_labelled_by_them() {
        let s = sweep(
            r#"
            case = "../cases/bddfs_fene_shear_2d.toml"
            [[knob]]
            key = "method"
            values = [{ polymer = { kind = "dumbbells" } },
                      { polymer = { kind = "bddfs", cells = 200 } }]
            [[knob]]
            key = "ensemble"
            values = [{ "flow.particles" = 20, "polymer.per_particle" = 10000 }]
            [[observable]]
            name = "polymer_viscosity"
            value = 0.613257
            "#,
        )
        .unwrap();
        // A bundle's entries in key order (a TOML table is unordered).
        assert_eq!(
            s.knobs[0].values,
            ["kind=dumbbells", "cells=200 kind=bddfs"]
        );
        assert_eq!(s.knobs[1].values, ["particles=20 per_particle=10000"]);
        let p = points(&s);
        assert_eq!(
            p[1],
            [
                "polymer.cells=200",
                "polymer.kind=\"bddfs\"",
                "flow.particles=20",
                "polymer.per_particle=10000"
            ]
        );
        assert_eq!(point_values(&s), [[0, 0], [1, 0]]);
        let e = sweep(
            r#"
            case = "../cases/bddfs_fene_shear_2d.toml"
            [[knob]]
            key = "method"
            values = [{}]
            [[observable]]
            name = "polymer_viscosity"
            value = 0.6
            "#,
        )
        .unwrap_err();
        assert!(e.contains("empty table"), "{e}");
    }

    /// The memory axis: the memory/error front and the leanest point meeting the tolerance.
    #[test]
    fn the_memory_front_and_the_leanest_point_that_meets_the_tolerance() {
        let s = one_knob("value = 1.0");
        let with_bytes = |dt: f64, mean: f64, wall: f64, bytes: f64| {
            let mut p = result(dt, mean, 0.001, wall);
            if let Status::Done {
                bytes_per_particle, ..
            } = &mut p.status
            {
                *bytes_per_particle = Some(bytes);
            }
            p
        };
        let r = vec![
            with_bytes(0.04, 1.005, 1.0, 16000.0), // cheapest in CPU, most memory
            with_bytes(0.02, 1.004, 2.0, 300.0),   // leanest that meets 0.01: on both fronts
            with_bytes(0.01, 1.060, 3.0, 100.0),   // leanest of all but 6 % off: memory front
            with_bytes(0.005, 1.005, 4.0, 400.0),  // beaten by the second on everything
        ];
        let a = analyse(&s, &r, Some(0.01)).unwrap();
        assert_eq!(a.pareto, [true, true, false, false]);
        assert_eq!(a.pareto_memory, [false, true, true, false]);
        assert_eq!(a.recommended, Some(0));
        assert!(
            a.recommendation.contains(
                "least memory for a tolerance of 0.01: integrator.dt=0.02 — 300 B per particle"
            ),
            "{}",
            a.recommendation
        );
        let csv = a.csv(&s);
        assert!(
            csv.lines()
                .next()
                .unwrap()
                .contains("bytes_per_particle,pareto_memory,pareto"),
            "{csv}"
        );
        assert!(
            csv.lines().nth(2).unwrap().ends_with(",300.0,1,1,0,0"),
            "{csv}"
        );
    }

    fn one_knob(reference: &str) -> Sweep {
        sweep(&format!(
            r#"
            case = "../cases/dumbbells_hookean_shear_3d.toml"
            [[knob]]
            key = "integrator.dt"
            values = [0.04, 0.02, 0.01]
            [[observable]]
            name = "polymer_viscosity"
            {reference}
            "#
        ))
        .unwrap()
    }

    #[test]
    fn richardson_removes_a_second_order_bias_exactly() {
        // A(h) = 1 + 3h²: the two smallest steps extrapolate to exactly 1.
        let s = one_knob("reference = \"richardson\"\norder = 2");
        let r: Vec<PointResult> = [0.04, 0.02, 0.01]
            .iter()
            .map(|&h| result(h, 1.0 + 3.0 * h * h, 0.001, 1.0 / h))
            .collect();
        let a = analyse(&s, &r, Some(0.002)).unwrap();
        assert!(
            (a.references[0].0 - 1.0).abs() < 1e-12,
            "{:?}",
            a.references
        );
        // σ* = √((1 + c)² + c²) σ with c = 1/3.
        let c: f64 = 1.0 / 3.0;
        let expect = ((1.0 + c).powi(2) + c * c).sqrt() * 0.001;
        assert!((a.references[0].1 - expect).abs() < 1e-15);
        // Errors 3h²: 4.8e-3, 1.2e-3, 3e-4; only Δt = 0.01 has e + 2s ≤ 2e-3... s is √(σ²+σ*²)
        // ≈ 1.7e-3, so none meets 2e-3 with 2σ to spare.
        assert_eq!(a.recommended, None);
        let a = analyse(&s, &r, Some(0.006)).unwrap();
        // Δt = 0.02: 1.2e-3 + 2 × 1.70e-3 = 4.6e-3 ≤ 6e-3, and cheaper than Δt = 0.01.
        assert_eq!(a.recommended, Some(1));
        let e = a.errors[0].as_ref().unwrap()[0];
        assert!((e.error - 3.0 * 0.04 * 0.04).abs() < 1e-12);
        assert!((e.systematic - (e.error.powi(2) - e.statistical.powi(2)).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn the_pareto_front_holds_the_points_nothing_beats_on_both_cost_and_error() {
        let s = one_knob("value = 1.0");
        let r = vec![
            result(0.04, 1.10, 0.0, 1.0),  // cheap, bad: on the front
            result(0.02, 1.12, 0.0, 2.0),  // dearer and worse than the first: off
            result(0.01, 1.01, 0.0, 4.0),  // dear, good: on
            result(0.005, 1.01, 0.0, 8.0), // as good, dearer: off
        ];
        let a = analyse(&s, &r, Some(0.05)).unwrap();
        assert_eq!(a.pareto, [true, false, true, false]);
        assert_eq!(a.recommended, Some(2));
        let csv = a.csv(&s);
        assert_eq!(csv.lines().count(), 5);
        assert!(csv.lines().nth(3).unwrap().ends_with(",1,0,1"), "{csv}");
    }

    /// A recommendation at the cheap end of a knob's sweep says so; one inside it does not.
    #[test]
    fn a_recommendation_at_the_cheap_edge_of_the_sweep_is_flagged() {
        let s = one_knob("value = 1.0");
        // Every point meets 0.05: the cheapest, Δt = 0.04, is the first value listed.
        let r = vec![
            result(0.04, 1.001, 0.0, 1.0),
            result(0.02, 1.001, 0.0, 2.0),
            result(0.01, 1.0, 0.0, 4.0),
        ];
        let a = analyse(&s, &r, Some(0.05)).unwrap();
        assert_eq!(a.recommended, Some(0));
        assert!(
            a.recommendation
                .contains("edge of the sweep in integrator.dt (integrator.dt=0.04"),
            "{}",
            a.recommendation
        );
        // Δt = 0.04 too inaccurate: Δt = 0.02 is recommended, inside the sweep: no warning.
        let r = vec![
            result(0.04, 1.2, 0.0, 1.0),
            result(0.02, 1.001, 0.0, 2.0),
            result(0.01, 1.0, 0.0, 4.0),
        ];
        let a = analyse(&s, &r, Some(0.05)).unwrap();
        assert_eq!(a.recommended, Some(1));
        assert!(!a.recommendation.contains("edge"), "{}", a.recommendation);
    }

    /// A categorical knob (here the dumbbell scheme) has no edge to extend past: the cheapest
    /// scheme recommended is not flagged. Mutation: the `numeric` guard in `cheap_edges`
    /// removed flags `polymer.scheme`.
    #[test]
    fn a_recommendation_at_the_end_of_a_categorical_knob_is_not_flagged() {
        let s = sweep(
            r#"
            case = "../cases/dumbbells_hookean_shear_3d.toml"
            [[knob]]
            key = "polymer.scheme"
            values = ["euler_maruyama", "heun"]
            [[observable]]
            name = "polymer_viscosity"
            value = 1.0
            "#,
        )
        .unwrap();
        let point = |scheme: &str, wall: f64| PointResult {
            knob_values: vec![s.knobs[0].values[usize::from(scheme == "heun")].clone()],
            status: Status::Done {
                values: vec![(1.001, 0.0)],
                wall_seconds: wall,
                cpu_seconds: None,
                bytes_per_particle: None,
            },
        };
        let r = vec![point("euler_maruyama", 1.0), point("heun", 2.0)];
        let a = analyse(&s, &r, Some(0.05)).unwrap();
        assert_eq!(a.recommended, Some(0));
        assert!(!a.recommendation.contains("edge"), "{}", a.recommendation);
    }

    #[test]
    fn the_converged_reference_is_the_most_expensive_point_and_never_the_recommendation() {
        let s = one_knob("reference = \"converged\"");
        let r = vec![
            result(0.04, 1.10, 0.001, 1.0),
            result(0.02, 1.02, 0.001, 2.0),
            result(0.01, 1.00, 0.001, 4.0),
        ];
        let a = analyse(&s, &r, Some(0.5)).unwrap();
        assert_eq!(a.reference_point, Some(2));
        assert_eq!(a.references[0], (1.0, 0.001));
        assert_eq!(a.recommended, Some(0));
        let a = analyse(&s, &r, Some(0.03)).unwrap();
        assert_eq!(a.recommended, Some(1));
        let a = analyse(&s, &r, Some(0.001)).unwrap();
        assert_eq!(
            a.recommended, None,
            "the reference itself is not recommended"
        );
    }

    #[test]
    fn unstable_and_refused_points_are_kept_out_of_the_analysis() {
        let s = one_knob("value = 1.0");
        let mut r = vec![result(0.01, 1.0, 0.001, 4.0)];
        r.push(PointResult {
            knob_values: vec!["0.04".into()],
            status: Status::Unstable("particle 3 …".into()),
        });
        r.push(PointResult {
            knob_values: vec!["0.02".into()],
            status: Status::Refused("Δt beyond".into()),
        });
        let a = analyse(&s, &r, Some(0.1)).unwrap();
        assert_eq!(a.pareto, [true, false, false]);
        assert!(
            a.recommendation
                .contains("1 point(s) blew up and 1 were refused")
        );
        assert!(a.csv(&s).contains("0.04,unstable"));
    }

    /// The cost of a point is its processes' CPU time, not the time it took: a child that
    /// sleeps 0.4 s costs (almost) nothing, a child that computes costs what it computes.
    /// Mutation: measuring the wall time around the child (the old cost) fails the first check.
    #[test]
    fn a_points_cost_is_its_cpu_time_not_its_wall_time() {
        let cpu = |script: &str| {
            let before = run::children_cpu_seconds().expect("getrusage");
            let start = std::time::Instant::now();
            let status = Command::new("sh")
                .args(["-c", script])
                .status()
                .expect("sh");
            assert!(status.success());
            (
                run::children_cpu_seconds().expect("getrusage") - before,
                start.elapsed().as_secs_f64(),
            )
        };
        let (sleeping, wall) = cpu("sleep 0.4");
        assert!(wall >= 0.4, "slept {wall} s");
        // A sleeping shell uses a few milliseconds of CPU to start.
        assert!(
            sleeping < 0.1,
            "a sleeping child cost {sleeping} CPU seconds"
        );
        let (busy, _) = cpu("i=0; while [ $i -lt 300000 ]; do i=$((i+1)); done");
        // 300 000 shell additions take ~0.2–1 s of CPU on anything current.
        assert!(
            busy > 0.05,
            "a computing child cost only {busy} CPU seconds"
        );
    }
}
