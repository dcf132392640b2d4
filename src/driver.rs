//! Running a case on a communicator: dimension dispatch, fresh start or restart, the step
//! loop with progress lines, checkpoints, snapshots and clean stops, and the summary.

use crate::comm::Comm;
use crate::config::LoadedCase;
use crate::diagnostics::Estimate;
use crate::sim::Simulation;
use crate::summary::{ProfilePoint, Summary, validate};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Options of one run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// rayon threads per rank (0: all available).
    pub threads: usize,
    /// Override of the case's step count.
    pub steps: Option<u64>,
    /// Stop cleanly, with a checkpoint, when this step is reached.
    pub until_step: Option<u64>,
    /// Output directory for checkpoints and snapshots (`None`: no files).
    pub out: Option<PathBuf>,
}

/// Set by SIGTERM / SIGUSR1: finish the step, checkpoint, stop.
static STOP_REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks every run of this process to stop cleanly after its current step (what the signal
/// handlers do; tests call it directly).
pub fn request_stop() {
    STOP_REQUESTED.store(true, Ordering::SeqCst);
}

/// Whether a stop was requested in this process (a signal, or [`request_stop`]).
pub(crate) fn stop_requested() -> bool {
    STOP_REQUESTED.load(Ordering::SeqCst)
}

/// Clears a stop request.
pub fn clear_stop() {
    STOP_REQUESTED.store(false, Ordering::SeqCst);
}

pub(crate) fn threads_of(options: &RunOptions) -> usize {
    if options.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        options.threads
    }
}

/// Runs a case from its initial state on this rank (collective over `comm`); every rank
/// returns the same summary.
pub fn run_case(
    loaded: &LoadedCase,
    comm: &dyn Comm,
    options: &RunOptions,
) -> Result<Summary, String> {
    let threads = threads_of(options);
    match loaded.case.dimension {
        2 => {
            let sim = Simulation::<2>::new(&loaded.case, comm, threads)?;
            drive(sim, loaded, None, comm, options, threads)
        }
        3 => {
            let sim = Simulation::<3>::new(&loaded.case, comm, threads)?;
            drive(sim, loaded, None, comm, options, threads)
        }
        d => Err(format!("dimension {d} is not supported")),
    }
}

/// Where a restart may start from: `path` itself (a checkpoint file, or a directory of them),
/// then every older checkpoint beside it, newest first.
pub fn restart_candidates(path: &Path) -> Vec<PathBuf> {
    #[cfg(feature = "hdf5")]
    {
        use crate::output::checkpoint;
        if path.is_dir() {
            return checkpoint::list(path).into_iter().map(|(_, p)| p).collect();
        }
        let mut out = vec![path.to_path_buf()];
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let step: Option<u64> = name
            .strip_prefix("checkpoint_")
            .and_then(|n| n.strip_suffix(".h5"))
            .and_then(|n| n.parse().ok());
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if let Some(step) = step {
            out.extend(
                checkpoint::list(dir)
                    .into_iter()
                    .filter(|(s, _)| *s < step)
                    .map(|(_, p)| p),
            );
        }
        out
    }
    #[cfg(not(feature = "hdf5"))]
    {
        vec![path.to_path_buf()]
    }
}

/// How a summary warning about a checkpoint that a restart refused (and replaced by an older
/// one) begins; the path and the reason follow.
pub const CHECKPOINT_REFUSED: &str = "checkpoint refused, an older one used";

/// Continues a run from a checkpoint (collective). A checkpoint that cannot be read or fails
/// its checksum is reported and the previous one in the same directory is used instead.
pub fn restart_case(
    checkpoint: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
) -> Result<Summary, String> {
    #[cfg(feature = "hdf5")]
    {
        use crate::output::checkpoint as ck;
        let threads = threads_of(options);
        if !checkpoint.exists() {
            return Err(format!(
                "{}: no such checkpoint file or directory (checkpoints are written to \
                 OUT/checkpoints/checkpoint_<step>.h5)",
                checkpoint.display()
            ));
        }
        let candidates = restart_candidates(checkpoint);
        if candidates.is_empty() {
            return Err(format!("no checkpoint found in {}", checkpoint.display()));
        }
        let mut refused = Vec::new();
        for path in candidates {
            // A homogeneous-flow checkpoint is continued by the flow driver (every rank reads
            // the same attribute; agreed collectively all the same).
            let is_flow = matches!(
                ck::format_of(&path),
                Ok(f) if f == crate::output::flow_checkpoint::FORMAT
            );
            let mut flow_flag = [if is_flow { 1.0 } else { 0.0 }];
            comm.allreduce_max(&mut flow_flag);
            let attempt = if flow_flag[0] > 0.0 {
                crate::flow_driver::restart_from(&path, comm, options, threads)
            } else {
                restart_particles(&path, comm, options, threads)
            };
            match attempt {
                Ok(mut summary) => {
                    // The run continued from an older checkpoint than asked for: say why.
                    summary
                        .warnings
                        .extend(refused.iter().map(|e| format!("{CHECKPOINT_REFUSED}: {e}")));
                    return Ok(summary);
                }
                Err(Restart::Failed(e)) => return Err(e),
                Err(Restart::Refused(e)) => {
                    if comm.rank() == 0 {
                        tracing::warn!(
                            "checkpoint {} refused: {e}; trying the previous one",
                            path.display()
                        );
                    }
                    refused.push(e.clone());
                    set_aside_if_corrupt(&path, &e, comm);
                }
            }
        }
        Err(format!("no usable checkpoint:\n  {}", refused.join("\n  ")))
    }
    #[cfg(not(feature = "hdf5"))]
    {
        let _ = (comm, options);
        Err(format!(
            "cannot restart from {}: this mesorheo was built without HDF5 (feature `hdf5`)",
            checkpoint.display()
        ))
    }
}

/// Continues a particle scene from the checkpoint `path` (collective).
#[cfg(feature = "hdf5")]
fn restart_particles(
    path: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, Restart> {
    let case = crate::output::checkpoint::read_case(path);
    let mut flag = [if case.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut flag);
    match case {
        Ok(case) if flag[0] == 0.0 => {
            let loaded = LoadedCase {
                source: toml::to_string(&case).unwrap_or_default(),
                case,
                path: path.to_path_buf(),
            };
            match loaded.case.dimension {
                2 => restore_and_drive::<2>(&loaded, path, comm, options, threads),
                3 => restore_and_drive::<3>(&loaded, path, comm, options, threads),
                d => Err(Restart::Refused(format!("dimension {d} is not supported"))),
            }
        }
        Ok(_) => Err(Restart::Refused("unreadable on another rank".into())),
        Err(e) => Err(Restart::Refused(e)),
    }
}

#[cfg(feature = "hdf5")]
pub(crate) enum Restart {
    /// The checkpoint is unusable: try an older one.
    Refused(String),
    /// The run itself failed after a good start.
    Failed(String),
}

#[cfg(feature = "hdf5")]
fn restore_and_drive<const D: usize>(
    loaded: &LoadedCase,
    path: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, Restart> {
    let r = crate::output::checkpoint::read::<D>(path, comm).map_err(Restart::Refused)?;
    let sim = Simulation::<D>::from_checkpoint(
        &r.case,
        comm,
        threads,
        r.particles,
        r.total,
        r.step,
        r.rebuild_step,
        r.series,
    )
    .map_err(Restart::Failed)?;
    log_restart(comm, path, r.step);
    drive(sim, loaded, Some(path), comm, options, threads).map_err(Restart::Failed)
}

/// A fresh run into an output directory that holds checkpoints of an earlier run moves them to
/// `checkpoints.previous/` (replacing an older one), so a later `restart OUT/checkpoints` can
/// never continue the wrong run and nothing is deleted unasked (collective).
pub(crate) fn set_aside_old_checkpoints(dir: &Path, comm: &dyn Comm) -> Result<(), String> {
    let mut result = Ok(());
    if comm.rank() == 0
        && dir.is_dir()
        && std::fs::read_dir(dir).is_ok_and(|mut d| d.next().is_some())
    {
        let previous = dir.with_file_name("checkpoints.previous");
        result = (|| -> std::io::Result<()> {
            if previous.exists() {
                std::fs::remove_dir_all(&previous)?;
            }
            std::fs::rename(dir, &previous)
        })()
        .map_err(|e| format!("cannot move the earlier run's {} aside: {e}", dir.display()));
        if result.is_ok() {
            tracing::warn!(
                "{} held checkpoints of an earlier run: moved to {}",
                dir.display(),
                previous.display()
            );
        }
    }
    let mut failed = [if result.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut failed);
    match result {
        Err(e) => Err(e),
        Ok(()) if failed[0] > 0.0 => Err("cannot move old checkpoints aside (rank 0)".into()),
        Ok(()) => Ok(()),
    }
}

/// A checkpoint refused for damage (not e.g. for a dimension mismatch) is renamed
/// `NAME.corrupt` (rank 0, after every rank has decided), so it is kept for inspection but no
/// restart picks it again.
#[cfg(feature = "hdf5")]
pub(crate) fn set_aside_if_corrupt(path: &Path, reason: &str, comm: &dyn Comm) {
    comm.barrier();
    let damaged = reason.contains("corrupt") || reason.contains("not a readable HDF5 file");
    if comm.rank() == 0 && damaged && path.is_file() {
        let aside = path.with_extension("h5.corrupt");
        match std::fs::rename(path, &aside) {
            Ok(()) => tracing::warn!("renamed {} to {}", path.display(), aside.display()),
            Err(e) => tracing::warn!("cannot rename {}: {e}", path.display()),
        }
    }
    comm.barrier();
}

/// Writes a checkpoint of the current step, if output is on (collective).
fn checkpoint<const D: usize>(
    sim: &mut Simulation<'_, D>,
    options: &RunOptions,
) -> Result<Option<PathBuf>, String> {
    let Some(out) = &options.out else {
        return Ok(None);
    };
    #[cfg(feature = "hdf5")]
    {
        let t = Instant::now();
        let path = crate::output::checkpoint::write(
            sim,
            &out.join("checkpoints"),
            sim.case.output.checkpoint_keep,
        )?;
        sim.times.checkpoints += t.elapsed().as_secs_f64();
        if sim.comm().rank() == 0 {
            tracing::info!(
                "checkpoint {} ({:.2} s)",
                path.display(),
                t.elapsed().as_secs_f64()
            );
        }
        Ok(Some(path))
    }
    #[cfg(not(feature = "hdf5"))]
    {
        let _ = (sim, out);
        Err("checkpoints need HDF5: this mesorheo was built without the `hdf5` feature".into())
    }
}

/// The step loop with its schedule of samples, snapshots and checkpoints, then the summary.
fn drive<const D: usize>(
    mut sim: Simulation<'_, D>,
    loaded: &LoadedCase,
    restarted_from: Option<&Path>,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, String> {
    let wall = Instant::now();
    let first_step = sim.step;
    if let Some(n) = options.steps {
        if n < first_step {
            return Err(format!(
                "--steps {n} is below the step {first_step} the run has already reached"
            ));
        }
        // Stored in the case, so later checkpoints (and restarts from them) keep it.
        sim.case.run.steps = n;
    }
    let case = sim.case.clone();
    let last_step = case.run.steps;
    let stop_at = options.until_step.map_or(last_step, |k| k.min(last_step));
    if stop_at <= first_step && first_step < last_step {
        return Err(format!(
            "--until-step {stop_at} is not after the current step {first_step}"
        ));
    }
    tracing::info!(
        particles = sim.total_particles,
        ranks = comm.size(),
        threads,
        owned = sim.particles.n_owned,
        "{} {} at step {first_step}",
        if restarted_from.is_some() {
            "continuing"
        } else {
            "set up"
        },
        loaded.path.display()
    );
    if restarted_from.is_none()
        && let Some(out) = &options.out
    {
        set_aside_old_checkpoints(&out.join("checkpoints"), comm)?;
    }
    #[cfg(feature = "hdf5")]
    let mut snapshots = match (&options.out, case.output.snapshot_every) {
        (Some(out), every) if every > 0 => Some(crate::output::snapshot::SnapshotWriter::open(
            &sim,
            out,
            restarted_from.is_some(),
        )?),
        _ => None,
    };
    #[cfg(not(feature = "hdf5"))]
    if options.out.is_some() && case.output.snapshot_every > 0 {
        return Err(
            "snapshots need HDF5: this mesorheo was built without the `hdf5` feature".into(),
        );
    }
    let every = case.run.progress_seconds;
    let is_root = comm.rank() == 0;
    let mut last_report = Instant::now();
    let start = Instant::now();
    let mut last_checkpoint: Option<PathBuf> = None;
    let mut checkpointed_at = None;
    let mut stopped_by_signal = false;
    while sim.step < stop_at {
        if STOP_REQUESTED.load(Ordering::SeqCst) {
            sim.request_stop();
        }
        sim.advance()?;
        if sim.is_sample_step() {
            sim.sample();
        }
        let step = sim.step;
        #[cfg(feature = "hdf5")]
        if let Some(w) = &mut snapshots
            && step.is_multiple_of(case.output.snapshot_every)
        {
            let t = Instant::now();
            w.write_frame(&sim)?;
            sim.times.snapshots += t.elapsed().as_secs_f64();
        }
        let ck = case.output.checkpoint_every;
        if ck > 0 && step.is_multiple_of(ck) && options.out.is_some() {
            last_checkpoint = checkpoint(&mut sim, options)?;
            checkpointed_at = Some(step);
        }
        // Agreed within the step's own reduction, so every rank stops after the same step.
        if sim.stop_agreed() {
            stopped_by_signal = true;
            if is_root {
                tracing::warn!("stop requested: stopping after step {step}");
            }
            break;
        }
        if is_root && every > 0.0 && last_report.elapsed().as_secs_f64() >= every {
            last_report = Instant::now();
            let done = (step - first_step) as f64;
            let rate = done / start.elapsed().as_secs_f64();
            let eta = (stop_at - step) as f64 / rate.max(1e-12);
            tracing::info!(
                "step {step}/{last_step} t = {:.4} {:.1} steps/s ETA {:.0} s",
                sim.time(),
                rate,
                eta
            );
        }
    }
    let loop_seconds = start.elapsed().as_secs_f64();
    let completed = sim.step >= last_step;
    let wants_final = case.output.checkpoint_at_end || !completed;
    if wants_final && options.out.is_some() && checkpointed_at != Some(sim.step) {
        last_checkpoint = checkpoint(&mut sim, options)?;
    }
    if stopped_by_signal || !completed {
        tracing::info!(
            "stopped at step {} of {last_step}; restart from {}",
            sim.step,
            last_checkpoint
                .as_deref()
                .map_or("(no checkpoint: no output directory)".into(), |p| p
                    .display()
                    .to_string())
        );
    }
    #[cfg(feature = "hdf5")]
    if let Some(w) = &mut snapshots {
        w.finish(&sim)?;
    }
    let blocks = case.diagnostics.blocks;
    let observables = sim.series.estimates(blocks);
    let warnings = crate::diagnostics::block_warnings(&sim.series.scalars, blocks);
    for w in &warnings {
        tracing::warn!("{w}");
    }
    let ly = case.domain.lengths[1];
    let profile: Vec<ProfilePoint> = sim
        .series
        .profile_estimates(blocks)
        .iter()
        .enumerate()
        .map(|(b, e): (usize, &Estimate)| {
            let nb = case.diagnostics.profile_bins as f64;
            let y = (b as f64 + 0.5) * ly / nb;
            ProfilePoint {
                y,
                mean: e.mean,
                stderr: e.stderr,
                expected: sim.sim_box.streaming_velocity(y),
            }
        })
        .collect();
    let validation = if completed {
        validate(&case, &observables, &profile)
    } else {
        Vec::new()
    };
    let state_digest = sim.state_digest();
    let steps_run = sim.step - first_step;
    Ok(Summary {
        version: env!("CARGO_PKG_VERSION").to_owned(),
        case: serde_json::to_value(&case).map_err(|e| e.to_string())?,
        case_file: loaded.path.display().to_string(),
        ranks: comm.size(),
        threads,
        dimension: D,
        particles: sim.total_particles,
        steps: sim.step,
        completed,
        restarted_from: restarted_from.map(|p| p.display().to_string()),
        last_checkpoint: last_checkpoint.map(|p| p.display().to_string()),
        time: sim.time(),
        wall_seconds: wall.elapsed().as_secs_f64(),
        loop_seconds,
        particle_steps_per_second: sim.total_particles as f64 * steps_run as f64
            / loop_seconds.max(1e-300),
        dumbbell_steps_per_second: None,
        observables,
        velocity_profile: profile,
        validation,
        warnings,
        state_digest,
        phase_seconds: sim.times.clone(),
    })
}

/// Writes `summary.json` into `out` (rank 0 only).
pub fn write_summary(summary: &Summary, out: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    let text = serde_json::to_string_pretty(summary).map_err(std::io::Error::other)?;
    let tmp = out.join("summary.json.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(tmp, out.join("summary.json"))
}

/// Runs `job` on `ranks` in-process ranks (threads connected by channels) and returns rank 0's
/// result — what the tests use to check that results do not depend on the decomposition
/// without launching `mpirun`.
pub fn in_process<T: Send + 'static>(
    ranks: usize,
    job: impl Fn(&dyn Comm) -> Result<T, String> + Send + Sync + 'static,
) -> Result<T, String> {
    let job = std::sync::Arc::new(job);
    let comms = crate::comm::local_universe(ranks);
    let handles: Vec<_> = comms
        .into_iter()
        .map(|comm| {
            let job = job.clone();
            std::thread::spawn(move || job(&comm))
        })
        .collect();
    let mut results: Vec<Result<T, String>> = handles
        .into_iter()
        .map(|h| {
            h.join()
                .unwrap_or_else(|_| Err("a rank thread panicked".into()))
        })
        .collect();
    results.swap_remove(0)
}

/// Runs a case on `ranks` in-process ranks, each with `threads` rayon workers, and returns
/// rank 0's summary.
pub fn run_in_process(
    loaded: &LoadedCase,
    ranks: usize,
    threads: usize,
    steps: Option<u64>,
) -> Result<Summary, String> {
    let loaded = loaded.clone();
    in_process(ranks, move |comm| {
        run_case(
            &loaded,
            comm,
            &RunOptions {
                threads,
                steps,
                ..RunOptions::default()
            },
        )
    })
}

/// Rank 0's log line after a restart has read its checkpoint.
#[cfg(feature = "hdf5")]
pub(crate) fn log_restart(comm: &dyn Comm, path: &Path, step: u64) {
    if comm.rank() == 0 {
        tracing::info!(
            "restarted from {} at step {step} on {} rank(s)",
            path.display(),
            comm.size()
        );
    }
}
