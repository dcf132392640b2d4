//! `mesorheo stability CASE --vary KEY --over KEY2=a..b`: the largest stable value of a knob
//! (usually the time step), measured by bisection at each value of a second parameter, beside
//! what `check` accepts.
//!
//! A trial is an ordinary run of the case with `run.beyond_stability_limits = true` (so that
//! `check`'s limits do not refuse it) for a fixed number of steps; it is *unstable* when a
//! blow-up detector stops it (exit code 4: a non-finite or runaway particle, a DPD particle
//! beyond 100 k_BT + a n_c, a DPD fluid hotter than 2 k_BT, a dumbbell outside its spring's
//! domain, …) and *stable* when it completes.
//! At each value x of the second parameter:
//!
//! 1. bracket: from the case's value v₀ of the knob, double while stable (or halve while
//!    unstable) until a stable v_s and an unstable v_u = 2 v_s are found;
//! 2. bisect geometrically, v = √(v_s v_u), until v_u / v_s ≤ 1 + tolerance.
//!
//! `check`'s verdict is the case validation without `beyond_stability_limits`; its limit v_c
//! (the largest accepted value) is found by bisection on the validation alone, to 10⁻⁶. The
//! map is consistent with `check` when, at every x, `check` refuses the unstable value
//! (v_c < v_u) and accepts at least 80 % of the stable range (v_c ≥ 0.8 v_s).
//!
//! The measured boundary depends on the run length: a step just beyond the limit may take
//! longer than the run to blow up, so v_s is an upper estimate for short runs.

use crate::study::{Launch, launch};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The fraction of the measured stable range `check` must accept.
pub const CHECK_ACCEPTS_AT_LEAST: f64 = 0.8;

/// Doublings or halvings tried when bracketing: beyond 2¹² × the case's value a knob is
/// reported stable over the whole bracket (smallest unstable = ∞).
const MAX_BRACKET: usize = 12;

/// What to map.
pub struct StabilityRequest {
    pub case: PathBuf,
    /// The knob whose largest stable value is measured (e.g. integrator.dt).
    pub vary: String,
    /// The second parameter and its values.
    pub over: String,
    pub over_values: Vec<f64>,
    /// Steps of every trial run.
    pub steps: u64,
    /// Bisection stops when v_u / v_s ≤ 1 + tolerance.
    pub tolerance: f64,
    /// Fixed overrides of every trial.
    pub set: Vec<String>,
    pub threads: usize,
    pub out: PathBuf,
    pub exe: PathBuf,
    pub python: Option<PathBuf>,
    pub progress: bool,
    /// The environment of the trial runs (see [`crate::study::Launch::env`]).
    pub child_env: Option<Vec<(std::ffi::OsString, std::ffi::OsString)>>,
}

/// One row of the map.
#[derive(Clone, Debug)]
pub struct MapRow {
    pub over: f64,
    /// Largest value found stable.
    pub stable: f64,
    /// Smallest value found unstable.
    pub unstable: f64,
    /// `check`'s largest accepted value (None: no limit found up to 2¹² v₀).
    pub check_limit: Option<f64>,
    pub runs: usize,
    /// The diagnosis of the run at `unstable`.
    pub diagnosis: String,
}

impl MapRow {
    /// `check` refuses the measured unstable value.
    pub fn check_refuses_unstable(&self) -> bool {
        // No unstable value was found: nothing to refuse.
        self.unstable.is_infinite() || self.check_limit.is_some_and(|c| c < self.unstable)
    }

    /// v_c / v_s, capped at 1: the share of the measured stable range `check` accepts.
    pub fn check_accepts(&self) -> f64 {
        self.check_limit.map_or(1.0, |c| (c / self.stable).min(1.0))
    }
}

/// Parses `KEY=a..b` (with `points` values, evenly spaced, or geometrically with `log`) or
/// `KEY=v1,v2,…`.
pub fn parse_over(text: &str, points: usize, log: bool) -> Result<(String, Vec<f64>), String> {
    let (key, spec) = text.split_once('=').ok_or_else(|| {
        format!("--over {text}: expected KEY=a..b or KEY=v1,v2,… (e.g. fluid.gamma=2..40)")
    })?;
    let num = |s: &str| {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("--over {text}: {s:?} is not a finite number"))
    };
    let values = if let Some((a, b)) = spec.split_once("..") {
        let (a, b) = (num(a)?, num(b)?);
        if points < 2 {
            return Err(format!("--points {points}: a range needs at least 2"));
        }
        if log && (a <= 0.0 || b <= 0.0) {
            return Err(format!("--over {text} with --log: both ends must be > 0"));
        }
        (0..points)
            .map(|i| {
                let f = i as f64 / (points - 1) as f64;
                if log {
                    a * (b / a).powf(f)
                } else {
                    a + (b - a) * f
                }
            })
            .collect()
    } else {
        spec.split(',').map(num).collect::<Result<Vec<_>, _>>()?
    };
    if key.trim().is_empty() || values.is_empty() {
        return Err(format!("--over {text}: give a key and at least one value"));
    }
    Ok((key.trim().to_string(), values))
}

/// A number as `--set` reads it (always with a decimal point or exponent, so a float key gets a
/// float).
fn toml_number(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// The override that sets the second parameter to `x`: a float (`toml_number`) unless the key
/// takes an integer (e.g. `seed`, to measure the spread over seeds) and `x` is whole, when the
/// float form is refused and the integer form is read.
fn over_assignment(req: &StabilityRequest, x: f64) -> String {
    let float = format!("{}={}", req.over, toml_number(x));
    if x.fract() != 0.0 || x.abs() >= 2f64.powi(53) {
        return float;
    }
    let reads = |assignment: &str| {
        let mut o = req.set.clone();
        o.push(assignment.to_string());
        o.push("run.beyond_stability_limits=true".into());
        crate::config::load_scene(&req.case, &o).is_ok()
    };
    let integer = format!("{}={}", req.over, x as i64);
    if !reads(&float) && reads(&integer) {
        integer
    } else {
        float
    }
}

/// The knob's value in the case (with the fixed overrides), read from the case text.
fn case_value(req: &StabilityRequest, overrides: &[String]) -> Result<f64, String> {
    // The case's own value may be beyond check's limits under these overrides.
    let mut o = overrides.to_vec();
    o.push("run.beyond_stability_limits=true".into());
    let text = crate::config::load_scene(&req.case, &o)
        .map_err(|e| format!("the case with the fixed overrides: {e}"))?
        .source;
    let table: toml::Table = toml::from_str(&text).map_err(|e| e.to_string())?;
    let mut item = toml::Value::Table(table);
    for part in req.vary.split('.') {
        item = item
            .get(part)
            .cloned()
            .ok_or_else(|| format!("{}: the case has no key {}", req.case.display(), req.vary))?;
    }
    item.as_float()
        .or_else(|| item.as_integer().map(|i| i as f64))
        .filter(|v| *v > 0.0)
        .ok_or_else(|| {
            format!(
                "{}: {} = {item} is not a positive number (the bisection needs one)",
                req.case.display(),
                req.vary
            )
        })
}

/// `check`'s largest accepted value of the knob at these overrides (None: accepted up to
/// 2¹² × `start`).
fn check_limit(req: &StabilityRequest, fixed: &[String], start: f64) -> Option<f64> {
    let accepted = |v: f64| {
        let mut o = fixed.to_vec();
        o.push(format!("{}={}", req.vary, toml_number(v)));
        crate::config::load_scene(&req.case, &o).is_ok()
    };
    let (mut lo, mut hi) = (start, start);
    if accepted(start) {
        for _ in 0..MAX_BRACKET {
            hi *= 2.0;
            if !accepted(hi) {
                break;
            }
            lo = hi;
        }
        if accepted(hi) {
            return None;
        }
    } else {
        let mut found = false;
        for _ in 0..4 * MAX_BRACKET {
            lo *= 0.5;
            if accepted(lo) {
                found = true;
                break;
            }
            hi = lo;
        }
        if !found {
            return Some(0.0);
        }
    }
    while hi / lo > 1.0 + 1e-6 {
        let mid = (lo * hi).sqrt();
        if accepted(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(lo)
}

/// Measures the map and writes `stability.csv` (and `stability.png`) in `req.out`.
pub fn run_stability(req: &StabilityRequest) -> Result<Vec<MapRow>, String> {
    if !(req.tolerance > 0.0 && req.tolerance.is_finite()) {
        return Err(format!(
            "--tolerance {}: must be > 0 (e.g. 0.05)",
            req.tolerance
        ));
    }
    std::fs::create_dir_all(&req.out)
        .map_err(|e| format!("cannot create {}: {e}", req.out.display()))?;
    let mut rows = Vec::new();
    let mut trial = 0usize;
    for (k, &x) in req.over_values.iter().enumerate() {
        let mut fixed = req.set.clone();
        fixed.push(over_assignment(req, x));
        let start = case_value(req, &fixed)?;
        let mut runs = 0usize;
        let mut last_diagnosis = String::new();
        let mut stable_at = |v: f64, diag: &mut String| -> Result<bool, String> {
            let mut o = fixed.clone();
            o.push(format!("{}={}", req.vary, toml_number(v)));
            o.push("run.beyond_stability_limits=true".into());
            o.push(format!("run.steps={}", req.steps));
            // The second half is sampled, so the heating detector (which watches the samples
            // after the equilibration) judges it, as it would in a run of the case.
            o.push(format!("run.equilibration={}", req.steps / 2));
            let dir = req.out.join("runs").join(format!("{k:02}_{trial:03}"));
            trial += 1;
            runs += 1;
            let (code, error) = launch(
                &req.exe,
                &Launch {
                    case: &req.case,
                    ranks: 1,
                    threads: req.threads,
                    launcher: "",
                    env: req.child_env.as_deref(),
                },
                &dir,
                &o,
            )?;
            let stable = match code {
                Some(0 | 3) => true,
                Some(4) => {
                    *diag = error;
                    false
                }
                _ => {
                    return Err(format!(
                        "the trial {} = {v:e} at {} = {x} failed (exit {code:?}): {error} (its \
                         output is in {}/)",
                        req.vary,
                        req.over,
                        dir.display()
                    ));
                }
            };
            if req.progress {
                eprintln!(
                    "[stability] {} = {x}: {} = {v:.5e} {}",
                    req.over,
                    req.vary,
                    if stable { "stable" } else { "UNSTABLE" }
                );
            }
            Ok(stable)
        };
        let (mut lo, mut hi);
        if stable_at(start, &mut last_diagnosis)? {
            lo = start;
            hi = start;
            let mut found = false;
            for _ in 0..MAX_BRACKET {
                hi *= 2.0;
                if !stable_at(hi, &mut last_diagnosis)? {
                    found = true;
                    break;
                }
                lo = hi;
            }
            if !found {
                // Stable over the whole bracket (an unconditionally stable scheme).
                lo = hi;
                hi = f64::INFINITY;
            }
        } else {
            hi = start;
            lo = start;
            let mut found = false;
            for _ in 0..MAX_BRACKET {
                lo *= 0.5;
                if stable_at(lo, &mut last_diagnosis)? {
                    found = true;
                    break;
                }
                hi = lo;
            }
            if !found {
                return Err(format!(
                    "{} = {x}: unstable down to {} = {lo:e}; is the case stable at all?",
                    req.over, req.vary
                ));
            }
        }
        let mut diagnosis = last_diagnosis.clone();
        while hi.is_finite() && hi / lo > 1.0 + req.tolerance {
            let mid = (lo * hi).sqrt();
            if stable_at(mid, &mut last_diagnosis)? {
                lo = mid;
            } else {
                hi = mid;
                diagnosis = last_diagnosis.clone();
            }
        }
        let row = MapRow {
            over: x,
            stable: lo,
            unstable: hi,
            check_limit: check_limit(req, &fixed, lo),
            runs,
            diagnosis,
        };
        if req.progress {
            eprintln!("[stability] {}", describe(req, &row));
        }
        rows.push(row);
    }
    let csv = req.out.join("stability.csv");
    std::fs::write(&csv, to_csv(req, &rows))
        .map_err(|e| format!("cannot write {}: {e}", csv.display()))?;
    if let Some(python) = &req.python {
        let png = req.out.join("stability.png");
        let output = std::process::Command::new(python)
            .arg("-c")
            .arg(PLOT_SCRIPT)
            .arg(&csv)
            .arg(&png)
            .arg(format!("{}", req.case.display()))
            .arg(&req.vary)
            .arg(req.steps.to_string())
            .output();
        match output {
            Ok(o) if o.status.success() => {}
            Ok(o) => eprintln!(
                "[stability] warning: no plot ({})",
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            ),
            Err(e) => eprintln!(
                "[stability] warning: no plot (cannot start {}: {e})",
                python.display()
            ),
        }
    }
    Ok(rows)
}

fn describe(req: &StabilityRequest, r: &MapRow) -> String {
    format!(
        "{} = {}: stable up to {} = {:.4e}, unstable at {:.4e} ({} runs); check accepts up to {} \
         → refuses the unstable value: {}, accepts {:.0} % of the stable range",
        req.over,
        r.over,
        req.vary,
        r.stable,
        r.unstable,
        r.runs,
        r.check_limit
            .map_or("any value".to_string(), |c| format!("{c:.4e}")),
        if r.check_refuses_unstable() {
            "yes"
        } else {
            "NO"
        },
        100.0 * r.check_accepts()
    )
}

/// The report printed at the end: a line per row and the verdict against `check`.
pub fn report(req: &StabilityRequest, rows: &[MapRow]) -> String {
    let mut s = String::new();
    for r in rows {
        let _ = writeln!(s, "{}", describe(req, r));
    }
    let refuses = rows.iter().all(MapRow::check_refuses_unstable);
    let least = rows.iter().map(MapRow::check_accepts).fold(1.0, f64::min);
    let _ = writeln!(
        s,
        "check refuses every unstable point: {}; accepts at least {:.0} % of the stable range \
         (required: {:.0} %): {}",
        if refuses { "yes" } else { "NO" },
        100.0 * least,
        100.0 * CHECK_ACCEPTS_AT_LEAST,
        if least >= CHECK_ACCEPTS_AT_LEAST {
            "yes"
        } else {
            "NO"
        }
    );
    s
}

fn to_csv(req: &StabilityRequest, rows: &[MapRow]) -> String {
    let mut s = format!(
        "{},largest_stable,smallest_unstable,check_limit,check_refuses_unstable,\
         check_accepts_fraction,runs,steps,diagnosis\n",
        req.over
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{:.6e},{:.6e},{},{},{:.4},{},{},\"{}\"",
            r.over,
            r.stable,
            r.unstable,
            r.check_limit.map_or(String::new(), |c| format!("{c:.6e}")),
            u8::from(r.check_refuses_unstable()),
            r.check_accepts(),
            r.runs,
            req.steps,
            r.diagnosis.replace('"', "'")
        );
    }
    s
}

const PLOT_SCRIPT: &str = r#"
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
path, png, case, vary, steps = sys.argv[1:6]
with open(path, newline="") as f:
    r = csv.reader(f); head = next(r); rows = list(r)
x = [float(v[0]) for v in rows]
st = [float(v[1]) for v in rows]
un = [float(v[2]) for v in rows]
ck = [float(v[3]) if v[3] else float("nan") for v in rows]
fig, ax = plt.subplots(figsize=(6, 4.2))
ax.fill_between(x, st, un, color="C3", alpha=0.25, label="boundary bracket")
ax.plot(x, st, "o-", color="C0", label="largest stable (measured)")
ax.plot(x, un, "x", color="C3", label="smallest unstable (measured)")
ax.plot(x, ck, "s--", color="C2", mfc="none", label="check's limit")
ax.set_xlabel(head[0]); ax.set_ylabel(vary + " (log scale)")
ax.set_yscale("log")
ax.set_title(f"{case}\nstability boundary in {vary} (stable: {steps} steps without a blow-up)",
             fontsize=8)
ax.legend(fontsize=7)
fig.tight_layout(); fig.savefig(png, dpi=110)
"#;

/// Path helper for the default output folder: `out/stability/<case stem>`.
pub fn default_out(case: &Path) -> PathBuf {
    let stem = case
        .file_stem()
        .map_or("case".into(), |s| s.to_string_lossy().to_string());
    PathBuf::from("out/stability").join(stem)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn over_ranges_and_lists() {
        let (k, v) = parse_over("fluid.gamma=2..8", 4, false).unwrap();
        assert_eq!(k, "fluid.gamma");
        assert_eq!(v, [2.0, 4.0, 6.0, 8.0]);
        let (_, v) = parse_over("flow.rate=1..100", 3, true).unwrap();
        assert!((v[1] - 10.0).abs() < 1e-12);
        let (_, v) = parse_over("flow.rate=0.5,1,3", 9, false).unwrap();
        assert_eq!(v, [0.5, 1.0, 3.0]);
        assert!(
            parse_over("flow.rate", 3, false)
                .unwrap_err()
                .contains("KEY=a..b")
        );
        assert!(parse_over("a=0..1", 3, true).unwrap_err().contains("> 0"));
        assert!(
            parse_over("a=1..x", 3, false)
                .unwrap_err()
                .contains("not a finite")
        );
    }

    #[test]
    fn numbers_reach_the_case_as_floats() {
        assert_eq!(toml_number(2.0), "2.0");
        assert_eq!(toml_number(0.015), "0.015");
        assert_eq!(toml_number(1e-7), "1e-7");
    }

    #[test]
    fn an_integer_key_gets_an_integer_and_a_float_key_a_float() {
        let request = |over: &str| StabilityRequest {
            case: PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/cases/dpd_equilibrium_2d.toml"
            )),
            vary: "integrator.dt".into(),
            over: over.into(),
            over_values: vec![],
            steps: 10,
            tolerance: 0.05,
            set: vec![],
            threads: 1,
            out: PathBuf::new(),
            exe: PathBuf::new(),
            python: None,
            progress: false,
            child_env: None,
        };
        // `seed` is a u64: the float form is refused, so the spread over seeds can be mapped.
        assert_eq!(over_assignment(&request("seed"), 3.0), "seed=3");
        assert_eq!(
            over_assignment(&request("fluid.gamma"), 3.0),
            "fluid.gamma=3.0"
        );
        assert_eq!(
            over_assignment(&request("fluid.gamma"), 4.5),
            "fluid.gamma=4.5"
        );
    }

    #[test]
    fn the_verdict_needs_the_unstable_value_refused_and_80_percent_accepted() {
        let row = |c: Option<f64>| MapRow {
            over: 1.0,
            stable: 0.10,
            unstable: 0.105,
            check_limit: c,
            runs: 8,
            diagnosis: String::new(),
        };
        assert!(row(Some(0.09)).check_refuses_unstable());
        assert!((row(Some(0.09)).check_accepts() - 0.9).abs() < 1e-12);
        assert!(!row(Some(0.11)).check_refuses_unstable());
        assert!(!row(None).check_refuses_unstable());
        assert!(row(Some(0.05)).check_accepts() < CHECK_ACCEPTS_AT_LEAST);
    }
}
