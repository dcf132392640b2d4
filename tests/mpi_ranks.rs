//! Real multi-process runs (`mpirun -n 1` and `-n 2`) of the MPI build: the final state digest
//! must be identical, the parallel-HDF5 (MPI-IO) snapshots and checkpoints hold the same
//! content, a 2-rank run stopped with --until-step continues on 1 rank to the same state, and a
//! decomposition that is too fine is refused with the usable rank count. Needs the `mpi`
//! feature (`./run test` builds it).

mod common;

use std::path::Path;
use std::process::Command;

fn mpirun(ranks: usize, threads: usize, case: &Path, out: &Path) -> std::process::Output {
    mpirun_args(
        ranks,
        &[
            "run",
            case.to_str().expect("utf-8 path"),
            "--out",
            out.to_str().expect("utf-8 path"),
            "-t",
            &threads.to_string(),
            "-q",
        ],
    )
}

/// `args` with `--no-plots` after a `run` or `restart` subcommand: these tests read summaries
/// and checkpoints, and drawing the PNGs costs each run 1–5 s of Python (the plots have their
/// own test in `tests/snapshots.rs`).
fn with_no_plots<'a>(args: &[&'a str]) -> Vec<&'a str> {
    let mut out = args.to_vec();
    if matches!(args.first(), Some(&"run") | Some(&"restart")) {
        out.insert(1, "--no-plots");
    }
    out
}

fn mpirun_args(ranks: usize, args: &[&str]) -> std::process::Output {
    Command::new("mpirun")
        .args([
            "-n",
            &ranks.to_string(),
            "--oversubscribe",
            "--bind-to",
            "none",
        ])
        .arg(env!("CARGO_BIN_EXE_mesorheo"))
        .args(with_no_plots(args))
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("NO_COLOR", "1")
        .output()
        .expect("mpirun is installed (./run installs openmpi-bin)")
}

fn digest(out: &Path) -> String {
    let text = std::fs::read_to_string(out.join("summary.json")).expect("summary.json");
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    v["state_digest"].as_str().expect("digest").to_owned()
}

/// The shared small Lees–Edwards DPD case of the integration tests.
fn case_text() -> String {
    common::small_dpd(
        3,
        6.0,
        0.3,
        200,
        "[output]\nsnapshot_every = 50\ncheckpoint_every = 100\n\
         [diagnostics]\nobservables = [\"temperature\", \"viscosity\"]\n",
    )
}

/// The summary's per-rank load (owned particles, ghosts, pairs: mean and largest over the
/// ranks) adds up to the particle count, and on more than one rank the phase times' spread
/// over the ranks is there, each mean at most its largest, the rebuild count the same on every
/// rank (every rank rebuilds together).
fn assert_load_and_phase_spread(v: &serde_json::Value, ranks: usize) {
    let num = |x: &serde_json::Value| x.as_f64().expect("a number");
    let owned = &v["load"]["owned"];
    let particles = num(&v["particles"]);
    assert_eq!(num(&owned["mean"]) * ranks as f64, particles, "{owned}");
    assert!(num(&owned["max"]) >= num(&owned["mean"]));
    assert!(num(&owned["max"]) < particles || ranks == 1);
    for k in ["ghosts", "pairs"] {
        assert!(num(&v["load"][k]["mean"]) > 0.0, "{k}: {}", v["load"]);
    }
    assert!(num(&v["phase_seconds"]["pass_wait"]) >= 0.0);
    let spread = &v["phase_seconds_over_ranks"];
    if ranks == 1 {
        assert!(spread.is_null(), "one rank has no spread: {spread}");
        return;
    }
    for phase in [
        "neighbour",
        "rebuild_comm",
        "halo",
        "forces",
        "pass_wait",
        "integrate",
    ] {
        let (mean, max) = (num(&spread["mean"][phase]), num(&spread["max"][phase]));
        assert!(
            0.0 <= mean && mean <= max,
            "{phase}: mean {mean}, max {max}"
        );
    }
    assert_eq!(spread["mean"]["rebuilds"], v["phase_seconds"]["rebuilds"]);
    assert_eq!(spread["max"]["rebuilds"], v["phase_seconds"]["rebuilds"]);
}

#[test]
fn mpirun_one_and_two_ranks_give_the_same_state() {
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("le.toml");
    std::fs::write(&case, case_text()).expect("write case");
    let mut seen = Vec::new();
    for (ranks, threads) in [(1, 1), (2, 1), (2, 2)] {
        let out = dir.path().join(format!("out{ranks}_{threads}"));
        let o = mpirun(ranks, threads, &case, &out);
        assert!(
            o.status.success(),
            "mpirun -n {ranks}: {}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        let v: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("summary.json")).expect("summary"),
        )
        .expect("json");
        assert_eq!(v["ranks"], ranks);
        assert_load_and_phase_spread(&v, ranks);
        seen.push((ranks, threads, digest(&out)));
        assert!(out.join("logs").join("rank0000.log").exists());
        if ranks == 2 {
            assert!(out.join("logs").join("rank0001.log").exists());
        }
    }
    for (r, t, d) in &seen {
        assert_eq!(
            d, &seen[0].2,
            "mpirun -n {r} × {t} threads differs from -n 1"
        );
    }
    // Parallel HDF5 (MPI-IO): the snapshot series and the final checkpoint hold the same
    // content whatever the rank count.
    let reference = dir.path().join("out1_1");
    for name in ["snapshots.h5", "checkpoints/checkpoint_000000000200.h5"] {
        let a = common::h5_content(&reference.join(name));
        assert!(a.len() > 5, "{name}: {} datasets", a.len());
        for other in ["out2_1", "out2_2"] {
            let b = common::h5_content(&dir.path().join(other).join(name));
            assert!(a == b, "{name} differs between -n 1 and {other}");
        }
    }
}

#[test]
fn mpirun_two_ranks_until_a_step_then_one_rank_restart_equals_one_run() {
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("le.toml");
    std::fs::write(&case, case_text()).expect("write case");
    let whole = dir.path().join("whole");
    let o = mpirun(1, 1, &case, &whole);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let parts = dir.path().join("parts");
    let p = parts.to_str().expect("utf-8");
    let o = mpirun_args(
        2,
        &[
            "run",
            case.to_str().expect("utf-8"),
            "--out",
            p,
            "--until-step",
            "130",
            "-q",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ck = parts.join("checkpoints").join("checkpoint_000000000130.h5");
    assert!(ck.exists());
    let o = mpirun_args(1, &["restart", ck.to_str().expect("utf-8"), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(digest(&parts), digest(&whole));
    assert!(
        common::h5_content(&parts.join("snapshots.h5"))
            == common::h5_content(&whole.join("snapshots.h5")),
        "snapshots of the restarted run differ"
    );
}

/// The engine's two-pass test model (summation density, then a pressure force that reads the
/// ghosts' refreshed densities) under Lees–Edwards shear: `mpirun -n 1` and `-n 2` end in the
/// same state, and a 2-rank run stopped at step 70 and continued on 1 rank from its checkpoint
/// (which holds no densities: they are derived anew) ends there too.
#[test]
fn mpirun_two_pass_model_is_the_same_on_one_and_two_ranks_and_across_a_restart() {
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("gas.toml");
    let text = common::small_gas(
        2,
        8.0,
        0.5,
        "random",
        150,
        "[output]\ncheckpoint_every = 70",
    );
    std::fs::write(&case, text).expect("write case");
    let one = dir.path().join("one");
    let o = mpirun(1, 1, &case, &one);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let two = dir.path().join("two");
    let o = mpirun(2, 2, &case, &two);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(digest(&two), digest(&one), "-n 2 differs from -n 1");
    let parts = dir.path().join("parts");
    let p = parts.to_str().expect("utf-8");
    let args = [
        "run",
        case.to_str().expect("utf-8"),
        "--out",
        p,
        "--until-step",
        "70",
        "-q",
    ];
    let o = mpirun_args(2, &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ck = parts.join("checkpoints").join("checkpoint_000000000070.h5");
    let o = mpirun_args(1, &["restart", ck.to_str().expect("utf-8"), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(digest(&parts), digest(&one), "the restarted run differs");
}

#[test]
fn too_many_ranks_are_refused_with_the_usable_maximum() {
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("thin.toml");
    // L_y = 2.9 holds two slabs of cutoff + skin = 1.3, not three.
    let text = common::with_overrides(
        &common::small_dpd(3, 6.0, 0.0, 20, ""),
        &["box.lengths=[6, 2.9, 6]"],
    );
    std::fs::write(&case, text).expect("write");
    let o = mpirun(3, 1, &case, &dir.path().join("o"));
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("at most 2 ranks"), "{err}");
}

/// A small homogeneous-flow scene (dumbbell ensembles under shear reversal, control variates).
const FLOW_CASE: &str = r#"
dimension = 3
seed = 4
[flow]
kind = "shear_reversal"
rate = 2.0
reverse_at = 0.5
particles = 41
[polymer]
kind = "dumbbells"
spring = "hookean"
relaxation_time = 1.0
per_particle = 30
variance_reduction = true
[integrator]
kind = "brownian_dynamics"
dt = 0.01
[run]
steps = 100
equilibration = 20
sample_every = 5
[diagnostics]
blocks = 4
"#;

#[test]
fn mpirun_flow_scene_same_state_and_restart_across_rank_counts() {
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("flow.toml");
    std::fs::write(&case, FLOW_CASE).expect("write case");
    let whole = dir.path().join("whole");
    let o = mpirun(1, 1, &case, &whole);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let two = dir.path().join("two");
    let o = mpirun(2, 2, &case, &two);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(digest(&two), digest(&whole), "mpirun -n 2 × 2 threads");
    // The final flow checkpoints (MPI-IO) hold the same content.
    let name = "checkpoints/checkpoint_000000000100.h5";
    assert!(
        common::h5_content(&whole.join(name)) == common::h5_content(&two.join(name)),
        "flow checkpoint differs between -n 1 and -n 2"
    );
    // Two ranks stop at step 60 (after the reversal), one rank finishes.
    let parts = dir.path().join("parts");
    let p = parts.to_str().expect("utf-8");
    let c = case.to_str().expect("utf-8");
    let o = mpirun_args(2, &["run", c, "--out", p, "--until-step", "60", "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ck = parts.join("checkpoints").join("checkpoint_000000000060.h5");
    let o = mpirun_args(1, &["restart", ck.to_str().expect("utf-8"), "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(digest(&parts), digest(&whole));
    assert_eq!(
        std::fs::read_to_string(parts.join("polymer_stress.csv")).expect("csv"),
        std::fs::read_to_string(whole.join("polymer_stress.csv")).expect("csv"),
        "the stress time series of the restarted run differs"
    );
}

/// The long steady-shear run as a batch system ends it: the CONNFFESSIT scene on
/// `mpirun -n 2`, one rank's process sent SIGTERM mid-run (the ranks agree to stop at the next
/// step and write a checkpoint), continued on `mpirun -n 1` from that checkpoint to the end ≡
/// one uninterrupted `mpirun -n 1` run, bitwise. Fails if a rank keeps running alone (mpirun
/// hangs or aborts), or if the ensembles are not checkpointed with their particles.
#[test]
fn mpirun_connffessit_sigterm_on_two_ranks_then_one_rank_restart_equals_one_run() {
    // Without the references (a short run meets none; a failed check is a non-zero exit).
    let text = common::stock_text_with(
        "connffessit_shear_2d.toml",
        &[
            "run.steps=3000",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
            "reference=[]",
        ],
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let case = dir.path().join("cf.toml");
    std::fs::write(&case, text).expect("write case");
    let whole = dir.path().join("whole");
    let o = mpirun(1, 1, &case, &whole);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let parts = dir.path().join("parts");
    let mut child = Command::new("mpirun")
        .args(["-n", "2", "--oversubscribe", "--bind-to", "none"])
        .arg(env!("CARGO_BIN_EXE_mesorheo"))
        .args([
            "run",
            case.to_str().expect("utf-8"),
            "-q",
            "--no-plots",
            "-t",
            "1",
            "--out",
        ])
        .arg(&parts)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("NO_COLOR", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("mpirun");
    let log = parts.join("logs").join("rank0000.log");
    let started = std::time::Instant::now();
    while !std::fs::read_to_string(&log)
        .unwrap_or_default()
        .contains("set up")
    {
        assert!(
            started.elapsed().as_secs() < 60,
            "the 2-rank run did not start"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    // One rank's process only (mpirun's children are the ranks).
    let ranks = Command::new("pgrep")
        .args(["-P", &child.id().to_string()])
        .output()
        .expect("pgrep");
    let pids = String::from_utf8_lossy(&ranks.stdout).to_string();
    let pid = pids.split_whitespace().last().expect("a rank process");
    let kill = Command::new("kill")
        .args(["-TERM", pid])
        .status()
        .expect("kill");
    assert!(kill.success());
    let status = child.wait().expect("wait");
    assert!(
        status.success(),
        "SIGTERM to one rank: mpirun ended with {status}"
    );
    let s: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(parts.join("summary.json")).expect("summary"),
    )
    .expect("json");
    assert_eq!(s["completed"], false, "the run finished before the signal");
    let stopped = s["steps"].as_u64().expect("steps");
    assert!(stopped > 0 && stopped < 3000, "stopped at {stopped}");
    let last = s["last_checkpoint"]
        .as_str()
        .expect("checkpoint")
        .to_owned();
    let o = mpirun_args(1, &["restart", &last, "-q"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    eprintln!("stopped by SIGTERM at step {stopped} on 2 ranks, continued on 1");
    assert_eq!(digest(&parts), digest(&whole));
}
