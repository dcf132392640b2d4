//! The homogeneous-flow scene (`[flow]` + `[polymer] kind = "dumbbells" | "bddfs"`): set-up or restart
//! of the ensembles, their step and the sampling of the polymer stress, its checkpoint, the
//! stress time series and its part of the summary. The step loop, signals and checkpoint
//! schedule are the one driver's ([`crate::scene::drive`]).
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
//! mean_square_connector_length      ⟨|Q|²⟩ in k_BT/H         (Hookean at rest: D; shear: D + 2Wi²)
//! max_connector_length              max |Q| over all dumbbells (FENE: < √b)
//! occupied_histogram_cells          BDDFS: occupied cells per particle (memory 8 B each)
//! ```

use crate::comm::Comm;
use crate::config::flow::{FlowKind, Precision};
use crate::config::{FlowCase, OutputCfg, RunCfg};
use crate::diagnostics::{Series, tensor_components};
use crate::domain::id_block;
use crate::error::{Error, Unstable};
use crate::models::homogeneous_flow::{
    EnsembleSpec, HomogeneousEnsembles, ParticleAverages, particle_moments,
};
use crate::particles::tensor_rows;
use crate::scene::{Scene, SceneReport};
use crate::sim::PhaseTimes;
use crate::summary::check_value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// ⟨|Q|²⟩'s name (the average older checkpoints do not hold).
const MEAN_SQUARE_LENGTH: &str = "mean_square_connector_length";

/// BDDFS: the occupied histogram cells per particle.
const OCCUPIED_CELLS: &str = "occupied_histogram_cells";

/// The observables that lead a row of `observables.csv` (and the progress line), in order.
const HEADLINE: [&str; 5] = [
    "polymer_viscosity",
    "extensional_viscosity",
    "first_normal_stress_difference",
    "polymer_stress_xy",
    MEAN_SQUARE_LENGTH,
];

/// Suffix of the per-sample standard errors (particle-to-particle spread) in the series.
const STDERR: &str = "_stderr";

/// The case's ensembles: `total` particles (the case's, or a checkpoint's) on `threads`.
fn ensemble_spec(case: &FlowCase, threads: usize, total: u64) -> EnsembleSpec {
    EnsembleSpec {
        threads,
        total,
        n_d: case.polymer.per_particle,
        params: case.dumbbell_params(),
        flow: case.flow_model(),
        seed: case.seed,
    }
}

fn fresh<'c, const D: usize>(
    case: &FlowCase,
    comm: &'c dyn Comm,
    threads: usize,
) -> Result<HomogeneousEnsembles<'c, D>, String> {
    if let Some(grid) = case.polymer.histogram_grid() {
        // BDDFS: validation refused single precision and control variates.
        return HomogeneousEnsembles::<D>::new_with_histograms(
            comm,
            ensemble_spec(case, threads, case.flow.particles),
            grid,
        );
    }
    let mut e =
        HomogeneousEnsembles::<D>::new(comm, ensemble_spec(case, threads, case.flow.particles))?;
    if case.polymer.variance_reduction {
        e = e.with_control_variates();
    }
    if case.polymer.precision == Precision::Single {
        e = e.with_single_precision();
    }
    Ok(e)
}

/// Memory of this rank's ensembles: its id block × N_d × D × (8 or 4) bytes (× 2 with control
/// variates).
pub fn rank_memory(case: &FlowCase, ranks: usize, rank: usize) -> f64 {
    let block = id_block(case.flow.particles, ranks, rank);
    (block.end - block.start) as f64 * case.polymer.bytes_per_particle(case.dimension)
}

/// Refuses (on every rank) a scene whose ensembles do not fit the memory this node has free.
fn check_memory(case: &FlowCase, comm: &dyn Comm) -> Result<(), Error> {
    let need = rank_memory(case, comm.size(), comm.rank());
    let verdict = match crate::capacity::available_memory() {
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
        Err(e) => Err(Error::DoesNotFit(e)),
        Ok(()) if failed[0] > 0.0 => Err(Error::DoesNotFit(
            "the dumbbell ensembles do not fit the memory of another rank's node".into(),
        )),
        Ok(()) => Ok(()),
    }
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

/// A per-particle observable, computed from one particle's τ/G (and its ⟨|Q|²⟩).
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
    /// ⟨|Q|²⟩ in units of k_BT/H.
    MeanSquareLength,
    /// BDDFS: occupied histogram cells.
    OccupiedCells,
}

impl Quantity {
    /// The value for one particle's τ/G `s` (D × D row-major), ⟨|Q|²⟩ `q2` and occupied
    /// histogram cells `cells`, modulus `g`, gradient `kappa`.
    fn of<const D: usize>(
        self,
        s: &[f64; 9],
        q2: f64,
        cells: f64,
        g: f64,
        kappa: &[[f64; D]; D],
    ) -> f64 {
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
            Quantity::MeanSquareLength => q2,
            Quantity::OccupiedCells => cells,
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
                MEAN_SQUARE_LENGTH => Quantity::MeanSquareLength,
                OCCUPIED_CELLS => Quantity::OccupiedCells,
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
    let kappa = tensor_rows(&case.flow_model().kappa::<D>(e.time()));
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
    let q2 = e.particle_mean_square_lengths();
    let (mean, stderr) = e.particle_mean(&q2);
    put(MEAN_SQUARE_LENGTH, mean, stderr);
    let cells = e.particle_occupied_cells();
    if let Some(cells) = &cells {
        let (mean, stderr) = e.particle_mean(cells);
        put(OCCUPIED_CELLS, mean, stderr);
    }
    series.push("max_connector_length", e.max_q2().sqrt());
    if e.step > case.run.equilibration {
        let q = quantities(case);
        for (k, ((row, s), &q2)) in averages.sums.iter_mut().zip(&per).zip(&q2).enumerate() {
            let occupied = cells.as_ref().map_or(0.0, |c| c[k]);
            for (x, (_, quantity)) in row.iter_mut().zip(&q) {
                *x += quantity.of::<D>(s, q2, occupied, g, &kappa);
            }
        }
        averages.samples += 1;
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

/// BDDFS: the connectors the grid clipped and the FENE reconstructions that fell back, summed
/// over the ranks (collective; nothing without histograms).
fn histogram_warnings<const D: usize>(
    e: &HomogeneousEnsembles<'_, D>,
    comm: &dyn Comm,
) -> Vec<String> {
    let Some(h) = &e.histograms else {
        return Vec::new();
    };
    let mut counts = [h.clipped, h.fallbacks];
    comm.allreduce_u64(&mut counts, crate::comm::U64Op::Sum);
    let mut out = Vec::new();
    if counts[0] > 0 {
        out.push(format!(
            "BDDFS: {} connector-steps left the grid [−{q}, {q}]^{D} and were counted in a \
             boundary cell (this process's steps); a larger polymer.q_max removes the clipping",
            counts[0],
            q = h.grid.q_max
        ));
    }
    if counts[1] > 0 {
        out.push(format!(
            "BDDFS: {} FENE reconstructions found no point of their cell inside |Q| < √b in 64 \
             draws and took the cell's point nearest the origin",
            counts[1]
        ));
    }
    out
}

/// A homogeneous-flow scene: the ensembles, the case, the sampled series and the
/// per-particle running sums.
pub struct FlowScene<'c, const D: usize> {
    e: HomogeneousEnsembles<'c, D>,
    case: FlowCase,
    series: Series,
    averages: ParticleAverages,
    times: PhaseTimes,
    comm: &'c dyn Comm,
    stop_requested_here: bool,
    stop_agreed: bool,
    /// The observables of the last step, when it was sampled.
    row: Option<Vec<(String, f64)>>,
}

impl<'c, const D: usize> FlowScene<'c, D> {
    /// The scene at equilibrium, after checking that its ensembles fit the node's memory
    /// (collective).
    pub fn fresh(case: &FlowCase, comm: &'c dyn Comm, threads: usize) -> Result<Self, Error> {
        check_memory(case, comm)?;
        let e = fresh::<D>(case, comm, threads)?;
        let averages = ParticleAverages::new(e.gids.len(), quantities(case).len());
        Ok(Self::new(
            e,
            case.clone(),
            Series::default(),
            averages,
            comm,
        ))
    }

    /// The scene continued from the checkpoint `path` of `case` (collective).
    #[cfg(feature = "hdf5")]
    pub fn restored(
        case: FlowCase,
        path: &Path,
        comm: &'c dyn Comm,
        threads: usize,
    ) -> Result<Self, crate::scene::Restart> {
        use crate::scene::Restart;
        check_memory(&case, comm).map_err(Restart::Failed)?;
        let r = crate::output::checkpoint::ensembles::read::<D>(path, comm)
            .map_err(Restart::Refused)?;
        let histograms = matches!(
            r.connectors,
            crate::models::homogeneous_flow::Connectors::Histograms { .. }
        );
        if histograms != case.polymer.histogram_grid().is_some() {
            return Err(Restart::Failed(
                format!(
                    "{}: the checkpoint holds {} but the case asks for {}",
                    path.display(),
                    if histograms {
                        "BDDFS histograms"
                    } else {
                        "connectors"
                    },
                    if histograms {
                        "connectors"
                    } else {
                        "BDDFS histograms"
                    }
                )
                .into(),
            ));
        }
        let e = HomogeneousEnsembles::<D>::from_state(
            comm,
            ensemble_spec(&case, threads, r.total),
            r.step,
            r.connectors,
            r.control,
        )
        .map_err(|e| Restart::Failed(e.into()))?;
        // The averaged observables of another version of mesorheo (collective: a rank without
        // particles has no row to look at). Checkpoints written before ⟨|Q|²⟩ was averaged
        // continue with that one average unknown (NaN): the others are unchanged.
        let names: Vec<String> = quantities(&case).into_iter().map(|(n, _)| n).collect();
        let mut held = [r.averages.sums.first().map_or(0.0, |row| row.len() as f64)];
        comm.allreduce_max(&mut held);
        let mut averages = r.averages;
        let added = names.iter().position(|n| n == MEAN_SQUARE_LENGTH);
        if let Some(at) = added
            && held[0] as usize + 1 == names.len()
        {
            for row in &mut averages.sums {
                row.insert(at, f64::NAN);
            }
        } else if held[0] as usize != names.len() {
            return Err(Restart::Failed(format!(
                "{}: the checkpoint holds {} averaged observables per particle, this version of \
                 mesorheo averages {} (the checkpoint was written by another version); start \
                 the run afresh",
                path.display(),
                held[0],
                names.len()
            ).into()));
        }
        // Its series, likewise, is unknown before the restart.
        let mut series = r.series;
        let samples = series.steps.len();
        for name in [
            MEAN_SQUARE_LENGTH.to_owned(),
            format!("{MEAN_SQUARE_LENGTH}{STDERR}"),
        ] {
            series
                .scalars
                .entry(name)
                .or_insert_with(|| vec![f64::NAN; samples]);
        }
        Ok(Self::new(e, case, series, averages, comm))
    }

    /// The step the ensembles have reached.
    pub fn step_reached(&self) -> u64 {
        self.e.step
    }

    /// The scene of `e` with its case, series and running sums so far.
    pub fn new(
        e: HomogeneousEnsembles<'c, D>,
        case: FlowCase,
        series: Series,
        averages: ParticleAverages,
        comm: &'c dyn Comm,
    ) -> Self {
        Self {
            e,
            case,
            series,
            averages,
            times: PhaseTimes::default(),
            comm,
            stop_requested_here: false,
            stop_agreed: false,
            row: None,
        }
    }
}

impl<const D: usize> Scene for FlowScene<'_, D> {
    fn step(&self) -> u64 {
        self.e.step
    }

    fn time(&self) -> f64 {
        self.e.time()
    }

    fn run(&self) -> &RunCfg {
        &self.case.run
    }

    fn output(&self) -> &OutputCfg {
        &self.case.output
    }

    fn set_steps(&mut self, steps: u64) {
        self.case.run.steps = steps;
    }

    fn describe(&self) -> String {
        let storage = match &self.e.histograms {
            Some(h) => format!(
                "BDDFS histograms ({} cells per axis, {:.0} occupied per particle on average)",
                h.grid.cells,
                h.rows.iter().map(Vec::len).sum::<usize>() as f64 / h.rows.len().max(1) as f64
            ),
            None => "ensembles".to_owned(),
        };
        format!(
            "homogeneous flow, {} particles × {} dumbbells ({}D), {:.1} MiB of {storage} here",
            self.e.total,
            self.e.n_d,
            D,
            self.e.memory_bytes() as f64 / (1024.0 * 1024.0)
        )
    }

    fn advance(&mut self) -> Result<(), Error> {
        let t = Instant::now();
        let outside = self.e.advance();
        self.times.integrate += t.elapsed().as_secs_f64();
        if self.e.step.is_multiple_of(self.case.run.sample_every) {
            let t = Instant::now();
            sample(&self.e, &self.case, &mut self.series, &mut self.averages);
            self.times.diagnostics += t.elapsed().as_secs_f64();
            // The sample just taken, for the time series (the particle-spread errors stay in
            // polymer_stress.csv).
            let k = self.series.steps.len() - 1;
            let mut row: Vec<(String, f64)> = (self.series.scalars.iter())
                .filter(|(name, _)| !name.ends_with(STDERR))
                .map(|(name, v)| (name.clone(), v[k]))
                .collect();
            // The flow's material function and N₁ first (what the progress line shows).
            let headline = |name: &str| {
                HEADLINE
                    .iter()
                    .position(|h| *h == name)
                    .unwrap_or(HEADLINE.len())
            };
            row.sort_by_key(|(name, _)| headline(name));
            self.row = Some(row);
        } else {
            self.row = None;
        }
        // Every rank stops after the same step; one reduction carries the stop requests and
        // the blow-ups. The rank that saw a dumbbell leave its domain names it; the others say
        // where to look.
        let mut stop = [
            if self.stop_requested_here { 1.0 } else { 0.0 },
            if outside.is_err() { 1.0 } else { 0.0 },
        ];
        self.comm.allreduce_max(&mut stop);
        outside?;
        if stop[1] > 0.0 {
            return Err(Unstable::new(
                crate::error::Quantity::Connector,
                None,
                self.e.step,
                format!(
                    "a dumbbell on another rank left the spring's domain at step {}: {} (see \
                     that rank's log)",
                    self.e.step,
                    crate::error::UNSTABLE
                ),
            )
            .into());
        }
        self.stop_agreed = stop[0] > 0.0;
        Ok(())
    }

    fn request_stop(&mut self) {
        self.stop_requested_here = true;
    }

    fn stop_agreed(&self) -> bool {
        self.stop_agreed
    }

    fn progress(&self, steps_per_second: f64) -> String {
        format!(
            "{:.3e} dumbbell-steps/s",
            steps_per_second * (self.e.total * self.e.n_d as u64) as f64,
        )
    }

    fn observables_row(&self) -> Option<&[(String, f64)]> {
        self.row.as_deref()
    }

    fn write_checkpoint(&mut self, dir: &Path, keep: usize) -> Result<PathBuf, Error> {
        #[cfg(feature = "hdf5")]
        {
            let (e, case, series, averages) = (&self.e, &self.case, &self.series, &self.averages);
            crate::output::checkpoint::ensembles::write(
                e, case, series, averages, dir, keep, self.comm,
            )
            .map_err(Error::from)
        }
        #[cfg(not(feature = "hdf5"))]
        {
            let _ = (dir, keep);
            Err("checkpoints need HDF5: this mesorheo was built without the `hdf5` feature".into())
        }
    }

    fn open_outputs(&mut self, _out: &Path, _restarted: bool) -> Result<(), Error> {
        Ok(())
    }

    fn write_outputs(&mut self) -> Result<(), Error> {
        Ok(())
    }

    fn close_outputs(&mut self, out: Option<&Path>) -> Result<(), Error> {
        if self.comm.rank() == 0
            && let Some(out) = out
        {
            write_series_csv(&self.series, self.case.dt(), out).map_err(|err| {
                format!("cannot write {}/polymer_stress.csv: {err}", out.display())
            })?;
        }
        Ok(())
    }

    fn report(&mut self, completed: bool) -> Result<SceneReport, Error> {
        let (e, case, series, averages) = (&self.e, &self.case, &self.series, &self.averages);
        // Time averages after equilibration: the mean over particles of each particle's time
        // average, with the standard error from their spread.
        let q = quantities(case);
        let k = averages.samples.max(1) as f64;
        let m = particle_moments(self.comm, averages.sums.len(), q.len(), e.total, |p, i| {
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
        let mut warnings: Vec<String> = observables
            .get(MEAN_SQUARE_LENGTH)
            .filter(|e| e.mean.is_nan() && averages.samples > 0)
            .map(|_| {
                format!(
                    "{MEAN_SQUARE_LENGTH} is not averaged: the run continued from a checkpoint \
                     written before that observable existed"
                )
            })
            .into_iter()
            .collect();
        warnings.extend(histogram_warnings(e, self.comm));
        let validation = if completed {
            case.reference
                .iter()
                .filter_map(|r| match r {
                    crate::config::ReferenceCfg::Value(v) => Some(check_value(v, &observables)),
                    crate::config::ReferenceCfg::LinearShearProfile(_)
                    | crate::config::ReferenceCfg::StartupProfile(_)
                    | crate::config::ReferenceCfg::DoublePoiseuilleProfile(_)
                    | crate::config::ReferenceCfg::DoublePoiseuilleStress(_) => None,
                })
                .collect()
        } else {
            Vec::new()
        };
        Ok(SceneReport {
            case: serde_json::to_value(case).map_err(|err| err.to_string())?,
            dimension: D,
            particles: e.total,
            dumbbells: Some(e.total * e.n_d as u64),
            ensemble_bytes_per_particle: Some(e.memory_bytes_per_particle()),
            observables,
            velocity_profile: Vec::new(),
            density_profile: Vec::new(),
            shear_stress_profile: Vec::new(),
            colloid_solvent_rdf: Vec::new(),
            validation,
            // The error bars come from the spread of independent particles' averages: no
            // blocks.
            warnings,
            state_digest: format!("{:016x}", e.digest()),
            load: None,
        })
    }

    fn times(&mut self) -> &mut PhaseTimes {
        &mut self.times
    }
}
