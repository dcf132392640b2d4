//! Running a case on a communicator: dimension dispatch, thread pool, progress, summary.

use crate::comm::Comm;
use crate::config::LoadedCase;
use crate::diagnostics::Estimate;
use crate::sim::Simulation;
use crate::summary::{ProfilePoint, Summary, validate};
use std::path::Path;
use std::time::Instant;

/// Options of one run.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// rayon threads per rank (0: all available).
    pub threads: usize,
    /// Override of the case's step count.
    pub steps: Option<u64>,
}

/// Runs a case on this rank (collective over `comm`); every rank returns the same summary.
pub fn run_case(
    loaded: &LoadedCase,
    comm: &dyn Comm,
    options: &RunOptions,
) -> Result<Summary, String> {
    let threads = if options.threads == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        options.threads
    };
    match loaded.case.dimension {
        2 => run_dim::<2>(loaded, comm, options, threads),
        3 => run_dim::<3>(loaded, comm, options, threads),
        d => Err(format!("dimension {d} is not supported")),
    }
}

fn run_dim<const D: usize>(
    loaded: &LoadedCase,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, String> {
    let wall = Instant::now();
    let case = &loaded.case;
    let steps = options.steps.unwrap_or(case.run.steps);
    let mut sim = Simulation::<D>::new(case, comm, threads)?;
    tracing::info!(
        particles = sim.total_particles,
        ranks = comm.size(),
        threads,
        owned = sim.particles.n_owned,
        "set up {}",
        loaded.path.display()
    );
    let every = case.run.progress_seconds;
    let is_root = comm.rank() == 0;
    let mut last = Instant::now();
    let start = Instant::now();
    let loop_time = sim.run_steps(steps, |s| {
        if is_root && every > 0.0 && last.elapsed().as_secs_f64() >= every {
            last = Instant::now();
            let done = s.step as f64;
            let rate = done / start.elapsed().as_secs_f64();
            let eta = (steps as f64 - done) / rate.max(1e-12);
            tracing::info!(
                "step {}/{} t = {:.4} {:.1} steps/s ETA {:.0} s",
                s.step,
                steps,
                s.time(),
                rate,
                eta
            );
        }
    })?;
    let loop_seconds = loop_time.as_secs_f64();
    let blocks = case.diagnostics.blocks;
    let observables = sim.series.estimates(blocks);
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
    let validation = validate(case, &observables, &profile);
    let state_digest = sim.state_digest();
    let summary = Summary {
        version: env!("CARGO_PKG_VERSION").to_owned(),
        case: serde_json::to_value(case).map_err(|e| e.to_string())?,
        case_file: loaded.path.display().to_string(),
        ranks: comm.size(),
        threads,
        dimension: D,
        particles: sim.total_particles,
        steps: sim.step,
        time: sim.time(),
        wall_seconds: wall.elapsed().as_secs_f64(),
        loop_seconds,
        particle_steps_per_second: sim.total_particles as f64 * steps as f64 / loop_seconds,
        observables,
        velocity_profile: profile,
        validation,
        state_digest,
        phase_seconds: sim.times.clone(),
    };
    Ok(summary)
}

/// Writes `summary.json` into `out` (rank 0 only).
pub fn write_summary(summary: &Summary, out: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    let text = serde_json::to_string_pretty(summary).map_err(std::io::Error::other)?;
    let tmp = out.join("summary.json.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(tmp, out.join("summary.json"))
}

/// Runs a case on `ranks` in-process ranks (threads connected by channels), each with `threads`
/// rayon workers, and returns rank 0's summary — what the tests use to check that results do
/// not depend on the decomposition without launching `mpirun`.
pub fn run_in_process(
    loaded: &LoadedCase,
    ranks: usize,
    threads: usize,
    steps: Option<u64>,
) -> Result<Summary, String> {
    let comms = crate::comm::local_universe(ranks);
    let handles: Vec<_> = comms
        .into_iter()
        .map(|comm| {
            let loaded = loaded.clone();
            std::thread::spawn(move || run_case(&loaded, &comm, &RunOptions { threads, steps }))
        })
        .collect();
    let mut results: Vec<Result<Summary, String>> = handles
        .into_iter()
        .map(|h| {
            h.join()
                .unwrap_or_else(|_| Err("a rank thread panicked".into()))
        })
        .collect();
    results.swap_remove(0)
}
