//! The engines' entry points for other crates (the tests, benchmarks and examples), compiled
//! once, here, for D = 2 and D = 3: [`Engine`] for the particle engine [`Simulation`],
//! [`Ensembles`] for the homogeneous-flow dumbbell ensembles [`HomogeneousEnsembles`].
//!
//! Why: both are generic over the dimension, and in release builds rustc does not share
//! generic code between crates (`-Zshare-generics` is off there): every crate that calls a
//! generic method compiles and optimises its own copy of everything the call reaches — the
//! step, every model's passes and kernels, the neighbour lists, the integrators, the rayon
//! jobs. `./run test` builds its test binaries in release mode, so each one that called, say,
//! `Simulation::<2>::new` and `.advance()` compiled the whole engine again: with
//! `cargo --timings` on 2 cores (2026-11-28) the integration suites `engine_suite` and
//! `sph_suite` took 238 s and 186 s beside the library's 359 s, almost all of it that copy.
//! Through these traits (same day, same machine, shared and noisier: 474 s and 420 s before)
//! they took 26 s and 7 s; `cargo llvm-lines` of the suites went from 2.09 M and 1.56 M lines
//! of LLVM IR (48 691 and 36 909 function copies) to 0.28 M and 0.09 M.
//!
//! Each trait is implemented for the concrete types of D = 2 and 3 (`Simulation<'c, 2>`, …). A
//! method of an impl for a concrete type has no type or const parameter left (lifetimes are
//! erased), so rustc compiles it in this crate only, and the other crates call that copy. The
//! methods forward to the generic inherent methods of the same name, which are `pub(crate)` for
//! this reason: from outside, `sim.advance()` only resolves to [`Engine::advance`] (with the
//! trait in scope; without it rustc says the inherent method is private and names the trait),
//! so a test cannot instantiate the engine again by accident. Inside the crate the inherent
//! methods stay the ones called. The checkpoint reader and writer of a particle scene, generic
//! too, are reached the same way ([`Engine::read_checkpoint`], [`Engine::write_checkpoint`]),
//! and so is the one step loop over a particle scene ([`Engine::drive`]).
//!
//! The forwarding methods are deliberately not `#[inline]`: an inlinable function is compiled
//! again in every crate that calls it, which is what this module avoids. Light accessors
//! (fields, [`Simulation::time`], [`Simulation::is_sample_step`], [`HomogeneousEnsembles::
//! ensemble`], …) stay generic: they cost little to instantiate. A test helper generic over the
//! dimension takes the bound `for<'c> Simulation<'c, D>: Engine<'c, D>`.

use crate::comm::Comm;
use crate::config::Case;
use crate::diagnostics::Series;
use crate::error::Error;
use crate::models::bddfs::QGrid;
use crate::models::homogeneous_flow::{
    Connectors, EnsembleSpec, HomogeneousEnsembles, StressEstimate,
};
use crate::models::interface::ParticleModel;
use crate::particles::Particles;
use crate::scene::RunOptions;
use crate::sim::{Measurement, Simulation};
use crate::species::Species;
use crate::summary::Summary;
use std::path::Path;
#[cfg(feature = "hdf5")]
use std::path::PathBuf;
use std::time::Duration;

/// One rank's [`Simulation`] of dimension `D`, through methods compiled once in this crate (the
/// module documentation says why). Each method is the inherent method of the same name.
pub trait Engine<'c, const D: usize>: Sized {
    /// Sets up the initial state on this rank and computes the initial forces; `threads`
    /// rayon workers serve this rank (0: all available cores).
    fn new(case: &Case, comm: &'c dyn Comm, threads: usize) -> Result<Self, Error>;

    /// Continues from a checkpointed state ([`Engine::read_checkpoint`] gives the arguments);
    /// bitwise the uninterrupted run.
    #[allow(clippy::too_many_arguments)]
    fn from_checkpoint(
        case: &Case,
        comm: &'c dyn Comm,
        threads: usize,
        particles: Particles<D>,
        total: u64,
        step: u64,
        rebuild_step: u64,
        series: Series,
        species: Option<Vec<Species>>,
        bodies: Option<&str>,
    ) -> Result<Self, Error>;

    /// Reads and verifies a checkpoint of this dimension (collective).
    #[cfg(feature = "hdf5")]
    fn read_checkpoint(
        path: &Path,
        comm: &dyn Comm,
    ) -> Result<crate::output::checkpoint::Restored<D>, crate::output::checkpoint::CheckpointError>;

    /// Writes the checkpoint of the current step into `dir` and keeps the newest `keep`
    /// (collective). Returns the path.
    #[cfg(feature = "hdf5")]
    fn write_checkpoint(&mut self, dir: &Path, keep: usize) -> Result<PathBuf, String>;

    /// Attaches a model (it joins from the next force evaluation).
    fn attach(&mut self, model: Box<dyn ParticleModel<D>>) -> Result<(), Error>;

    /// Gives the particles species: `assign` maps a particle's id and initial position to its
    /// index into `table`. Collective.
    fn set_species(
        &mut self,
        table: Vec<Species>,
        assign: &dyn Fn(u64, &[f64; D]) -> u8,
    ) -> Result<(), Error>;

    /// One step.
    fn advance(&mut self) -> Result<(), Error>;

    /// Runs `steps` steps, sampling on schedule.
    fn run_steps(&mut self, steps: u64) -> Result<Duration, Error>;

    /// Runs the particle scene of this simulation through the one step loop
    /// ([`crate::scene::drive`]) and returns the summary.
    fn drive(
        self,
        case_file: &Path,
        restarted_from: Option<&Path>,
        comm: &dyn Comm,
        options: &RunOptions,
        threads: usize,
    ) -> Result<Summary, Error>;

    /// Jumps to `step` and rebuilds halo and lists there (tests that need a non-zero
    /// Lees–Edwards offset).
    fn jump_to_step(&mut self, step: u64) -> Result<(), Error>;

    /// Evaluates the forces (and the virial when asked) again at the current step.
    fn recompute_forces(&mut self, want_virial: bool) -> Result<(), Error>;

    /// The observables of the current step (collective).
    fn measure(&mut self) -> Measurement;

    /// Samples the observables into the series (collective).
    fn sample(&mut self) -> Result<(), Error>;

    /// [`Engine::sample`], returning the scalar values it averaged (collective).
    fn sample_values(&mut self) -> Result<Vec<(String, f64)>, Error>;

    /// The scalar observables of the current step, for the time series only (collective).
    fn record(&mut self) -> Vec<(String, f64)>;

    /// Feeds the current pressure tensor to the Green–Kubo correlators (collective).
    fn correlate(&mut self);

    /// Feeds the transverse currents to their correlators (collective).
    fn sample_currents(&mut self);

    /// The Green–Kubo viscosity estimate, when the case asks for it.
    fn green_kubo(&self) -> Option<crate::green_kubo::GreenKuboEstimate>;

    /// The transverse-current viscosity estimate, when the case asks for it.
    fn transverse_current(&self) -> Option<crate::transverse_current::TransverseCurrentEstimate>;

    /// A hash of the complete owned state, the same for any decomposition (collective).
    fn state_digest(&self) -> String;

    /// The models' counted warnings (summed over the ranks), the non-zero ones. Collective.
    fn counted_warnings(&self) -> Vec<String>;

    /// Dumbbells in the whole system, or None without ensembles. Collective.
    fn dumbbell_count(&self) -> Option<u64>;

    /// The bytes the variable-length fields hold per particle that carries any. Collective.
    fn ensemble_bytes_per_particle(&self) -> Option<f64>;

    /// The values of the snapshot quantity `name` of the owned particles.
    fn snapshot_values(&self, name: &str) -> Option<Vec<f64>>;

    /// Owned particles with the list-build positions: everything a checkpoint holds (the
    /// ensembles moved out; hand them back with [`Simulation::return_checkpoint_particles`]).
    fn lend_checkpoint_particles(&mut self) -> Particles<D>;
}

/// `impl Engine<'c, D> for Simulation<'c, D>` for one literal `D`: every method calls the
/// inherent (generic, `pub(crate)`) method of the same name, which inherent-first method
/// resolution picks here.
macro_rules! engine_for_dimension {
    ($d:literal) => {
        impl<'c> Engine<'c, $d> for Simulation<'c, $d> {
            fn new(case: &Case, comm: &'c dyn Comm, threads: usize) -> Result<Self, Error> {
                Simulation::<$d>::new(case, comm, threads)
            }

            fn from_checkpoint(
                case: &Case,
                comm: &'c dyn Comm,
                threads: usize,
                particles: Particles<$d>,
                total: u64,
                step: u64,
                rebuild_step: u64,
                series: Series,
                species: Option<Vec<Species>>,
                bodies: Option<&str>,
            ) -> Result<Self, Error> {
                Simulation::<$d>::from_checkpoint(
                    case,
                    comm,
                    threads,
                    particles,
                    total,
                    step,
                    rebuild_step,
                    series,
                    species,
                    bodies,
                )
            }

            #[cfg(feature = "hdf5")]
            fn read_checkpoint(
                path: &Path,
                comm: &dyn Comm,
            ) -> Result<
                crate::output::checkpoint::Restored<$d>,
                crate::output::checkpoint::CheckpointError,
            > {
                crate::output::checkpoint::read::<$d>(path, comm)
            }

            #[cfg(feature = "hdf5")]
            fn write_checkpoint(&mut self, dir: &Path, keep: usize) -> Result<PathBuf, String> {
                crate::output::checkpoint::write(self, dir, keep)
            }

            fn attach(&mut self, model: Box<dyn ParticleModel<$d>>) -> Result<(), Error> {
                Simulation::<$d>::attach(self, model)
            }

            fn set_species(
                &mut self,
                table: Vec<Species>,
                assign: &dyn Fn(u64, &[f64; $d]) -> u8,
            ) -> Result<(), Error> {
                Simulation::<$d>::set_species(self, table, assign)
            }

            fn advance(&mut self) -> Result<(), Error> {
                Simulation::<$d>::advance(self)
            }

            fn run_steps(&mut self, steps: u64) -> Result<Duration, Error> {
                Simulation::<$d>::run_steps(self, steps)
            }

            fn drive(
                self,
                case_file: &Path,
                restarted_from: Option<&Path>,
                comm: &dyn Comm,
                options: &RunOptions,
                threads: usize,
            ) -> Result<Summary, Error> {
                crate::scene::drive(
                    crate::scene::ParticleScene::new(self),
                    case_file,
                    restarted_from,
                    comm,
                    options,
                    threads,
                )
            }

            fn jump_to_step(&mut self, step: u64) -> Result<(), Error> {
                Simulation::<$d>::jump_to_step(self, step)
            }

            fn recompute_forces(&mut self, want_virial: bool) -> Result<(), Error> {
                Simulation::<$d>::recompute_forces(self, want_virial)
            }

            fn measure(&mut self) -> Measurement {
                Simulation::<$d>::measure(self)
            }

            fn sample(&mut self) -> Result<(), Error> {
                Simulation::<$d>::sample(self)
            }

            fn sample_values(&mut self) -> Result<Vec<(String, f64)>, Error> {
                Simulation::<$d>::sample_values(self)
            }

            fn record(&mut self) -> Vec<(String, f64)> {
                Simulation::<$d>::record(self)
            }

            fn correlate(&mut self) {
                Simulation::<$d>::correlate(self)
            }

            fn sample_currents(&mut self) {
                Simulation::<$d>::sample_currents(self)
            }

            fn green_kubo(&self) -> Option<crate::green_kubo::GreenKuboEstimate> {
                Simulation::<$d>::green_kubo(self)
            }

            fn transverse_current(
                &self,
            ) -> Option<crate::transverse_current::TransverseCurrentEstimate> {
                Simulation::<$d>::transverse_current(self)
            }

            fn state_digest(&self) -> String {
                Simulation::<$d>::state_digest(self)
            }

            fn counted_warnings(&self) -> Vec<String> {
                Simulation::<$d>::counted_warnings(self)
            }

            fn dumbbell_count(&self) -> Option<u64> {
                Simulation::<$d>::dumbbell_count(self)
            }

            fn ensemble_bytes_per_particle(&self) -> Option<f64> {
                Simulation::<$d>::ensemble_bytes_per_particle(self)
            }

            fn snapshot_values(&self, name: &str) -> Option<Vec<f64>> {
                Simulation::<$d>::snapshot_values(self, name)
            }

            fn lend_checkpoint_particles(&mut self) -> Particles<$d> {
                Simulation::<$d>::lend_checkpoint_particles(self)
            }
        }
    };
}

engine_for_dimension!(2);
engine_for_dimension!(3);

/// One rank's [`HomogeneousEnsembles`] of dimension `D`, through methods compiled once in this
/// crate (the module documentation says why). Each method is the inherent method of the same
/// name.
pub trait Ensembles<'c, const D: usize>: Sized {
    /// `spec.total` particles × `spec.n_d` dumbbells at equilibrium; this rank keeps its id
    /// block.
    fn new(comm: &'c dyn Comm, spec: EnsembleSpec) -> Result<Self, String>;

    /// Ensembles restored from a checkpoint at `step` (this rank's id block).
    fn from_state(
        comm: &'c dyn Comm,
        spec: EnsembleSpec,
        step: u64,
        q: Connectors,
        control: Option<Vec<Vec<f64>>>,
    ) -> Result<Self, String>;

    /// BDDFS: histograms on `grid` instead of connectors.
    fn new_with_histograms(
        comm: &'c dyn Comm,
        spec: EnsembleSpec,
        grid: QGrid,
    ) -> Result<Self, String>;

    /// Stores the connectors in single precision from now on (before the first step).
    fn with_single_precision(self) -> Self;

    /// Switches on the control-variate variance reduction (before the first step).
    fn with_control_variates(self) -> Self;

    /// Bytes of connector storage on this rank.
    fn memory_bytes(&self) -> usize;

    /// Advances every ensemble by one step.
    fn advance(&mut self) -> Result<(), Error>;

    /// τ/G of each of this rank's particles (its ensemble's Kramers average).
    fn particle_stresses(&self) -> Vec<[f64; 9]>;

    /// ⟨|Q|²⟩ of each of this rank's particles.
    fn particle_mean_square_lengths(&self) -> Vec<f64>;

    /// BDDFS: the occupied cells of each of this rank's particles (None without histograms).
    fn particle_occupied_cells(&self) -> Option<Vec<f64>>;

    /// The mean over all particles of a per-particle value, with its standard error
    /// (collective).
    fn particle_mean(&self, per: &[f64]) -> (f64, f64);

    /// τ/G averaged over all particles, with standard errors (collective).
    fn stress(&self) -> StressEstimate<D>;

    /// [`Ensembles::stress`] of given [`Ensembles::particle_stresses`] (collective).
    fn stress_of(&self, per: &[[f64; 9]]) -> StressEstimate<D>;

    /// Largest |Q|² of any dumbbell (collective).
    fn max_q2(&self) -> f64;

    /// Bytes of connector storage per particle over every rank (collective).
    fn memory_bytes_per_particle(&self) -> f64;

    /// A digest of every connector vector (collective, order-independent).
    fn digest(&self) -> u64;
}

/// `impl Ensembles<'c, D> for HomogeneousEnsembles<'c, D>` for one literal `D`, forwarding
/// like [`engine_for_dimension`].
macro_rules! ensembles_for_dimension {
    ($d:literal) => {
        impl<'c> Ensembles<'c, $d> for HomogeneousEnsembles<'c, $d> {
            fn new(comm: &'c dyn Comm, spec: EnsembleSpec) -> Result<Self, String> {
                HomogeneousEnsembles::<$d>::new(comm, spec)
            }

            fn from_state(
                comm: &'c dyn Comm,
                spec: EnsembleSpec,
                step: u64,
                q: Connectors,
                control: Option<Vec<Vec<f64>>>,
            ) -> Result<Self, String> {
                HomogeneousEnsembles::<$d>::from_state(comm, spec, step, q, control)
            }

            fn new_with_histograms(
                comm: &'c dyn Comm,
                spec: EnsembleSpec,
                grid: QGrid,
            ) -> Result<Self, String> {
                HomogeneousEnsembles::<$d>::new_with_histograms(comm, spec, grid)
            }

            fn with_single_precision(self) -> Self {
                HomogeneousEnsembles::<$d>::with_single_precision(self)
            }

            fn with_control_variates(self) -> Self {
                HomogeneousEnsembles::<$d>::with_control_variates(self)
            }

            fn memory_bytes(&self) -> usize {
                HomogeneousEnsembles::<$d>::memory_bytes(self)
            }

            fn advance(&mut self) -> Result<(), Error> {
                HomogeneousEnsembles::<$d>::advance(self)
            }

            fn particle_stresses(&self) -> Vec<[f64; 9]> {
                HomogeneousEnsembles::<$d>::particle_stresses(self)
            }

            fn particle_mean_square_lengths(&self) -> Vec<f64> {
                HomogeneousEnsembles::<$d>::particle_mean_square_lengths(self)
            }

            fn particle_occupied_cells(&self) -> Option<Vec<f64>> {
                HomogeneousEnsembles::<$d>::particle_occupied_cells(self)
            }

            fn particle_mean(&self, per: &[f64]) -> (f64, f64) {
                HomogeneousEnsembles::<$d>::particle_mean(self, per)
            }

            fn stress(&self) -> StressEstimate<$d> {
                HomogeneousEnsembles::<$d>::stress(self)
            }

            fn stress_of(&self, per: &[[f64; 9]]) -> StressEstimate<$d> {
                HomogeneousEnsembles::<$d>::stress_of(self, per)
            }

            fn max_q2(&self) -> f64 {
                HomogeneousEnsembles::<$d>::max_q2(self)
            }

            fn memory_bytes_per_particle(&self) -> f64 {
                HomogeneousEnsembles::<$d>::memory_bytes_per_particle(self)
            }

            fn digest(&self) -> u64 {
                HomogeneousEnsembles::<$d>::digest(self)
            }
        }
    };
}

ensembles_for_dimension!(2);
ensembles_for_dimension!(3);
