//! Dumbbell ensembles in homogeneous flows: every particle sees the same imposed velocity
//! gradient κ(t); the particles are carriers of their ensembles only (no positions needed).
//! Each rank holds the particles of its global-id block and advances their ensembles with its
//! rayon threads; the stress is averaged over particles with exact sums, so every result is
//! bitwise the same on any number of ranks and threads.
//!
//! Flows (κ_αβ = ∂v_α/∂x_β, rate ε̇ or γ̇):
//! - simple shear: κ_xy = γ̇;
//! - shear reversal: κ_xy = γ̇ for t < t_r, −γ̇ after;
//! - planar elongation: κ = diag(ε̇, −ε̇, 0);
//! - uniaxial elongation (3D): κ = diag(ε̇, −ε̇/2, −ε̇/2).
//!
//! Variance reduction (optional; Öttinger 1996 §4.4, control variates): every particle also
//! carries a copy of its ensemble that started from the same connectors and is driven by the
//! *same* noise but no flow. The estimator τ(Q) − τ(Q_eq) + E[τ(Q_eq)] has the same mean (E[τ_eq]
//! is known: 0 in the continuum, for Hookean springs the exact discrete value is used) and, while
//! the two ensembles stay correlated, a much smaller variance — most of all at small Wi, where the
//! polymer stress is a small signal on large thermal noise. It doubles memory and work.
//!
//! BDDFS storage (optional; [`super::bddfs`]): a particle keeps a sparse histogram of its
//! connectors on a Q-grid instead of the connectors; every step regenerates them within their
//! cells, advances them with the same scheme and noise keys, measures their stress and
//! histograms them again ([`HomogeneousEnsembles::new_with_histograms`]).

use super::bddfs::{QGrid, StepMoments, Workspace, histogram_of, step_histogram};
use super::dumbbells::{
    DumbbellParams, Spring, hookean_discrete_moment, init_stream, kramers_stress, noise_stream,
    outside_domain, sample_equilibrium, step_ensemble,
};
use crate::comm::Comm;
use crate::domain::id_block;
use crate::error::{Error, Quantity, Unstable};
use crate::fixed_sum::FixedSum;
use crate::particles::{Tensor, tensor_rows};
use rayon::prelude::*;

/// An imposed homogeneous flow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flow {
    /// At rest.
    Rest,
    /// v_x = γ̇ y.
    SimpleShear {
        /// γ̇.
        rate: f64,
    },
    /// Shear at γ̇, reversed to −γ̇ at `at`.
    ShearReversal {
        /// γ̇.
        rate: f64,
        /// Reversal time.
        at: f64,
    },
    /// v = ε̇ (x, −y, 0).
    PlanarElongation {
        /// ε̇.
        rate: f64,
    },
    /// v = ε̇ (x, −y/2, −z/2) (3D).
    UniaxialElongation {
        /// ε̇.
        rate: f64,
    },
}

impl Flow {
    /// The |Q|² beyond which a Hookean connector is a runaway in this flow, in units of k_BT/H:
    /// 10⁴ × (D + 2 Wi²), Wi = λ × rate, ten thousand times the steady shear ⟨Q²⟩ — a Gaussian
    /// connector exceeds it with probability e^{−thousands}. Infinite in an elongation with a
    /// stretching rate beyond 1/(2λ), where the Hookean model itself grows without bound.
    pub fn hookean_runaway_q2(&self, dim: usize, lambda: f64) -> f64 {
        let (rate, stretching) = match *self {
            Flow::Rest => (0.0, 0.0),
            Flow::SimpleShear { rate } | Flow::ShearReversal { rate, .. } => (rate, 0.0),
            Flow::PlanarElongation { rate } => (rate, rate.abs()),
            Flow::UniaxialElongation { rate } => {
                (rate, if rate >= 0.0 { rate } else { -0.5 * rate })
            }
        };
        if stretching * lambda >= 0.5 {
            return f64::INFINITY;
        }
        let wi = lambda * rate;
        1e4 * (dim as f64 + 2.0 * wi * wi)
    }

    /// κ(t).
    pub fn kappa<const D: usize>(&self, t: f64) -> Tensor<D> {
        let mut k = Tensor::<D>::zeros();
        match *self {
            Flow::Rest => {}
            Flow::SimpleShear { rate } => k[(0, 1)] = rate,
            Flow::ShearReversal { rate, at } => k[(0, 1)] = if t < at { rate } else { -rate },
            Flow::PlanarElongation { rate } => {
                k[(0, 0)] = rate;
                k[(1, 1)] = -rate;
            }
            Flow::UniaxialElongation { rate } => {
                k[(0, 0)] = rate;
                for d in 1..D {
                    k[(d, d)] = -rate / 2.0;
                }
            }
        }
        k
    }
}

/// Ensembles of one rank in a homogeneous flow.
pub struct HomogeneousEnsembles<'c, const D: usize> {
    comm: &'c dyn Comm,
    /// Global ids of this rank's particles.
    pub gids: Vec<u64>,
    /// Connector vectors, N_d × D per particle (double-precision storage; empty vectors when
    /// the ensembles are stored in single precision, see [`Self::q_single`]).
    pub q: Vec<Vec<f64>>,
    /// Connector vectors stored in single precision (`Some` after
    /// [`Self::with_single_precision`]): half the memory; each step widens a particle's
    /// ensemble to f64, advances it with the same arithmetic and rounds it back, so the
    /// storage adds a relative error of 2⁻²⁴ per step, far below the sampling error.
    pub q_single: Option<Vec<Vec<f32>>>,
    /// Dumbbells per particle.
    pub n_d: usize,
    /// Model parameters.
    pub params: DumbbellParams,
    /// The flow.
    pub flow: Flow,
    /// Seed.
    pub seed: u64,
    /// Current step.
    pub step: u64,
    /// Total particle count.
    pub total: u64,
    /// Equilibrium copies driven by the same noise (variance reduction), if enabled.
    pub control: Option<Vec<Vec<f64>>>,
    /// BDDFS: histograms instead of connectors (`Some` from [`Self::new_with_histograms`]; `q`
    /// then holds empty vectors).
    pub histograms: Option<Histograms>,
    pool: rayon::ThreadPool,
}

/// The BDDFS storage of one rank ([`super::bddfs`]): each particle's sparse histogram, and what
/// its last step measured on the advanced connectors (the stress is sampled from those, not
/// from the histogram).
#[derive(Clone, Debug, PartialEq)]
pub struct Histograms {
    /// The Q-grid.
    pub grid: QGrid,
    /// Per particle: the occupied cells, packed (cell << 32 | count), by increasing cell.
    pub rows: Vec<Vec<u64>>,
    /// Per particle: the moments of the connectors its last step produced (unknown after a
    /// restart until the next step).
    pub moments: Vec<StepMoments>,
    /// Connectors this rank found outside the grid (clipped into a boundary cell) since the
    /// process started.
    pub clipped: u64,
    /// FENE reconstructions that fell back to the cell's point nearest the origin.
    pub fallbacks: u64,
}

/// Means over all particles of all ranks of `width` per-particle values (`value(k, i)`: value i
/// of this rank's particle k), each with its standard error from the particle-to-particle spread
/// (s/√N): the particles carry independent ensembles, so they are independent samples.
/// Collective; the sums are exact (fixed point), so the result does not depend on the rank count.
pub fn particle_moments(
    comm: &dyn Comm,
    local: usize,
    width: usize,
    total: u64,
    value: impl Fn(usize, usize) -> f64,
) -> Vec<(f64, f64)> {
    let mut sums = vec![FixedSum::ZERO; 2 * width];
    for k in 0..local {
        if k % 2048 == 2047 {
            sums.iter_mut().for_each(FixedSum::normalize);
        }
        for i in 0..width {
            let v = value(k, i);
            sums[i].add(v);
            sums[width + i].add(v * v);
        }
    }
    FixedSum::allreduce(comm, &mut sums);
    let n = total as f64;
    (0..width)
        .map(|i| {
            let m = sums[i].value() / n;
            let var = (sums[width + i].value() / n - m * m).max(0.0) * n / (n - 1.0).max(1.0);
            (m, (var / n).sqrt())
        })
        .collect()
}

/// Running sums, per particle of this rank, of every averaged observable (the `quantities` of [`crate::flow_scene`]) over the samples after
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

/// Particle `i`'s connectors in double precision: borrowed from f64 storage, widened from f32.
fn widened<'a>(
    q: &'a [Vec<f64>],
    single: Option<&'a [Vec<f32>]>,
    i: usize,
) -> std::borrow::Cow<'a, [f64]> {
    match single {
        Some(s) => std::borrow::Cow::Owned(s[i].iter().map(|&x| f64::from(x)).collect()),
        None => std::borrow::Cow::Borrowed(&q[i]),
    }
}

/// Connector storage handed to [`HomogeneousEnsembles::from_state`].
pub enum Connectors {
    /// f64 storage, one vector of N_d × D per particle.
    Double(Vec<Vec<f64>>),
    /// f32 storage.
    Single(Vec<Vec<f32>>),
    /// BDDFS histograms on `grid`, one sparse row per particle.
    Histograms {
        /// The Q-grid.
        grid: QGrid,
        /// Packed occupied cells per particle.
        rows: Vec<Vec<u64>>,
    },
}

/// A view of the connector storage.
pub enum ConnectorsRef<'a> {
    /// f64 storage.
    Double(&'a [Vec<f64>]),
    /// f32 storage.
    Single(&'a [Vec<f32>]),
    /// BDDFS histograms.
    Histograms(&'a [Vec<u64>]),
}

/// What one run's ensembles are, on every rank alike: `total` particles of `n_d` dumbbells each,
/// their model, the flow, the seed of their streams, and the worker threads that advance a
/// rank's share (0: one per core).
#[derive(Clone, Copy, Debug)]
pub struct EnsembleSpec {
    /// Worker threads of this rank (0: one per core).
    pub threads: usize,
    /// Particles over all ranks (each carries one ensemble).
    pub total: u64,
    /// Dumbbells per ensemble.
    pub n_d: usize,
    /// The dumbbell model and its integration.
    pub params: DumbbellParams,
    /// The imposed homogeneous flow.
    pub flow: Flow,
    /// The seed of every particle's streams.
    pub seed: u64,
}

/// Ensemble-averaged stress with its error bar.
#[derive(Clone, Debug, PartialEq)]
pub struct StressEstimate<const D: usize> {
    /// Mean over particles of τ/G (each particle's ensemble average), D × D.
    pub mean: [[f64; D]; D],
    /// Standard error of `mean` from the spread between particles (independent ensembles).
    pub stderr: [[f64; D]; D],
    /// N₁/G = (τ_xx − τ_yy)/G and its standard error.
    pub n1: (f64, f64),
    /// N₂/G = (τ_yy − τ_zz)/G and its standard error (0 in 2D).
    pub n2: (f64, f64),
}

// The heavy methods are `pub(crate)`: other crates call them through `facade::Ensembles`,
// compiled once in this crate for D = 2 and 3 (see there why); the light accessors stay public.
impl<'c, const D: usize> HomogeneousEnsembles<'c, D> {
    /// `spec.total` particles × `spec.n_d` dumbbells at equilibrium; this rank keeps its id
    /// block.
    pub(crate) fn new(comm: &'c dyn Comm, spec: EnsembleSpec) -> Result<Self, String> {
        let EnsembleSpec {
            threads,
            total,
            n_d,
            params,
            flow,
            seed,
        } = spec;
        params.check()?;
        let pool = crate::workers::worker_pool(comm, threads)?;
        let gids: Vec<u64> = id_block(total, comm.size(), comm.rank()).collect();
        let spring = params.spring;
        let q = pool.install(|| {
            gids.par_iter()
                .map(|&g| {
                    let mut q = vec![0.0; n_d * D];
                    sample_equilibrium::<D>(&mut q, spring, &mut init_stream(seed, g));
                    q
                })
                .collect()
        });
        Ok(Self {
            comm,
            gids,
            q,
            n_d,
            params,
            flow,
            seed,
            step: 0,
            total,
            control: None,
            q_single: None,
            histograms: None,
            pool,
        })
    }

    /// Ensembles restored from a checkpoint: `q` (and `control`) hold this rank's id block
    /// (`comm`'s [`id_block`]) at `step`.
    pub(crate) fn from_state(
        comm: &'c dyn Comm,
        spec: EnsembleSpec,
        step: u64,
        q: Connectors,
        control: Option<Vec<Vec<f64>>>,
    ) -> Result<Self, String> {
        spec.params.check()?;
        let gids: Vec<u64> = id_block(spec.total, comm.size(), comm.rank()).collect();
        let rows = match &q {
            Connectors::Double(q) => q.len(),
            Connectors::Single(q) => q.len(),
            Connectors::Histograms { rows, .. } => rows.len(),
        };
        let mismatch =
            rows != gids.len() || control.as_ref().is_some_and(|c| c.len() != gids.len());
        // Decided together, so that every rank returns the error or none does: the pool start
        // below is collective, and a rank left waiting there would hang the run.
        let mut any = [if mismatch { 1.0 } else { 0.0 }];
        comm.allreduce_max(&mut any);
        if any[0] > 0.0 {
            return Err(if mismatch {
                format!(
                    "restored {rows} ensembles for an id block of {} particles",
                    gids.len()
                )
            } else {
                "another rank restored a wrong number of ensembles for its id block".to_owned()
            });
        }
        let pool = crate::workers::worker_pool(comm, spec.threads)?;
        let mut histograms = None;
        let (q, q_single) = match q {
            Connectors::Double(q) => (q, None),
            Connectors::Single(q) => (vec![Vec::new(); gids.len()], Some(q)),
            Connectors::Histograms { grid, rows } => {
                histograms = Some(Histograms {
                    grid,
                    moments: vec![StepMoments::unknown(); rows.len()],
                    rows,
                    clipped: 0,
                    fallbacks: 0,
                });
                (vec![Vec::new(); gids.len()], None)
            }
        };
        Ok(Self {
            comm,
            gids,
            q,
            n_d: spec.n_d,
            params: spec.params,
            flow: spec.flow,
            seed: spec.seed,
            step,
            total: spec.total,
            control,
            q_single,
            histograms,
            pool,
        })
    }

    /// `total` particles at equilibrium that keep, instead of their `n_d` connectors, the
    /// histogram of them on `grid` (BDDFS): each particle draws the plain ensembles' initial
    /// connectors (the same stream), histograms them and keeps their moments as the step-0
    /// sample; only one thread's buffer of connectors exists at a time, never a whole rank's.
    pub(crate) fn new_with_histograms(
        comm: &'c dyn Comm,
        spec: EnsembleSpec,
        grid: QGrid,
    ) -> Result<Self, String> {
        let (n_d, seed) = (spec.n_d, spec.seed);
        let mut e = Self::new(comm, EnsembleSpec { n_d: 0, ..spec })?;
        e.n_d = n_d;
        let spring = spec.params.spring;
        let per: Vec<(Vec<u64>, StepMoments, u64)> = e.pool.install(|| {
            e.gids
                .par_iter()
                .map_init(Vec::new, |q: &mut Vec<f64>, &g| {
                    q.clear();
                    q.resize(n_d * D, 0.0);
                    sample_equilibrium::<D>(q, spring, &mut init_stream(seed, g));
                    let (row, clipped) = histogram_of::<D>(q, &grid);
                    (row, StepMoments::of::<D>(q, spring), clipped)
                })
                .collect()
        });
        let mut h = Histograms {
            grid,
            rows: Vec::with_capacity(per.len()),
            moments: Vec::with_capacity(per.len()),
            clipped: 0,
            fallbacks: 0,
        };
        for (row, moments, clipped) in per {
            h.rows.push(row);
            h.moments.push(moments);
            h.clipped += clipped;
        }
        e.histograms = Some(h);
        Ok(e)
    }

    /// Stores the connectors in single precision from now on (before the first step).
    pub(crate) fn with_single_precision(mut self) -> Self {
        assert_eq!(self.step, 0, "the storage precision is chosen at the start");
        let single = self
            .q
            .iter_mut()
            .map(|q| std::mem::take(q).into_iter().map(|x| x as f32).collect())
            .collect();
        self.q_single = Some(single);
        self
    }

    /// The connectors of this rank's particles, in their storage precision.
    pub fn connectors(&self) -> ConnectorsRef<'_> {
        if let Some(h) = &self.histograms {
            return ConnectorsRef::Histograms(&h.rows);
        }
        match &self.q_single {
            Some(q) => ConnectorsRef::Single(q),
            None => ConnectorsRef::Double(&self.q),
        }
    }

    /// Particle `i`'s connectors in double precision (widened from single storage; empty with
    /// BDDFS histograms, which hold no connectors between steps).
    pub fn ensemble(&self, i: usize) -> std::borrow::Cow<'_, [f64]> {
        widened(&self.q, self.q_single.as_deref(), i)
    }

    /// Bytes of connector storage on this rank (incl. the control copy; BDDFS: 8 per occupied
    /// cell).
    pub(crate) fn memory_bytes(&self) -> usize {
        if let Some(h) = &self.histograms {
            return h.rows.iter().map(|r| r.len() * 8).sum();
        }
        let words: usize = match &self.q_single {
            Some(q) => q.iter().map(|v| v.len() * 4).sum(),
            None => self.q.iter().map(|v| v.len() * 8).sum(),
        };
        words
            + self
                .control
                .as_ref()
                .map_or(0, |c| c.iter().map(|v| v.len() * 8).sum())
    }

    /// Switches on the control-variate variance reduction (before the first step; double
    /// precision only, so that both copies see the same arithmetic).
    pub(crate) fn with_control_variates(mut self) -> Self {
        assert_eq!(self.step, 0, "control variates start with the ensembles");
        assert!(
            self.q_single.is_none(),
            "control variates need double-precision storage"
        );
        self.control = Some(self.q.clone());
        self
    }

    /// Simulated time.
    pub fn time(&self) -> f64 {
        self.step as f64 * self.params.dt
    }

    /// Advances every ensemble by one step (κ frozen at the start of the step). A dumbbell left
    /// outside the spring's domain (not finite, or |Q|² ≥ b) stops the run, named by its
    /// particle and index (the lowest particle id, so the message does not depend on threads).
    pub(crate) fn advance(&mut self) -> Result<(), Error> {
        // As rows for the per-dumbbell kernel (one conversion per step).
        let kappa = tensor_rows(&self.flow.kappa::<D>(self.time()));
        let (p, seed, step) = (self.params, self.seed, self.step);
        let limit = match p.spring {
            Spring::Fene { b } => b,
            Spring::Hookean => self.flow.hookean_runaway_q2(D, p.lambda),
        };
        let (q, gids) = (&mut self.q, &self.gids);
        let outside = if let Some(h) = &mut self.histograms {
            let grid = h.grid;
            let moments: Vec<StepMoments> = self.pool.install(|| {
                h.rows
                    .par_iter_mut()
                    .zip(gids.par_iter())
                    .map_init(Workspace::default, |ws, (row, &g)| {
                        step_histogram::<D>(row, &grid, &kappa, &p, limit, seed, g, step, ws)
                    })
                    .collect()
            });
            h.clipped += moments.iter().map(|m| m.clipped).sum::<u64>();
            h.fallbacks += moments.iter().map(|m| m.fallbacks).sum::<u64>();
            let outside = moments
                .iter()
                .zip(gids)
                .filter_map(|(m, &g)| m.outside.map(|(k, q2)| (g, k, q2)))
                .min_by_key(|v| (v.0, v.1));
            h.moments = moments;
            outside
        } else if let Some(single) = &mut self.q_single {
            self.pool.install(|| {
                single
                    .par_iter_mut()
                    .zip(gids.par_iter())
                    .map_init(Vec::new, |wide: &mut Vec<f64>, (q, &g)| {
                        wide.clear();
                        wide.extend(q.iter().map(|&x| f64::from(x)));
                        step_ensemble::<D>(wide, &kappa, &p, &mut noise_stream(seed, g, step, 0));
                        for (s, w) in q.iter_mut().zip(wide.iter()) {
                            *s = *w as f32;
                        }
                        // What is stored, after the rounding to single precision.
                        outside_domain::<D, f32>(q, limit).map(|(k, q2)| (g, k, q2))
                    })
                    .flatten()
                    .min_by_key(|v| (v.0, v.1))
            })
        } else {
            self.pool.install(|| {
                q.par_iter_mut()
                    .zip(gids.par_iter())
                    .filter_map(|(q, &g)| {
                        step_ensemble::<D>(q, &kappa, &p, &mut noise_stream(seed, g, step, 0));
                        outside_domain::<D, f64>(q, limit).map(|(k, q2)| (g, k, q2))
                    })
                    .min_by_key(|v| (v.0, v.1))
            })
        };
        if let Some(c) = &mut self.control {
            let rest = [[0.0; D]; D];
            self.pool.install(|| {
                c.par_iter_mut().zip(gids.par_iter()).for_each(|(q, &g)| {
                    // The same key, hence the same normals as the flowing copy.
                    step_ensemble::<D>(q, &rest, &p, &mut noise_stream(seed, g, step, 0));
                })
            });
        }
        self.step += 1;
        match outside {
            None => Ok(()),
            Some((g, k, q2)) => Err(Unstable::new(
                Quantity::Connector,
                Some(g),
                self.step,
                format!(
                    "dumbbell {k} of particle {g} has |Q|² = {q2:.6e}{} at step {}: {} (the \
                 connector left the spring's domain; reduce the time step{})",
                    match p.spring {
                        Spring::Fene { b } => format!(" ≥ b = {b}"),
                        Spring::Hookean if q2.is_finite() => format!(
                            " (a runaway Hookean connector: beyond {limit:.3e}, 10⁴ × its steady \
                         shear size)"
                        ),
                        Spring::Hookean => " (not finite)".into(),
                    },
                    self.step,
                    crate::error::UNSTABLE,
                    if self.q_single.is_some() {
                        ", or store the connectors in double precision"
                    } else {
                        ""
                    }
                ),
            )
            .into()),
        }
    }

    /// τ/G of each particle of this rank: its ensemble average, with control variates the
    /// corrected estimator τ(Q) − τ(Q_eq) + E[τ_eq]; D × D row-major in the first D² entries.
    pub(crate) fn particle_stresses(&self) -> Vec<[f64; 9]> {
        if let Some(h) = &self.histograms {
            return h.moments.iter().map(|m| m.stress).collect();
        }
        let spring = self.params.spring;
        let n = self.gids.len();
        let (q, single) = (&self.q, self.q_single.as_deref());
        let mut per: Vec<[f64; 9]> = self.pool.install(|| {
            (0..n)
                .into_par_iter()
                .map(|i| kramers_stress::<D>(&widened(q, single, i), spring))
                .collect()
        });
        if let Some(c) = &self.control {
            // E[τ_eq/G]: the exact discrete value for Hookean springs, 0 otherwise.
            let mut expected = [0.0; 9];
            if spring == Spring::Hookean {
                let m = hookean_discrete_moment::<D>(&[[0.0; D]; D], &self.params, self.step);
                for a in 0..D {
                    for b in 0..D {
                        expected[a * D + b] = m[a][b] - if a == b { 1.0 } else { 0.0 };
                    }
                }
            }
            let eq: Vec<[f64; 9]> = self.pool.install(|| {
                c.par_iter()
                    .map(|q| kramers_stress::<D>(q, spring))
                    .collect()
            });
            for (s, e) in per.iter_mut().zip(&eq) {
                for i in 0..D * D {
                    s[i] += expected[i] - e[i];
                }
            }
        }
        per
    }

    /// ⟨|Q|²⟩ (units k_BT/H) of each particle of this rank: its ensemble average, with control
    /// variates ⟨|Q|²⟩ − ⟨|Q_eq|²⟩ + E[|Q_eq|²], where E[|Q_eq|²] is the exact discrete trace for
    /// Hookean springs and the continuum equilibrium D b/(b + D + 2) for FENE (Bird et al., DPL
    /// vol. 2: the FENE equilibrium density ∝ (1 − Q²/b)^(b/2)).
    pub(crate) fn particle_mean_square_lengths(&self) -> Vec<f64> {
        if let Some(h) = &self.histograms {
            return h.moments.iter().map(|m| m.mean_q2).collect();
        }
        let n = self.gids.len();
        let (q, single) = (&self.q, self.q_single.as_deref());
        let mean_square = |c: &[f64]| -> f64 {
            let sum: f64 = c.iter().map(|x| x * x).sum();
            sum / (c.len() / D).max(1) as f64
        };
        let mut per: Vec<f64> = self.pool.install(|| {
            (0..n)
                .into_par_iter()
                .map(|i| mean_square(&widened(q, single, i)))
                .collect()
        });
        if let Some(c) = &self.control {
            let expected = match self.params.spring {
                Spring::Hookean => {
                    let m = hookean_discrete_moment::<D>(&[[0.0; D]; D], &self.params, self.step);
                    (0..D).map(|a| m[a][a]).sum()
                }
                Spring::Fene { b } => D as f64 * b / (b + D as f64 + 2.0),
            };
            let eq: Vec<f64> = self
                .pool
                .install(|| c.par_iter().map(|q| mean_square(q)).collect());
            for (s, e) in per.iter_mut().zip(&eq) {
                *s += expected - e;
            }
        }
        per
    }

    /// BDDFS: the occupied histogram cells of each particle of this rank (None without
    /// histograms).
    pub(crate) fn particle_occupied_cells(&self) -> Option<Vec<f64>> {
        self.histograms
            .as_ref()
            .map(|h| h.rows.iter().map(|r| r.len() as f64).collect())
    }

    /// The mean over all particles of all ranks of a per-particle value of this rank's particles,
    /// with the standard error from their spread (collective; exact sums).
    pub(crate) fn particle_mean(&self, per: &[f64]) -> (f64, f64) {
        particle_moments(self.comm, per.len(), 1, self.total, |p, _| per[p])[0]
    }

    /// τ/G averaged over all particles of all ranks, with the standard error from the
    /// particle-to-particle spread (collective; exact sums, so rank-count independent).
    pub(crate) fn stress(&self) -> StressEstimate<D> {
        self.stress_of(&self.particle_stresses())
    }

    /// [`Self::stress`] of given [`Self::particle_stresses`] (collective).
    pub(crate) fn stress_of(&self, per: &[[f64; 9]]) -> StressEstimate<D> {
        // Per particle: the D² components, then N₁ and N₂.
        let w = D * D + 2;
        let value = |s: &[f64; 9], i: usize| -> f64 {
            match i {
                i if i < D * D => s[i],
                i if i == D * D => s[0] - s[D + 1],
                _ if D == 3 => s[4] - s[8],
                _ => 0.0,
            }
        };
        let m = particle_moments(self.comm, per.len(), w, self.total, |k, i| {
            value(&per[k], i)
        });
        let moments = |i: usize| m[i];
        let mut est = StressEstimate {
            mean: [[0.0; D]; D],
            stderr: [[0.0; D]; D],
            n1: moments(D * D),
            n2: moments(D * D + 1),
        };
        for a in 0..D {
            for b in 0..D {
                (est.mean[a][b], est.stderr[a][b]) = moments(a * D + b);
            }
        }
        est
    }

    /// Largest |Q|² of any dumbbell (collective).
    pub(crate) fn max_q2(&self) -> f64 {
        let local = if let Some(h) = &self.histograms {
            h.moments.iter().map(|m| m.max_q2).fold(0.0, f64::max)
        } else {
            self.max_q2_of_connectors()
        };
        let mut v = [local];
        self.comm.allreduce_max(&mut v);
        v[0]
    }

    /// Largest |Q|² of this rank's stored connectors.
    fn max_q2_of_connectors(&self) -> f64 {
        (0..self.gids.len())
            .map(|i| {
                self.ensemble(i)
                    .chunks_exact(D)
                    .map(|c| c.iter().map(|v| v * v).sum::<f64>())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max)
    }

    /// Bytes of connector storage per particle over every rank ([`Self::memory_bytes`]
    /// summed, over the particle count; collective).
    pub(crate) fn memory_bytes_per_particle(&self) -> f64 {
        let mut bytes = [self.memory_bytes() as u64];
        self.comm.allreduce_u64(&mut bytes, crate::comm::U64Op::Sum);
        bytes[0] as f64 / self.total.max(1) as f64
    }

    /// A digest of every connector vector (collective, order-independent).
    pub(crate) fn digest(&self) -> u64 {
        let mut acc = [0u64];
        for (i, &g) in self.gids.iter().enumerate() {
            let mut words = vec![g];
            words.extend(self.ensemble(i).iter().map(|x| x.to_bits()));
            if let Some(c) = &self.control {
                words.extend(c[i].iter().map(|x| x.to_bits()));
            }
            if let Some(h) = &self.histograms {
                words.extend_from_slice(&h.rows[i]);
            }
            acc[0] = acc[0].wrapping_add(crate::workers::hash_words(&words));
        }
        self.comm.allreduce_u64(&mut acc, crate::comm::U64Op::Sum);
        acc[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comm::local_universe;
    use crate::models::dumbbells::Scheme;

    #[test]
    fn a_state_with_the_wrong_row_count_on_one_rank_fails_on_every_rank_without_a_hang() {
        let params = DumbbellParams {
            spring: Spring::Hookean,
            scheme: Scheme::Heun,
            lambda: 1.0,
            dt: 0.01,
        };
        let results: Vec<Result<usize, String>> = std::thread::scope(|scope| {
            let handles: Vec<_> = local_universe(2)
                .into_iter()
                .map(|comm| {
                    scope.spawn(move || {
                        // 10 particles: ids 0–4 on rank 0, 5–9 on rank 1; rank 1 restores 4.
                        let rows = if comm.rank() == 1 { 4 } else { 5 };
                        let q = Connectors::Double(vec![vec![0.0; 3]; rows]);
                        HomogeneousEnsembles::<3>::from_state(
                            &comm,
                            EnsembleSpec {
                                threads: 1,
                                total: 10,
                                n_d: 1,
                                params,
                                flow: Flow::Rest,
                                seed: 1,
                            },
                            0,
                            q,
                            None,
                        )
                        .map(|e| e.gids.len())
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("rank thread"))
                .collect()
        });
        assert!(
            results[0]
                .as_ref()
                .is_err_and(|e| e.contains("another rank"))
        );
        assert!(
            results[1]
                .as_ref()
                .is_err_and(|e| e.contains("restored 4 ensembles"))
        );
    }
}
