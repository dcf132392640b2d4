//! A scene, and the one step loop that runs every scene.
//!
//! A scene ([`Scene`]) is what the loop steps: the particle scene ([`ParticleScene`], a
//! [`Simulation`] and its snapshot series) or the homogeneous-flow scene
//! ([`crate::flow_scene::FlowScene`], dumbbell ensembles in an imposed flow). The loop
//! ([`drive`]), its schedule of samples, snapshots and checkpoints, its signals and clean stops,
//! and the common part of the summary are written once, here; [`crate::driver`] sets scenes up
//! and restarts them.

use crate::comm::Comm;
use crate::config::{OutputCfg, RunCfg};
use crate::diagnostics::{DENSITY_PROFILE_PREFIX, Estimate};
use crate::error::Error;
use crate::sim::{PhaseTimes, Simulation};
use crate::summary::{DensityPoint, ProfilePoint, Summary, Validation, check_references};
use std::collections::BTreeMap;
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
    /// Wall-clock budget in hours: the run measures its first [`BUDGET_PROBE_STEPS`] steps
    /// and stops there (with a checkpoint) when the remaining steps would take longer.
    pub max_hours: Option<f64>,
}

/// A duration for the progress line: seconds, minutes, hours or days as fits.
fn duration(seconds: f64) -> String {
    match seconds {
        s if !s.is_finite() => "?".into(),
        s if s < 90.0 => format!("{s:.0} s"),
        s if s < 5400.0 => format!("{:.1} min", s / 60.0),
        s if s < 172_800.0 => format!("{:.1} h", s / 3600.0),
        s => format!("{:.1} d", s / 86400.0),
    }
}

/// Observables a progress line shows (the case's first ones; all are in `observables.csv`).
const THERMO_COLUMNS: usize = 4;

/// Steps timed before a run with `--max-hours` decides whether it fits its budget.
pub const BUDGET_PROBE_STEPS: u64 = 20;

/// Set by SIGTERM / SIGUSR1: finish the step, checkpoint, stop.
static STOP_REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks every run of this process to stop cleanly after its current step (what the signal
/// handlers do; tests call it directly).
pub fn request_stop() {
    STOP_REQUESTED.store(true, Ordering::SeqCst);
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

/// What the step loop of [`drive`] needs of a scene.
pub trait Scene {
    /// The step reached.
    fn step(&self) -> u64;
    /// Simulated time.
    fn time(&self) -> f64;
    /// Run length and sampling of the case.
    fn run(&self) -> &RunCfg;
    /// Checkpoints and snapshots of the case.
    fn output(&self) -> &OutputCfg;
    /// Stores a new step count (`--steps`), so that later checkpoints keep it.
    fn set_steps(&mut self, steps: u64);
    /// What the set-up line of the log says: what is simulated, and how big.
    fn describe(&self) -> String;
    /// Advances one step and samples on the scene's schedule; any rank's stop request is
    /// agreed within the step (collective).
    fn advance(&mut self) -> Result<(), Error>;
    /// Marks that this rank was asked to stop.
    fn request_stop(&mut self);
    /// Whether any rank asked to stop before the last step (the same on every rank).
    fn stop_agreed(&self) -> bool;
    /// What the progress line says beside the step, the time and the ETA, at `steps_per_second`.
    fn progress(&self, steps_per_second: f64) -> String;
    /// The scalar observables the last [`Self::advance`] recorded for the time series
    /// (`observables.csv`), or `None` when its step is not a recorded one: every
    /// `run.sample_every` steps from the first step on, equilibration included.
    fn observables_row(&self) -> Option<&[(String, f64)]>;
    /// Writes the checkpoint of the current step into `dir`, keeping the newest `keep`
    /// (collective).
    fn write_checkpoint(&mut self, dir: &Path, keep: usize) -> Result<PathBuf, Error>;
    /// Opens the scene's output series in `out` (continued after a restart).
    fn open_outputs(&mut self, out: &Path, restarted: bool) -> Result<(), Error>;
    /// Writes what the series take at this step.
    fn write_outputs(&mut self) -> Result<(), Error>;
    /// Closes the series and writes the scene's end-of-run files into `out`, if any.
    fn close_outputs(&mut self, out: Option<&Path>) -> Result<(), Error>;
    /// The scene's part of the summary.
    fn report(&mut self, completed: bool) -> Result<SceneReport, Error>;
    /// Phase timers.
    fn times(&mut self) -> &mut PhaseTimes;
}

/// The part of the summary a scene fills in.
pub struct SceneReport {
    /// The case as run (with `--steps` applied).
    pub case: serde_json::Value,
    /// 2 or 3.
    pub dimension: usize,
    /// Total particle count.
    pub particles: u64,
    /// Dumbbells per step (homogeneous-flow scenes), for the dumbbell-steps rate.
    pub dumbbells: Option<u64>,
    /// Bytes of ensemble storage (connectors or BDDFS histograms) per particle that carries
    /// one, at the end of the run (particle scenes with ensembles).
    pub ensemble_bytes_per_particle: Option<f64>,
    /// Time averages with error bars.
    pub observables: BTreeMap<String, Estimate>,
    /// Binned velocity profile.
    pub velocity_profile: Vec<ProfilePoint>,
    /// Binned SPH density profile.
    pub density_profile: Vec<DensityPoint>,
    /// Binned shear stress.
    pub shear_stress_profile: Vec<ProfilePoint>,
    /// The colloid–solvent RDF.
    pub colloid_solvent_rdf: Vec<crate::summary::RdfPoint>,
    /// Checks against the case's references (after a completed run).
    pub validation: Vec<Validation>,
    /// Warnings about the averages.
    pub warnings: Vec<String>,
    /// Digest of the final state.
    pub state_digest: String,
    /// This rank's owned particles, ghosts and listed pairs at the end (particle scenes).
    pub load: Option<[f64; 3]>,
}

/// A particle scene: the simulation and its snapshot series.
pub struct ParticleScene<'c, const D: usize> {
    /// The simulation.
    pub sim: Simulation<'c, D>,
    #[cfg(feature = "hdf5")]
    snapshots: Option<crate::output::snapshot::SnapshotWriter>,
    /// The scalar observables of the last step, when it was a recorded one.
    row: Option<Vec<(String, f64)>>,
}

impl<'c, const D: usize> ParticleScene<'c, D> {
    /// The scene of `sim`.
    pub fn new(sim: Simulation<'c, D>) -> Self {
        Self {
            sim,
            #[cfg(feature = "hdf5")]
            snapshots: None,
            row: None,
        }
    }
}

impl<const D: usize> Scene for ParticleScene<'_, D> {
    fn step(&self) -> u64 {
        self.sim.step
    }

    fn time(&self) -> f64 {
        self.sim.time()
    }

    fn run(&self) -> &RunCfg {
        &self.sim.case.run
    }

    fn output(&self) -> &OutputCfg {
        &self.sim.case.output
    }

    fn set_steps(&mut self, steps: u64) {
        self.sim.case.run.steps = steps;
    }

    fn describe(&self) -> String {
        format!(
            "{} particles ({}D), {} owned here",
            self.sim.total_particles, D, self.sim.particles.n_owned
        )
    }

    fn advance(&mut self) -> Result<(), Error> {
        self.sim.advance()?;
        // The profiles' bins are series of their own (the summary's profiles), not columns.
        let scalar = |(name, _): &(String, f64)| {
            !name.starts_with(crate::diagnostics::SHEAR_STRESS_PROFILE_PREFIX)
                && !name.starts_with(DENSITY_PROFILE_PREFIX)
                && !name.starts_with(crate::observable::COLLOID_SOLVENT_RDF_PREFIX)
        };
        self.row = None;
        if self.sim.is_sample_step() {
            let mut row = self.sim.sample_values()?;
            row.retain(scalar);
            self.row = Some(row);
        } else if self.sim.is_record_step() {
            let mut row = self.sim.record();
            row.retain(scalar);
            self.row = Some(row);
        }
        if self.sim.is_correlation_step() {
            self.sim.correlate();
        }
        if self.sim.is_current_step() {
            self.sim.sample_currents();
        }
        Ok(())
    }

    fn request_stop(&mut self) {
        self.sim.request_stop();
    }

    fn stop_agreed(&self) -> bool {
        self.sim.stop_agreed()
    }

    fn progress(&self, steps_per_second: f64) -> String {
        format!("{steps_per_second:.1} steps/s")
    }

    fn observables_row(&self) -> Option<&[(String, f64)]> {
        self.row.as_deref()
    }

    fn write_checkpoint(&mut self, dir: &Path, keep: usize) -> Result<PathBuf, Error> {
        #[cfg(feature = "hdf5")]
        {
            crate::output::checkpoint::write(&mut self.sim, dir, keep).map_err(Error::from)
        }
        #[cfg(not(feature = "hdf5"))]
        {
            let _ = (dir, keep);
            Err(NO_HDF5_CHECKPOINTS.into())
        }
    }

    fn open_outputs(&mut self, out: &Path, restarted: bool) -> Result<(), Error> {
        if self.sim.case.output.snapshot_every == 0 {
            return Ok(());
        }
        #[cfg(feature = "hdf5")]
        {
            let w = crate::output::snapshot::SnapshotWriter::open(&self.sim, out, restarted)?;
            self.snapshots = Some(w);
            Ok(())
        }
        #[cfg(not(feature = "hdf5"))]
        {
            let _ = (out, restarted);
            Err("snapshots need HDF5: this mesorheo was built without the `hdf5` feature".into())
        }
    }

    fn write_outputs(&mut self) -> Result<(), Error> {
        #[cfg(feature = "hdf5")]
        if let Some(w) = &mut self.snapshots
            && self
                .sim
                .step
                .is_multiple_of(self.sim.case.output.snapshot_every)
        {
            let t = Instant::now();
            w.write_frame(&self.sim)?;
            self.sim.times.snapshots += t.elapsed().as_secs_f64();
        }
        Ok(())
    }

    fn close_outputs(&mut self, out: Option<&Path>) -> Result<(), Error> {
        #[cfg(feature = "hdf5")]
        if let Some(w) = &mut self.snapshots {
            w.finish(&self.sim)?;
        }
        if let (Some(out), Some(gk)) = (out, self.sim.green_kubo())
            && self.sim.comm().rank() == 0
        {
            write_green_kubo_csv(&gk, out)
                .map_err(|e| format!("cannot write {}/green_kubo.csv: {e}", out.display()))?;
        }
        if let (Some(out), Some(tc)) = (out, self.sim.transverse_current())
            && self.sim.comm().rank() == 0
        {
            write_transverse_current_csv(&tc, out).map_err(|e| {
                format!("cannot write {}/transverse_current.csv: {e}", out.display())
            })?;
        }
        Ok(())
    }

    fn report(&mut self, completed: bool) -> Result<SceneReport, Error> {
        let sim = &self.sim;
        let case = &sim.case;
        let blocks = case.diagnostics.blocks;
        let mut observables = sim.series.estimates(blocks);
        if let Some(gk) = sim.green_kubo() {
            observables.insert(
                crate::config::Observable::GreenKuboViscosity
                    .name()
                    .to_owned(),
                gk.viscosity,
            );
        }
        if let Some(tc) = sim.transverse_current() {
            observables.insert(
                crate::config::Observable::TransverseCurrentViscosity
                    .name()
                    .to_owned(),
                tc.viscosity,
            );
            for (j, m) in tc.modes.iter().enumerate() {
                observables.insert(
                    crate::transverse_current::mode_observable(j + 1),
                    m.viscosity,
                );
            }
        }
        let ly = case.domain.lengths[1];
        let nb = case.diagnostics.profile_bins as f64;
        // The density profile's bins leave the scalar observables for their own list.
        let density_bins: Vec<String> = (observables.keys())
            .filter(|k| k.starts_with(DENSITY_PROFILE_PREFIX))
            .cloned()
            .collect();
        let density_profile: Vec<DensityPoint> = (density_bins.iter().enumerate())
            .map(|(b, name)| {
                let e = observables.remove(name).expect("listed above");
                DensityPoint {
                    y: (b as f64 + 0.5) * ly / nb,
                    mean: e.mean,
                    stderr: e.stderr,
                }
            })
            .collect();
        // The RDF's bins likewise, and the exclusion radius read from their block means
        // ([`crate::rigid_bodies::rdf::exclusion_estimate`]) joins the scalars (references
        // check it).
        let colloid_solvent_rdf = {
            use crate::observable::{COLLOID_EXCLUSION_RADIUS, COLLOID_SOLVENT_RDF_PREFIX};
            let width = case.diagnostics.rdf_bin_width;
            let names: Vec<String> = (observables.keys())
                .filter(|k| k.starts_with(COLLOID_SOLVENT_RDF_PREFIX))
                .cloned()
                .collect();
            if !names.is_empty() {
                let series: Vec<&[f64]> = names
                    .iter()
                    .map(|k| sim.series.scalars[k].as_slice())
                    .collect();
                observables.insert(
                    COLLOID_EXCLUSION_RADIUS.to_owned(),
                    crate::rigid_bodies::rdf::exclusion_estimate(&series, blocks, width),
                );
            }
            (names.iter().enumerate())
                .map(|(b, name)| {
                    let e = observables.remove(name).expect("listed above");
                    crate::summary::RdfPoint {
                        r: (b as f64 + 0.5) * width,
                        mean: e.mean,
                        stderr: e.stderr,
                    }
                })
                .collect::<Vec<_>>()
        };
        let mut warnings = crate::diagnostics::block_warnings(&sim.series.scalars, blocks);
        warnings.extend(sim.counted_warnings());
        // The expected profile: the reverse-Poiseuille solution when the case checks one,
        // else the streaming velocity (0 without shear).
        let estimates = sim.series.profile_estimates(blocks);
        let double_poiseuille = case.reference.iter().find_map(|r| match r {
            crate::config::ReferenceCfg::DoublePoiseuilleProfile(dp) => {
                let means: Vec<f64> = estimates.iter().map(|e| e.mean).collect();
                Some(crate::summary::double_poiseuille_expected(case, dp, &means))
            }
            _ => None,
        });
        let velocity_profile: Vec<ProfilePoint> = (estimates.iter())
            .enumerate()
            .map(|(b, e): (usize, &Estimate)| {
                let y = (b as f64 + 0.5) * ly / nb;
                let expected = match &double_poiseuille {
                    Some(exact) => exact[b],
                    None => sim.sim_box.streaming_velocity(y),
                };
                ProfilePoint {
                    y,
                    mean: e.mean,
                    stderr: e.stderr,
                    expected,
                }
            })
            .collect();
        let validation = if completed {
            check_references(
                case,
                &observables,
                &velocity_profile,
                Some(crate::summary::ProfileSeries {
                    steps: &sim.series.steps,
                    profiles: &sim.series.profile,
                    dt: sim.dt(),
                }),
            )
        } else {
            Vec::new()
        };
        // The stress profile's bins, like the density's, leave the scalar observables for
        // their own list (after the checks, which read them).
        let shear_stress_profile = crate::summary::shear_stress_points(case, &observables);
        observables.retain(|k, _| !k.starts_with(crate::diagnostics::SHEAR_STRESS_PROFILE_PREFIX));
        Ok(SceneReport {
            case: serde_json::to_value(case).map_err(|e| e.to_string())?,
            dimension: D,
            particles: sim.total_particles,
            dumbbells: sim.dumbbell_count(),
            ensemble_bytes_per_particle: sim.ensemble_bytes_per_particle(),
            observables,
            velocity_profile,
            density_profile,
            validation,
            warnings,
            shear_stress_profile,
            colloid_solvent_rdf,
            state_digest: sim.state_digest(),
            load: Some(sim.load()),
        })
    }

    fn times(&mut self) -> &mut PhaseTimes {
        &mut self.sim.times
    }
}

/// `OUT/transverse_current.csv`: per mode j, k_j, η_k ± error, τ_k ± error, the measured and
/// the equipartition C⊥(k, 0), then t, C⊥(k, t)/C⊥(k, 0) (the block mean) and the fitted
/// Maxwell curve.
fn write_transverse_current_csv(
    tc: &crate::transverse_current::TransverseCurrentEstimate,
    out: &Path,
) -> std::io::Result<()> {
    use std::fmt::Write as _;
    std::fs::create_dir_all(out)?;
    let mut text = String::from(
        "mode,k,eta_k,eta_k_stderr,tau_k,tau_k_stderr,c0,c0_stderr,c0_equipartition,t,c_normalised,maxwell_fit\n",
    );
    for (j, m) in tc.modes.iter().enumerate() {
        for &(t, c, fit) in &m.curve {
            let _ = writeln!(
                text,
                "{},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e},{:.10e}",
                j + 1,
                m.wavenumber,
                m.viscosity.mean,
                m.viscosity.stderr,
                m.relaxation_time.mean,
                m.relaxation_time.stderr,
                m.initial.mean,
                m.initial.stderr,
                m.initial_expected,
                t,
                c,
                fit
            );
        }
    }
    let tmp = out.join("transverse_current.csv.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(tmp, out.join("transverse_current.csv"))
}

/// `OUT/green_kubo.csv`: t, G(t) = V C(t)/k_BT (the block mean) and its running integral η(t).
fn write_green_kubo_csv(
    gk: &crate::green_kubo::GreenKuboEstimate,
    out: &Path,
) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    let mut text = String::from("time,stress_autocorrelation,running_integral\n");
    for (t, g, integral) in &gk.table {
        text.push_str(&format!("{t:.10e},{g:.10e},{integral:.10e}\n"));
    }
    let tmp = out.join("green_kubo.csv.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(tmp, out.join("green_kubo.csv"))
}

#[cfg(not(feature = "hdf5"))]
const NO_HDF5_CHECKPOINTS: &str =
    "checkpoints need HDF5: this mesorheo was built without the `hdf5` feature";

/// Why a restart attempt did not give a summary.
#[cfg(feature = "hdf5")]
pub enum Restart {
    /// The checkpoint is unusable: try an older one.
    Refused(crate::output::checkpoint::CheckpointError),
    /// The run itself failed after a good start.
    Failed(Error),
}

/// A fresh run into an output directory that holds checkpoints of an earlier run moves them to
/// `checkpoints.previous/` (replacing an older one), so a later `restart OUT/checkpoints` can
/// never continue the wrong run and nothing is deleted unasked (collective).
pub(crate) fn set_aside_old_checkpoints(dir: &Path, comm: &dyn Comm) -> Result<(), Error> {
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
        Err(e) => Err(e.into()),
        Ok(()) if failed[0] > 0.0 => Err("cannot move old checkpoints aside (rank 0)".into()),
        Ok(()) => Ok(()),
    }
}

/// Writes a checkpoint of the current step, if output is on (collective).
fn checkpoint(
    scene: &mut dyn Scene,
    options: &RunOptions,
    comm: &dyn Comm,
) -> Result<Option<PathBuf>, Error> {
    let Some(out) = &options.out else {
        return Ok(None);
    };
    let t = Instant::now();
    let keep = scene.output().checkpoint_keep;
    let path = scene.write_checkpoint(&out.join("checkpoints"), keep)?;
    scene.times().checkpoints += t.elapsed().as_secs_f64();
    if comm.rank() == 0 {
        tracing::info!(
            "checkpoint {} ({:.2} s)",
            path.display(),
            t.elapsed().as_secs_f64()
        );
    }
    Ok(Some(path))
}

/// The step loop of every scene, with its schedule of samples, snapshots and checkpoints and
/// its clean stops; then the summary.
pub fn drive(
    mut scene: impl Scene,
    case_file: &Path,
    restarted_from: Option<&Path>,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, Error> {
    // The loop itself takes the scene as a trait object: compiled once, not once per scene
    // type (the particle and the homogeneous-flow scenes in 2 and 3 dimensions). A call per
    // step through the vtable costs nothing next to the step.
    drive_scene(
        &mut scene,
        case_file,
        restarted_from,
        comm,
        options,
        threads,
    )
}

/// [`drive`], not generic.
fn drive_scene(
    scene: &mut dyn Scene,
    case_file: &Path,
    restarted_from: Option<&Path>,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, Error> {
    let wall = Instant::now();
    let first_step = scene.step();
    if let Some(n) = options.steps {
        if n < first_step {
            return Err(format!(
                "--steps {n} is below the step {first_step} the run has already reached"
            )
            .into());
        }
        // Stored in the case, so later checkpoints (and restarts from them) keep it.
        scene.set_steps(n);
    }
    let last_step = scene.run().steps;
    if let Some(checkpoint) = restarted_from
        && first_step >= last_step
    {
        return Err(Error::InvalidCase(format!(
            "{}: the run is already complete: it reached its last step {last_step} (run.steps \
             = {last_step}), so there is nothing to run, and {} is left as it was. To extend \
             it, give the new total step count: `mesorheo restart {} --steps N` with N > \
             {first_step} (--steps and --until-step are step numbers counted from the start of \
             the first run, not a number of further steps)",
            checkpoint.display(),
            options.out.as_deref().map_or_else(
                || "the summary".to_owned(),
                |o| o.join("summary.json").display().to_string()
            ),
            checkpoint.display()
        )));
    }
    let stop_at = options.until_step.map_or(last_step, |k| k.min(last_step));
    if stop_at <= first_step && first_step < last_step {
        return Err(Error::InvalidCase(format!(
            "--until-step {stop_at} is not after the current step {first_step} (--until-step \
             is a step number counted from the start of the first run, not a number of \
             further steps)"
        )));
    }
    // The segments run before this one, from the run directory's summary.json (a restart).
    let earlier = match (restarted_from, &options.out) {
        (Some(_), Some(out)) => crate::summary::earlier_segments(&out.join("summary.json")),
        _ => Vec::new(),
    };
    let is_root = comm.rank() == 0;
    if is_root {
        tracing::info!(
            ranks = comm.size(),
            threads,
            "{} {}: {} at step {first_step}",
            if restarted_from.is_some() {
                "continuing"
            } else {
                "set up"
            },
            case_file.display(),
            scene.describe()
        );
    }
    if let Some(out) = &options.out {
        if restarted_from.is_none() {
            set_aside_old_checkpoints(&out.join("checkpoints"), comm)?;
        }
        scene.open_outputs(out, restarted_from.is_some())?;
    }
    // The time series of the observables (rank 0), continued after a restart.
    let mut csv = match &options.out {
        Some(out) if comm.rank() == 0 => Some(crate::observables_csv::ObservablesCsv::open(
            out,
            restarted_from.is_some(),
            first_step,
        )?),
        _ => None,
    };
    // The latest recorded observables, for the progress line.
    let mut latest: Vec<(String, f64)> = Vec::new();
    let every = scene.run().progress_seconds;
    let checkpoint_every = scene.output().checkpoint_every;
    let mut last_report = Instant::now();
    // Each rank's neighbour-list rebuilds, logged as one line per progress interval.
    let mut rebuilds = RebuildLog::new(scene.times(), first_step);
    let start = Instant::now();
    let mut last_checkpoint: Option<PathBuf> = None;
    let mut checkpointed_at = None;
    let mut stopped_by_signal = false;
    let mut over_budget: Option<String> = None;
    while scene.step() < stop_at {
        if STOP_REQUESTED.load(Ordering::SeqCst) {
            scene.request_stop();
        }
        if let Err(e) = scene.advance() {
            return Err(keep_blown_up_state(scene, options, e));
        }
        let step = scene.step();
        if let Some(row) = scene.observables_row() {
            if let Some(csv) = &mut csv {
                csv.write(step, scene.time(), row)?;
            }
            latest.clear();
            latest.extend_from_slice(row);
        }
        if options.out.is_some() {
            scene.write_outputs()?;
        }
        if checkpoint_every > 0 && step.is_multiple_of(checkpoint_every) && options.out.is_some() {
            if let Some(csv) = &mut csv {
                csv.flush()?;
            }
            last_checkpoint = checkpoint(scene, options, comm)?;
            checkpointed_at = Some(step);
        }
        // Agreed within the step itself, so every rank stops after the same step.
        if scene.stop_agreed() {
            stopped_by_signal = true;
            if is_root {
                tracing::warn!("stop requested: stopping after step {step}");
            }
            break;
        }
        // The budget: decided after the same step on every rank, from the slowest rank's time.
        if let Some(hours) = options.max_hours
            && step - first_step == BUDGET_PROBE_STEPS
            && step < stop_at
        {
            let mut seconds = [start.elapsed().as_secs_f64()];
            comm.allreduce_max(&mut seconds);
            let per_step = seconds[0] / BUDGET_PROBE_STEPS as f64;
            let estimate = per_step * (stop_at - step) as f64 / 3600.0;
            if estimate > hours {
                over_budget = Some(format!(
                    "the remaining {} steps would take about {estimate:.3} h ({:.0} s at {:.3e} s per step \
                     over the first {BUDGET_PROBE_STEPS}), beyond --max-hours {hours}; stopped \
                     at step {step}. Raise --max-hours, run on more ranks or threads, or ask for \
                     fewer steps (--steps, --until-step)",
                    stop_at - step,
                    estimate * 3600.0,
                    per_step
                ));
                break;
            }
        }
        // Every rank on its own clock: only logging, no collective.
        if every > 0.0 && last_report.elapsed().as_secs_f64() >= every {
            last_report = Instant::now();
            if is_root {
                let rate = (step - first_step) as f64 / start.elapsed().as_secs_f64();
                let eta = (stop_at - step) as f64 / rate.max(1e-12);
                let line = [
                    format!("step {step}/{last_step}"),
                    format!("t={:.4}", scene.time()),
                    crate::observables_csv::thermo(&latest, THERMO_COLUMNS),
                    scene.progress(rate),
                    format!("ETA {}", duration(eta)),
                ];
                let line: Vec<&str> = (line.iter().map(String::as_str))
                    .filter(|s| !s.is_empty())
                    .collect();
                tracing::info!("{}", line.join("  "));
                if let Some(csv) = &mut csv {
                    csv.flush()?;
                }
            }
            rebuilds.log(scene.times(), step);
        }
    }
    let reached = scene.step();
    rebuilds.log(scene.times(), reached);
    if let Some(csv) = &mut csv {
        csv.flush()?;
    }
    let loop_seconds = start.elapsed().as_secs_f64();
    let completed = scene.step() >= last_step;
    let wants_final = scene.output().checkpoint_at_end || !completed;
    if wants_final && options.out.is_some() && checkpointed_at != Some(scene.step()) {
        last_checkpoint = checkpoint(scene, options, comm)?;
    }
    if stopped_by_signal || !completed {
        tracing::info!(
            "stopped at step {} of {last_step}; restart from {}",
            scene.step(),
            last_checkpoint
                .as_deref()
                .map_or("(no checkpoint: no output directory)".into(), |p| p
                    .display()
                    .to_string())
        );
    }
    if let Some(reason) = over_budget {
        scene.close_outputs(options.out.as_deref())?;
        return Err(format!(
            "{reason}; restart from {}",
            last_checkpoint
                .as_deref()
                .map_or("(no checkpoint: no output directory)".into(), |p| p
                    .display()
                    .to_string())
        )
        .into());
    }
    scene.close_outputs(options.out.as_deref())?;
    // The warnings reach the console once, with the results (`mesorheo::summary::render`).
    let report = scene.report(completed)?;
    let times = scene.times().clone();
    let steps_run = (scene.step() - first_step) as f64;
    let rate = |n: f64| n * steps_run / loop_seconds.max(1e-300);
    let mut peak = [crate::capacity::peak_resident_memory().unwrap_or(-1.0)];
    comm.allreduce_max(&mut peak);
    let wall_seconds = wall.elapsed().as_secs_f64();
    let mut segments = earlier;
    segments.push(crate::summary::Segment {
        started_from: case_file.display().to_string(),
        first_step,
        last_step: scene.step(),
        ranks: comm.size(),
        threads,
        wall_seconds,
        loop_seconds,
    });
    Ok(Summary {
        version: env!("CARGO_PKG_VERSION").to_owned(),
        case: report.case,
        // The case the first segment started from (a restart's own checkpoint when the run
        // directory holds no earlier summary).
        case_file: segments[0].started_from.clone(),
        total_wall_seconds: segments.iter().map(|s| s.wall_seconds).sum(),
        segments,
        ranks: comm.size(),
        threads,
        dimension: report.dimension,
        particles: report.particles,
        steps: scene.step(),
        completed,
        restarted_from: restarted_from.map(|p| p.display().to_string()),
        last_checkpoint: last_checkpoint.map(|p| p.display().to_string()),
        time: scene.time(),
        wall_seconds,
        loop_seconds,
        particle_steps_per_second: rate(report.particles as f64),
        dumbbell_steps_per_second: report.dumbbells.map(|n| rate(n as f64)),
        ensemble_bytes_per_particle: report.ensemble_bytes_per_particle,
        peak_memory_mib: (peak[0] >= 0.0).then(|| peak[0] / (1024.0 * 1024.0)),
        observables: report.observables,
        velocity_profile: report.velocity_profile,
        density_profile: report.density_profile,
        shear_stress_profile: report.shear_stress_profile,
        colloid_solvent_rdf: report.colloid_solvent_rdf,
        validation: report.validation,
        warnings: report.warnings,
        state_digest: report.state_digest,
        phase_seconds_over_ranks: (comm.size() > 1).then(|| spread(comm, &times)),
        load: report.load.map(|load| {
            let mut sum = load;
            let mut max = load;
            comm.allreduce_sum(&mut sum);
            comm.allreduce_max(&mut max);
            let n = comm.size() as f64;
            let stat = |k: usize| crate::summary::MeanMax {
                mean: sum[k] / n,
                max: max[k],
            };
            crate::summary::Load {
                owned: stat(0),
                ghosts: stat(1),
                pairs: stat(2),
            }
        }),
        phase_seconds: times,
    })
}

/// Every rank's phase times reduced: their mean and the largest (collective).
fn spread(comm: &dyn Comm, times: &PhaseTimes) -> crate::summary::PhaseSpread {
    let mine = times.to_numbers();
    let mut sum = mine.clone();
    let mut max = mine;
    comm.allreduce_sum(&mut sum);
    comm.allreduce_max(&mut max);
    let n = comm.size() as f64;
    sum.iter_mut().for_each(|x| *x /= n);
    crate::summary::PhaseSpread {
        mean: times.with_numbers(&sum),
        max: times.with_numbers(&max),
    }
}

/// One rank's neighbour-list rebuilds since its last progress interval, logged at debug as one
/// line per interval (each rebuild itself is a trace record), so a long run's log stays
/// bounded.
struct RebuildLog {
    rebuilds: u64,
    seconds: f64,
    step: u64,
}

impl RebuildLog {
    fn new(times: &PhaseTimes, step: u64) -> Self {
        Self {
            rebuilds: times.rebuilds,
            seconds: times.neighbour + times.rebuild_comm,
            step,
        }
    }

    fn log(&mut self, times: &PhaseTimes, step: u64) {
        let now = Self::new(times, step);
        if step > self.step && now.rebuilds > self.rebuilds {
            tracing::debug!(
                "steps {}–{step}: {} neighbour-list rebuilds ({:.1} ms)",
                self.step + 1,
                now.rebuilds - self.rebuilds,
                (now.seconds - self.seconds) * 1e3
            );
        }
        *self = now;
    }
}

/// On a blow-up (every detector decides collectively, so every rank is here), writes the state
/// as the detector found it to `OUT/blowup/` for inspection (`mesorheo info`, h5py): the
/// offending particle with its position, velocity or ensemble is in it. The last good state is
/// the newest checkpoint in `OUT/checkpoints/`. Other errors pass through unchanged.
fn keep_blown_up_state(scene: &mut dyn Scene, options: &RunOptions, error: Error) -> Error {
    let Some(out) = options.out.as_ref() else {
        return error;
    };
    let Error::Unstable(mut blow_up) = error else {
        return error;
    };
    let checkpoints = out.join("checkpoints");
    let earlier = std::fs::read_dir(&checkpoints).is_ok_and(|d| {
        d.flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with("checkpoint_"))
    });
    let kept = match scene.write_checkpoint(&out.join("blowup"), 1) {
        Ok(path) => format!(
            ". The state at the blow-up is in {} (inspect it with `mesorheo info` or \
             h5py); {}",
            path.display(),
            if earlier {
                format!(
                    "the last good state is the newest checkpoint in {}",
                    checkpoints.display()
                )
            } else {
                "no earlier checkpoint was written (output.checkpoint_every)".to_string()
            }
        ),
        Err(e) => format!(" (the state at the blow-up could not be written: {e})"),
    };
    blow_up.message.push_str(&kept);
    Error::Unstable(blow_up)
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
