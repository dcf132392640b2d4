//! Running a study's points: each an ordinary `mesorheo run` in its own directory, resumed
//! when its record matches, a refusal or a blow-up recorded, not fatal.

#[allow(unused_imports)]
use super::*;

/// What became of one point.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Ran to the end: per observable (mean, stderr), and the cost.
    Done {
        values: Vec<(f64, f64)>,
        wall_seconds: f64,
        /// CPU seconds (user + system) of the point's processes, every rank and thread, measured
        /// by the study around its child (None for a point whose record predates the measure:
        /// its cost is then wall × ranks × threads).
        cpu_seconds: Option<f64>,
        /// Stored ensemble bytes per carrying particle at the end of the run (summary.json's
        /// `ensemble_bytes_per_particle`: N_d × D × 8 B for dumbbells, 8 B per occupied
        /// histogram cell for BDDFS); None for scenes without ensembles.
        bytes_per_particle: Option<f64>,
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
    /// The point's CPU seconds ([`Status::Done::cpu_seconds`]); absent in older records.
    #[serde(default)]
    cpu_seconds: Option<f64>,
}

/// Runs (or resumes) every point of the sweep, then analyses and writes the outputs.
pub fn run_study(sweep: &Sweep, opts: &StudyOptions) -> Result<Analysis, String> {
    let pts = points(sweep);
    let labels: Vec<Vec<String>> = point_values(sweep)
        .iter()
        .map(|p| {
            p.iter()
                .enumerate()
                .map(|(k, &j)| sweep.knobs[k].values[j].clone())
                .collect()
        })
        .collect();
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
        let knob_values = labels[i].clone();
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
            ..
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
        "done" => read_summary(point_dir, obs, rec.cpu_seconds).ok(),
        "unstable" => Some(Status::Unstable(rec.message)),
        _ => None,
    }
}

fn read_summary(
    point_dir: &Path,
    obs: &[ObservableSpec],
    cpu_seconds: Option<f64>,
) -> Result<Status, String> {
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
    let bytes_per_particle = v["ensemble_bytes_per_particle"].as_f64();
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
        cpu_seconds,
        bytes_per_particle,
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
    let cpu_before = children_cpu_seconds();
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
        Some(0 | 3) => {
            let cpu = match (cpu_before, children_cpu_seconds()) {
                (Some(a), Some(b)) if b >= a => Some(b - a),
                _ => None,
            };
            read_summary(point_dir, &sweep.observables, cpu)?
        }
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
        cpu_seconds: match &status {
            Status::Done { cpu_seconds, .. } => *cpu_seconds,
            _ => None,
        },
    };
    let text = serde_json::to_string_pretty(&record).map_err(|e| e.to_string())?;
    std::fs::write(point_dir.join("point.json"), text)
        .map_err(|e| format!("cannot write {}/point.json: {e}", point_dir.display()))?;
    Ok(status)
}

/// CPU seconds (user + system) used so far by every terminated child of this process that it
/// waited for, and their waited-for descendants (`getrusage(RUSAGE_CHILDREN)`): under `mpirun`
/// that is every rank, and in each rank every thread. The difference around one child is that
/// child's cost, which unlike its wall time hardly moves with the other load on the machine
/// (a run on a busy 2-core machine took 2–3× its quiet wall time but about its quiet CPU time).
/// None where the call fails.
pub fn children_cpu_seconds() -> Option<f64> {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: `getrusage` writes one `struct rusage` through the pointer, which points at a
    // zeroed, properly aligned `rusage` owned by this frame; RUSAGE_CHILDREN is a valid `who`.
    // The value is read only when the call reports success (0), so it is fully initialised.
    let ok = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, usage.as_mut_ptr()) } == 0;
    if !ok {
        return None;
    }
    // SAFETY: initialised by the successful call above (and zeroed before it).
    let usage = unsafe { usage.assume_init() };
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
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
            "--no-plots",
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
