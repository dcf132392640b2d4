//! The step loop of one rank: initial state, the step, sampling and the state digest.
//!
//! One step (the same for every model; the models and the integrator are components chosen by
//! the case, [`build_fluid`] and [`build_integrator`]):
//!
//! ```text
//! integrator.before_forces        positions to t + Δt, velocities the new forces see
//! walls reflect; step += 1; every model's update_state (its per-particle state)
//! rebuild (migration, halo, lists) if 2 max|Δx| + |Δs| > skin, else refresh the ghosts
//! forces := 0; for each model, for each pass: refresh the ghost fields it names, run it
//! integrator.after_forces         complete the velocities
//! ```
//!
//! Neighbour lists are rebuilt, and particles migrated, when 2 max|Δx| + |Δs| exceeds the skin
//! (Δs: Lees–Edwards offset drift since the last build); otherwise only the ghosts' positions
//! and velocities are refreshed.

use crate::comm::{Comm, U64Op};
use crate::config::{Case, IntegratorCfg, Lattice, Observable, VelocityProfile};
use crate::diagnostics::{SHEAR_STRESS_PROFILE_PREFIX, Series};
use crate::domain::{HaloPlan, Slab, send_leavers, wrap_owned};
use crate::error::{Error, Quantity, Unstable};
use crate::fixed_sum::FixedSum;
use crate::geometry::{GRADIENT, SimBox};
use crate::integrators::{
    GrootWarren, IntegratedField, Integrator, KickDriftKick, TwoStage, TwoStageVariant,
};
use crate::models::gather::FullList;
use crate::models::interface::{
    FieldKind, MeasureContext, ParticleModel, PassContext, StateBlowUp,
};
use crate::models::pair_loop::{Virial, VirialScope};
use crate::neighbour::{NeighbourList, spatial_order};
use crate::particles::Particles;
use crate::rigid_bodies::RigidBodies;
use crate::rng::{Purpose, StreamKey};
use crate::simd::Isa;
use crate::species::{Motion, Species};
pub use crate::workers::{hash_words, worker_pool};
use std::time::{Duration, Instant};

impl PhaseTimes {
    /// Every number in a fixed order (the phases, the rebuild count, then the passes'
    /// seconds): what a reduction over the ranks combines. Every rank runs the same passes in
    /// the same order, so the vectors line up.
    pub fn to_numbers(&self) -> Vec<f64> {
        let mut v = vec![
            self.integrate,
            self.particle_state,
            self.neighbour,
            self.rebuild_comm,
            self.halo,
            self.forces,
            self.pass_wait,
            self.diagnostics,
            self.snapshots,
            self.checkpoints,
            self.rebuilds as f64,
        ];
        v.extend(self.passes.iter().map(|p| p.seconds));
        v
    }

    /// These times with the numbers of [`Self::to_numbers`] put back (reduced over ranks).
    pub fn with_numbers(&self, v: &[f64]) -> Self {
        let mut t = self.clone();
        let &[a, b, c, d, e, f, g, h, i, j, k] = &v[..11] else {
            unreachable!("11 phase numbers")
        };
        (
            t.integrate,
            t.particle_state,
            t.neighbour,
            t.rebuild_comm,
            t.halo,
        ) = (a, b, c, d, e);
        (
            t.forces,
            t.pass_wait,
            t.diagnostics,
            t.snapshots,
            t.checkpoints,
        ) = (f, g, h, i, j);
        t.rebuilds = k as u64;
        for (p, &x) in t.passes.iter_mut().zip(&v[11..]) {
            p.seconds = x;
        }
        t
    }
}

/// Wall time spent per phase of the step (this rank).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PhaseTimes {
    /// Integration (both half steps).
    pub integrate: f64,
    /// The models' per-particle state updates (the dumbbell ensembles of a CONNFFESSIT fluid).
    pub particle_state: f64,
    /// Neighbour-list builds.
    pub neighbour: f64,
    /// Migration and halo build at rebuilds.
    pub rebuild_comm: f64,
    /// Ghost refresh between rebuilds.
    pub halo: f64,
    /// Pair evaluation and gather (each pass's own work).
    pub forces: f64,
    /// Waits at the collective check after each pass: the lag behind the slowest rank (load
    /// imbalance and jitter), not work.
    pub pass_wait: f64,
    /// Sampling of observables.
    pub diagnostics: f64,
    /// Snapshot frames (collective writes, incl. the id-order redistribution).
    pub snapshots: f64,
    /// Checkpoints (collective writes, incl. the id-order redistribution).
    pub checkpoints: f64,
    /// Number of neighbour-list builds.
    pub rebuilds: u64,
    /// `forces` split by model pass, in evaluation order (each pass's own work, its ghost
    /// refresh and the wait for the slowest rank's pass excluded).
    pub passes: Vec<PassSeconds>,
}

/// Wall time of one model pass summed over the run (this rank).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct PassSeconds {
    /// The model.
    pub model: &'static str,
    /// The pass's name.
    pub pass: &'static str,
    /// Seconds.
    pub seconds: f64,
}

/// A running simulation on one rank.
pub struct Simulation<'c, const D: usize> {
    /// The case.
    pub case: Case,
    comm: &'c dyn Comm,
    /// Box.
    pub sim_box: SimBox<D>,
    slab: Slab,
    /// Particles of this rank.
    pub particles: Particles<D>,
    halo: HaloPlan,
    /// Neighbour lists.
    pub list: NeighbourList<D>,
    /// Every owned particle's neighbours, for models that gather (else empty).
    full: FullList,
    /// The models, in evaluation order (the fluid first).
    models: Vec<Box<dyn ParticleModel<D>>>,
    /// For every model and pass: the indices of the fields its ghosts need refreshed first.
    pass_fields: Vec<Vec<Vec<usize>>>,
    /// Names of the models' passes (for errors).
    pass_names: Vec<Vec<&'static str>>,
    /// The time integrator.
    integrator: Box<dyn Integrator<D>>,
    /// The fields the models ask the integrator to advance.
    integrated: Vec<IntegratedField>,
    /// The field the particles drift with besides their velocity (XSPH), if a model has one.
    drift_correction: Option<usize>,
    /// The species (one, the fluid, unless [`Self::set_species`] gave more).
    species: Vec<Species>,
    /// The largest interaction range of the models.
    cutoff: f64,
    /// Whether a model gathers over the full list.
    wants_full_list: bool,
    /// Whether this run continues from a checkpoint (models then find their state fields).
    restarted: bool,
    /// Virial of the last force evaluation that computed one, and its step.
    virial: Option<(u64, Virial)>,
    /// The pair part of the binned shear virial of that evaluation, when asked for.
    shear_virial_profile: Option<(u64, Vec<FixedSum>)>,
    /// The virial components the case's observables need.
    virial_scope: VirialScope,
    /// Current step.
    pub step: u64,
    dt: f64,
    skin: f64,
    /// Total particle count.
    pub total_particles: u64,
    /// Sampled time series.
    pub series: Series,
    /// Phase timers.
    pub times: PhaseTimes,
    /// This rank's worker threads.
    pool: rayon::ThreadPool,
    /// This rank was asked to stop (a signal); shared with the others in the next step.
    stop_requested_here: bool,
    /// The blow-up this rank's models found in their particles' own state at this step (the
    /// model's index and the particle), reduced with the displacement.
    state_blow_up: Option<(usize, StateBlowUp)>,
    /// Some rank asked to stop during the last step (the same on every rank).
    stop_agreed: bool,
    /// Rigid bodies of spring-tied constituents, when the fluid suspends any (the same table
    /// on every rank; [`crate::rigid_bodies`]).
    bodies: Option<RigidBodies<D>>,
}

use crate::error::UNSTABLE;

mod factory;
mod initial;
mod measure;

pub use factory::{build_companions, build_fluid, build_integrator};
pub use initial::initial_particles;
pub use measure::Measurement;
use measure::*;

/// Name of the extra field that carries the neighbour-list build positions in checkpoints.
pub const LIST_REFERENCE_FIELD: &str = "list_reference_position";

// The heavy methods are `pub(crate)`: other crates call them through `facade::Engine`, compiled
// once in this crate for D = 2 and 3 (see there why); the light accessors stay public.
impl<'c, const D: usize> Simulation<'c, D> {
    /// Sets up the initial state on this rank and computes the initial forces.
    /// `threads` rayon workers serve this rank (0: all available cores).
    pub(crate) fn new(case: &Case, comm: &'c dyn Comm, threads: usize) -> Result<Self, Error> {
        let (sim_box, slab) = Self::geometry(case, comm)?;
        let mut bodies = case
            .fluid
            .builder::<D>()
            .rigid_bodies(case)
            .map_err(Error::InvalidCase)?;
        let (particles, total) = initial_particles(case, &sim_box, &slab, bodies.as_mut());
        let mut sim = Self::assemble(case, comm, threads, sim_box, slab, particles, total, false)?;
        sim.bodies = bodies;
        sim.attach(build_fluid::<D>(case))?;
        if let Some(layout) = case.fluid.builder::<D>().species_layout(case) {
            sim.set_species(layout.table, |_, x| (layout.species_at)(x))?;
        } else {
            sim.rebuild()?;
            sim.compute_forces(sim.virial_scope)?;
        }
        let companions = build_companions::<D>(case)?;
        if !companions.is_empty() {
            for model in companions {
                sim.attach(model)?;
            }
            // The initial forces with the companions' initial state (the ensembles' stress).
            sim.compute_forces(sim.virial_scope)?;
        }
        Ok(sim)
    }

    /// Continues from a checkpointed state: `particles` are any share of the saved particles
    /// (their forces and half-step velocities included) carrying the list-build positions in
    /// the extra field [`LIST_REFERENCE_FIELD`]; `rebuild_step` is the step of the last
    /// neighbour-list build.
    ///
    /// Bitwise continuation: between list builds, positions are not wrapped into the box, so
    /// the state depends on when lists were built. The restart therefore rebuilds *as of*
    /// `rebuild_step` — migration, halo and pair list from the saved build positions and the
    /// Lees–Edwards offset of that step — and then puts the current positions back and refreshes
    /// the ghosts. The next rebuild then happens at the same step, with the same wrap, as in the
    /// uninterrupted run; forces are not recomputed (the saved ones are those of the step).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_checkpoint(
        case: &Case,
        comm: &'c dyn Comm,
        threads: usize,
        mut particles: Particles<D>,
        total: u64,
        step: u64,
        rebuild_step: u64,
        series: Series,
        species: Option<Vec<Species>>,
        bodies: Option<&str>,
    ) -> Result<Self, Error> {
        let (sim_box, slab) = Self::geometry(case, comm)?;
        let mut built = case
            .fluid
            .builder::<D>()
            .rigid_bodies(case)
            .map_err(Error::InvalidCase)?;
        match (&mut built, bodies) {
            (Some(b), Some(text)) => b.restore_json(text)?,
            (None, None) => {}
            (Some(_), None) => {
                return Err("the case suspends rigid bodies but the checkpoint has none".into());
            }
            (None, Some(_)) => {
                return Err("the checkpoint holds rigid bodies the case does not have".into());
            }
        }
        let field = particles
            .extra_index(LIST_REFERENCE_FIELD)
            .ok_or_else(|| format!("the checkpoint lacks the field {LIST_REFERENCE_FIELD}"))?;
        if particles.extra[field].width != D {
            return Err(
                format!("the checkpoint's {LIST_REFERENCE_FIELD} field is malformed").into(),
            );
        }
        // Positions ↔ build positions: the rebuild below sees the build-time configuration.
        let n = particles.n_owned;
        for i in 0..n {
            let r = &mut particles.extra[field].data[i * D..(i + 1) * D];
            for d in 0..D {
                std::mem::swap(&mut particles.pos[i][d], &mut r[d]);
            }
        }
        let particles = crate::domain::redistribute(&particles, comm, |i| {
            slab.owner_of(particles.pos[i][slab.axis])
        });
        let mut sim = Self::assemble(case, comm, threads, sim_box, slab, particles, total, true)?;
        sim.bodies = built;
        // The species table first: the rebuild below must not reflect boundary particles.
        if let Some(table) = species {
            if sim.particles.species.is_none() {
                return Err("the checkpoint has a species table but no particle species".into());
            }
            sim.integrator = build_integrator::<D>(case, &table);
            sim.species = table;
        }
        sim.step = rebuild_step;
        sim.rebuild()?;
        let p = &mut sim.particles;
        let field = p.extra_index(LIST_REFERENCE_FIELD).expect("checked above");
        let mut current = p.extra.remove(field);
        for i in 0..p.n_owned {
            p.pos[i].copy_from_slice(&current.data[i * D..(i + 1) * D]);
        }
        current.data.clear();
        // The models register their fields now, after the list-build positions have left:
        // the indices they keep stay valid.
        sim.attach(build_fluid::<D>(case))?;
        for model in build_companions::<D>(case)? {
            sim.attach(model)?;
        }
        // The list was built at the build positions, not at the current ones.
        sim.list.at_build_positions = false;
        sim.step = step;
        sim.halo.forward(
            &mut sim.particles,
            &sim.sim_box,
            &sim.slab,
            comm,
            step,
            sim.dt,
        );
        sim.series = series;
        // A checkpoint without correlators (written before the observable was asked for):
        // the Green–Kubo estimate uses the blocks after the restart.
        if sim.series.green_kubo.is_empty() {
            sim.series.green_kubo = fresh_green_kubo(&sim.case);
        }
        if sim.series.transverse_current.is_empty() {
            sim.series.transverse_current = fresh_transverse_current(&sim.case);
        }
        Ok(sim)
    }

    fn geometry(case: &Case, comm: &dyn Comm) -> Result<(SimBox<D>, Slab), Error> {
        if case.dimension != D {
            return Err(Error::InvalidCase(format!(
                "the case is {}-dimensional, this run is {D}-dimensional",
                case.dimension
            )));
        }
        let mut lengths = [0.0; D];
        lengths.copy_from_slice(&case.domain.lengths);
        let mut boundaries = [crate::geometry::Boundary::Periodic; D];
        boundaries.copy_from_slice(&case.boundaries());
        let sim_box = SimBox {
            lengths,
            boundaries,
            shear_rate: case.domain.shear_rate,
        };
        let axis = case.decomposition.axis.index();
        let slab = Slab {
            axis,
            length: lengths[axis],
            rank: comm.rank(),
            size: comm.size(),
            periodic: boundaries[axis] == crate::geometry::Boundary::Periodic,
        };
        let range = case.cutoff() + case.neighbour.skin;
        if comm.size() > 1 && slab.width() < range {
            let max_ranks = (lengths[axis] / range).floor().max(1.0) as usize;
            return Err(Error::DoesNotFit(format!(
                "{} ranks give slabs {:.4} wide along {}, thinner than cutoff + skin = {range}; \
                 use at most {max_ranks} ranks for this case (or decompose along another axis)",
                comm.size(),
                slab.width(),
                ["x", "y", "z"][axis]
            )));
        }
        crate::capacity::check_particles_per_rank(case, comm.size()).map_err(Error::DoesNotFit)?;
        crate::capacity::check_rank_memory(case, comm.size(), crate::capacity::available_memory())
            .map_err(Error::DoesNotFit)?;
        Ok((sim_box, slab))
    }

    #[allow(clippy::too_many_arguments)]
    fn assemble(
        case: &Case,
        comm: &'c dyn Comm,
        threads: usize,
        sim_box: SimBox<D>,
        slab: Slab,
        particles: Particles<D>,
        total: u64,
        restarted: bool,
    ) -> Result<Self, Error> {
        let integrator = build_integrator::<D>(case, &[]);
        let pool = worker_pool(comm, threads)?;
        let mut sim = Simulation {
            case: case.clone(),
            comm,
            sim_box,
            slab,
            particles,
            halo: HaloPlan::default(),
            list: NeighbourList::default(),
            full: FullList::default(),
            models: Vec::new(),
            pass_fields: Vec::new(),
            pass_names: Vec::new(),
            dt: integrator.dt(),
            integrator,
            integrated: Vec::new(),
            drift_correction: None,
            species: vec![Species::fluid(case.particles.mass)],
            cutoff: 0.0,
            wants_full_list: false,
            restarted,
            virial: None,
            shear_virial_profile: None,
            virial_scope: virial_scope(&case.diagnostics.observables),
            step: 0,
            skin: case.neighbour.skin,
            total_particles: total,
            series: Series {
                green_kubo: fresh_green_kubo(case),
                transverse_current: fresh_transverse_current(case),
                ..Series::default()
            },
            times: PhaseTimes::default(),
            pool,
            stop_requested_here: false,
            state_blow_up: None,
            stop_agreed: false,
            bodies: None,
        };
        // The range the first list build needs; the attached models confirm or widen it.
        sim.cutoff = case.cutoff();
        Ok(sim)
    }

    /// Attaches a model: registers its fields (on a restart, checks that the checkpoint brought
    /// the checkpointed ones), lets it initialise them, and resolves the ghost fields of its
    /// passes. A model attached after the set-up computed the forces joins from the next step.
    pub(crate) fn attach(&mut self, mut model: Box<dyn ParticleModel<D>>) -> Result<(), Error> {
        let p = &mut self.particles;
        for spec in model.fields() {
            let name = spec.name;
            if self.restarted && spec.flags.checkpointed {
                let present = match spec.kind {
                    FieldKind::Ensemble(_) => p.var.iter().any(|f| f.name == name),
                    _ => p.extra_index(name).is_some(),
                };
                if !present {
                    return Err(format!(
                        "the checkpoint lacks the field `{name}` of the model {}",
                        model.name()
                    )
                    .into());
                }
            }
            match spec.kind {
                FieldKind::Ensemble(storage) => match p.var.iter().find(|f| f.name == name) {
                    None => {
                        p.register_var_in(name, storage);
                    }
                    Some(f) if f.data.storage() != storage => {
                        return Err(format!(
                            "the field `{name}` of the model {} is stored as {:?}, {storage:?} \
                             declared",
                            model.name(),
                            f.data.storage()
                        )
                        .into());
                    }
                    Some(_) => {}
                },
                kind => {
                    let width = kind.width(D);
                    if spec.flags.velocity_like && width != D {
                        return Err(format!(
                            "the velocity-like field `{name}` of the model {} must be a vector",
                            model.name()
                        )
                        .into());
                    }
                    p.register_field(name, width, spec.flags)?;
                }
            }
        }
        model.attach(p, self.restarted)?;
        let passes = model.passes();
        let mut fields = Vec::with_capacity(passes.len());
        for pass in &passes {
            let mut indices = Vec::new();
            for name in &pass.ghost_fields {
                indices.push(p.extra_index(name).ok_or_else(|| {
                    format!(
                        "pass `{}` of the model {} needs the ghost field `{name}`, which no \
                         model registers",
                        pass.name,
                        model.name()
                    )
                })?);
            }
            fields.push(indices);
        }
        self.pass_fields.push(fields);
        self.pass_names
            .push(passes.iter().map(|p| p.name).collect());
        for spec in model.integrated_fields() {
            let (state, rate) = (spec.state, spec.rate);
            let index = |name: &str| {
                p.extra_index(name).ok_or_else(|| {
                    format!(
                        "the model {} integrates the unregistered field `{name}`",
                        model.name()
                    )
                })
            };
            let (state, rate) = (index(state)?, index(rate)?);
            if p.extra[state].width != p.extra[rate].width {
                return Err(format!(
                    "the model {} integrates fields of unequal widths",
                    model.name()
                )
                .into());
            }
            self.integrated.push(IntegratedField {
                state,
                rate,
                boundary_particles: spec.boundary_particles,
            });
        }
        self.integrator.bind(p, &self.integrated);
        if let Some(name) = model.drift_correction() {
            let field = p.extra_index(name).ok_or_else(|| {
                format!(
                    "the model {} drifts with the unregistered field `{name}`",
                    model.name()
                )
            })?;
            self.drift_correction = Some(field);
            self.integrator.bind_drift_correction(field)?;
        }
        self.cutoff = self.cutoff.max(model.cutoff());
        self.wants_full_list |= model.uses_full_list();
        if self.wants_full_list && self.full.rows() != self.particles.n_owned {
            // Attached after the list was built (a restart, a late model): its rows now.
            self.full = FullList::from_half(&self.list, self.particles.n_owned);
        }
        self.models.push(model);
        Ok(())
    }

    /// Gives the particles species (walls, inclusions: boundary particles that are frozen or
    /// move at a prescribed velocity; [`crate::species`]): `table` lists them, `assign` gives
    /// each particle's index into it from its id and initial position. Call it on a fresh run
    /// before the first step (a restart brings the species back from its checkpoint). Rebuilds
    /// the halo, so the ghosts carry their species, and recomputes the forces. Collective.
    pub(crate) fn set_species(
        &mut self,
        table: Vec<Species>,
        assign: impl Fn(u64, &[f64; D]) -> u8,
    ) -> Result<(), Error> {
        let bad_table = if table.is_empty() || table.len() > 256 {
            Some(format!("{} species; 1 to 256 are supported", table.len()))
        } else {
            table
                .iter()
                .find(|s| !(s.mass.is_finite() && s.mass > 0.0))
                .map(|s| format!("species {}: mass {} must be > 0", s.name, s.mass))
        };
        if let Some(e) = bad_table {
            return Err(Error::InvalidCase(e));
        }
        let p = &mut self.particles;
        p.clear_ghosts();
        let given: Vec<u8> = (0..p.n_owned)
            .map(|i| assign(p.gid[i], &p.pos[i]))
            .collect();
        let beyond = given.iter().position(|&s| s as usize >= table.len());
        let mut failed = [if beyond.is_some() { 1.0 } else { 0.0 }];
        self.comm.allreduce_max(&mut failed);
        if let Some(i) = beyond {
            return Err(format!(
                "particle {} was given species {}, but the table has {}",
                p.gid[i],
                given[i],
                table.len()
            )
            .into());
        }
        if failed[0] > 0.0 {
            return Err("another rank gave a particle a species beyond the table".into());
        }
        p.assign_species(|i| given[i]);
        // Boundary particles start with their own motion, not the fluid's Maxwellian.
        for i in 0..p.n_owned {
            let v = match table[given[i] as usize].motion {
                Motion::Free => continue,
                Motion::Frozen => [0.0; D],
                Motion::Prescribed(u) => std::array::from_fn(|d| u[d]),
            };
            p.vel[i] = v;
            p.vel_half[i] = v;
        }
        self.integrator = build_integrator::<D>(&self.case, &table);
        self.integrator.bind(&mut self.particles, &self.integrated);
        if let Some(field) = self.drift_correction {
            self.integrator.bind_drift_correction(field)?;
        }
        self.species = table;
        self.rebuild()?;
        self.compute_forces(self.virial_scope)
    }

    /// The species table.
    pub fn species(&self) -> &[Species] {
        &self.species
    }

    /// The values of the snapshot quantity `name` of the owned particles (in the rank's order),
    /// from the first model that gives it
    /// ([`crate::models::interface::ParticleModel::snapshot_values`]).
    pub(crate) fn snapshot_values(&self, name: &str) -> Option<Vec<f64>> {
        self.models
            .iter()
            .find_map(|m| m.snapshot_values(name, &self.particles))
    }

    /// Owned particles (no ghosts) with the list-build positions as the extra field
    /// [`LIST_REFERENCE_FIELD`]: everything a checkpoint must hold. Fields derived anew every
    /// step ([`crate::particles::FieldFlags::checkpointed`] unset) are left out. The
    /// variable-length fields (dumbbell ensembles, the largest state) are *moved* out, not
    /// copied, so a checkpoint never doubles them in memory: hand the particles back with
    /// [`Self::return_checkpoint_particles`] before the next step.
    pub(crate) fn lend_checkpoint_particles(&mut self) -> Particles<D> {
        let src = &mut self.particles;
        let n = src.n_owned;
        let mut p = src.owned_core();
        for f in src.extra.iter().filter(|f| f.flags.checkpointed) {
            p.extra.push(crate::particles::ExtraField {
                data: f.data[..n * f.width].to_vec(),
                name: f.name.clone(),
                ..*f
            });
        }
        p.var = std::mem::take(&mut src.var);
        let k = p.register_extra(LIST_REFERENCE_FIELD, D);
        for (i, x) in self.list.build_pos.iter().enumerate() {
            p.extra[k].data[i * D..(i + 1) * D].copy_from_slice(x);
        }
        p
    }

    /// Takes back the variable-length fields lent by [`Self::lend_checkpoint_particles`].
    pub fn return_checkpoint_particles(&mut self, lent: Particles<D>) {
        self.particles.var = lent.var;
    }

    /// Marks that this rank was asked to stop; [`Self::stop_agreed`] tells every rank after the
    /// next step (no extra collective: it travels with the step's displacement reduction).
    pub fn request_stop(&mut self) {
        self.stop_requested_here = true;
    }

    /// Whether any rank asked to stop before the last step (collectively agreed).
    pub fn stop_agreed(&self) -> bool {
        self.stop_agreed
    }

    /// Step of the last neighbour-list build.
    pub fn rebuild_step(&self) -> u64 {
        self.halo.step_at_build()
    }

    /// Time step.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    fn range(&self) -> f64 {
        self.cutoff + self.skin
    }

    /// Jumps to `step` (as a restart would) and rebuilds halo and lists there; used by tests
    /// that need a non-zero Lees–Edwards offset.
    pub(crate) fn jump_to_step(&mut self, step: u64) -> Result<(), Error> {
        self.step = step;
        self.rebuild()?;
        self.compute_forces(VirialScope::Off)?;
        Ok(())
    }

    /// Migrates, rebuilds the halo and the neighbour lists.
    fn rebuild(&mut self) -> Result<(), Error> {
        let t0 = Instant::now();
        let offset = self.sim_box.le_offset(self.step, self.dt);
        let range = self.range();
        let (particles, sim_box, slab) = (&mut self.particles, &self.sim_box, &self.slab);
        // Boundary particles live beyond the wall faces: never reflected there.
        let reflected: Vec<bool> = self.species.iter().map(Species::is_fluid).collect();
        let owners = self
            .pool
            .install(|| wrap_owned(particles, sim_box, slab, offset, &reflected));
        send_leavers(&mut self.particles, &self.slab, self.comm, &owners)?;
        // Spatial order for cache locality (results do not depend on the order).
        let order = self
            .pool
            .install(|| spatial_order(&self.particles.pos, 0.5 * range));
        let particles = &mut self.particles;
        self.pool.install(|| particles.permute_owned(&order));
        self.halo = HaloPlan::build(
            &mut self.particles,
            &self.sim_box,
            &self.slab,
            self.comm,
            range,
            self.step,
            self.dt,
            &self.pool,
        );
        let t1 = Instant::now();
        let particles = &self.particles;
        let cutoff = self.cutoff;
        self.list = self
            .pool
            .install(|| NeighbourList::build(particles, range, cutoff));
        if self.wants_full_list {
            self.full = FullList::from_half(&self.list, self.particles.n_owned);
        }
        // One record per rebuild (every step in DPD shear): trace only; the step loop logs a
        // count per progress interval at debug.
        tracing::trace!(
            owned = self.particles.n_owned,
            ghosts = self.particles.len() - self.particles.n_owned,
            pairs = self.list.len(),
            ms = t1.elapsed().as_secs_f64() * 1e3,
            "neighbour list rebuilt at step {}",
            self.step
        );
        self.times.rebuild_comm += (t1 - t0).as_secs_f64();
        self.times.neighbour += t1.elapsed().as_secs_f64();
        self.times.rebuilds += 1;
        Ok(())
    }

    /// Evaluates the forces (and the virial when asked) again at the current step, leaving the
    /// state as it was: what the pair-force benchmark times.
    pub(crate) fn recompute_forces(&mut self, want_virial: bool) -> Result<(), Error> {
        let scope = if want_virial {
            VirialScope::Full
        } else {
            VirialScope::Off
        };
        self.compute_forces(scope)
    }

    /// Forces (and the virial when asked) at the current step: every model's passes in order,
    /// each after the ghost fields it names are refreshed. Collective: a pass that fails on
    /// any rank (a blown-up pair) stops every rank after that pass, with the same error there.
    fn compute_forces(&mut self, virial_scope: VirialScope) -> Result<(), Error> {
        let t0 = Instant::now();
        let mut halo_seconds = 0.0;
        let mut wait_seconds = 0.0;
        self.particles.force.fill([0.0; D]);
        let mut virial = None;
        let mut shear_profile = None;
        for (m, model) in self.models.iter_mut().enumerate() {
            for (k, fields) in self.pass_fields[m].iter().enumerate() {
                let t = Instant::now();
                let (sim_box, slab) = (&self.sim_box, &self.slab);
                self.halo
                    .refresh_fields(&mut self.particles, fields, sim_box, slab, self.comm);
                halo_seconds += t.elapsed().as_secs_f64();
                let ctx = PassContext {
                    particles: &mut self.particles,
                    list: &self.list,
                    full: &self.full,
                    step: self.step,
                    virial: virial_scope,
                    isa: Isa::current(),
                };
                let pass_start = Instant::now();
                let result = self.pool.install(|| model.pass(k, ctx));
                let seconds = pass_start.elapsed().as_secs_f64();
                let wait_start = Instant::now();
                let mut failed = [if result.is_err() { 1.0 } else { 0.0 }];
                self.comm.allreduce_max(&mut failed);
                wait_seconds += wait_start.elapsed().as_secs_f64();
                let name = self.pass_names[m][k];
                match self
                    .times
                    .passes
                    .iter_mut()
                    .find(|p| p.pass == name && p.model == model.name())
                {
                    Some(entry) => entry.seconds += seconds,
                    None => self.times.passes.push(PassSeconds {
                        model: model.name(),
                        pass: name,
                        seconds,
                    }),
                }
                match result {
                    Ok(out) => {
                        virial = out.virial.or(virial);
                        shear_profile = out.shear_virial_profile.or(shear_profile);
                    }
                    Err(e) => return Err(e),
                }
                if failed[0] > 0.0 {
                    return Err(Unstable::new(
                        Quantity::PairForce,
                        None,
                        self.step,
                        format!(
                            "the pass `{}` of the model {} failed on another rank at step {} \
                             (a pair term not finite or out of range): {UNSTABLE} (time step \
                             too large?)",
                            self.pass_names[m][k],
                            model.name(),
                            self.step
                        ),
                    )
                    .into());
                }
            }
        }
        if let Some(bodies) = &mut self.bodies {
            let t = Instant::now();
            bodies.couple(&mut self.particles, &self.sim_box, self.step, self.comm)?;
            let seconds = t.elapsed().as_secs_f64();
            match self
                .times
                .passes
                .iter_mut()
                .find(|p| p.pass == "rigid bodies")
            {
                Some(entry) => entry.seconds += seconds,
                None => self.times.passes.push(PassSeconds {
                    model: "engine",
                    pass: "rigid bodies",
                    seconds,
                }),
            }
        }
        if let Some(v) = virial {
            self.virial = Some((self.step, v));
        }
        if let Some(p) = shear_profile {
            self.shear_virial_profile = Some((self.step, p));
        }
        self.times.halo += halo_seconds;
        self.times.pass_wait += wait_seconds;
        self.times.forces += t0.elapsed().as_secs_f64() - halo_seconds - wait_seconds;
        Ok(())
    }

    /// Virial of the current forces (recomputed if the last evaluation did not keep it).
    fn current_virial(&mut self) -> Virial {
        let zero = || std::array::from_fn(|_| vec![FixedSum::ZERO; D * D]);
        if self.virial_scope == VirialScope::Off {
            return zero();
        }
        if let Some((step, v)) = &self.virial
            && *step == self.step
        {
            return v.clone();
        }
        // The forces and every per-particle field the passes write (densities, gradients, the
        // rates the next step integrates), restored after: the recomputation sees the current
        // velocities, which a velocity-dependent rate (an SPH polymer stress) must not keep.
        let saved = (self.particles.force.clone(), self.particles.extra.clone());
        // The same forces were computed successfully by the step itself.
        let _ = self.compute_forces(self.virial_scope);
        (self.particles.force, self.particles.extra) = saved;
        self.virial.as_ref().map_or_else(zero, |(_, v)| v.clone())
    }

    /// Advances one time step: each of the integrator's stages moves the particles, brings
    /// lists and ghosts up to date and evaluates the forces (the first stage also advances the
    /// step counter and the models' per-particle state).
    pub(crate) fn advance(&mut self) -> Result<(), Error> {
        let stages = self.integrator.stages();
        for stage in 0..stages {
            self.advance_stage(stage, stage + 1 == stages)?;
        }
        Ok(())
    }

    fn advance_stage(&mut self, stage: usize, last: bool) -> Result<(), Error> {
        let t0 = Instant::now();
        let dt = self.dt;
        // The positions move: the list's marks of the pairs within the cutoff no longer hold.
        self.list.at_build_positions = false;
        {
            let (integrator, p) = (&self.integrator, &mut self.particles);
            self.pool.install(|| integrator.before_forces(p, stage));
        }
        self.reflect_at_walls();
        self.times.integrate += t0.elapsed().as_secs_f64();
        if stage == 0 {
            let t = Instant::now();
            self.step += 1;
            let (models, p, step) = (&self.models, &mut self.particles, self.step);
            self.state_blow_up = self.pool.install(|| {
                let mut first: Option<(usize, StateBlowUp)> = None;
                for (m, model) in models.iter().enumerate() {
                    if let Some(b) = model.update_state(p, step)
                        && first.is_none_or(|(_, f)| (b.gid, b.item) < (f.gid, f.item))
                    {
                        first = Some((m, b));
                    }
                }
                first
            });
            self.times.particle_state += t.elapsed().as_secs_f64();
        }

        let t1 = Instant::now();
        let (list, particles) = (&self.list, &self.particles);
        // One reduction per stage carries the displacement, the largest peculiar kinetic
        // energy and any rank's stop request.
        let (largest, culprit) = self.pool.install(|| list.largest_displacement(particles));
        let (fluid, species, sim_box) = (&self.case.fluid, &self.species, &self.sim_box);
        let (hottest, hot_culprit) = self
            .pool
            .install(|| largest_kinetic_energy_in_kt(fluid, particles, species, sim_box));
        let mut moved = [
            largest,
            if self.stop_requested_here { 1.0 } else { 0.0 },
            hottest,
            // The lowest id of a particle whose own state blew up, negated for the maximum.
            self.state_blow_up
                .map_or(f64::NEG_INFINITY, |(_, b)| -(b.gid as f64)),
        ];
        self.comm.allreduce_max(&mut moved);
        self.stop_agreed = moved[1] > 0.0;
        if moved[3] > f64::NEG_INFINITY {
            let gid = -moved[3];
            // The rank holding it tells the model and the numbers; the others learn them here.
            let mut detail = match self.state_blow_up {
                Some((m, b)) if b.gid as f64 == gid => [m as f64, b.item as f64, b.value],
                _ => [f64::NEG_INFINITY; 3],
            };
            self.comm.allreduce_max(&mut detail);
            let blow_up = StateBlowUp {
                gid: gid as u64,
                item: detail[1] as u64,
                value: detail[2],
            };
            let model = &self.models[detail[0] as usize];
            return Err(Unstable::new(
                model.state_quantity(),
                Some(blow_up.gid),
                self.step,
                format!(
                    "{}, at step {}: {UNSTABLE}; reduce the time step",
                    model.describe_state_blow_up(&blow_up),
                    self.step
                ),
            )
            .into());
        }
        if moved[0] > self.range() {
            // Decided on the globally reduced value, so every rank count stops alike; the rank
            // holding the particle names it (the largest id among ties).
            let mut id = [if largest == moved[0] && culprit < self.particles.n_owned {
                self.particles.gid[culprit] as f64
            } else {
                -1.0
            }];
            self.comm.allreduce_max(&mut id);
            let what = if moved[0].is_finite() {
                format!(
                    "moved {:.3} (more than cutoff + skin = {:.3}) since the neighbour list was \
                     built at step {}",
                    moved[0],
                    self.range(),
                    self.halo.step_at_build()
                )
            } else {
                "has a position that is not finite (NaN or infinite)".to_string()
            };
            return Err(Unstable::new(
                Quantity::Displacement,
                Some(id[0] as u64),
                self.step,
                format!(
                    "particle {} {what}, at step {}: {UNSTABLE}; reduce the time step",
                    id[0] as u64, self.step
                ),
            )
            .into());
        }
        // After the displacement check, which names a particle thrown out of the lists
        // more specifically.
        let bound = self
            .case
            .fluid
            .model()
            .runaway_bound_in_kt(D, self.total_particles as f64 / self.sim_box.volume());
        if moved[2] > bound {
            let mut id = [
                if hottest == moved[2] && hot_culprit < self.particles.n_owned {
                    self.particles.gid[hot_culprit] as f64
                } else {
                    -1.0
                },
            ];
            self.comm.allreduce_max(&mut id);
            return Err(Unstable::new(
                Quantity::KineticEnergy,
                Some(id[0] as u64),
                self.step,
                format!(
                    "particle {} has a peculiar kinetic energy ½m|v − u|² = {:.3e} k_BT (a \
                     runaway: beyond {bound:.4} k_BT, which a thermalised particle never \
                     reaches), at step {}: {UNSTABLE}; reduce the time step (or start the \
                     particles nearer k_BT)",
                    id[0] as u64, moved[2], self.step
                ),
            )
            .into());
        }
        let drift = if self.sim_box.sheared() {
            self.sim_box.le_velocity_jump() * dt * (self.step - self.halo.step_at_build()) as f64
        } else {
            0.0
        };
        if 2.0 * moved[0] + drift.abs() > self.skin {
            self.times.halo += t1.elapsed().as_secs_f64();
            self.rebuild()?;
        } else {
            self.halo.forward(
                &mut self.particles,
                &self.sim_box,
                &self.slab,
                self.comm,
                self.step,
                dt,
            );
            self.times.halo += t1.elapsed().as_secs_f64();
        }
        // A recorded step (every sample_every steps, equilibration included) keeps its virial
        // too, so recording it does not evaluate the forces again; the virial only adds up
        // the pair terms the step computes anyway.
        let scope = if last && (self.is_record_step() || self.is_correlation_step()) {
            self.virial_scope
        } else {
            VirialScope::Off
        };
        self.compute_forces(scope)?;

        let t2 = Instant::now();
        let (integrator, p) = (&self.integrator, &mut self.particles);
        self.pool.install(|| integrator.after_forces(p, stage));
        self.times.integrate += t2.elapsed().as_secs_f64();
        Ok(())
    }

    /// Specular reflection of owned particles at wall faces, every step (a reflected particle is
    /// never farther from its list-build position than it was, so the lists stay valid).
    fn reflect_at_walls(&mut self) {
        let walls: Vec<usize> = (0..D)
            .filter(|&a| self.sim_box.boundaries[a] == crate::geometry::Boundary::Wall)
            .collect();
        if walls.is_empty() {
            return;
        }
        let n = self.particles.n_owned;
        let p = &mut self.particles;
        for i in 0..n {
            if !self.species[p.species_of(i) as usize].is_fluid() {
                continue;
            }
            for &a in &walls {
                let l = self.sim_box.lengths[a];
                let x = &mut p.pos[i][a];
                if *x < 0.0 || *x >= l {
                    *x = if *x < 0.0 { -*x } else { 2.0 * l - *x };
                    *x = x.clamp(0.0, l.next_down());
                    p.vel[i][a] = -p.vel[i][a];
                    p.vel_half[i][a] = -p.vel_half[i][a];
                }
            }
        }
    }

    /// This rank's load now: owned particles, ghosts, listed pairs.
    pub fn load(&self) -> [f64; 3] {
        let owned = self.particles.n_owned;
        let ghosts = self.particles.len() - owned;
        [owned as f64, ghosts as f64, self.list.len() as f64]
    }

    /// A hash of the complete owned state — id, position, velocity, force, image counts and
    /// every registered field of every particle — combined over particles with an
    /// order-independent wrapping sum and xor, so it is the same for any decomposition
    /// (collective).
    pub(crate) fn state_digest(&self) -> String {
        let p = &self.particles;
        let mut acc = [0u64, 0u64];
        for i in 0..p.n_owned {
            let mut words: Vec<u64> = vec![p.gid[i]];
            words.extend(p.pos[i].iter().map(|x| x.to_bits()));
            words.extend(p.vel[i].iter().map(|x| x.to_bits()));
            words.extend(p.force[i].iter().map(|x| x.to_bits()));
            words.extend(p.image[i].iter().map(|&k| k as u32 as u64));
            if p.species.is_some() {
                words.push(u64::from(p.species_of(i)));
            }
            for f in p.extra.iter().filter(|f| f.flags.digested) {
                words.extend(
                    f.data[i * f.width..(i + 1) * f.width]
                        .iter()
                        .map(|x| x.to_bits()),
                );
            }
            for f in &p.var {
                words.push(f.data.row_len(i) as u64);
                f.data.extend_bits(i, &mut words);
            }
            let h = hash_words(&words);
            acc[0] = acc[0].wrapping_add(h);
            acc[1] ^= h.rotate_left(17).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
        // The body table is the same on every rank: rank 0 adds it once.
        if let Some(bodies) = &self.bodies
            && self.comm.rank() == 0
        {
            let h = hash_words(&bodies.words());
            acc[0] = acc[0].wrapping_add(h);
            acc[1] ^= h.rotate_left(17).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
        let mut sum = [acc[0]];
        let mut xor = [acc[1]];
        self.comm.allreduce_u64(&mut sum, U64Op::Sum);
        self.comm.allreduce_u64(&mut xor, U64Op::Xor);
        format!("{:016x}{:016x}", sum[0], xor[0])
    }

    /// The models' counted warnings (summed over the ranks), the non-zero ones. Collective.
    pub(crate) fn counted_warnings(&self) -> Vec<String> {
        let mut counts = Vec::new();
        let mut texts = Vec::new();
        for model in &self.models {
            for (n, text) in model.counted_warnings() {
                counts.push(n);
                texts.push(text);
            }
        }
        if counts.is_empty() {
            return Vec::new(); // the same models on every rank: all return here
        }
        self.comm.allreduce_u64(&mut counts, U64Op::Sum);
        counts
            .iter()
            .zip(texts)
            .filter(|(n, _)| **n > 0)
            .map(|(n, text)| text.replace("{n}", &n.to_string()))
            .collect()
    }

    /// Dumbbells in the whole system (the rows of the `connectors` ensemble field over every
    /// rank, / D; or the counts of the BDDFS `histograms`), or None without ensembles.
    /// Collective.
    pub(crate) fn dumbbell_count(&self) -> Option<u64> {
        use crate::models::dumbbell_ensemble::{CONNECTORS, HISTOGRAMS};
        let p = &self.particles;
        let f = p
            .var
            .iter()
            .find(|f| f.name == CONNECTORS || f.name == HISTOGRAMS)?;
        let mine = match f.data.words() {
            Some(rows) => (rows.iter())
                .map(Vec::as_slice)
                .map(crate::models::bddfs::dumbbell_count)
                .sum(),
            None => ((0..p.n_owned).map(|i| f.data.row_len(i)).sum::<usize>() / D) as u64,
        };
        let mut total = [mine];
        self.comm.allreduce_u64(&mut total, U64Op::Sum);
        Some(total[0])
    }

    /// The bytes the variable-length fields (dumbbell connectors, BDDFS histograms) hold per
    /// particle that carries any, over every rank (8 per f64 or word, 4 per f32), or None
    /// without such fields. Collective.
    pub(crate) fn ensemble_bytes_per_particle(&self) -> Option<f64> {
        use crate::particles::VarStorage;
        let p = &self.particles;
        let first = p.var.first()?;
        let bytes: usize = (p.var.iter())
            .map(|f| {
                let word = match f.data.storage() {
                    VarStorage::Single => 4,
                    VarStorage::Double | VarStorage::Words => 8,
                };
                word * (0..p.n_owned).map(|i| f.data.row_len(i)).sum::<usize>()
            })
            .sum();
        let carriers = (0..p.n_owned)
            .filter(|&i| first.data.row_len(i) > 0)
            .count();
        let mut total = [bytes as u64, carriers as u64];
        self.comm.allreduce_u64(&mut total, U64Op::Sum);
        Some(total[0] as f64 / total[1].max(1) as f64)
    }

    /// Runs `steps` steps, sampling on schedule.
    pub(crate) fn run_steps(&mut self, steps: u64) -> Result<Duration, Error> {
        let start = Instant::now();
        for _ in 0..steps {
            self.advance()?;
            if self.is_sample_step() {
                self.sample()?;
            }
        }
        Ok(start.elapsed())
    }

    /// The rigid bodies, when the case suspends any.
    pub fn rigid_bodies(&self) -> Option<&RigidBodies<D>> {
        self.bodies.as_ref()
    }

    /// Simulated time.
    pub fn time(&self) -> f64 {
        self.step as f64 * self.dt
    }

    /// The communicator.
    pub fn comm(&self) -> &dyn Comm {
        self.comm
    }
}

/// Empty transverse-current correlators (blocks × modes) for a case that asks for that
/// viscosity, none otherwise.
fn fresh_transverse_current(case: &Case) -> Vec<crate::correlator::MultipleTauCorrelator> {
    if !case.wants(crate::config::Observable::TransverseCurrentViscosity) {
        return Vec::new();
    }
    let d = &case.diagnostics;
    crate::transverse_current::block_correlators(
        d.blocks,
        d.transverse_current_modes,
        d.transverse_current_time,
        d.transverse_current_every as f64 * case.integrator.dt(),
        case.dimension,
    )
}

/// Empty Green–Kubo correlators for a case that asks for the viscosity that way (one per block),
/// none otherwise.
fn fresh_green_kubo(case: &Case) -> Vec<crate::correlator::MultipleTauCorrelator> {
    if !case.wants(crate::config::Observable::GreenKuboViscosity) {
        return Vec::new();
    }
    crate::green_kubo::block_correlators(
        case.diagnostics.blocks,
        case.diagnostics.green_kubo_time,
        case.integrator.dt(),
        case.dimension,
    )
}

/// The largest peculiar kinetic energy ½ m |v − u_LE(y)|² / k_BT of an owned fluid particle
/// of a DPD fluid, and its index (ties to the lower index, so the answer does not depend on
/// the threads); (0, MAX) for other fluids, which have no k_BT. A velocity that is not
/// finite counts as infinite.
fn largest_kinetic_energy_in_kt<const D: usize>(
    fluid: &crate::config::FluidCfg,
    p: &Particles<D>,
    species: &[Species],
    sim_box: &SimBox<D>,
) -> (f64, usize) {
    use rayon::prelude::*;
    let Some(kt) = fluid.model().thermal_energy() else {
        return (0.0, usize::MAX);
    };
    p.vel[..p.n_owned]
        .par_iter()
        .enumerate()
        .with_min_len(4096)
        .map(|(i, v)| {
            let s = &species[p.species_of(i) as usize];
            if !s.is_fluid() {
                return (0.0, i);
            }
            let mut u = *v;
            u[0] -= sim_box.streaming_velocity(p.pos[i][crate::geometry::GRADIENT]);
            let e = 0.5 * s.mass * u.iter().map(|c| c * c).sum::<f64>() / kt;
            (if e.is_nan() { f64::INFINITY } else { e }, i)
        })
        .reduce(
            || (0.0, usize::MAX),
            crate::neighbour::larger_then_lower_index,
        )
}
