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
//! The study's error of a point is the largest e over its observables; its cost is the run's
//! wall time × ranks × threads (core-seconds). A point is on the Pareto front when no other
//! point is both cheaper and more accurate. The recommendation for a target tolerance τ is the
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
#[derive(Clone, Debug)]
pub struct Knob {
    pub key: String,
    pub values: Vec<String>,
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
        knobs.push(Knob {
            key: k.key.clone(),
            values: k.values.iter().map(toml_text).collect(),
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
/// slowest), each as its list of `key=value` overrides.
pub fn points(sweep: &Sweep) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = vec![Vec::new()];
    for k in &sweep.knobs {
        out = out
            .into_iter()
            .flat_map(|p| {
                k.values.iter().map(move |v| {
                    let mut q = p.clone();
                    q.push(format!("{}={v}", k.key));
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
        let varied = |key: &str| sweep.knobs.iter().any(|k| k.key == key);
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

/// What became of one point.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Ran to the end: per observable (mean, stderr), and the cost.
    Done {
        values: Vec<(f64, f64)>,
        wall_seconds: f64,
    },
    /// Refused by the case validation (the message says why).
    Refused(String),
    /// Stopped by a blow-up detector (exit code 4).
    Unstable(String),
}

/// One point's knob values (as given) and its outcome.
#[derive(Clone, Debug)]
pub struct PointResult {
    pub knob_values: Vec<String>,
    pub status: Status,
}

/// How to run the points.
pub struct StudyOptions {
    /// The study's folder (points/, study.csv, study.png, recommendation.txt).
    pub out: PathBuf,
    /// The mesorheo executable that runs each point.
    pub exe: PathBuf,
    /// Target tolerance of the recommendation (overrides the sweep's).
    pub target: Option<f64>,
    /// Run every point again even when done.
    pub rerun: bool,
    /// Python with matplotlib for the PNG (none: no plot).
    pub python: Option<PathBuf>,
    /// Progress lines on stderr.
    pub progress: bool,
    /// The environment of the child runs (see [`Launch::env`]).
    pub child_env: Option<Vec<(std::ffi::OsString, std::ffi::OsString)>>,
}

#[derive(serde::Serialize, Deserialize)]
struct PointRecord {
    overrides: Vec<String>,
    status: String,
    message: String,
}

/// Runs (or resumes) every point of the sweep, then analyses and writes the outputs.
pub fn run_study(sweep: &Sweep, opts: &StudyOptions) -> Result<Analysis, String> {
    let pts = points(sweep);
    let base = crate::config::load_scene(&sweep.case, &sweep.set)
        .map_err(|e| format!("the sweep's case with its `set` overrides: {e}"))?;
    let base = base.scene.dt_and_run();
    let full: Vec<Vec<String>> = pts
        .iter()
        .map(|p| point_overrides(sweep, Some((base.0, base.1)), p))
        .collect();
    // Every point is validated before anything runs: a typo in a knob key fails now, not after
    // the first hours of a sweep. A value refused by the validation is a refused point.
    let mut refused = BTreeMap::new();
    for (i, all) in full.iter().enumerate() {
        if let Err(e) = crate::config::load_scene(&sweep.case, all) {
            refused.insert(i, e.to_string());
        }
    }
    if refused.len() == pts.len() {
        let (_, first) = refused.iter().next().expect("at least one point");
        return Err(format!(
            "every point of the sweep is refused by the case validation; the first: {first}"
        ));
    }
    let dir = opts.out.join("points");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut results = Vec::with_capacity(pts.len());
    for (i, p) in pts.iter().enumerate() {
        let knob_values: Vec<String> = p
            .iter()
            .map(|o| o.split_once('=').map_or("", |(_, v)| v).to_string())
            .collect();
        let label = p.join(" ");
        let point_dir = dir.join(format!("{i:03}"));
        let status = if let Some(msg) = refused.get(&i) {
            Status::Refused(msg.clone())
        } else {
            match (!opts.rerun)
                .then(|| read_done(&point_dir, &full[i], &sweep.observables))
                .flatten()
            {
                Some(s) => s,
                None => {
                    if opts.progress {
                        eprintln!("[study] point {}/{}: {label} …", i + 1, pts.len());
                    }
                    run_point(sweep, opts, &full[i], &point_dir)?
                }
            }
        };
        if opts.progress {
            eprintln!(
                "[study] point {}/{}: {label}: {}",
                i + 1,
                pts.len(),
                describe(&status, &sweep.observables)
            );
        }
        results.push(PointResult {
            knob_values,
            status,
        });
    }
    let target = opts.target.or(sweep.target);
    let analysis = analyse(sweep, &results, target)?;
    let csv = opts.out.join("study.csv");
    std::fs::write(&csv, analysis.csv(sweep))
        .map_err(|e| format!("cannot write {}: {e}", csv.display()))?;
    let rec = opts.out.join("recommendation.txt");
    std::fs::write(&rec, &analysis.recommendation)
        .map_err(|e| format!("cannot write {}: {e}", rec.display()))?;
    if let Some(python) = &opts.python {
        let png = opts.out.join("study.png");
        match plot(python, &csv, &png, &sweep.title, target) {
            Ok(()) => {}
            Err(e) => eprintln!("[study] warning: no plot ({e}); the CSV is complete"),
        }
    }
    Ok(analysis)
}

fn describe(status: &Status, obs: &[ObservableSpec]) -> String {
    match status {
        Status::Done {
            values,
            wall_seconds,
        } => {
            let v: Vec<String> = obs
                .iter()
                .zip(values)
                .map(|(o, (m, s))| format!("{} = {m:.6} ± {s:.2e}", o.name))
                .collect();
            format!("{} ({wall_seconds:.1} s)", v.join(", "))
        }
        Status::Refused(m) => format!("refused: {m}"),
        Status::Unstable(m) => format!("unstable: {m}"),
    }
}

/// A finished point from an earlier (interrupted) invocation, if its overrides are the same.
fn read_done(point_dir: &Path, overrides: &[String], obs: &[ObservableSpec]) -> Option<Status> {
    let text = std::fs::read_to_string(point_dir.join("point.json")).ok()?;
    let rec: PointRecord = serde_json::from_str(&text).ok()?;
    if rec.overrides != overrides {
        return None;
    }
    match rec.status.as_str() {
        "done" => read_summary(point_dir, obs).ok(),
        "unstable" => Some(Status::Unstable(rec.message)),
        _ => None,
    }
}

fn read_summary(point_dir: &Path, obs: &[ObservableSpec]) -> Result<Status, String> {
    let path = point_dir.join("summary.json");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| format!("{}: not a summary ({e})", path.display()))?;
    let wall_seconds = v["wall_seconds"]
        .as_f64()
        .ok_or_else(|| format!("{}: no wall_seconds", path.display()))?;
    let available = v["observables"]
        .as_object()
        .ok_or_else(|| format!("{}: no observables", path.display()))?;
    let mut values = Vec::new();
    for o in obs {
        let e = available.get(&o.name).ok_or_else(|| {
            format!(
                "the observable {} is not in {} (it has: {})",
                o.name,
                path.display(),
                available.keys().cloned().collect::<Vec<_>>().join(", ")
            )
        })?;
        let mean = e["mean"].as_f64().unwrap_or(f64::NAN);
        let stderr = e["stderr"].as_f64().unwrap_or(f64::NAN);
        values.push((mean, stderr));
    }
    Ok(Status::Done {
        values,
        wall_seconds,
    })
}

fn run_point(
    sweep: &Sweep,
    opts: &StudyOptions,
    overrides: &[String],
    point_dir: &Path,
) -> Result<Status, String> {
    let _ = std::fs::remove_file(point_dir.join("point.json"));
    std::fs::create_dir_all(point_dir)
        .map_err(|e| format!("cannot create {}: {e}", point_dir.display()))?;
    let (code, last_error) = launch(
        &opts.exe,
        &Launch {
            case: &sweep.case,
            ranks: sweep.ranks,
            threads: sweep.threads,
            launcher: &sweep.launcher,
            env: opts.child_env.as_deref(),
        },
        point_dir,
        overrides,
    )?;
    // 0: done; 3: done, but the case's own reference checks failed (expected away from the
    // case's own settings); 4: a blow-up.
    let status = match code {
        Some(0 | 3) => read_summary(point_dir, &sweep.observables)?,
        Some(4) => Status::Unstable(last_error.clone()),
        _ => {
            return Err(format!(
                "the run of the point {} failed (exit {code:?}): {last_error} (its output is in \
                 {}/)",
                overrides.join(" "),
                point_dir.display()
            ));
        }
    };
    let record = PointRecord {
        overrides: overrides.to_vec(),
        status: match status {
            Status::Done { .. } => "done",
            Status::Unstable(_) => "unstable",
            Status::Refused(_) => "refused",
        }
        .into(),
        message: if matches!(status, Status::Unstable(_)) {
            last_error
        } else {
            String::new()
        },
    };
    let text = serde_json::to_string_pretty(&record).map_err(|e| e.to_string())?;
    std::fs::write(point_dir.join("point.json"), text)
        .map_err(|e| format!("cannot write {}/point.json: {e}", point_dir.display()))?;
    Ok(status)
}

/// How a child run is started.
pub struct Launch<'a> {
    pub case: &'a Path,
    pub ranks: usize,
    pub threads: usize,
    /// Command prefix for ranks > 1, `{ranks}` replaced.
    pub launcher: &'a str,
    /// The environment the children get (None: this process's). Under an MPI build it must be
    /// the environment from before `MPI_Init`: a singleton's PMIx variables would make a child
    /// `mpirun` or `mesorheo` join the parent's job instead of starting its own.
    pub env: Option<&'a [(std::ffi::OsString, std::ffi::OsString)]>,
}

/// Runs `mesorheo run` once as a child process in `dir` with `overrides` (and no checkpoint at
/// the end: a study reruns a point, it does not extend it). Returns the exit code (0: done;
/// 3: done, but the case's own reference checks failed, as expected away from its settings;
/// 4: a blow-up; 2: refused) and the last `error:` line of its stderr, kept in
/// `dir/stderr.txt`.
pub fn launch(
    exe: &Path,
    how: &Launch,
    dir: &Path,
    overrides: &[String],
) -> Result<(Option<i32>, String), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut argv: Vec<String> = Vec::new();
    if how.ranks > 1 {
        argv.extend(
            how.launcher
                .replace("{ranks}", &how.ranks.to_string())
                .split_whitespace()
                .map(str::to_string),
        );
    }
    argv.push(exe.display().to_string());
    argv.extend(
        [
            "run",
            &how.case.display().to_string(),
            "--out",
            &dir.display().to_string(),
            "-q",
            "-t",
            &how.threads.to_string(),
        ]
        .map(str::to_string),
    );
    for o in overrides
        .iter()
        .map(String::as_str)
        .chain(["output.checkpoint_at_end=false"])
    {
        argv.push("--set".into());
        argv.push(o.to_string());
    }
    let mut command = Command::new(&argv[0]);
    command.args(&argv[1..]);
    if let Some(env) = how.env {
        command.env_clear().envs(env.iter().map(|(k, v)| (k, v)));
    }
    let output = command
        .output()
        .map_err(|e| format!("cannot start {}: {e}", argv[0]))?;
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    let _ = std::fs::write(dir.join("stderr.txt"), &stderr);
    let last_error = stderr
        .lines()
        .rev()
        .find(|l| l.starts_with("error:"))
        .unwrap_or("")
        .trim_start_matches("error: ")
        .to_string();
    Ok((output.status.code(), last_error))
}

/// One observable's error at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorParts {
    pub mean: f64,
    pub stderr: f64,
    /// |A − A*| (relative or absolute).
    pub error: f64,
    /// √(σ² + σ*²) on the same scale.
    pub statistical: f64,
    /// √(max(0, e² − s²)).
    pub systematic: f64,
}

/// The analysed study.
#[derive(Clone, Debug)]
pub struct Analysis {
    pub points: Vec<PointResult>,
    /// Per observable: the reference value and its standard error.
    pub references: Vec<(f64, f64)>,
    /// Per point (None unless done): per observable.
    pub errors: Vec<Option<Vec<ErrorParts>>>,
    /// Per point: core-seconds (NaN unless done).
    pub core_seconds: Vec<f64>,
    pub pareto: Vec<bool>,
    /// The point serving as the reference (converged / Richardson), if any.
    pub reference_point: Option<usize>,
    /// Index of the recommended point.
    pub recommended: Option<usize>,
    pub target: Option<f64>,
    /// Human-readable recommendation.
    pub recommendation: String,
}

fn done(p: &PointResult) -> Option<(&[(f64, f64)], f64)> {
    match &p.status {
        Status::Done {
            values,
            wall_seconds,
        } => Some((values, *wall_seconds)),
        _ => None,
    }
}

/// Errors, Pareto front and recommendation from the points' results.
pub fn analyse(
    sweep: &Sweep,
    results: &[PointResult],
    target: Option<f64>,
) -> Result<Analysis, String> {
    let cores = (sweep.ranks * sweep.threads) as f64;
    let core_seconds: Vec<f64> = results
        .iter()
        .map(|p| done(p).map_or(f64::NAN, |(_, w)| w * cores))
        .collect();
    let most_expensive = (0..results.len())
        .filter(|&i| core_seconds[i].is_finite())
        .max_by(|&a, &b| core_seconds[a].total_cmp(&core_seconds[b]))
        .ok_or("no point of the sweep completed (all refused or unstable)")?;
    let mut reference_point = None;
    let mut references = Vec::new();
    for (k, o) in sweep.observables.iter().enumerate() {
        let r = match &o.reference {
            Reference::Value { value, stderr } => (*value, *stderr),
            Reference::Converged => {
                reference_point = Some(most_expensive);
                let (v, _) = done(&results[most_expensive]).expect("done");
                v[k]
            }
            Reference::Richardson { knob, order } => {
                richardson(sweep, results, most_expensive, k, knob, *order)?
            }
        };
        references.push(r);
    }
    let mut errors = Vec::new();
    for (i, p) in results.iter().enumerate() {
        errors.push(done(p).map(|(values, _)| {
            values
                .iter()
                .zip(&references)
                .zip(&sweep.observables)
                .map(|((&(mean, stderr), &(r, rs)), o)| {
                    let scale = if o.relative { r.abs() } else { 1.0 };
                    let own = o.reference == Reference::Converged && Some(i) == reference_point;
                    let error = (mean - r).abs() / scale;
                    // The reference point against itself: no error, and the noise it shares
                    // with the reference cancels.
                    let statistical = if own {
                        0.0
                    } else {
                        (stderr * stderr + rs * rs).sqrt() / scale
                    };
                    ErrorParts {
                        mean,
                        stderr,
                        error,
                        statistical,
                        systematic: (error * error - statistical * statistical).max(0.0).sqrt(),
                    }
                })
                .collect()
        }));
    }
    let combined: Vec<f64> = errors
        .iter()
        .map(|e| {
            e.as_ref().map_or(f64::NAN, |e: &Vec<ErrorParts>| {
                e.iter().map(|p| p.error).fold(0.0, f64::max)
            })
        })
        .collect();
    let pareto: Vec<bool> = (0..results.len())
        .map(|i| {
            combined[i].is_finite()
                && !(0..results.len()).any(|j| {
                    j != i
                        && combined[j].is_finite()
                        && core_seconds[j] <= core_seconds[i]
                        && combined[j] <= combined[i]
                        && (core_seconds[j] < core_seconds[i] || combined[j] < combined[i])
                })
        })
        .collect();
    let recommended = target.and_then(|t| {
        (0..results.len())
            // The reference point's error against itself is 0 by construction: it is no
            // recommendation.
            .filter(|&i| Some(i) != reference_point)
            .filter(|&i| {
                errors[i]
                    .as_ref()
                    .is_some_and(|e| e.iter().all(|p| p.error + 2.0 * p.statistical <= t))
            })
            .min_by(|&a, &b| core_seconds[a].total_cmp(&core_seconds[b]))
    });
    let mut text = String::new();
    let names: Vec<&str> = sweep.knobs.iter().map(|k| k.key.as_str()).collect();
    let show = |i: usize| -> String {
        names
            .iter()
            .zip(&results[i].knob_values)
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let _ = writeln!(text, "study: {}", sweep.title);
    for (o, (r, rs)) in sweep.observables.iter().zip(&references) {
        let how = match &o.reference {
            Reference::Value { .. } => "given value".to_string(),
            Reference::Converged => format!("most expensive point ({})", show(most_expensive)),
            Reference::Richardson { knob, order } => {
                format!("Richardson extrapolation in {knob} (order {order})")
            }
        };
        let _ = writeln!(text, "reference {}: {r:.6} ± {rs:.2e} ({how})", o.name);
    }
    match (target, recommended) {
        (None, _) => {
            let _ = writeln!(
                text,
                "no target tolerance given (--target TOL): the Pareto front is marked in the CSV"
            );
        }
        (Some(t), Some(i)) => {
            let e = errors[i].as_ref().expect("done");
            let _ = writeln!(
                text,
                "recommended for a tolerance of {t}: {} — {:.1} core-s; {}",
                show(i),
                core_seconds[i],
                sweep
                    .observables
                    .iter()
                    .zip(e)
                    .map(|(o, p)| format!(
                        "{} error {:.3e} (statistical {:.1e}, systematic {:.1e})",
                        o.name, p.error, p.statistical, p.systematic
                    ))
                    .collect::<Vec<_>>()
                    .join("; ")
            );
        }
        (Some(t), None) => {
            let best = (0..results.len())
                .filter(|&i| combined[i].is_finite() && Some(i) != reference_point)
                .min_by(|&a, &b| combined[a].total_cmp(&combined[b]));
            let _ = writeln!(
                text,
                "no point meets a tolerance of {t} with 2σ to spare{}",
                best.map_or(String::new(), |b| format!(
                    "; the most accurate is {} with error {:.3e} ({:.1} core-s)",
                    show(b),
                    combined[b],
                    core_seconds[b]
                ))
            );
        }
    }
    let unstable = results
        .iter()
        .filter(|p| matches!(p.status, Status::Unstable(_)))
        .count();
    let refused_n = results
        .iter()
        .filter(|p| matches!(p.status, Status::Refused(_)))
        .count();
    if unstable + refused_n > 0 {
        let _ = writeln!(
            text,
            "{unstable} point(s) blew up and {refused_n} were refused by the case validation \
             (see study.csv)"
        );
    }
    Ok(Analysis {
        points: results.to_vec(),
        references,
        errors,
        core_seconds,
        pareto,
        reference_point,
        recommended,
        target,
        recommendation: text,
    })
}

fn richardson(
    sweep: &Sweep,
    results: &[PointResult],
    most_expensive: usize,
    k: usize,
    knob: &str,
    order: f64,
) -> Result<(f64, f64), String> {
    let at = sweep
        .knobs
        .iter()
        .position(|kn| kn.key == knob)
        .expect("validated");
    let anchor = &results[most_expensive].knob_values;
    let mut line: Vec<(f64, f64, f64)> = results
        .iter()
        .filter(|p| {
            p.knob_values
                .iter()
                .enumerate()
                .all(|(j, v)| j == at || *v == anchor[j])
        })
        .filter_map(|p| {
            let h = p.knob_values[at].parse::<f64>().ok()?;
            let (v, _) = done(p)?;
            Some((h, v[k].0, v[k].1))
        })
        .collect();
    line.sort_by(|a, b| a.0.total_cmp(&b.0));
    if line.len() < 2 || line[0].0 <= 0.0 || line[1].0 <= line[0].0 {
        return Err(format!(
            "Richardson extrapolation of {} in {knob}: fewer than two completed points with \
             distinct positive {knob} at the other knobs of the most expensive point",
            sweep.observables[k].name
        ));
    }
    let (h1, a1, s1) = line[0];
    let (h2, a2, s2) = line[1];
    let c = 1.0 / ((h2 / h1).powf(order) - 1.0);
    Ok((
        a1 + c * (a1 - a2),
        ((1.0 + c).powi(2) * s1 * s1 + c * c * s2 * s2).sqrt(),
    ))
}

impl Analysis {
    /// The CSV: knob values, status, per observable mean ± stderr, error, statistical and
    /// systematic parts, the study error, wall time, core-seconds, Pareto and recommendation.
    pub fn csv(&self, sweep: &Sweep) -> String {
        let mut s = String::new();
        let mut head: Vec<String> = sweep.knobs.iter().map(|k| k.key.clone()).collect();
        head.push("status".into());
        for o in &sweep.observables {
            for part in ["mean", "stderr", "error", "statistical", "systematic"] {
                head.push(format!("{}:{part}", o.name));
            }
        }
        head.extend(
            [
                "error",
                "wall_seconds",
                "core_seconds",
                "pareto",
                "reference",
                "recommended",
            ]
            .map(str::to_string),
        );
        let _ = writeln!(s, "{}", head.join(","));
        let cores = (sweep.ranks * sweep.threads) as f64;
        for (i, p) in self.points.iter().enumerate() {
            let mut row: Vec<String> = p.knob_values.iter().map(|v| csv_field(v)).collect();
            row.push(
                match &p.status {
                    Status::Done { .. } => "done",
                    Status::Refused(_) => "refused",
                    Status::Unstable(_) => "unstable",
                }
                .into(),
            );
            match &self.errors[i] {
                Some(e) => {
                    for q in e {
                        for x in [q.mean, q.stderr, q.error, q.statistical, q.systematic] {
                            row.push(format!("{x:.10e}"));
                        }
                    }
                    let worst = e.iter().map(|q| q.error).fold(0.0, f64::max);
                    row.push(format!("{worst:.10e}"));
                    row.push(format!("{:.3}", self.core_seconds[i] / cores));
                    row.push(format!("{:.3}", self.core_seconds[i]));
                }
                None => {
                    for _ in 0..sweep.observables.len() * 5 + 3 {
                        row.push(String::new());
                    }
                }
            }
            row.push(u8::from(self.pareto[i]).to_string());
            row.push(u8::from(self.reference_point == Some(i)).to_string());
            row.push(u8::from(self.recommended == Some(i)).to_string());
            let _ = writeln!(s, "{}", row.join(","));
        }
        s
    }
}

fn csv_field(v: &str) -> String {
    let v = v.trim_matches('"');
    if v.contains(',') || v.contains('"') {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_string()
    }
}

/// The plotting script (matplotlib), run with the CSV and the PNG paths.
const PLOT_SCRIPT: &str = include_str!("study_plot.py");

fn plot(
    python: &Path,
    csv: &Path,
    png: &Path,
    title: &str,
    target: Option<f64>,
) -> Result<(), String> {
    let output = Command::new(python)
        .arg("-c")
        .arg(PLOT_SCRIPT)
        .arg(csv)
        .arg(png)
        .arg(title)
        .arg(target.map_or(String::new(), |t| t.to_string()))
        .output()
        .map_err(|e| format!("cannot start {}: {e}", python.display()))?;
    if output.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{} failed: {}",
            python.display(),
            String::from_utf8_lossy(&output.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ))
    }
}

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
            },
        }
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
}
