//! `mesorheo run`'s exit codes follow the error's variant (`mesorheo::error::Error::exit_code`):
//! 4 a blow-up, 2 an invalid case or one that does not fit, 0 done. A script, a study or a
//! stability bisection tells them apart by the code alone. Fails if the code is taken from the
//! message again and a diagnosis loses the words, or if a blow-up is reported as a plain
//! failure (1).

use std::path::{Path, PathBuf};
use std::process::Command;

fn run(out: &std::path::Path, sets: &[&str]) -> (Option<i32>, String) {
    let case =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/dpd_equilibrium_3d.toml");
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_mesorheo"));
    cmd.arg("run")
        .arg(case)
        .arg("--out")
        .arg(out)
        .args(["-q", "--no-plots", "-t", "1"]);
    for s in sets {
        cmd.arg("--set").arg(s);
    }
    let o = cmd.output().expect("run the binary");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn a_blow_up_exits_4_and_names_the_particle_and_the_step() {
    let dir = tempfile::tempdir().expect("temp dir");
    // Δt = 0.5 is twelve times the stock 0.04: the random start throws particles beyond the
    // neighbour list's reach at the first step (the check, which refuses it, is switched off).
    let (code, err) = run(
        dir.path(),
        &[
            "integrator.dt=0.5",
            "run.beyond_stability_limits=true",
            "run.steps=400",
            "run.equilibration=100",
        ],
    );
    assert_eq!(code, Some(4), "{err}");
    assert!(
        err.contains("particle ")
            && err.contains("at step ")
            && err.contains("the run is unstable"),
        "{err}"
    );
    assert!(
        dir.path().join("blowup").is_dir(),
        "the state at the blow-up is kept"
    );
}

#[test]
fn an_invalid_case_and_one_that_does_not_fit_exit_2() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (code, err) = run(dir.path(), &["integrator.dt=-1"]);
    assert_eq!(code, Some(2), "{err}");
    let (code, err) = run(dir.path(), &["box.lengths=[800.0,800.0,800.0]"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("GiB"), "{err}");
}

/// The binary with `args`, in the working directory `cwd`, with extra environment `env`:
/// (exit code, stderr).
fn mesorheo(cwd: &Path, args: &[&str], env: &[(&str, &str)]) -> (Option<i32>, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_mesorheo"));
    cmd.current_dir(cwd).args(args).env_remove("MESORHEO_LOG");
    for (k, v) in env {
        cmd.env(k, v);
    }
    let o = cmd.output().expect("run the binary");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn stock(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name)
}

/// The names in `dir`, sorted.
fn entries(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("read dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// `restart` given a case file by mistake: an invalid request (2) that says what the file is
/// and what to do, and leaves it exactly as it was, with nothing written beside it. Fails if a
/// file that is not HDF5 is taken for a damaged checkpoint of ours and renamed `.h5.corrupt`
/// again (mutation: `named_like_a_checkpoint` true for every name), or if the refusal comes
/// only after the logs are set up.
#[test]
fn restart_refuses_a_case_file_and_leaves_it_untouched() {
    let dir = tempfile::tempdir().expect("temp dir");
    let case = dir.path().join("mycase.toml");
    let text = std::fs::read(stock("default.toml")).expect("stock case");
    std::fs::write(&case, &text).expect("copy");
    let (code, err) = mesorheo(dir.path(), &["restart", "mycase.toml"], &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("mycase.toml: not a mesorheo checkpoint")
            && err.contains("mesorheo run mycase.toml")
            && !err.contains("renamed"),
        "{err}"
    );
    assert_eq!(std::fs::read(&case).expect("still there"), text);
    assert_eq!(
        entries(dir.path()),
        ["mycase.toml"],
        "nothing written beside it"
    );
    // An HDF5-less file under any other name is refused the same way.
    std::fs::write(dir.path().join("notes.h5"), "not HDF5").expect("write");
    let (code, err) = mesorheo(dir.path(), &["restart", "notes.h5"], &[]);
    assert_eq!(code, Some(2), "{err}");
    assert_eq!(entries(dir.path()), ["mycase.toml", "notes.h5"]);
}

/// A short DPD shear run (every step may rebuild the neighbour list) into `out`.
fn shear_run(cwd: &Path, out: &str, extra: &[&str], env: &[(&str, &str)]) -> String {
    let case = stock("dpd_shear_2d.toml");
    let mut args = vec![
        "run",
        case.to_str().expect("utf-8 path"),
        "--out",
        out,
        "-q",
        "-t",
        "1",
        "--steps",
        "400",
        "--set",
        "run.equilibration=100",
        "--set",
        "reference=[]",
        "--set",
        "diagnostics.blocks=2",
        "--no-plots",
    ];
    args.extend_from_slice(extra);
    let (code, err) = mesorheo(cwd, &args, env);
    assert_eq!(code, Some(0), "{err}");
    std::fs::read_to_string(cwd.join(out).join("logs/rank0000.log")).expect("rank log")
}

/// The per-rank log files are at info by default: no neighbour-list record at all, a few
/// hundred bytes for the whole run; at debug one count per progress interval, each rebuild
/// only at trace; the level comes from `--log-level` or MESORHEO_LOG, and a misspelt one is
/// refused. Fails with the files at debug again (mutation: `DEFAULT_FILE_LEVEL = "debug"`) or
/// with the per-rebuild record back at debug (`tracing::debug!` in `Simulation::rebuild`).
#[test]
fn log_files_are_at_info_by_default_and_rebuilds_are_counted_not_listed() {
    let dir = tempfile::tempdir().expect("temp dir");
    let info = shear_run(dir.path(), "info", &[], &[]);
    assert!(
        !info.contains("neighbour") && info.len() < 1000,
        "{} bytes:\n{info}",
        info.len()
    );
    let debug = shear_run(dir.path(), "debug", &["--log-level", "debug"], &[]);
    let counted = debug.matches("neighbour-list rebuilds").count();
    assert!(
        counted >= 1 && !debug.contains("neighbour list rebuilt at step") && debug.len() < 2000,
        "{debug}"
    );
    let trace = shear_run(dir.path(), "trace", &[], &[("MESORHEO_LOG", "trace")]);
    assert!(
        trace.matches("neighbour list rebuilt at step").count() > 100,
        "MESORHEO_LOG=trace lists every rebuild"
    );
    let (code, err) = mesorheo(
        dir.path(),
        &["--log-level", "debg", "run", "whatever.toml"],
        &[],
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("\"debg\" is not a log level"), "{err}");
    let case = stock("dpd_shear_2d.toml");
    let (code, err) = mesorheo(
        dir.path(),
        &["run", case.to_str().expect("utf-8 path"), "--out", "x"],
        &[("MESORHEO_LOG", "verbose")],
    );
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("MESORHEO_LOG=\"verbose\""), "{err}");
    assert!(!dir.path().join("x").exists(), "refused before the run");
}

/// Each warning of the results reaches the console once, in plain words with what to do.
/// Fails if the step loop logs them again beside the results table (mutation: the
/// `tracing::warn!` loop over `report.warnings` back in `scene::drive`).
#[test]
fn each_warning_is_printed_once_in_plain_words() {
    let dir = tempfile::tempdir().expect("temp dir");
    let case = stock("dpd_shear_2d.toml");
    // 40 blocks of 2 samples: far too short for the correlated series.
    let (code, err) = mesorheo(
        dir.path(),
        &[
            "run",
            case.to_str().expect("utf-8 path"),
            "--out",
            "o",
            "-t",
            "1",
            "--steps",
            "1000",
            "--set",
            "run.equilibration=200",
            "--set",
            "diagnostics.blocks=40",
            "--set",
            "reference=[]",
        ],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    let first = "viscosity: its ± error bar is probably too small";
    assert_eq!(err.matches(first).count(), 1, "{err}");
    assert!(
        err.contains("To fix it, set `blocks = ") && !err.contains("τ_int"),
        "{err}"
    );
    // The log file keeps it too.
    let log = std::fs::read_to_string(dir.path().join("o/logs/rank0000.log")).expect("log");
    assert!(log.contains(first), "{log}");
}

/// A restart of a finished run says so and how to extend it (exit 2, summary.json untouched);
/// `--steps N` is the new total, and the summary then lists both segments, keeps the case
/// file the run started from, and adds their wall times. Fails without the check (mutation:
/// delete the `first_step >= last_step` refusal in `scene::drive`: exit 0, summary rewritten)
/// or without the segments (`let earlier = Vec::new()`).
#[test]
fn a_finished_run_is_not_restarted_and_an_extended_one_lists_its_segments() {
    let dir = tempfile::tempdir().expect("temp dir");
    let case = stock("dpd_shear_2d.toml");
    let case = case.to_str().expect("utf-8 path");
    let (code, err) = mesorheo(
        dir.path(),
        &[
            "run",
            case,
            "--out",
            "o",
            "-q",
            "-t",
            "1",
            "--steps",
            "200",
            "--set",
            "run.equilibration=100",
            "--set",
            "reference=[]",
        ],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    let summary = dir.path().join("o/summary.json");
    let before = std::fs::read(&summary).expect("summary");
    let (code, err) = mesorheo(dir.path(), &["restart", "o/checkpoints", "-q"], &[]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("the run is already complete")
            && err.contains("--steps N")
            && err.contains("not a number of further steps"),
        "{err}"
    );
    assert_eq!(std::fs::read(&summary).expect("summary"), before);
    let (code, err) = mesorheo(
        dir.path(),
        &["restart", "o", "-q", "-t", "1", "--steps", "300"],
        &[],
    );
    assert_eq!(code, Some(0), "{err}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).expect("summary")).expect("json");
    assert_eq!(s["steps"], 300);
    assert_eq!(s["case_file"], case);
    let segments = s["segments"].as_array().expect("segments");
    assert_eq!(segments.len(), 2, "{s}");
    assert_eq!(segments[0]["started_from"], case);
    let steps = |g: &serde_json::Value| (g["first_step"].as_u64(), g["last_step"].as_u64());
    assert_eq!(steps(&segments[0]), (Some(0), Some(200)), "{s}");
    assert_eq!(steps(&segments[1]), (Some(200), Some(300)), "{s}");
    assert!(
        segments[1]["started_from"]
            .as_str()
            .is_some_and(|p| p.ends_with("checkpoint_000000000200.h5")),
        "{s}"
    );
    let walls: f64 = segments
        .iter()
        .map(|g| g["wall_seconds"].as_f64().expect("wall"))
        .sum();
    // To round-off: the total is summed from the segments' unrounded times, the listed ones
    // are what JSON kept of them (an exact comparison failed once: 0.222624271 against
    // 0.22262427099999998).
    let total = s["total_wall_seconds"].as_f64().expect("total wall");
    assert!(
        (total - walls).abs() <= 1e-9 * walls.max(1.0),
        "{total} vs {walls}: {s}"
    );
}

/// `./run case` called from another directory takes the case file and `--out` relative to that
/// directory, and puts a case's default output under its `out/` (MESORHEO_BIN: this build, no
/// MPI build). Fails if the script resolves them in the repository again (mutation: drop
/// `file=$(from_caller "$file")` or the `from_caller` of `--out` in `run_case`).
#[test]
fn the_run_script_takes_paths_from_the_callers_directory() {
    if Command::new("mpirun").arg("--version").output().is_err() {
        use std::io::Write;
        let _ = writeln!(
            std::io::stderr().lock(),
            "SKIPPED ./run from another directory: no mpirun on the PATH (./run test installs it)"
        );
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    std::fs::create_dir(dir.path().join("cases")).expect("mkdir");
    std::fs::copy(
        stock("dpd_shear_2d.toml"),
        dir.path().join("cases/mycase.toml"),
    )
    .expect("copy");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("run");
    let run = |out: &[&str]| {
        let o = Command::new("bash")
            .arg(&script)
            .args(["case", "cases/mycase.toml", "-n", "1", "-t", "1"])
            .args(out)
            .args(["-q", "--steps", "200", "--set", "run.equilibration=100"])
            .args(["--set", "reference=[]", "--set", "diagnostics.blocks=2"])
            .current_dir(dir.path())
            .env("MESORHEO_BIN", env!("CARGO_BIN_EXE_mesorheo"))
            .output()
            .expect("run the script");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&["--out", "results/a"]);
    assert!(dir.path().join("results/a/summary.json").is_file());
    run(&[]);
    assert!(dir.path().join("out/mycase/summary.json").is_file());
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    assert!(!repo.join("results").exists() && !repo.join("out/mycase").exists());
}

/// `-q` drops the progress and info lines, not the results: a run whose reference fails exits 3
/// and still says which reference and by how much. Fails if the results table is printed only
/// without `-q` again (mutation: `if !quiet` around `summary::render` in `main.rs`, the form
/// before 2026-11-27: the stderr then holds no `[FAIL]` line).
#[test]
fn a_quiet_run_still_prints_its_results_and_the_failed_reference() {
    let dir = tempfile::tempdir().expect("temp dir");
    // k_BT = 1 against a deliberately wrong reference value (the stock case's first reference,
    // moved to 2): a failed reference, exit 3.
    let (code, err) = run(
        &dir.path().join("o"),
        &[
            "run.steps=200",
            "run.equilibration=100",
            "diagnostics.blocks=2",
            "reference=[{kind = \"value\", name = \"k_BT moved\", observable = \"temperature\", \
             value = 2.0, metric = \"relative_error\", tolerance = 0.01}]",
        ],
    );
    assert_eq!(code, Some(3), "{err}");
    assert!(err.contains("[FAIL] k_BT moved"), "{err}");
    assert!(
        err.contains("temperature") && err.contains("state digest"),
        "{err}"
    );
}
