//! Running a case on a communicator: dimension dispatch, the set-up of a fresh scene or of a
//! restarted one (with the fallback to older checkpoints), then the one step loop
//! ([`crate::scene::drive`]); in-process ranks for the tests.

use crate::comm::Comm;
use crate::config::{FlowCase, LoadedCase};
use crate::error::Error;
use crate::flow_scene::FlowScene;
use crate::scene::{ParticleScene, drive};
use crate::sim::Simulation;
use crate::summary::Summary;
use std::path::{Path, PathBuf};

pub use crate::comm::in_process;
pub(crate) use crate::scene::threads_of;
#[cfg(feature = "hdf5")]
use crate::scene::{Restart, log_restart};
pub use crate::scene::{RunOptions, clear_stop, request_stop};

/// Runs a particle case from its initial state on this rank (collective over `comm`); every
/// rank returns the same summary.
pub fn run_case(
    loaded: &LoadedCase,
    comm: &dyn Comm,
    options: &RunOptions,
) -> Result<Summary, Error> {
    let threads = threads_of(options);
    let path = &loaded.path;
    if loaded.case.run.beyond_stability_limits && comm.rank() == 0 {
        tracing::warn!(
            "run.beyond_stability_limits: the time step is not checked against the stability \
             limits (see `mesorheo check`); a blow-up stops the run"
        );
    }
    match loaded.case.dimension {
        2 => {
            let sim = Simulation::<2>::new(&loaded.case, comm, threads)?;
            drive(ParticleScene::new(sim), path, None, comm, options, threads)
        }
        3 => {
            let sim = Simulation::<3>::new(&loaded.case, comm, threads)?;
            drive(ParticleScene::new(sim), path, None, comm, options, threads)
        }
        d => Err(format!("dimension {d} is not supported").into()),
    }
}

/// Runs a homogeneous-flow scene from equilibrium (collective); every rank returns the same
/// summary.
pub fn run_flow_case(
    case: &FlowCase,
    case_file: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
) -> Result<Summary, Error> {
    let threads = threads_of(options);
    if comm.rank() == 0 {
        for w in crate::config::flow::accuracy_warnings(case) {
            tracing::warn!("{w}");
        }
    }
    match case.dimension {
        2 => {
            let scene = FlowScene::<2>::fresh(case, comm, threads)?;
            drive(scene, case_file, None, comm, options, threads)
        }
        3 => {
            let scene = FlowScene::<3>::fresh(case, comm, threads)?;
            drive(scene, case_file, None, comm, options, threads)
        }
        d => Err(format!("dimension {d} is not supported").into()),
    }
}

/// Continues a homogeneous-flow run from the checkpoint `path` (collective).
#[cfg(feature = "hdf5")]
fn restart_flow(
    path: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, Restart> {
    use crate::output::checkpoint::{CheckpointError, agree, ensembles};
    let case = agree(ensembles::read_case(path), path, comm).map_err(Restart::Refused)?;
    match case.dimension {
        2 => {
            let scene = FlowScene::<2>::restored(case, path, comm, threads)?;
            log_restart(comm, path, scene.step_reached());
            drive(scene, path, Some(path), comm, options, threads).map_err(Restart::Failed)
        }
        3 => {
            let scene = FlowScene::<3>::restored(case, path, comm, threads)?;
            log_restart(comm, path, scene.step_reached());
            drive(scene, path, Some(path), comm, options, threads).map_err(Restart::Failed)
        }
        d => Err(Restart::Refused(CheckpointError::incompatible(
            path,
            format!("dimension {d} is not supported"),
        ))),
    }
}

/// Where a restart may start from: `path` itself (a checkpoint file, or a directory of them),
/// then every older checkpoint beside it, newest first.
pub fn restart_candidates(path: &Path) -> Vec<PathBuf> {
    #[cfg(feature = "hdf5")]
    {
        use crate::output::checkpoint;
        if path.is_dir() {
            let found = checkpoint::list(path);
            // A run directory OUT (not OUT/checkpoints): its checkpoints.
            let found = if found.is_empty() {
                checkpoint::list(&path.join("checkpoints"))
            } else {
                found
            };
            return found.into_iter().map(|(_, p)| p).collect();
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

/// Refuses, before anything is opened or written, what `restart` cannot start from: a path
/// that does not exist, a file that is not a checkpoint (a case file given by mistake: it is
/// left exactly as it is), a directory without checkpoints. An invalid request (exit code 2).
pub fn check_restart_source(checkpoint: &Path) -> Result<(), Error> {
    if !checkpoint.exists() {
        return Err(Error::InvalidCase(format!(
            "{}: no such checkpoint file or directory (checkpoints are written to \
             OUT/checkpoints/checkpoint_<step>.h5)",
            checkpoint.display()
        )));
    }
    #[cfg(feature = "hdf5")]
    {
        crate::output::checkpoint::identify(checkpoint)
            .map_err(|e| Error::InvalidCase(e.to_string()))?;
        if checkpoint.is_dir() && restart_candidates(checkpoint).is_empty() {
            return Err(Error::InvalidCase(format!(
                "no checkpoint found in {} (checkpoints are OUT/checkpoints/\
                 checkpoint_<step>.h5; give the file, OUT/checkpoints or the run directory OUT)",
                checkpoint.display()
            )));
        }
    }
    Ok(())
}

/// Continues a run from a checkpoint (collective), whatever its scene. A checkpoint that
/// cannot be used is reported and the previous one in the same directory is tried instead; a
/// damaged one of ours is also set aside ([`crate::output::checkpoint::CheckpointError`]); a
/// file mesorheo did not write is refused and never touched.
pub fn restart_case(
    checkpoint: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
) -> Result<Summary, Error> {
    check_restart_source(checkpoint)?;
    #[cfg(feature = "hdf5")]
    {
        use crate::output::checkpoint::{self as ck, SceneKind};
        let threads = threads_of(options);
        let candidates = restart_candidates(checkpoint);
        let mut refused = Vec::new();
        for path in candidates {
            // Every rank identifies the file itself; the verdict is agreed collectively.
            let scene = ck::agree(ck::scene_of(&path), &path, comm);
            let attempt = match scene {
                Ok(SceneKind::Particles) => restart_particles(&path, comm, options, threads),
                Ok(SceneKind::HomogeneousFlow) => restart_flow(&path, comm, options, threads),
                Err(e) => Err(Restart::Refused(e)),
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
                    // A file that is not a checkpoint at all: the request is wrong, and no
                    // other file is a substitute for it.
                    if e.is_not_a_checkpoint() {
                        return Err(Error::InvalidCase(e.to_string()));
                    }
                    if comm.rank() == 0 {
                        tracing::warn!("checkpoint refused: {e}; trying the previous one");
                    }
                    set_aside_if_damaged(&path, &e, comm);
                    refused.push(e.to_string());
                }
            }
        }
        Err(format!("no usable checkpoint:\n  {}", refused.join("\n  ")).into())
    }
    #[cfg(not(feature = "hdf5"))]
    {
        let _ = (comm, options);
        Err(Error::InvalidCase(format!(
            "cannot restart from {}: this mesorheo was built without HDF5 (feature `hdf5`)",
            checkpoint.display()
        )))
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
    use crate::output::checkpoint as ck;
    let case = ck::agree(ck::read_case(path), path, comm).map_err(Restart::Refused)?;
    let loaded = LoadedCase {
        source: toml::to_string(&case).unwrap_or_default(),
        case,
        path: path.to_path_buf(),
    };
    match loaded.case.dimension {
        2 => restore_and_drive::<2>(&loaded, path, comm, options, threads),
        3 => restore_and_drive::<3>(&loaded, path, comm, options, threads),
        d => Err(Restart::Refused(ck::CheckpointError::incompatible(
            path,
            format!("dimension {d} is not supported"),
        ))),
    }
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
        r.species,
        r.rigid_bodies.as_deref(),
    )
    .map_err(Restart::Failed)?;
    log_restart(comm, path, r.step);
    let scene = ParticleScene::new(sim);
    drive(scene, &loaded.path, Some(path), comm, options, threads).map_err(Restart::Failed)
}

/// A checkpoint of ours refused because it is damaged on any rank (not, e.g., for a dimension
/// mismatch, and never a file mesorheo did not write) is renamed `NAME.h5.corrupt` by rank 0,
/// so it is kept for inspection but no restart picks it again (collective).
#[cfg(feature = "hdf5")]
pub(crate) fn set_aside_if_damaged(
    path: &Path,
    error: &crate::output::checkpoint::CheckpointError,
    comm: &dyn Comm,
) {
    let mut damaged = [if error.is_damaged() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut damaged);
    if comm.rank() == 0 && damaged[0] > 0.0 && path.is_file() {
        let aside = path.with_extension("h5.corrupt");
        match std::fs::rename(path, &aside) {
            Ok(()) => tracing::warn!(
                "{} is a damaged mesorheo checkpoint: renamed to {} (kept for inspection; no \
                 later restart picks it)",
                path.display(),
                aside.display()
            ),
            Err(e) => tracing::warn!(
                "{} is a damaged mesorheo checkpoint and cannot be renamed: {e}",
                path.display()
            ),
        }
    }
    comm.barrier();
}

/// Writes `summary.json` into `out` (rank 0 only).
pub fn write_summary(summary: &Summary, out: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    let text = serde_json::to_string_pretty(summary).map_err(std::io::Error::other)?;
    let tmp = out.join("summary.json.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(tmp, out.join("summary.json"))
}

/// Runs a case on `ranks` in-process ranks, each with `threads` rayon workers, and returns
/// rank 0's summary.
pub fn run_in_process(
    loaded: &LoadedCase,
    ranks: usize,
    threads: usize,
    steps: Option<u64>,
) -> Result<Summary, Error> {
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
