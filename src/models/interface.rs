//! The model interface: what a particle model declares, and what the engine does with it.
//!
//! # Adding a model
//!
//! A fluid model is one directory in `src/models/` and one line of the registry
//! ([`crate::config::registry`]); its parameter struct says everything about the model to the
//! generic layers ([`crate::models::fluid_model::FluidModel`]) and builds the particle models it
//! runs ([`crate::models::fluid_model::BuildModels`]). Each particle model implements
//! [`ParticleModel`]:
//!
//! 1. **Fields** ([`ParticleModel::fields`]): every per-particle quantity it keeps, each with its
//!    kind ([`FieldKind`]: scalar, D-vector, D×D tensor, or a fixed number of values) and its
//!    [`FieldFlags`]: whether it migrates, is checkpointed, enters the state digest, and
//!    whether it transforms like a velocity (then, and only then, its ghost copies get the
//!    Lees–Edwards velocity shift). State (a stress tensor) is [`FieldFlags::STATE`]; a
//!    quantity derived anew every step (a summation density, a velocity gradient) is
//!    [`FieldFlags::DERIVED`]. The engine registers them ([`crate::particles::Particles`]);
//!    on a restart it checks that the checkpoint brought the checkpointed ones.
//! 2. **Passes** ([`ParticleModel::passes`]): the pair passes of one force evaluation, in
//!    order, each naming the fields its ghosts must hold up to date before it runs. Between
//!    passes the engine refreshes exactly those ghost fields
//!    ([`crate::domain::HaloPlan::refresh_fields`]); physics never sees a rank.
//! 3. **The pass itself** ([`ParticleModel::pass`]): usually a [`GatherKernel`] — the
//!    contribution of neighbour j to particle i, and of i to itself — handed to
//!    [`gather`](super::gather::gather), which sums it over the full neighbour list of every
//!    owned particle on the rank's threads, exactly, under the [`Scale`] the kernel states for
//!    each accumulated quantity (a term out of range stops the run with an error naming the
//!    pair; nothing wraps), and returns the sums; the model's finish writes them into its
//!    fields or adds them to the forces. A model with a faster specialised loop (DPD's
//!    vectorised half-list scatter, [`super::pair_loop`]) runs that instead.
//! 4. **State update** ([`ParticleModel::update_state`]): per owned particle, after the
//!    integrator has moved it (a stress ODE, a conformation vector, a dumbbell ensemble), on
//!    the rank's worker threads.
//!
//! The engine zeroes the forces before the first pass of a step; every model *adds* its forces
//! (0 + x = x bitwise, so a single model's forces are exactly its sums).
//!
//! [`Scale`]: crate::fixed_sum::Scale

use super::pair_loop::{Virial, VirialScope};
use crate::error::Error;
use crate::fixed_sum::FixedSum;
use crate::neighbour::NeighbourList;
use crate::observable::Observable;
use crate::particles::{FieldFlags, Particles, VarStorage};
use crate::simd::Isa;
use crate::species::Species;

pub use super::gather::{FullList, GatherKernel, PairError};

/// The shape of a per-particle field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldKind {
    /// One number.
    Scalar,
    /// D numbers (a velocity-like field must be one).
    Vector,
    /// D × D numbers, row-major (a velocity gradient κ_αβ = ∂v_α/∂x_β, a stress).
    Tensor,
    /// A fixed number of values (an MSPH moment matrix, a packed symmetric tensor).
    Values(usize),
    /// A variable-length array per owned particle (a dumbbell ensemble, a BDDFS histogram),
    /// in the given storage; never sent to ghosts, always migrated, checkpointed and digested.
    Ensemble(VarStorage),
}

impl FieldKind {
    /// Numbers per particle in `dimension` dimensions.
    pub fn width(self, dimension: usize) -> usize {
        match self {
            FieldKind::Scalar => 1,
            FieldKind::Vector => dimension,
            FieldKind::Tensor => dimension * dimension,
            FieldKind::Values(n) => n,
            FieldKind::Ensemble(_) => 0,
        }
    }
}

/// A per-particle field a model declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FieldSpec {
    /// Name (unique in the scene; appears in checkpoints).
    pub name: &'static str,
    /// Shape.
    pub kind: FieldKind,
    /// Migration, checkpoint, digest and Lees–Edwards treatment.
    pub flags: FieldFlags,
}

/// The shape of a per-particle quantity a model offers to the snapshots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SnapshotShape {
    /// One number per particle.
    Scalar,
    /// A symmetric D × D tensor, its upper triangle packed row by row (2D: xx, xy, yy; 3D: xx,
    /// xy, xz, yy, yz, zz, XDMF's `Tensor6` order).
    SymmetricTensor,
}

impl SnapshotShape {
    /// Numbers per particle in `dimension` dimensions.
    pub fn width(self, dimension: usize) -> usize {
        match self {
            SnapshotShape::Scalar => 1,
            SnapshotShape::SymmetricTensor => dimension * (dimension + 1) / 2,
        }
    }
}

/// A per-particle quantity a fluid model offers to the snapshots (`output.snapshot_fields`):
/// declared by the fluid model for a case
/// ([`crate::models::fluid_model::FluidModel::snapshot_quantities`]), its values given by one of
/// the particle models the case runs ([`ParticleModel::snapshot_values`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SnapshotQuantity {
    /// Its `output.snapshot_fields` name, which is also its H5MD element.
    pub name: &'static str,
    /// Its shape.
    pub shape: SnapshotShape,
}

/// A pair pass a model declares.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PassSpec {
    /// Name (for errors and logs).
    pub name: &'static str,
    /// Fields whose ghost copies must be refreshed before the pass runs.
    pub ghost_fields: Vec<&'static str>,
}

/// What a pass sees: the rank's particles (owned first, then ghosts), the half neighbour list
/// (pairs within cutoff + skin, i owned), the full list of every owned particle's neighbours
/// when the model asked for it, the step, and the virial the diagnostics want.
pub struct PassContext<'a, const D: usize> {
    /// Owned particles and ghosts, with every registered field.
    pub particles: &'a mut Particles<D>,
    /// Half list: every pair within cutoff + skin with at least one owned end, once.
    pub list: &'a NeighbourList<D>,
    /// Full list of every owned particle's neighbours (empty unless
    /// [`ParticleModel::uses_full_list`]).
    pub full: &'a FullList,
    /// The step whose forces are evaluated.
    pub step: u64,
    /// Which virial components the diagnostics need from this evaluation.
    pub virial: VirialScope,
    /// Instruction set for the vectorised loops.
    pub isa: Isa,
}

/// What a pass returns to the engine.
#[derive(Debug, Default)]
pub struct PassOutput {
    /// The pair virial, when the pass computed one.
    pub virial: Option<Virial>,
    /// The pair part of the binned shear virial ([`crate::models::stress_profile`]), when the model
    /// was asked for it and the pass computed the full virial.
    pub shear_virial_profile: Option<Vec<crate::fixed_sum::FixedSum>>,
}

/// A field the integrator advances ([`ParticleModel::integrated_fields`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Integrated {
    /// The state s.
    pub state: &'static str,
    /// Its rate ṡ, written by the model's passes.
    pub rate: &'static str,
    /// Whether boundary particles (frozen or prescribed species, which are never moved by
    /// the integrator) advance it too: a polymer stress does (walls carry the stress of their
    /// own velocity gradient, as the Newtonian nested summation gives them), a continuity
    /// density does not (walls stay at ρ₀).
    pub boundary_particles: bool,
}

/// A particle model: fields, pair passes and a per-particle state update (module
/// documentation: the guide to adding one).
pub trait ParticleModel<const D: usize>: Send + Sync {
    /// Name (for errors and logs).
    fn name(&self) -> &'static str;

    /// Interaction range of its pair passes (0: none).
    fn cutoff(&self) -> f64 {
        0.0
    }

    /// The per-particle fields it keeps.
    fn fields(&self) -> Vec<FieldSpec> {
        Vec::new()
    }

    /// Its pair passes, in order.
    fn passes(&self) -> Vec<PassSpec> {
        Vec::new()
    }

    /// Whether its passes gather over the full neighbour list ([`FullList`]), which the engine
    /// then builds at every neighbour-list rebuild.
    fn uses_full_list(&self) -> bool {
        false
    }

    /// Called once the fields are registered: on a fresh run (`restarted` false) it sets the
    /// initial values of its state fields (they start at zero); after a restart they hold the
    /// checkpoint's values. Also where it looks up and keeps the indices of its fields.
    fn attach(&mut self, particles: &mut Particles<D>, restarted: bool) -> Result<(), Error> {
        let _ = (particles, restarted);
        Ok(())
    }

    /// Runs pass `pass` (an index into [`Self::passes`]); the ghost fields it named are up to
    /// date. Runs on the rank's worker pool.
    fn pass(&mut self, pass: usize, ctx: PassContext<'_, D>) -> Result<PassOutput, Error> {
        let _ = ctx;
        Err(format!("{} declares no pass {pass}", self.name()).into())
    }

    /// The fields the integrator advances with the particles ([`Integrated`]: state and rate,
    /// scalar or fixed-width fields of equal width): ṡ = rate, integrated by the case's scheme
    /// exactly like the velocity with the acceleration (a continuity density with its dρ/dt, a
    /// stress with its constitutive rate). The model's passes write the rates; the integrator
    /// owns the time stepping.
    fn integrated_fields(&self) -> Vec<Integrated> {
        Vec::new()
    }

    /// A vector field the particles move with in addition to their velocity, ṙ = v + c (the
    /// XSPH correction), written by the model's passes; `None` (the default) for ṙ = v.
    fn drift_correction(&self) -> Option<&'static str> {
        None
    }

    /// Advances the owned particles' own state to `step`, after the integrator has moved them
    /// (once per step). Runs on the rank's worker pool. Returns the owned particle of lowest
    /// global id whose state left its domain (a blow-up), if any, for
    /// [`Self::describe_state_blow_up`].
    fn update_state(&self, particles: &mut Particles<D>, step: u64) -> Option<StateBlowUp> {
        let _ = (particles, step);
        None
    }

    /// What a [`StateBlowUp`] of this model is (its typed error's quantity).
    fn state_quantity(&self) -> crate::error::Quantity {
        crate::error::Quantity::ModelState
    }

    /// The diagnosis of a [`StateBlowUp`] (the same on every rank: built from the reduced
    /// numbers), ending before the step and "the run is unstable".
    fn describe_state_blow_up(&self, blow_up: &StateBlowUp) -> String {
        format!(
            "particle {}'s state {} reached {:.6e}",
            blow_up.gid, blow_up.item, blow_up.value
        )
    }

    /// Whether this model measures `o` itself, from its own fields (an SPH fluid's density
    /// profile, constitutive stress or wall forces). The engine measures what no model claims.
    fn measures(&self, o: Observable) -> bool {
        let _ = o;
        false
    }

    /// This rank's share of observable `o` ([`Self::measures`]) as exact sums over its owned
    /// particles, each normalised; the engine reduces them over the ranks (so the value is
    /// bitwise the same on any decomposition) and hands them to [`Self::observable_values`].
    fn observable_sums(
        &self,
        o: Observable,
        particles: &Particles<D>,
        ctx: &MeasureContext<'_, D>,
    ) -> Vec<FixedSum> {
        let _ = (o, particles, ctx);
        Vec::new()
    }

    /// The named values of observable `o` from its sums reduced over the ranks.
    fn observable_values(
        &self,
        o: Observable,
        sums: &[f64],
        ctx: &MeasureContext<'_, D>,
    ) -> Vec<(String, f64)> {
        let _ = (o, sums, ctx);
        Vec::new()
    }

    /// The values of the snapshot quantity `name` ([`SnapshotQuantity`]) of every owned
    /// particle, in the rank's order, [`SnapshotShape::width`] numbers each; `None` when this
    /// model does not give it (the engine asks the models in order and takes the first answer).
    fn snapshot_values(&self, name: &str, particles: &Particles<D>) -> Option<Vec<f64>> {
        let _ = (name, particles);
        None
    }

    /// Events this rank counted since the process started (a restart counts afresh) that the
    /// summary should warn about, each with the sentence that explains it (`{n}` stands for the count summed over
    /// the ranks); the engine sums the counts and reports the non-zero ones.
    fn counted_warnings(&self) -> Vec<(u64, &'static str)> {
        Vec::new()
    }
}

/// What a model's own observables read besides the particles.
pub struct MeasureContext<'a, const D: usize> {
    /// The species table (which are fluid, their masses), indexed by species.
    pub species: &'a [Species],
    /// The box's edge lengths.
    pub lengths: [f64; D],
    /// The imposed shear rate γ̇ (0 without Lees–Edwards shear).
    pub shear_rate: f64,
    /// `diagnostics.profile_bins`.
    pub profile_bins: usize,
}

impl<const D: usize> MeasureContext<'_, D> {
    /// The box volume (area in 2D).
    pub fn volume(&self) -> f64 {
        self.lengths.iter().product()
    }

    /// Whether owned particle `k` is fluid.
    pub fn is_fluid(&self, p: &Particles<D>, k: usize) -> bool {
        self.species[p.species_of(k) as usize].is_fluid()
    }
}

/// A particle whose own state left its domain in [`ParticleModel::update_state`]: its global
/// id, which item of its state (a dumbbell's index) and the offending value (+∞ when not
/// finite).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StateBlowUp {
    /// Global particle id.
    pub gid: u64,
    /// Index of the item in the particle's state.
    pub item: u64,
    /// The value beyond the domain (+∞ for NaN or infinite).
    pub value: f64,
}
