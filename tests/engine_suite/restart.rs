//! Checkpoints and restart: N steps ≡ N/2 steps + checkpoint + restart + N/2 steps, bitwise
//! (`state_digest`), for Lees–Edwards DPD with a non-zero offset in 2D and 3D, also when the
//! restart runs on a different rank count; the same for a test-only model that carries a
//! fixed-width tensor and a variable-length array per particle; a corrupt or truncated
//! checkpoint is refused and the previous one used; a process killed while writing a checkpoint
//! leaves the previous one intact; SIGTERM stops a run cleanly with a checkpoint.
#![cfg(feature = "hdf5")]

use crate::common;
use common::{case_from_str, small_dpd, stock_text_with};
use mesorheo::comm::Comm;
use mesorheo::driver::{CHECKPOINT_REFUSED, RunOptions, in_process, restart_case, run_case};
use mesorheo::facade::Engine;
use mesorheo::models::{FieldKind, FieldSpec, ParticleModel};
use mesorheo::output::checkpoint;
use mesorheo::particles::Particles;
use mesorheo::particles::{FieldFlags, VarStorage};
use mesorheo::sim::Simulation;
use mesorheo::summary::Summary;
use std::path::{Path, PathBuf};
use std::process::Command;

fn le_case(dim: usize, steps: u64, extra: &str) -> String {
    let (side, shear) = if dim == 2 { (10.0, 0.5) } else { (6.0, 0.4) };
    small_dpd(
        dim,
        side,
        shear,
        steps,
        &format!("{extra}\n[diagnostics]\nobservables = [\"temperature\", \"viscosity\"]\n"),
    )
}

fn options(out: Option<&Path>, until: Option<u64>) -> RunOptions {
    RunOptions {
        threads: 1,
        steps: None,
        until_step: until,
        out: out.map(Path::to_path_buf),
        max_hours: None,
    }
}

/// Digest of an uninterrupted run on one rank.
fn uninterrupted(text: &str) -> String {
    let loaded = case_from_str(text, "whole");
    in_process(1, move |c| run_case(&loaded, c, &options(None, None)))
        .expect("uninterrupted run")
        .state_digest
}

/// Runs `text` on `ranks` in-process ranks with output into `out`, stopping cleanly (with a
/// checkpoint) at step `until`.
fn run_until(text: &str, ranks: usize, out: &Path, until: u64) -> Summary {
    let loaded = case_from_str(text, "first part");
    let o = out.to_path_buf();
    in_process(ranks, move |c| {
        run_case(&loaded, c, &options(Some(&o), Some(until)))
    })
    .expect("first part of the run")
}

/// Restarts from `checkpoint` (a file or a directory) on `ranks` in-process ranks with output
/// into `out`, to the end of the run.
fn restart_into(
    checkpoint: &Path,
    ranks: usize,
    out: &Path,
) -> Result<Summary, mesorheo::error::Error> {
    let (ck, o) = (checkpoint.to_path_buf(), out.to_path_buf());
    in_process(ranks, move |c| {
        restart_case(&ck, c, &options(Some(&o), None))
    })
}

fn attr_u64(path: &Path, name: &str) -> u64 {
    let f = mesorheo::output::h5_options()
        .open(path)
        .expect("open checkpoint");
    f.attr(name)
        .expect("attr")
        .read_scalar::<u64>()
        .expect("u64")
}

#[test]
fn restart_is_bitwise_in_2d_and_3d_and_on_other_rank_counts() {
    for dim in [2, 3] {
        let text = le_case(dim, 120, "");
        let whole = uninterrupted(&text);
        for (first, second) in [(1, 1), (2, 1), (1, 2), (1, 3)] {
            let dir = tempfile::tempdir().expect("tempdir");
            let out = dir.path().to_path_buf();
            let half = run_until(&text, first, &out, 60);
            assert!(!half.completed);
            assert_eq!(half.steps, 60);
            let ck = PathBuf::from(half.last_checkpoint.expect("checkpoint written"));
            assert_eq!(ck, out.join("checkpoints").join(checkpoint::file_name(60)));
            // The Lees–Edwards offset is non-zero at the checkpoint.
            let f = mesorheo::output::h5_options().open(&ck).expect("open");
            let offset: f64 = f.attr("le_offset").unwrap().read_scalar().unwrap();
            assert!(offset.abs() > 0.1, "offset {offset}");
            let rest = restart_into(&out.join("checkpoints"), second, &out).expect("second half");
            assert!(rest.completed);
            assert_eq!(rest.steps, 120);
            assert_eq!(
                rest.state_digest, whole,
                "{dim}D: {first} ranks → checkpoint at 60 → {second} ranks differs from one run"
            );
        }
    }
}

#[test]
fn restart_between_neighbour_list_builds_is_bitwise() {
    // Checkpoints at every step from 41 to 50: most fall between list builds, where positions
    // are not wrapped and the lists must be rebuilt as of the last build. (A wide skin and a
    // slow shear, so lists live for several steps.)
    let text = common::with_overrides(&small_dpd(3, 6.0, 0.1, 80, ""), &["neighbour.skin=0.8"]);
    let whole = uninterrupted(&text);
    let mut between = 0;
    for stop in 41..=50u64 {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().to_path_buf();
        run_until(&text, 2, &out, stop);
        let ck = out.join("checkpoints").join(checkpoint::file_name(stop));
        if attr_u64(&ck, "rebuild_step") != stop {
            between += 1;
        }
        let rest = restart_into(&ck, 1, &out).expect("restart");
        assert_eq!(rest.state_digest, whole, "checkpoint at step {stop}");
    }
    assert!(
        between >= 3,
        "only {between} checkpoints fell between list builds"
    );
}

/// A test-only model with per-particle state: a D×D tensor relaxing towards a function of the
/// position, and an array whose length changes with time (the shape of a dumbbell ensemble).
struct TensorAndArray;

impl<const D: usize> ParticleModel<D> for TensorAndArray {
    fn name(&self) -> &'static str {
        "tensor_and_array"
    }

    // Two fields of each kind, declared out of alphabetical order (a file lists its members
    // alphabetically; the restart must keep the registration order).
    fn fields(&self) -> Vec<FieldSpec> {
        let spec = |name, kind| FieldSpec {
            name,
            kind,
            flags: FieldFlags::STATE,
        };
        vec![
            spec("tensor", FieldKind::Tensor),
            spec("a_scalar", FieldKind::Scalar),
            spec("history", FieldKind::Ensemble(VarStorage::Double)),
            // Single-precision storage, like a dumbbell ensemble with precision = "single".
            spec("aa_log", FieldKind::Ensemble(VarStorage::Single)),
        ]
    }

    fn attach(
        &mut self,
        p: &mut Particles<D>,
        restarted: bool,
    ) -> Result<(), mesorheo::error::Error> {
        if restarted {
            let names: Vec<&str> = p.extra.iter().map(|f| f.name.as_str()).collect();
            let vars: Vec<&str> = p.var.iter().map(|f| f.name.as_str()).collect();
            return if names.starts_with(&["tensor", "a_scalar"]) && vars == ["history", "aa_log"] {
                Ok(())
            } else {
                Err(format!("checkpoint fields {names:?} {vars:?}").into())
            };
        }
        let index = |name: &str| p.extra_index(name).expect("registered");
        let (k, s) = (index("tensor"), index("a_scalar"));
        let var = |name: &str| {
            p.var
                .iter()
                .position(|f| f.name == name)
                .expect("registered")
        };
        let (v, l) = (var("history"), var("aa_log"));
        for i in 0..p.n_owned {
            let g = p.gid[i];
            for c in 0..D * D {
                p.extra[k].data[i * D * D + c] = (g % 13) as f64 + c as f64 * 0.25;
            }
            p.extra[s].data[i] = g as f64;
            let history = p.var[v].data.double_mut().expect("f64 storage");
            history[i] = (0..g % 4).map(|j| j as f64 + 0.5).collect();
            let log = p.var[l].data.single_mut().expect("f32 storage");
            log[i] = vec![-(g as f32) / 3.0; (g % 3) as usize];
        }
        Ok(())
    }

    fn update_state(
        &self,
        p: &mut Particles<D>,
        step: u64,
    ) -> Option<mesorheo::models::StateBlowUp> {
        let k = p.extra_index("tensor").expect("registered");
        let v = p
            .var
            .iter()
            .position(|f| f.name == "history")
            .expect("registered");
        for i in 0..p.n_owned {
            let x = p.pos[i];
            for c in 0..D * D {
                let t = &mut p.extra[k].data[i * D * D + c];
                *t = 0.9 * *t + 0.1 * x[c % D] * (c + 1) as f64;
            }
            let h = &mut p.var[v].data.double_mut().expect("f64 storage")[i];
            if (p.gid[i] + step).is_multiple_of(5) {
                h.push(x[0] - x[1]);
            }
            if h.len() > 6 {
                h.remove(0);
            }
            let s = p.extra_index("a_scalar").expect("registered");
            p.extra[s].data[i] += x[1];
            let l = p
                .var
                .iter()
                .position(|f| f.name == "aa_log")
                .expect("registered");
            if step.is_multiple_of(7) {
                let t = p.extra[k].data[i * D * D];
                let log = p.var[l].data.single_mut().expect("f32 storage");
                log[i].push(t as f32);
            }
        }
        None
    }
}

fn model_run(
    comm: &dyn Comm,
    text: &str,
    from: Option<&Path>,
    to_step: u64,
    save_to: Option<&Path>,
) -> Result<String, mesorheo::error::Error> {
    let case = case_from_str(text, "model").case;
    let mut sim = match from {
        None => Simulation::<3>::new(&case, comm, 1)?,
        Some(path) => {
            let r = Simulation::<3>::read_checkpoint(path, comm).map_err(|e| e.to_string())?;
            Simulation::<3>::from_checkpoint(
                &r.case,
                comm,
                1,
                r.particles,
                r.total,
                r.step,
                r.rebuild_step,
                r.series,
                r.species,
                r.rigid_bodies.as_deref(),
            )?
        }
    };
    sim.attach(Box::new(TensorAndArray))?;
    let steps = to_step - sim.step;
    sim.run_steps(steps)?;
    if let Some(dir) = save_to {
        sim.write_checkpoint(dir, 2)?;
    }
    Ok(sim.state_digest())
}

#[test]
fn model_fields_migrate_checkpoint_and_restart_bitwise_on_any_rank_count() {
    let text = le_case(3, 100, "");
    let mut reference = None;
    for ranks in 1..=3 {
        let t = text.clone();
        let d = in_process(ranks, move |c| model_run(c, &t, None, 100, None)).expect("run");
        let r = reference.get_or_insert(d.clone());
        assert_eq!(&d, r, "model state differs on {ranks} ranks");
    }
    let reference = reference.expect("reference");
    // The model must actually change the digest (its fields are part of the state).
    assert_ne!(reference, uninterrupted(&text));
    for (first, second) in [(1, 3), (3, 1), (2, 2)] {
        let dir = tempfile::tempdir().expect("tempdir");
        let ckdir = dir.path().join("checkpoints");
        let (t, c1) = (text.clone(), ckdir.clone());
        in_process(first, move |c| model_run(c, &t, None, 47, Some(&c1))).expect("first part");
        let ck = ckdir.join(checkpoint::file_name(47));
        let t = text.clone();
        let d = in_process(second, move |c| model_run(c, &t, Some(&ck), 100, None))
            .expect("second part");
        assert_eq!(d, reference, "model: {first} ranks → 47 → {second} ranks");
    }
}

fn write_case(dir: &Path, text: &str) -> PathBuf {
    let p = dir.join("case.toml");
    std::fs::write(&p, text).expect("write case");
    p
}

#[test]
fn a_corrupt_or_truncated_checkpoint_is_refused_and_the_previous_one_used() {
    let text = le_case(
        2,
        200,
        "[output]\ncheckpoint_every = 50\ncheckpoint_keep = 3\ncheckpoint_at_end = false",
    );
    let whole = uninterrupted(&text);
    for damage in ["truncate", "flip"] {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().to_path_buf();
        run_until(&text, 1, &out, 150);
        let cks = out.join("checkpoints");
        let newest = cks.join(checkpoint::file_name(150));
        assert!(cks.join(checkpoint::file_name(100)).exists());
        match damage {
            "truncate" => {
                let len = std::fs::metadata(&newest).unwrap().len();
                let f = std::fs::OpenOptions::new()
                    .write(true)
                    .open(&newest)
                    .unwrap();
                f.set_len(len / 2).unwrap();
            }
            _ => {
                // A valid HDF5 file with one wrong number: only the checksum can tell.
                let f = mesorheo::output::h5_options().open_rw(&newest).unwrap();
                let ds = f.dataset("particles/velocity").unwrap();
                let mut v: Vec<f64> = ds.read_raw().unwrap();
                v[7] += 1e-12;
                let shape = ds.shape();
                ds.write(
                    ndarray::Array2::from_shape_vec((shape[0], shape[1]), v)
                        .unwrap()
                        .view(),
                )
                .unwrap();
            }
        }
        // Refused when named explicitly…
        let n = newest.clone();
        let read =
            move |c: &dyn Comm| Simulation::<2>::read_checkpoint(&n, c).map_err(|e| e.to_string());
        let err =
            in_process(1, move |c| read(c).map(|_| ())).expect_err("damaged checkpoint accepted");
        let expect = if damage == "flip" { "checksum" } else { "HDF5" };
        assert!(err.contains(expect), "{damage}: {err}");
        // …and the restart falls back to step 100 and still ends in the uninterrupted state.
        let rest = restart_into(&newest, 2, &out).expect("restart from the previous checkpoint");
        // The damaged file is kept for inspection under another name, out of the way.
        assert!(newest.with_extension("h5.corrupt").exists());
        assert_eq!(
            rest.restarted_from.as_deref(),
            Some(cks.join(checkpoint::file_name(100)).to_str().unwrap()),
            "{damage}: {:?}",
            rest.warnings
        );
        // The summary says which checkpoint was refused and why, and nothing else was.
        let refusals: Vec<&String> = rest
            .warnings
            .iter()
            .filter(|w| w.starts_with(CHECKPOINT_REFUSED))
            .collect();
        assert!(
            refusals.len() == 1
                && refusals[0].contains(&checkpoint::file_name(150))
                && refusals[0].contains(expect),
            "{damage}: {:?}",
            rest.warnings
        );
        assert_eq!(rest.state_digest, whole, "{damage}");
    }
}

/// A lock on a checkpoint held through another open file description (what a child process
/// forked while the file was being written inherits, since HDF5 opens files without
/// close-on-exec) does not stop a restart from reading it: mesorheo opens its files without
/// HDF5's advisory locks. This was the cause of a flaky fallback to an older checkpoint.
#[test]
fn a_checkpoint_locked_by_another_process_handle_is_still_read() {
    let text = le_case(
        2,
        100,
        "[output]\ncheckpoint_every = 50\ncheckpoint_at_end = false",
    );
    let whole = uninterrupted(&text);
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_path_buf();
    run_until(&text, 1, &out, 50);
    let ck = out.join("checkpoints").join(checkpoint::file_name(50));
    let holder = std::fs::File::open(&ck).expect("open");
    holder.lock().expect("exclusive flock");
    let rest =
        restart_into(&ck, 2, &out).expect("restart from a checkpoint another handle has locked");
    drop(holder);
    assert_eq!(rest.restarted_from.as_deref(), ck.to_str());
    assert!(
        rest.warnings
            .iter()
            .all(|w| !w.starts_with(CHECKPOINT_REFUSED))
    );
    assert_eq!(rest.state_digest, whole);
}

fn binary(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_mesorheo"));
    c.env("NO_COLOR", "1");
    match args.split_first() {
        // These tests read summaries and checkpoints: no PNGs (1–5 s of Python per run). The
        // flag goes right after the subcommand: a caller's args may end in `--out` and add the
        // folder with `.arg`.
        Some((&sub, rest)) if sub == "run" || sub == "restart" => {
            c.arg(sub).arg("--no-plots").args(rest);
        }
        _ => {
            c.args(args);
        }
    }
    c
}

fn summary(out: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).expect("summary"))
        .expect("json")
}

#[test]
fn a_process_killed_while_writing_a_checkpoint_leaves_the_previous_one_usable() {
    let text = le_case(2, 200, "[output]\ncheckpoint_every = 50");
    let whole = uninterrupted(&text);
    let dir = tempfile::tempdir().expect("tempdir");
    let case = write_case(dir.path(), &text);
    let out = dir.path().join("out");
    let o = binary(&[
        "run",
        case.to_str().unwrap(),
        "-q",
        "-t",
        "1",
        "--out",
        out.to_str().unwrap(),
    ])
    .env("MESORHEO_FAULT", "abort-in-checkpoint:2")
    .output()
    .expect("run");
    assert!(!o.status.success(), "the fault hook did not fire");
    let cks = out.join("checkpoints");
    assert!(cks.join(checkpoint::file_name(50)).exists());
    assert!(!cks.join(checkpoint::file_name(100)).exists());
    assert!(
        cks.join(format!("{}.tmp", checkpoint::file_name(100)))
            .exists(),
        "the abort happened before the temporary file existed"
    );
    let o = binary(&["restart", cks.to_str().unwrap(), "-q", "-t", "1"])
        .output()
        .expect("restart");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = summary(&out);
    assert_eq!(s["state_digest"], whole.as_str());
    assert_eq!(s["steps"], 200);
    assert!(
        s["restarted_from"]
            .as_str()
            .unwrap()
            .ends_with(&checkpoint::file_name(50))
    );
}

#[test]
fn until_step_and_sigterm_stop_cleanly_and_the_restart_matches_one_run() {
    until_step_and_sigterm_then_restart(&le_case(3, 3000, ""), 3000);
}

/// The CONNFFESSIT shear scene (ensembles, velocity gradient) stopped at step 300 by
/// --until-step, continued, stopped by SIGTERM, continued to the end ≡ one run, bitwise.
#[test]
fn connffessit_stopped_by_sigterm_continues_bitwise() {
    // Without the references (a short run meets none; a failed check is a non-zero exit).
    let text = stock_text_with(
        "connffessit_shear_2d.toml",
        &[
            "run.steps=3000",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
            "reference=[]",
        ],
    );
    until_step_and_sigterm_then_restart(&text, 3000);
}

/// `text` (of `total` steps) run with --until-step 300, restarted and stopped by SIGTERM,
/// restarted again to the end: the final state equals one uninterrupted run.
fn until_step_and_sigterm_then_restart(text: &str, total: u64) {
    let text = text.to_owned();
    let whole = uninterrupted(&text);
    let dir = tempfile::tempdir().expect("tempdir");
    let case = write_case(dir.path(), &text);
    let out = dir.path().join("out");
    // --until-step
    let o = binary(&[
        "run",
        case.to_str().unwrap(),
        "-q",
        "-t",
        "1",
        "--until-step",
        "300",
        "--out",
    ])
    .arg(&out)
    .output()
    .expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = summary(&out);
    assert_eq!(s["completed"], false);
    assert_eq!(s["steps"], 300);
    // SIGTERM while running from the checkpoint.
    let ck = out.join("checkpoints").join(checkpoint::file_name(300));
    let mut child = binary(&["restart", ck.to_str().unwrap(), "-q", "-t", "1"])
        .spawn()
        .expect("restart");
    let log = out.join("logs").join("rank0000.log");
    let started = std::time::Instant::now();
    while !std::fs::read_to_string(&log)
        .unwrap_or_default()
        .contains("continuing")
    {
        assert!(started.elapsed().as_secs() < 60, "restart did not start");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .expect("kill");
    assert!(kill.success());
    let status = child.wait().expect("wait");
    assert!(
        status.success(),
        "SIGTERM did not end the run cleanly: {status}"
    );
    let s = summary(&out);
    let stopped = s["steps"].as_u64().unwrap();
    assert_eq!(s["completed"], false, "the run finished before the signal");
    assert!(stopped > 300 && stopped < total);
    let last = s["last_checkpoint"].as_str().unwrap().to_owned();
    assert!(last.ends_with(&checkpoint::file_name(stopped)));
    // Continue to the end.
    let o = binary(&["restart", &last, "-q", "-t", "1"])
        .output()
        .expect("restart");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let s = summary(&out);
    assert_eq!(s["completed"], true);
    assert_eq!(s["state_digest"], whole.as_str());
}

#[test]
fn restart_with_more_steps_extends_the_run_and_remembers_it() {
    let text = le_case(2, 100, "");
    let longer = uninterrupted(&common::with_overrides(&text, &["run.steps=150"]));
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_path_buf();
    let loaded = case_from_str(&text, "short");
    let o = out.clone();
    let done = in_process(1, move |c| run_case(&loaded, c, &options(Some(&o), None))).expect("run");
    assert!(done.completed);
    // Extend to 150, but stop at 120 as a batch job would …
    let o = out.clone();
    let part = in_process(2, move |c| {
        let mut opts = options(Some(&o), Some(120));
        opts.steps = Some(150);
        restart_case(&o.join("checkpoints"), c, &opts)
    })
    .expect("extend");
    assert!(!part.completed);
    assert_eq!(part.steps, 120);
    // … and the next plain restart still knows the run now ends at 150.
    let rest = restart_into(&out.join("checkpoints"), 1, &out).expect("finish");
    assert!(rest.completed);
    assert_eq!(rest.steps, 150);
    assert_eq!(rest.state_digest, longer);
    // Shortening below the reached step is refused.
    let o = out.clone();
    let err = in_process(1, move |c| {
        let mut opts = options(Some(&o), None);
        opts.steps = Some(50);
        restart_case(&o.join("checkpoints"), c, &opts)
    })
    .expect_err("steps below the checkpoint accepted");
    assert!(err.to_string().contains("--steps 50"), "{err}");
}

#[test]
fn a_fresh_run_moves_an_earlier_runs_checkpoints_aside() {
    let text = le_case(2, 40, "[output]\ncheckpoint_every = 20");
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_path_buf();
    for _ in 0..2 {
        let loaded = case_from_str(&text, "again");
        let o = out.clone();
        in_process(1, move |c| run_case(&loaded, c, &options(Some(&o), None))).expect("run");
    }
    let steps: Vec<u64> = checkpoint::list(&out.join("checkpoints"))
        .iter()
        .map(|c| c.0)
        .collect();
    assert_eq!(steps, vec![40, 20]);
    let previous: Vec<u64> = checkpoint::list(&out.join("checkpoints.previous"))
        .iter()
        .map(|c| c.0)
        .collect();
    assert_eq!(previous, vec![40, 20]);
}

#[test]
fn an_unwritable_checkpoint_directory_stops_every_rank_with_an_error_not_a_hang() {
    let text = le_case(2, 40, "[output]\ncheckpoint_every = 20");
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).expect("mkdir");
    // `checkpoints` is a file, so the directory cannot be created (on rank 0 only).
    std::fs::write(out.join("checkpoints"), "not a directory").expect("write");
    let loaded = case_from_str(&text, "unwritable");
    let err = in_process(3, move |c| run_case(&loaded, c, &options(Some(&out), None)))
        .expect_err("a checkpoint was written into a file");
    assert!(err.to_string().contains("checkpoints"), "{err}");
}

/// A walled SPH channel (boundary species, a moving wall, XSPH's drift correction, integrated
/// continuity density, the two-stage integrator's scratch fields, the density profile's
/// series, a polymer stress): N steps ≡ N/2 + checkpoint + restart on another rank count + N/2, bitwise.
#[test]
fn sph_channel_restart_is_bitwise() {
    let channel = |extra_fluid: &str, integrator: &str| {
        format!(
            r#"
dimension = 2
[box]
lengths = [0.6, 0.6]
boundaries = ["periodic", "wall"]
[decomposition]
axis = "x"
[particles]
lattice = "cubic"
density = 2500.0
mass = 0.0004
temperature = 0.0
[fluid]
kind = "sph"
smoothing_length = 0.05
sound_speed = 10.0
viscosity = 1.0
equation_of_state = "tait"
{extra_fluid}
[walls]
upper_velocity = [1.0, 0.0]
treatment = "morris"
[integrator]
kind = "{integrator}"
dt = 1e-4
[neighbour]
skin = 0.002
[run]
steps = 120
[diagnostics]
observables = ["velocity_profile", "density_profile"]
profile_bins = 6
"#
        )
    };
    for text in [
        channel("xsph = 0.5", "kick_drift_kick"),
        channel(
            "density = \"continuity\"\nviscous_term = \"morris\"",
            "heun",
        ),
        // A Maxwell fluid: the polymer stress, its rate and the half-step scratch.
        channel(
            "viscous_term = \"morris\"\n[fluid.polymer]\nmodel = \"corotational_maxwell\"\n\
             viscosity = 1.0\nrelaxation_time = 0.05",
            "kick_drift_kick",
        ),
    ] {
        assert_restart_at_60_is_bitwise(&text, "SPH channel");
    }
}

/// The GENERIC polymer fluid particle (`kind = "generic_polymer"`) in Lees–Edwards shear with
/// its thermal noise on: the continuity density, the conformation vectors and their
/// kick–drift–kick half-step scratch travel in the checkpoint, and the pair and conformation
/// noise, keyed by (seed, step, ids), continue where they stopped: N steps ≡ N/2 + checkpoint
/// + restart on another rank count + N/2, bitwise.
///
/// Also with the smoothed velocity gradient in the Q equation (a derived field, recomputed,
/// never checkpointed), and Model A (3 explicit dumbbells per particle: the ensemble is
/// checkpointed, its average ⟨QQ⟩ derived).
#[test]
fn generic_polymer_restart_is_bitwise() {
    // The GENERIC tests' box (16 × 16, k_BT = 1, λ_H = 0.1), sheared at 0.3, 120 steps.
    for extra in [
        "",
        "conformation_gradient = \"smoothed\"",
        "explicit_dumbbells = 3",
    ] {
        let text = super::generic_polymer::at_rest(0.01, 120, 0.3, extra);
        assert_restart_at_60_is_bitwise(&text, &format!("GENERIC polymer, Lees–Edwards {extra}"));
    }
}

/// `text` run whole ≡ run to step 60 on 1 (2) ranks + restarted on 2 (1) ranks, bitwise.
fn assert_restart_at_60_is_bitwise(text: &str, name: &str) {
    let whole = uninterrupted(text);
    for (first, second) in [(1, 2), (2, 1)] {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().to_path_buf();
        let half = run_until(text, first, &out, 60);
        assert_eq!(half.steps, 60);
        let rest = restart_into(&out.join("checkpoints"), second, &out).expect("second half");
        assert!(rest.completed);
        assert_eq!(
            rest.state_digest, whole,
            "{name}: {first} ranks → checkpoint at 60 → {second} ranks differs"
        );
    }
}

/// A sheared cell with an inclusion in a Maxwell fluid (the inclusion species and offsets, the
/// polymer stress, XSPH): N steps ≡ N/2 + checkpoint + restart on another rank count + N/2,
/// bitwise.
#[test]
fn sph_inclusion_restart_is_bitwise() {
    let text = stock_text_with(
        "inclusion_maxwell_2d.toml",
        &["run.steps=120", "run.equilibration=0"],
    );
    assert_restart_at_60_is_bitwise(&text, "inclusion cell");
}

/// CONNFFESSIT in Lees–Edwards shear (the dumbbell ensembles, checkpointed as variable-length
/// rows, and the velocity gradient they step with): N steps ≡ N/2 + checkpoint + restart on
/// another rank count + N/2, bitwise.
#[test]
fn connffessit_restart_is_bitwise() {
    let text = stock_text_with(
        "connffessit_shear_2d.toml",
        &[
            "run.steps=120",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
        ],
    );
    assert_restart_at_60_is_bitwise(&text, "CONNFFESSIT shear");
}

/// CONNFFESSIT with BDDFS histograms per particle (variable-length word rows, and the stress
/// measured on the last step's advanced connectors, which the histogram no longer holds: both
/// checkpointed): N steps ≡ N/2 + checkpoint + restart on another rank count + N/2, bitwise.
#[test]
fn bddfs_connffessit_restart_is_bitwise() {
    let text = stock_text_with(
        "bddfs_connffessit_shear_2d.toml",
        &[
            "reference=[]",
            "run.steps=120",
            "run.equilibration=0",
            "fluid.polymer.per_particle=8",
        ],
    );
    assert_restart_at_60_is_bitwise(&text, "BDDFS CONNFFESSIT shear");
}

/// The CONNFFESSIT channel with MSPH derivatives and mirror walls (the moment systems and the
/// mirror fits are re-formed at every evaluation; the connectors and the velocity gradient
/// they step with are checkpointed): N steps ≡ N/2 + checkpoint + restart on another rank
/// count + N/2, bitwise.
#[test]
fn msph_connffessit_channel_restart_is_bitwise() {
    let text = stock_text_with(
        "connffessit_channel_2d.toml",
        &[
            "reference=[]",
            "run.steps=120",
            "run.sample_every=10",
            "fluid.polymer.per_particle=8",
        ],
    );
    assert_restart_at_60_is_bitwise(&text, "CONNFFESSIT channel (MSPH)");
}

/// The Green–Kubo and transverse-current correlators travel in the checkpoint: the viscosities
/// of N/2 steps + checkpoint + restart on another rank count + N/2 equal those of one run,
/// bitwise, and so does the state.
#[test]
fn green_kubo_correlators_restart_bitwise_on_other_rank_counts() {
    let text = small_dpd(
        3,
        6.0,
        0.0,
        120,
        "equilibration = 10\n[diagnostics]\nobservables = [\"temperature\", \
         \"green_kubo_viscosity\", \"transverse_current_viscosity\"]\nblocks = 2\n\
         green_kubo_time = 0.4\ntransverse_current_modes = 2\ntransverse_current_every = 1\n\
         transverse_current_time = 0.64\n",
    );
    let loaded = case_from_str(&text, "whole");
    let whole = in_process(1, move |c| run_case(&loaded, c, &options(None, None)))
        .expect("uninterrupted run");
    let eta = |s: &Summary| s.observables["green_kubo_viscosity"];
    let tcaf = |s: &Summary| s.observables["transverse_current_viscosity_k1"];
    let reference = eta(&whole);
    assert!(tcaf(&whole).mean.is_finite(), "{:?}", tcaf(&whole));
    assert!(
        reference.mean.is_finite() && reference.samples == 2,
        "{reference:?}"
    );
    for (first, second) in [(1, 2), (2, 1)] {
        let dir = tempfile::tempdir().expect("tempdir");
        let out = dir.path().to_path_buf();
        // Step 60: inside the first block, with products at every level pending.
        let half = run_until(&text, first, &out, 60);
        assert_eq!(half.steps, 60);
        let rest = restart_into(&out.join("checkpoints"), second, &out).expect("second half");
        assert!(rest.completed);
        assert_eq!(rest.state_digest, whole.state_digest);
        let got = eta(&rest);
        assert_eq!(
            (got.mean.to_bits(), got.stderr.to_bits()),
            (reference.mean.to_bits(), reference.stderr.to_bits()),
            "{first} → {second} ranks: {got:?} vs {reference:?}"
        );
        assert!(out.join("green_kubo.csv").exists());
        let (a, b) = (tcaf(&rest), tcaf(&whole));
        assert_eq!(
            (a.mean.to_bits(), a.stderr.to_bits()),
            (b.mean.to_bits(), b.stderr.to_bits()),
            "transverse-current viscosity, {first} → {second} ranks: {a:?} vs {b:?}"
        );
    }
}

/// `--max-hours`: a run whose first 20 steps project beyond the budget stops there on every
/// rank, with a checkpoint and an error saying so; restarting from it gives the uninterrupted
/// run's bits; a generous budget changes nothing. (Issue #18.) Fails if the budget is ignored
/// (the run completes) or decided per rank (the ranks disagree and the run hangs).
#[test]
fn a_run_beyond_its_time_budget_stops_after_the_probe_with_a_checkpoint() {
    let text = le_case(2, 120, "");
    let whole = uninterrupted(&text);
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_path_buf();
    let loaded = case_from_str(&text, "budget");
    let o = out.clone();
    let err = in_process(2, move |c| {
        let options = RunOptions {
            max_hours: Some(1e-12),
            ..options(Some(&o), None)
        };
        run_case(&loaded, c, &options)
    })
    .expect_err("over budget");
    assert!(
        err.to_string().contains("--max-hours") && err.to_string().contains("stopped at step 20"),
        "{err}"
    );
    let ck = out.join("checkpoints").join(checkpoint::file_name(20));
    assert!(ck.exists(), "{err}");
    let rest = restart_into(&out.join("checkpoints"), 1, &out).expect("restart");
    assert_eq!(rest.state_digest, whole);
    let loaded = case_from_str(&text, "budget");
    let generous = in_process(1, move |c| {
        let options = RunOptions {
            max_hours: Some(100.0),
            ..options(None, None)
        };
        run_case(&loaded, c, &options)
    })
    .expect("within budget");
    assert!(generous.completed && generous.state_digest == whole);
}
