//! Running a homogeneous-flow scene (`[flow]` + `[polymer] kind = "dumbbells"`): set-up or
//! restart of the ensembles, the step loop with progress lines, sampling of the polymer stress,
//! checkpoints and clean stops, the stress time series and the summary.
//!
//! Observables (stresses in units of `polymer.modulus` G). Each sample takes every particle's
//! ensemble average; the series (`polymer_stress.csv`) holds their mean over particles with the
//! spread's standard error; the summary holds, after `run.equilibration`, the mean over particles
//! of each particle's time average with the standard error s/√N of those N independent time
//! averages (exact sums, so bitwise the same on any rank count):
//!
//! ```text
//! polymer_stress_αβ                 τ_αβ = G (⟨Q F(Q)⟩ − I)_αβ
//! first_normal_stress_difference    N₁ = τ_xx − τ_yy        second_…  N₂ = τ_yy − τ_zz (3D)
//! polymer_viscosity                 η_p = τ_xy / κ_xy(t)    (shear; Hookean: G λ)
//! first_normal_stress_coefficient   Ψ₁ = N₁ / γ̇²           (Hookean: 2 G λ²)
//! second_normal_stress_coefficient  Ψ₂ = N₂ / γ̇²           (Hookean: 0)
//! extensional_viscosity             η_E = (τ_xx − τ_yy) / ε̇ (elongation)
//! max_connector_length              max |Q| over all dumbbells (FENE: < √b)
//! ```

use crate::comm::Comm;
use crate::config::FlowCase;
use crate::config::flow::{FlowKind, Precision};
use crate::diagnostics::{Series, tensor_components};
use crate::domain::id_block;
use crate::driver::{RunOptions, set_aside_old_checkpoints, stop_requested, threads_of};
use crate::models::homogeneous_flow::{HomogeneousEnsembles, particle_moments};
use crate::summary::{Summary, check_value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Suffix of the per-sample standard errors (particle-to-particle spread) in the series.
const STDERR: &str = "_stderr";

/// Runs a homogeneous-flow scene from equilibrium (collective); every rank returns the same
/// summary.
pub fn run_flow_case(
    case: &FlowCase,
    case_file: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
) -> Result<Summary, String> {
    let threads = threads_of(options);
    check_memory(case, comm)?;
    match case.dimension {
        2 => start::<2>(case, case_file, comm, options, threads),
        3 => start::<3>(case, case_file, comm, options, threads),
        d => Err(format!("dimension {d} is not supported")),
    }
}

fn start<const D: usize>(
    case: &FlowCase,
    case_file: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, String> {
    let e = fresh::<D>(case, comm, threads)?;
    let averages = ParticleAverages::new(e.gids.len(), quantities(case).len());
    let series = Series::default();
    drive(
        e,
        case.clone(),
        series,
        averages,
        case_file,
        None,
        comm,
        options,
        threads,
    )
}

fn fresh<'c, const D: usize>(
    case: &FlowCase,
    comm: &'c dyn Comm,
    threads: usize,
) -> Result<HomogeneousEnsembles<'c, D>, String> {
    let mut e = HomogeneousEnsembles::<D>::new(
        comm,
        threads,
        case.flow.particles,
        case.polymer.per_particle,
        case.dumbbell_params(),
        case.flow_model(),
        case.seed,
    )?;
    if case.polymer.variance_reduction {
        e = e.with_control_variates();
    }
    if case.polymer.precision == Precision::Single {
        e = e.with_single_precision();
    }
    Ok(e)
}

/// Bytes of MemAvailable on this node (None where /proc/meminfo is missing).
pub fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024.0)
}

/// Memory of this rank's ensembles: its id block × N_d × D × (8 or 4) bytes (× 2 with control
/// variates).
pub fn rank_memory(case: &FlowCase, ranks: usize, rank: usize) -> f64 {
    let block = id_block(case.flow.particles, ranks, rank);
    (block.end - block.start) as f64 * case.polymer.bytes_per_particle(case.dimension)
}

/// Refuses (on every rank) a scene whose ensembles do not fit the memory this node has free.
fn check_memory(case: &FlowCase, comm: &dyn Comm) -> Result<(), String> {
    let need = rank_memory(case, comm.size(), comm.rank());
    let verdict = match available_memory() {
        Some(free) if need > 0.9 * free => Err(format!(
            "the dumbbell ensembles need {:.2} GiB on rank {} but the node has {:.2} GiB \
             available; use more ranks (or nodes), fewer dumbbells per particle \
             (polymer.per_particle), or polymer.precision = \"single\"",
            need / GIB,
            comm.rank(),
            free / GIB
        )),
        _ => Ok(()),
    };
    let mut failed = [if verdict.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut failed);
    match verdict {
        Err(e) => Err(e),
        Ok(()) if failed[0] > 0.0 => {
            Err("the dumbbell ensembles do not fit the memory of another rank's node".into())
        }
        Ok(()) => Ok(()),
    }
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// Continues a homogeneous-flow run from the checkpoint `path` (collective).
#[cfg(feature = "hdf5")]
pub(crate) fn restart_from(
    path: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, crate::driver::Restart> {
    use crate::driver::Restart;
    let case = crate::output::flow_checkpoint::read_case(path);
    let mut flag = [if case.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut flag);
    let case = match case {
        Ok(c) if flag[0] == 0.0 => c,
        Ok(_) => return Err(Restart::Refused("unreadable on another rank".into())),
        Err(e) => return Err(Restart::Refused(e)),
    };
    check_memory(&case, comm).map_err(Restart::Failed)?;
    match case.dimension {
        2 => restore::<2>(case, path, comm, options, threads),
        3 => restore::<3>(case, path, comm, options, threads),
        d => Err(Restart::Refused(format!("dimension {d} is not supported"))),
    }
}

#[cfg(feature = "hdf5")]
fn restore<const D: usize>(
    case: FlowCase,
    path: &Path,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, crate::driver::Restart> {
    use crate::driver::Restart;
    let r = crate::output::flow_checkpoint::read::<D>(path, comm).map_err(Restart::Refused)?;
    let e = HomogeneousEnsembles::<D>::from_state(
        comm,
        threads,
        r.total,
        case.polymer.per_particle,
        case.dumbbell_params(),
        case.flow_model(),
        case.seed,
        r.step,
        r.connectors,
        r.control,
    )
    .map_err(Restart::Failed)?;
    crate::driver::log_restart(comm, path, r.step);
    drive(
        e,
        case,
        r.series,
        r.averages,
        path,
        Some(path),
        comm,
        options,
        threads,
    )
    .map_err(Restart::Failed)
}

/// A per-particle observable, computed from one particle's τ/G.
#[derive(Clone, Copy, Debug)]
enum Quantity {
    /// G τ_ab/G.
    Stress(usize, usize),
    /// N₁ = τ_xx − τ_yy.
    N1,
    /// N₂ = τ_yy − τ_zz.
    N2,
    /// τ_xy / κ_xy.
    Viscosity,
    /// N₁ / κ_xy².
    Psi1,
    /// N₂ / κ_xy².
    Psi2,
    /// N₁ / κ_xx.
    Extensional,
}

impl Quantity {
    /// The value for one particle's τ/G `s` (D × D row-major), modulus `g`, gradient `kappa`.
    fn of<const D: usize>(self, s: &[f64; 9], g: f64, kappa: &[[f64; D]; D]) -> f64 {
        let n1 = s[0] - s[D + 1];
        let n2 = if D == 3 { s[4] - s[8] } else { 0.0 };
        let shear = kappa[0][1];
        match self {
            Quantity::Stress(a, b) => g * s[a * D + b],
            Quantity::N1 => g * n1,
            Quantity::N2 => g * n2,
            Quantity::Viscosity => g * s[1] / shear,
            Quantity::Psi1 => g * n1 / (shear * shear),
            Quantity::Psi2 => g * n2 / (shear * shear),
            Quantity::Extensional => g * n1 / kappa[0][0],
        }
    }
}

/// The observables averaged per particle — every scalar name of the scene but
/// `max_connector_length` — in [`FlowCase::scalar_names`] order.
fn quantities(case: &FlowCase) -> Vec<(String, Quantity)> {
    case.scalar_names()
        .into_iter()
        .filter_map(|name| {
            let q = match name.as_str() {
                "first_normal_stress_difference" => Quantity::N1,
                "second_normal_stress_difference" => Quantity::N2,
                "polymer_viscosity" => Quantity::Viscosity,
                "first_normal_stress_coefficient" => Quantity::Psi1,
                "second_normal_stress_coefficient" => Quantity::Psi2,
                "extensional_viscosity" => Quantity::Extensional,
                other => {
                    let c = other.strip_prefix("polymer_stress_")?.as_bytes();
                    let axis = |x: u8| (x - b'x') as usize;
                    Quantity::Stress(axis(c[0]), axis(c[1]))
                }
            };
            Some((name, q))
        })
        .collect()
}

/// Running sums, per particle of this rank, of every [`quantities`] value over the samples after
/// equilibration. The time average of each particle is an independent estimate (independent
/// noise, no interaction), so the spread between particles gives honest error bars whatever
/// the time correlation of the stress (which block averages of short runs underestimate).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParticleAverages {
    /// sums[k][i]: quantity i of this rank's particle k.
    pub sums: Vec<Vec<f64>>,
    /// Samples added.
    pub samples: u64,
}

impl ParticleAverages {
    /// Zero sums for `particles` particles and `width` quantities.
    pub fn new(particles: usize, width: usize) -> Self {
        Self {
            sums: vec![vec![0.0; width]; particles],
            samples: 0,
        }
    }
}

/// Records the stress of the current step (collective): the particle-averaged series (from step
/// 0) and, after equilibration, the per-particle running sums.
fn sample<const D: usize>(
    e: &HomogeneousEnsembles<'_, D>,
    case: &FlowCase,
    series: &mut Series,
    averages: &mut ParticleAverages,
) {
    let per = e.particle_stresses();
    let st = e.stress_of(&per);
    let g = case.polymer.modulus;
    let kappa = case.flow_model().kappa::<D>(e.time());
    series.steps.push(e.step);
    let mut put = |name: &str, value: f64, stderr: f64| {
        series.push(name, value);
        series.push(&format!("{name}{STDERR}"), stderr);
    };
    for (a, b, name) in tensor_components(D) {
        put(
            &format!("polymer_stress_{name}"),
            g * st.mean[a][b],
            g * st.stderr[a][b],
        );
    }
    put("first_normal_stress_difference", g * st.n1.0, g * st.n1.1);
    if D == 3 {
        put("second_normal_stress_difference", g * st.n2.0, g * st.n2.1);
    }
    match case.flow.kind {
        FlowKind::SimpleShear | FlowKind::ShearReversal => {
            let rate = kappa[0][1];
            put(
                "polymer_viscosity",
                g * st.mean[0][1] / rate,
                g * st.stderr[0][1] / rate.abs(),
            );
            put(
                "first_normal_stress_coefficient",
                g * st.n1.0 / (rate * rate),
                g * st.n1.1 / (rate * rate),
            );
            if D == 3 {
                put(
                    "second_normal_stress_coefficient",
                    g * st.n2.0 / (rate * rate),
                    g * st.n2.1 / (rate * rate),
                );
            }
        }
        FlowKind::PlanarElongation | FlowKind::UniaxialElongation => {
            let rate = kappa[0][0];
            put(
                "extensional_viscosity",
                g * st.n1.0 / rate,
                g * st.n1.1 / rate.abs(),
            );
        }
        FlowKind::Rest => {}
    }
    series.push("max_connector_length", e.max_q2().sqrt());
    if e.step > case.run.equilibration {
        let q = quantities(case);
        for (row, s) in averages.sums.iter_mut().zip(&per) {
            for (x, (_, quantity)) in row.iter_mut().zip(&q) {
                *x += quantity.of::<D>(s, g, &kappa);
            }
        }
        averages.samples += 1;
    }
}

/// Writes a checkpoint of the current step, if output is on (collective).
fn checkpoint<const D: usize>(
    e: &HomogeneousEnsembles<'_, D>,
    case: &FlowCase,
    series: &Series,
    averages: &ParticleAverages,
    out: &Path,
    comm: &dyn Comm,
) -> Result<PathBuf, String> {
    #[cfg(feature = "hdf5")]
    {
        let t = Instant::now();
        let path = crate::output::flow_checkpoint::write(
            e,
            case,
            series,
            averages,
            &out.join("checkpoints"),
            case.output.checkpoint_keep,
            comm,
        )?;
        if comm.rank() == 0 {
            tracing::info!(
                "checkpoint {} ({:.2} s)",
                path.display(),
                t.elapsed().as_secs_f64()
            );
        }
        Ok(path)
    }
    #[cfg(not(feature = "hdf5"))]
    {
        let _ = (e, case, series, averages, out, comm);
        Err("checkpoints need HDF5: this mesorheo was built without the `hdf5` feature".into())
    }
}

/// `OUT/polymer_stress.csv`: every sample (from the start, transient included) with its
/// particle-spread standard error (rank 0).
fn write_series_csv(series: &Series, dt: f64, out: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(out)?;
    let names: Vec<&String> = series
        .scalars
        .keys()
        .filter(|n| !n.ends_with(STDERR))
        .collect();
    let mut text = String::from("step,time");
    for n in &names {
        text.push(',');
        text.push_str(n);
        if series.scalars.contains_key(&format!("{n}{STDERR}")) {
            text.push_str(&format!(",{n}{STDERR}"));
        }
    }
    text.push('\n');
    for (k, step) in series.steps.iter().enumerate() {
        text.push_str(&format!("{step},{:.10e}", *step as f64 * dt));
        for n in &names {
            text.push_str(&format!(",{:.10e}", series.scalars[*n][k]));
            if let Some(err) = series.scalars.get(&format!("{n}{STDERR}")) {
                text.push_str(&format!(",{:.10e}", err[k]));
            }
        }
        text.push('\n');
    }
    let tmp = out.join("polymer_stress.csv.tmp");
    std::fs::write(&tmp, text)?;
    std::fs::rename(tmp, out.join("polymer_stress.csv"))
}

/// The step loop, then the summary.
#[allow(clippy::too_many_arguments)]
fn drive<const D: usize>(
    mut e: HomogeneousEnsembles<'_, D>,
    mut case: FlowCase,
    mut series: Series,
    mut averages: ParticleAverages,
    case_file: &Path,
    restarted_from: Option<&Path>,
    comm: &dyn Comm,
    options: &RunOptions,
    threads: usize,
) -> Result<Summary, String> {
    let wall = Instant::now();
    let first_step = e.step;
    if let Some(n) = options.steps {
        if n < first_step {
            return Err(format!(
                "--steps {n} is below the step {first_step} the run has already reached"
            ));
        }
        case.run.steps = n;
    }
    let last_step = case.run.steps;
    let stop_at = options.until_step.map_or(last_step, |k| k.min(last_step));
    if stop_at <= first_step && first_step < last_step {
        return Err(format!(
            "--until-step {stop_at} is not after the current step {first_step}"
        ));
    }
    let is_root = comm.rank() == 0;
    if is_root {
        tracing::info!(
            particles = e.total,
            dumbbells_per_particle = e.n_d,
            ranks = comm.size(),
            threads,
            memory_mib = e.memory_bytes() as f64 / (1024.0 * 1024.0),
            "{} homogeneous-flow scene {} at step {first_step}",
            if restarted_from.is_some() {
                "continuing"
            } else {
                "set up"
            },
            case_file.display()
        );
    }
    if restarted_from.is_none()
        && let Some(out) = &options.out
    {
        set_aside_old_checkpoints(&out.join("checkpoints"), comm)?;
    }
    let mut times = crate::sim::PhaseTimes::default();
    let every = case.run.progress_seconds;
    let (mut last_report, start) = (Instant::now(), Instant::now());
    let mut last_checkpoint: Option<PathBuf> = None;
    let mut checkpointed_at = None;
    while e.step < stop_at {
        let t = Instant::now();
        e.advance();
        times.integrate += t.elapsed().as_secs_f64();
        let step = e.step;
        if step.is_multiple_of(case.run.sample_every) {
            let t = Instant::now();
            sample(&e, &case, &mut series, &mut averages);
            times.diagnostics += t.elapsed().as_secs_f64();
        }
        let ck = case.output.checkpoint_every;
        if let Some(out) = &options.out
            && ck > 0
            && step.is_multiple_of(ck)
        {
            let t = Instant::now();
            last_checkpoint = Some(checkpoint(&e, &case, &series, &averages, out, comm)?);
            times.checkpoints += t.elapsed().as_secs_f64();
            checkpointed_at = Some(step);
        }
        // Every rank stops after the same step.
        let mut stop = [if stop_requested() { 1.0 } else { 0.0 }];
        comm.allreduce_max(&mut stop);
        if stop[0] > 0.0 {
            if is_root {
                tracing::warn!("stop requested: stopping after step {step}");
            }
            break;
        }
        if is_root && every > 0.0 && last_report.elapsed().as_secs_f64() >= every {
            last_report = Instant::now();
            let rate = (step - first_step) as f64 / start.elapsed().as_secs_f64();
            let latest = |n: &str| series.scalars.get(n).and_then(|v| v.last().copied());
            tracing::info!(
                "step {step}/{last_step} t = {:.4} τ_xy = {:.5} N₁ = {:.5} {:.3e} dumbbell-steps/s ETA {:.0} s",
                e.time(),
                latest("polymer_stress_xy").unwrap_or(f64::NAN),
                latest("first_normal_stress_difference").unwrap_or(f64::NAN),
                rate * (e.total * e.n_d as u64) as f64,
                (stop_at - step) as f64 / rate.max(1e-12)
            );
        }
    }
    let loop_seconds = start.elapsed().as_secs_f64();
    let completed = e.step >= last_step;
    let wants_final = case.output.checkpoint_at_end || !completed;
    if let Some(out) = &options.out
        && wants_final
        && checkpointed_at != Some(e.step)
    {
        let t = Instant::now();
        last_checkpoint = Some(checkpoint(&e, &case, &series, &averages, out, comm)?);
        times.checkpoints += t.elapsed().as_secs_f64();
    }
    if !completed {
        tracing::info!(
            "stopped at step {} of {last_step}; restart from {}",
            e.step,
            last_checkpoint
                .as_deref()
                .map_or("(no checkpoint: no output directory)".into(), |p| p
                    .display()
                    .to_string())
        );
    }
    if is_root && let Some(out) = &options.out {
        write_series_csv(&series, case.dt(), out)
            .map_err(|err| format!("cannot write {}/polymer_stress.csv: {err}", out.display()))?;
    }
    // Time averages after equilibration: the mean over particles of each particle's time
    // average, with the standard error from their spread.
    let q = quantities(&case);
    let k = averages.samples.max(1) as f64;
    let m = particle_moments(comm, averages.sums.len(), q.len(), e.total, |p, i| {
        averages.sums[p][i] / k
    });
    let mut observables: BTreeMap<String, crate::diagnostics::Estimate> = q
        .iter()
        .zip(&m)
        .map(|((name, _), &(mean, stderr))| {
            let (mean, stderr) = if averages.samples == 0 {
                (f64::NAN, f64::NAN)
            } else {
                (mean, stderr)
            };
            let est = crate::diagnostics::Estimate {
                mean,
                stderr,
                samples: averages.samples as usize,
            };
            (name.clone(), est)
        })
        .collect();
    // The largest |Q| seen after equilibration (not an average).
    if let Some(values) = series.scalars.get("max_connector_length") {
        let window: Vec<f64> = (0..series.steps.len())
            .filter(|&k| series.steps[k] > case.run.equilibration)
            .map(|k| values[k])
            .collect();
        observables.insert(
            "max_connector_length".into(),
            crate::diagnostics::Estimate {
                mean: window.iter().copied().fold(f64::NAN, f64::max),
                stderr: 0.0,
                samples: window.len(),
            },
        );
    }
    let validation = if completed {
        case.reference
            .iter()
            .filter_map(|r| match r {
                crate::config::ReferenceCfg::Value(v) => Some(check_value(v, &observables)),
                crate::config::ReferenceCfg::LinearShearProfile(_) => None,
            })
            .collect()
    } else {
        Vec::new()
    };
    let steps_run = (e.step - first_step) as f64;
    let loop_rate = |n: f64| n * steps_run / loop_seconds.max(1e-300);
    Ok(Summary {
        version: env!("CARGO_PKG_VERSION").to_owned(),
        case: serde_json::to_value(&case).map_err(|err| err.to_string())?,
        case_file: case_file.display().to_string(),
        ranks: comm.size(),
        threads,
        dimension: D,
        particles: e.total,
        steps: e.step,
        completed,
        restarted_from: restarted_from.map(|p| p.display().to_string()),
        last_checkpoint: last_checkpoint.map(|p| p.display().to_string()),
        time: e.time(),
        wall_seconds: wall.elapsed().as_secs_f64(),
        loop_seconds,
        particle_steps_per_second: loop_rate(e.total as f64),
        dumbbell_steps_per_second: Some(loop_rate((e.total * e.n_d as u64) as f64)),
        observables,
        velocity_profile: Vec::new(),
        validation,
        // The error bars come from the spread of independent particles' averages: no blocks.
        warnings: Vec::new(),
        state_digest: format!("{:016x}", e.digest()),
        phase_seconds: times,
    })
}
