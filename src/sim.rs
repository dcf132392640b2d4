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
use crate::diagnostics::{DENSITY_PROFILE_PREFIX, SHEAR_STRESS_PROFILE_PREFIX, Series};
use crate::domain::{HaloPlan, Slab, send_leavers, wrap_owned};
use crate::fixed_sum::FixedSum;
use crate::geometry::{GRADIENT, SimBox};
use crate::integrators::{
    GrootWarren, IntegratedField, Integrator, KickDriftKick, TwoStage, TwoStageVariant,
};
use crate::models::gather::FullList;
use crate::models::interface::{FieldKind, ParticleModel, PassContext, StateBlowUp};
use crate::models::pair_loop::{Virial, VirialScope};
use crate::neighbour::{NeighbourList, spatial_order};
use crate::particles::Particles;
use crate::rng::{Purpose, StreamKey};
use crate::simd::Isa;
use crate::species::{Motion, Species};
pub use crate::workers::{hash_words, worker_pool};
use std::time::{Duration, Instant};

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
    /// Pair evaluation and gather.
    pub forces: f64,
    /// Sampling of observables.
    pub diagnostics: f64,
    /// Snapshot frames (collective writes, incl. the id-order redistribution).
    pub snapshots: f64,
    /// Checkpoints (collective writes, incl. the id-order redistribution).
    pub checkpoints: f64,
    /// Number of neighbour-list builds.
    pub rebuilds: u64,
    /// `forces` split by model pass, in evaluation order (each pass's own work, its ghost
    /// refresh excluded; the wait for the slowest rank's pass included).
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
}

pub use crate::error::UNSTABLE;

/// Name of the extra field that carries the neighbour-list build positions in checkpoints.
pub const LIST_REFERENCE_FIELD: &str = "list_reference_position";

/// The fluid model the case names ([`crate::config::registry`]).
pub fn build_fluid<const D: usize>(case: &Case) -> Box<dyn ParticleModel<D>> {
    case.fluid.builder::<D>().build_fluid(case)
}

/// The models a case needs beside its fluid (the dumbbell ensembles of a CONNFFESSIT fluid),
/// attached after the species are known.
pub fn build_companions<const D: usize>(
    case: &Case,
) -> Result<Vec<Box<dyn ParticleModel<D>>>, String> {
    case.fluid.builder::<D>().build_companions(case)
}

/// The integrator the case names, for the species `species` (a one-species scene: `&[]`).
pub fn build_integrator<const D: usize>(
    case: &Case,
    species: &[Species],
) -> Box<dyn Integrator<D>> {
    match &case.integrator {
        IntegratorCfg::GrootWarren(gw) => {
            let integrator = GrootWarren::new(gw, case.particles.mass);
            if species.is_empty() {
                Box::new(integrator)
            } else {
                Box::new(integrator.with_species(species))
            }
        }
        IntegratorCfg::KickDriftKick(k) => {
            Box::new(KickDriftKick::new(k, case.particles.mass, species))
        }
        IntegratorCfg::Heun(t) => Box::new(TwoStage::new(
            t,
            TwoStageVariant::Heun,
            case.particles.mass,
            species,
        )),
        IntegratorCfg::Midpoint(t) => Box::new(TwoStage::new(
            t,
            TwoStageVariant::Midpoint,
            case.particles.mass,
            species,
        )),
        IntegratorCfg::ThesisPredictorCorrector(t) => Box::new(TwoStage::new(
            t,
            TwoStageVariant::ThesisPrinted,
            case.particles.mass,
            species,
        )),
    }
}

/// Where an SPH particle's deviatoric stress lives: the Newtonian (viscous) stress, D×D, and
/// the polymer stress, packed symmetric; either may be absent.
struct ParticleStress {
    viscous: Option<usize>,
    polymer: Option<usize>,
}

impl ParticleStress {
    fn of<const D: usize>(p: &Particles<D>) -> Self {
        Self {
            viscous: p.extra_index(crate::models::sph::VISCOUS_STRESS),
            polymer: p.extra_index(crate::models::sph::POLYMER_STRESS),
        }
    }

    /// σ_ab of particle k, viscous + polymer.
    #[inline]
    fn component<const D: usize>(&self, p: &Particles<D>, k: usize, a: usize, b: usize) -> f64 {
        use crate::models::sph::polymer::{packed_index, packed_width};
        let mut s = self
            .viscous
            .map_or(0.0, |v| p.extra[v].data[k * D * D + a * D + b]);
        if let Some(t) = self.polymer {
            s += p.extra[t].data[k * packed_width(D) + packed_index::<D>(a, b)];
        }
        s
    }
}

impl<'c, const D: usize> Simulation<'c, D> {
    /// Sets up the initial state on this rank and computes the initial forces.
    /// `threads` rayon workers serve this rank (0: all available cores).
    pub fn new(case: &Case, comm: &'c dyn Comm, threads: usize) -> Result<Self, String> {
        let (sim_box, slab) = Self::geometry(case, comm)?;
        let (particles, total) = initial_particles(case, &sim_box, &slab);
        let mut sim = Self::assemble(case, comm, threads, sim_box, slab, particles, total, false)?;
        sim.attach(build_fluid::<D>(case))?;
        if case.walls.is_some() || case.inclusions.is_some() {
            use crate::models::sph::{FLUID, INCLUSION, LOWER_WALL, UPPER_WALL};
            let table = crate::models::sph::boundary_species::<D>(
                case.walls.as_ref(),
                case.inclusions.is_some(),
                case.particles.mass,
            );
            let wall_axis = case.walls.as_ref().map(|w| {
                let axis = w.axis.index();
                (axis, case.domain.lengths[axis])
            });
            let inclusions = case.inclusions.as_ref();
            sim.set_species(table, |_, x| match wall_axis {
                Some((axis, _)) if x[axis] < 0.0 => LOWER_WALL,
                Some((axis, l)) if x[axis] >= l => UPPER_WALL,
                _ if inclusions.is_some_and(|inc| inc.offset(x).is_some()) => INCLUSION,
                _ => FLUID,
            })?;
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
    pub fn from_checkpoint(
        case: &Case,
        comm: &'c dyn Comm,
        threads: usize,
        mut particles: Particles<D>,
        total: u64,
        step: u64,
        rebuild_step: u64,
        series: Series,
        species: Option<Vec<Species>>,
    ) -> Result<Self, String> {
        let (sim_box, slab) = Self::geometry(case, comm)?;
        let field = particles
            .extra_index(LIST_REFERENCE_FIELD)
            .ok_or_else(|| format!("the checkpoint lacks the field {LIST_REFERENCE_FIELD}"))?;
        if particles.extra[field].width != D {
            return Err(format!(
                "the checkpoint's {LIST_REFERENCE_FIELD} field is malformed"
            ));
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

    fn geometry(case: &Case, comm: &dyn Comm) -> Result<(SimBox<D>, Slab), String> {
        if case.dimension != D {
            return Err(format!(
                "the case is {}-dimensional, this run is {D}-dimensional",
                case.dimension
            ));
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
            return Err(format!(
                "{} ranks give slabs {:.4} wide along {}, thinner than cutoff + skin = {range}; \
                 use at most {max_ranks} ranks for this case (or decompose along another axis)",
                comm.size(),
                slab.width(),
                ["x", "y", "z"][axis]
            ));
        }
        crate::capacity::check_particles_per_rank(case, comm.size())?;
        crate::capacity::check_rank_memory(case, comm.size(), crate::capacity::available_memory())?;
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
    ) -> Result<Self, String> {
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
        };
        // The range the first list build needs; the attached models confirm or widen it.
        sim.cutoff = case.cutoff();
        Ok(sim)
    }

    /// Attaches a model: registers its fields (on a restart, checks that the checkpoint brought
    /// the checkpointed ones), lets it initialise them, and resolves the ghost fields of its
    /// passes. A model attached after the set-up computed the forces joins from the next step.
    pub fn attach(&mut self, mut model: Box<dyn ParticleModel<D>>) -> Result<(), String> {
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
                    ));
                }
            }
            match spec.kind {
                FieldKind::Ensemble(precision) => match p.var.iter().find(|f| f.name == name) {
                    None => {
                        p.register_var_in(name, precision);
                    }
                    Some(f) if f.data.precision() != precision => {
                        return Err(format!(
                            "the field `{name}` of the model {} is stored in {:?} precision, \
                             {precision:?} declared",
                            model.name(),
                            f.data.precision()
                        ));
                    }
                    Some(_) => {}
                },
                kind => {
                    let width = kind.width(D);
                    if spec.flags.velocity_like && width != D {
                        return Err(format!(
                            "the velocity-like field `{name}` of the model {} must be a vector",
                            model.name()
                        ));
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
                ));
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
    pub fn set_species(
        &mut self,
        table: Vec<Species>,
        assign: impl Fn(u64, &[f64; D]) -> u8,
    ) -> Result<(), String> {
        let bad_table = if table.is_empty() || table.len() > 256 {
            Some(format!("{} species; 1 to 256 are supported", table.len()))
        } else {
            table
                .iter()
                .find(|s| !(s.mass.is_finite() && s.mass > 0.0))
                .map(|s| format!("species {}: mass {} must be > 0", s.name, s.mass))
        };
        if let Some(e) = bad_table {
            return Err(e);
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
            ));
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

    /// Owned particles (no ghosts) with the list-build positions as the extra field
    /// [`LIST_REFERENCE_FIELD`]: everything a checkpoint must hold. Fields derived anew every
    /// step ([`crate::particles::FieldFlags::checkpointed`] unset) are left out. The
    /// variable-length fields (dumbbell ensembles, the largest state) are *moved* out, not
    /// copied, so a checkpoint never doubles them in memory: hand the particles back with
    /// [`Self::return_checkpoint_particles`] before the next step.
    pub fn lend_checkpoint_particles(&mut self) -> Particles<D> {
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
    pub fn jump_to_step(&mut self, step: u64) -> Result<(), String> {
        self.step = step;
        self.rebuild()?;
        self.compute_forces(VirialScope::Off)?;
        Ok(())
    }

    /// Migrates, rebuilds the halo and the neighbour lists.
    fn rebuild(&mut self) -> Result<(), String> {
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
        self.particles.permute_owned(&order);
        self.halo = HaloPlan::build(
            &mut self.particles,
            &self.sim_box,
            &self.slab,
            self.comm,
            range,
            self.step,
            self.dt,
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
        tracing::debug!(
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
    pub fn recompute_forces(&mut self, want_virial: bool) -> Result<(), String> {
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
    fn compute_forces(&mut self, virial_scope: VirialScope) -> Result<(), String> {
        let t0 = Instant::now();
        let mut halo_seconds = 0.0;
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
                let mut failed = [if result.is_err() { 1.0 } else { 0.0 }];
                self.comm.allreduce_max(&mut failed);
                let name = self.pass_names[m][k];
                let seconds = pass_start.elapsed().as_secs_f64();
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
                    return Err(format!(
                        "the pass `{}` of the model {} failed on another rank at step {} (a \
                         pair term not finite or out of range): {UNSTABLE} (time step \
                         too large?)",
                        self.pass_names[m][k],
                        model.name(),
                        self.step
                    ));
                }
            }
        }
        if let Some(v) = virial {
            self.virial = Some((self.step, v));
        }
        if let Some(p) = shear_profile {
            self.shear_virial_profile = Some((self.step, p));
        }
        self.times.halo += halo_seconds;
        self.times.forces += t0.elapsed().as_secs_f64() - halo_seconds;
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
    pub fn advance(&mut self) -> Result<(), String> {
        let stages = self.integrator.stages();
        for stage in 0..stages {
            self.advance_stage(stage, stage + 1 == stages)?;
        }
        Ok(())
    }

    fn advance_stage(&mut self, stage: usize, last: bool) -> Result<(), String> {
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
            return Err(format!(
                "{}, at step {}: {UNSTABLE}; reduce the time step",
                self.models[detail[0] as usize].describe_state_blow_up(&blow_up),
                self.step
            ));
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
            return Err(format!(
                "particle {} {what}, at step {}: {UNSTABLE}; reduce the time step",
                id[0] as u64, self.step
            ));
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
            return Err(format!(
                "particle {} has a peculiar kinetic energy ½m|v − u|² = {:.3e} k_BT (a \
                 runaway: beyond {bound:.4} k_BT, which a thermalised particle never reaches), \
                 at step {}: {UNSTABLE}; reduce the time step (or start the particles nearer \
                 k_BT)",
                id[0] as u64, moved[2], self.step
            ));
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
        let scope = if last && (self.is_sample_step() || self.is_correlation_step()) {
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

    /// Whether the current step is a sampling step.
    pub fn is_sample_step(&self) -> bool {
        let r = &self.case.run;
        self.step > r.equilibration && self.step.is_multiple_of(r.sample_every)
    }

    /// Whether the current step feeds the Green–Kubo correlators (every step after
    /// equilibration, when asked).
    pub fn is_correlation_step(&self) -> bool {
        !self.series.green_kubo.is_empty() && self.step > self.case.run.equilibration
    }

    /// Feeds the symmetric traceless part of the current pressure tensor (kinetic +
    /// conservative + dissipative + random, the random forces the step used) to the block's
    /// Green–Kubo correlator (collective; exact sums, so the same on every rank).
    pub fn correlate(&mut self) {
        let t0 = Instant::now();
        let virial = self.current_virial();
        let n = self.particles.n_owned;
        let dd = D * D;
        let mut sums = vec![FixedSum::ZERO; 4 * dd];
        let (particles, species) = (&self.particles, &self.species);
        for (k, v) in particles.vel[..n].iter().enumerate() {
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
            let s = &species[particles.species_of(k) as usize];
            if !s.is_fluid() {
                continue;
            }
            for a in 0..D {
                for b in 0..D {
                    sums[a * D + b].add(s.mass * v[a] * v[b]);
                }
            }
        }
        for (k, w) in virial.iter().enumerate() {
            sums[(k + 1) * dd..(k + 2) * dd].copy_from_slice(w);
        }
        FixedSum::allreduce(self.comm, &mut sums);
        let volume = self.sim_box.volume();
        let tensor: Vec<f64> = (0..dd)
            .map(|i| (0..4).map(|k| sums[k * dd + i].value()).sum::<f64>() / volume)
            .collect();
        let channels = crate::green_kubo::traceless_symmetric(&tensor, D);
        let r = &self.case.run;
        let blocks = self.series.green_kubo.len();
        let b = crate::green_kubo::block_of(self.step, r.equilibration, r.steps, blocks);
        self.series.green_kubo[b].add(&channels);
        self.times.diagnostics += t0.elapsed().as_secs_f64();
    }

    /// Whether the current step feeds the transverse-current correlators (every
    /// `diagnostics.transverse_current_every` steps after equilibration, when asked).
    pub fn is_current_step(&self) -> bool {
        !self.series.transverse_current.is_empty()
            && self.step > self.case.run.equilibration
            && (self.step).is_multiple_of(self.case.diagnostics.transverse_current_every)
    }

    /// Feeds the transverse currents J⊥(k_j) of the fluid particles, j = 1 … modes, to the
    /// block's correlators ([`crate::transverse_current`]; collective, exact sums).
    pub fn sample_currents(&mut self) {
        let t0 = Instant::now();
        let modes = self.case.diagnostics.transverse_current_modes;
        let channels = crate::transverse_current::channels(D);
        let mut sums = vec![FixedSum::ZERO; modes * channels];
        let (particles, species) = (&self.particles, &self.species);
        let length = self.sim_box.lengths[0];
        let n = particles.n_owned;
        for (k, (x, v)) in particles.pos[..n]
            .iter()
            .zip(&particles.vel[..n])
            .enumerate()
        {
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
            if species[particles.species_of(k) as usize].is_fluid() {
                crate::transverse_current::add_particle(&mut sums, x, v, length, modes);
            }
        }
        FixedSum::allreduce(self.comm, &mut sums);
        let r = &self.case.run;
        let blocks = self.series.transverse_current.len() / modes;
        let b = crate::green_kubo::block_of(self.step, r.equilibration, r.steps, blocks);
        for mode in 0..modes {
            let x: Vec<f64> = sums[mode * channels..(mode + 1) * channels]
                .iter()
                .map(FixedSum::value)
                .collect();
            self.series.transverse_current[b * modes + mode].add(&x);
        }
        self.times.diagnostics += t0.elapsed().as_secs_f64();
    }

    /// η_k and η₀ from the transverse-current correlators so far; `None` when the case does
    /// not ask for them.
    pub fn transverse_current(
        &self,
    ) -> Option<crate::transverse_current::TransverseCurrentEstimate> {
        let kt = self.case.fluid.model().thermal_energy()?;
        if self.series.transverse_current.is_empty() {
            return None;
        }
        let (count, mass, inverse_mass) = self.fluid_mass_moments();
        let fluid = crate::transverse_current::FluidState {
            particles: count,
            mass_density: mass / self.sim_box.volume(),
            kt_over_mass: kt * inverse_mass / count,
            length: self.sim_box.lengths[0],
        };
        let d = &self.case.diagnostics;
        Some(crate::transverse_current::estimate(
            &self.series.transverse_current,
            d.transverse_current_modes,
            d.transverse_current_every as f64 * self.dt,
            &fluid,
            D,
        ))
    }

    /// (N, Σ m, Σ 1/m) over the fluid particles of every rank (collective, exact).
    fn fluid_mass_moments(&self) -> (f64, f64, f64) {
        let p = &self.particles;
        let mut sums = [FixedSum::ZERO; 3];
        for k in 0..p.n_owned {
            let s = &self.species[p.species_of(k) as usize];
            if s.is_fluid() {
                sums[0].add(1.0);
                sums[1].add(s.mass);
                sums[2].add(1.0 / s.mass);
            }
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
        }
        FixedSum::allreduce(self.comm, &mut sums);
        (sums[0].value(), sums[1].value(), sums[2].value())
    }

    /// The Green–Kubo viscosity of the correlators so far ([`crate::green_kubo::estimate`]);
    /// `None` when the case does not ask for it.
    pub fn green_kubo(&self) -> Option<crate::green_kubo::GreenKuboEstimate> {
        let kt = self.case.fluid.model().thermal_energy()?;
        if self.series.green_kubo.is_empty() {
            return None;
        }
        Some(crate::green_kubo::estimate(
            &self.series.green_kubo,
            self.dt,
            self.sim_box.volume(),
            kt,
            self.case.diagnostics.green_kubo_time,
            D,
        ))
    }

    /// The mean SPH density of the fluid particles in each of `diagnostics.profile_bins` bins
    /// across the box along y (NaN for an empty bin), summed exactly over the ranks
    /// (collective).
    fn density_profile(&self) -> Vec<f64> {
        let bins = self.case.diagnostics.profile_bins;
        let ly = self.sim_box.lengths[GRADIENT];
        let p = &self.particles;
        let mut sums = vec![FixedSum::ZERO; 2 * bins];
        if let Some(rho) = p.extra_index(crate::models::sph::DENSITY) {
            let density = &p.extra[rho].data;
            for k in 0..p.n_owned {
                if !self.species[p.species_of(k) as usize].is_fluid() {
                    continue;
                }
                let y = p.pos[k][GRADIENT];
                let b = profile_bin(y, ly, bins);
                sums[2 * b].add(1.0);
                sums[2 * b + 1].add(density[k]);
                if k % 2048 == 2047 {
                    sums.iter_mut().for_each(FixedSum::normalize);
                }
            }
        }
        sums.iter_mut().for_each(FixedSum::normalize);
        FixedSum::allreduce(self.comm, &mut sums);
        (0..bins)
            .map(|b| sums[2 * b + 1].value() / sums[2 * b].value())
            .collect()
    }

    /// The mean deviatoric stress of the SPH fluid particles, σ̄ = viscous stress (nested
    /// summation) + polymer stress τ, D×D row-major (the thesis's unweighted particle mean,
    /// Eq. 3.18), and the mean |tr τ|; summed exactly over the ranks (collective).
    fn sph_mean_stress(&self) -> (Vec<f64>, f64) {
        use crate::models::sph::POLYMER_STRESS;
        use crate::models::sph::polymer::{packed_index, packed_width};
        let p = &self.particles;
        let dd = D * D;
        let stress = ParticleStress::of(p);
        let polymer = p.extra_index(POLYMER_STRESS);
        let w = packed_width(D);
        // Count, D² stress components, |tr τ|.
        let mut sums = vec![FixedSum::ZERO; dd + 2];
        for k in 0..p.n_owned {
            if !self.species[p.species_of(k) as usize].is_fluid() {
                continue;
            }
            sums[0].add(1.0);
            for a in 0..D {
                for b in 0..D {
                    sums[1 + a * D + b].add(stress.component(p, k, a, b));
                }
            }
            if let Some(t) = polymer {
                let trace: f64 = (0..D)
                    .map(|a| p.extra[t].data[k * w + packed_index::<D>(a, a)])
                    .sum();
                sums[dd + 1].add(trace.abs());
            }
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
        }
        sums.iter_mut().for_each(FixedSum::normalize);
        FixedSum::allreduce(self.comm, &mut sums);
        let n = sums[0].value();
        let mean = (0..dd).map(|c| sums[1 + c].value() / n).collect();
        (mean, sums[dd + 1].value() / n)
    }

    /// The composite shear stress of an SPH suspension, [Σ_fluid (m/ρ_i) σ_i,xy + Σ_inclusion
    /// particles M_j^{xy}] / V with M the traction moments F ⊗ (x − c) (Batchelor 1970: the
    /// cell average of the stress, the inclusions' share from their surface tractions), and
    /// the mean torque per inclusion about z, Σ_j (M_j^{yx} − M_j^{xy}) / N_inclusions
    /// (collective).
    fn composite_stress(&self) -> (f64, f64) {
        use crate::models::sph::{DENSITY, INCLUSION, INCLUSION_TRACTION_MOMENT};
        let p = &self.particles;
        let (Some(density), Some(moment)) = (
            p.extra_index(DENSITY),
            p.extra_index(INCLUSION_TRACTION_MOMENT),
        ) else {
            return (f64::NAN, f64::NAN);
        };
        let dd = D * D;
        let stress = ParticleStress::of(p);
        // Fluid Σ V_i σ_i,xy; inclusions Σ M^{xy}; Σ (M^{yx} − M^{xy}).
        let mut sums = [FixedSum::ZERO; 3];
        for k in 0..p.n_owned {
            let species = p.species_of(k);
            if self.species[species as usize].is_fluid() {
                let s = stress.component(p, k, 0, 1);
                sums[0].add(self.species[species as usize].mass / p.extra[density].data[k] * s);
            } else if species == INCLUSION {
                let m = &p.extra[moment].data[k * dd..(k + 1) * dd];
                sums[1].add(m[1]);
                sums[2].add(m[D] - m[1]);
            }
            if k % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
        }
        sums.iter_mut().for_each(FixedSum::normalize);
        FixedSum::allreduce(self.comm, &mut sums);
        let inclusions = self.case.inclusions.as_ref().map_or(1, |i| i.centres.len()) as f64;
        (
            (sums[0].value() + sums[1].value()) / self.sim_box.volume(),
            sums[2].value() / inclusions,
        )
    }

    /// Samples every observable the case asked for (collective). A thermostatted (DPD) fluid
    /// whose kinetic temperature has passed [`crate::models::FluidModel::heating`] stops the run (the
    /// decision is on an exactly reduced sum, so every rank count stops alike).
    pub fn sample(&mut self) -> Result<(), String> {
        let t0 = Instant::now();
        let values = self.measure();
        self.times.diagnostics += t0.elapsed().as_secs_f64();
        let density = self.total_particles as f64 / self.sim_box.volume();
        if let Some(heating) = self.case.fluid.model().heating(
            values.kinetic_temperature,
            D,
            density,
            self.case.particles.mass,
            self.time(),
        ) {
            return Err(format!(
                "{heating}, at step {}: {UNSTABLE}; reduce the time step",
                self.step
            ));
        }
        for (name, v) in values.scalars {
            self.series.push(&name, v);
        }
        if let Some(profile) = values.profile {
            self.series.profile.push(profile);
        }
        self.series.steps.push(self.step);
        Ok(())
    }

    /// Instantaneous observables (collective).
    pub fn measure(&mut self) -> Measurement {
        let virial = self.current_virial();
        let case = &self.case;
        let sheared = self.sim_box.sheared();
        // Binned along y under shear, and in a walled channel whose profile is asked for (the
        // temperature is then profile-unbiased too).
        let walled_profile = (self
            .sim_box
            .boundaries
            .contains(&crate::geometry::Boundary::Wall)
            || case.body_forced())
            && case.wants(Observable::VelocityProfile);
        let bins = if sheared || walled_profile {
            case.diagnostics.profile_bins
        } else {
            1
        };
        let ly = self.sim_box.lengths[GRADIENT];
        let bin_of = |y: f64| profile_bin(y, ly, bins);
        let n = self.particles.n_owned;
        let (pos, vel) = (&self.particles.pos[..n], &self.particles.vel[..n]);
        // Boundary particles (walls, inclusions) are not fluid: left out of every average.
        let (particles, species) = (&self.particles, &self.species);
        let fluid = |k: usize| species[particles.species_of(k) as usize].is_fluid();
        // Every sum below is accumulated exactly ([`FixedSum`]) and reduced exactly over the
        // ranks, so the observables are bitwise the same for any decomposition, like the state.
        // Pass 1: bin counts and momenta → mean velocity per bin; Σ 1/m per bin (for the
        // degrees of freedom the subtraction removes).
        let mut first = vec![FixedSum::ZERO; bins * (2 + D)];
        for (k, (x, v)) in pos.iter().zip(vel).enumerate() {
            if k % 2048 == 2047 {
                first.iter_mut().for_each(FixedSum::normalize);
            }
            if !fluid(k) {
                continue;
            }
            let b = bin_of(x[GRADIENT]);
            first[b].add(1.0);
            for d in 0..D {
                first[bins + b * D + d].add(v[d]);
            }
            first[bins * (1 + D) + b].add(1.0 / species[particles.species_of(k) as usize].mass);
        }
        FixedSum::allreduce(self.comm, &mut first);
        let first: Vec<f64> = first.iter().map(FixedSum::value).collect();
        let mean: Vec<[f64; D]> = (0..bins)
            .map(|b| {
                let c = first[b].max(1.0);
                let mut u = [0.0; D];
                for d in 0..D {
                    u[d] = first[bins + b * D + d] / c;
                }
                u
            })
            .collect();
        // The local streaming velocity: the bin means interpolated linearly between bin centres
        // (periodically, with the Lees–Edwards jump ±γ̇L_y across the plane), so the profile
        // inside a bin is not counted as thermal motion (a constant bin mean would add
        // ρ m γ̇²Δ²/12 to P_xx and to k_BT).
        let jump = self.sim_box.le_velocity_jump();
        let width = ly / bins as f64;
        // The interpolation weights of the local mean at y: (bin, weight) twice.
        let weights = |y: f64| -> [(usize, f64); 2] {
            if bins == 1 {
                return [(0, 1.0), (0, 0.0)];
            }
            let s = y / width - 0.5;
            let k = s.floor();
            let t = s - k;
            let nb = bins as i64;
            [
                ((k as i64).rem_euclid(nb) as usize, 1.0 - t),
                ((k as i64 + 1).rem_euclid(nb) as usize, t),
            ]
        };
        let local_mean = |y: f64| -> [f64; D] {
            if bins == 1 {
                return mean[0];
            }
            let s = y / width - 0.5; // position in units of bin centres
            let k = s.floor();
            let t = s - k;
            let at = |b: i64| -> [f64; D] {
                let nb = bins as i64;
                let wrapped = b.rem_euclid(nb);
                let mut u = mean[wrapped as usize];
                u[0] += jump * ((b - wrapped) / nb) as f64;
                u
            };
            let (u0, u1) = (at(k as i64), at(k as i64 + 1));
            let mut u = [0.0; D];
            for d in 0..D {
                u[d] = (1.0 - t) * u0[d] + t * u1[d];
            }
            u
        };
        // Pass 2: kinetic tensor, peculiar momentum, virial.
        let dd = D * D;
        // The last slot: the degrees of freedom per dimension the local mean leaves (below).
        let mut second = vec![FixedSum::ZERO; dd + D + 3 * dd + 1];
        let dof_slot = dd + D + 3 * dd;
        for (k, (x, v)) in pos.iter().zip(vel).enumerate() {
            if k % 2048 == 2047 {
                second.iter_mut().for_each(FixedSum::normalize);
            }
            if !fluid(k) {
                continue;
            }
            let m = species[particles.species_of(k) as usize].mass;
            // With V = (I − P)v, P_ij = φ_b(j)(y_i)/n_b(j) (the interpolated bin means), and
            // independent thermal velocities ⟨v_j²⟩ = k_BT/m_j per component:
            // ⟨Σ_i m_i V_i²⟩ = k_BT Σ_i [1 − 2P_ii + m_i Σ_b φ_b(y_i)² Σ_{j∈b} (1/m_j)/n_b²]
            // per dimension — N − B for piecewise-constant means of equal masses, more with
            // the interpolation.
            let own = bin_of(x[GRADIENT]);
            let mut kept = 1.0;
            for (b, phi) in weights(x[GRADIENT]) {
                let count = first[b];
                if count > 0.0 && phi != 0.0 {
                    if b == own {
                        kept -= 2.0 * phi / count;
                    }
                    kept += m * phi * phi * first[bins * (1 + D) + b] / (count * count);
                }
            }
            second[dof_slot].add(kept);
            let u = &local_mean(x[GRADIENT]);
            for a in 0..D {
                let va = v[a] - u[a];
                for b in 0..D {
                    second[a * D + b].add(m * va * (v[b] - u[b]));
                }
            }
            let mut p = *v;
            p[0] -= self.sim_box.streaming_velocity(x[GRADIENT]);
            for d in 0..D {
                second[dd + d].add(m * p[d]);
            }
        }
        for (k, w) in virial.iter().enumerate() {
            second[dd + D + k * dd..dd + D + (k + 1) * dd].copy_from_slice(w);
        }
        FixedSum::allreduce(self.comm, &mut second);
        let second: Vec<f64> = second.iter().map(FixedSum::value).collect();
        let volume = self.sim_box.volume();
        let kinetic = &second[..dd];
        let mut parts: Vec<Vec<f64>> = vec![kinetic.iter().map(|k| k / volume).collect()];
        for k in 0..3 {
            let w = &second[dd + D + k * dd..dd + D + (k + 1) * dd];
            parts.push(w.iter().map(|x| x / volume).collect());
        }
        // The momentum flux: kinetic part plus every model's pair virial (for SPH, the pair
        // forces of the momentum equation: `crate::models::sph::momentum_flux`).
        let total: Vec<f64> = (0..dd).map(|i| parts.iter().map(|p| p[i]).sum()).collect();
        // SPH: the particles' own constitutive stress σ̄ (viscous + polymer), when asked.
        let constitutive = case
            .diagnostics
            .observables
            .iter()
            .any(|o| {
                matches!(
                    o,
                    Observable::ConstitutiveStress | Observable::PolymerStressTrace
                )
            })
            .then(|| self.sph_mean_stress());
        let trace_k: f64 = (0..D).map(|a| kinetic[a * D + a]).sum();
        // k_BT = Σ m V²/(degrees of freedom the local-mean subtraction leaves): unbiased for
        // any bin occupancy (N·D − B·D would overstate k_BT by the interpolation's share,
        // ≈ 10 % at 10 particles per bin).
        let dof = (D as f64) * second[dof_slot];
        let mut out = Measurement {
            kinetic_temperature: trace_k / dof,
            ..Measurement::default()
        };
        let pt = |a: usize, b: usize| total[a * D + b];
        for o in &case.diagnostics.observables {
            match o {
                Observable::Temperature => out.scalars.push(("temperature".into(), trace_k / dof)),
                Observable::Pressure => out.scalars.push((
                    "pressure".into(),
                    (0..D).map(|a| pt(a, a)).sum::<f64>() / D as f64,
                )),
                Observable::Stress => {
                    let all: Vec<&Vec<f64>> = std::iter::once(&total).chain(parts.iter()).collect();
                    let names = crate::config::observables::stress_parts(case);
                    for (part, tensor) in names.iter().zip(all) {
                        for (a, b, c) in crate::config::observables::stress_components(case) {
                            out.scalars
                                .push((format!("stress_{part}_{c}"), tensor[a * D + b]));
                        }
                    }
                }
                Observable::Viscosity => out
                    .scalars
                    .push(("viscosity".into(), -pt(0, 1) / self.sim_box.shear_rate)),
                // Not a sampled series: the correlators are fed every step ([`Self::correlate`]).
                Observable::GreenKuboViscosity | Observable::TransverseCurrentViscosity => {}
                Observable::FirstNormalStressDifference => out
                    .scalars
                    .push(("first_normal_stress_difference".into(), pt(1, 1) - pt(0, 0))),
                Observable::SecondNormalStressDifference => out.scalars.push((
                    "second_normal_stress_difference".into(),
                    pt(2, 2) - pt(1, 1),
                )),
                Observable::Momentum => {
                    for d in 0..D {
                        out.scalars
                            .push((format!("momentum_{}", ["x", "y", "z"][d]), second[dd + d]));
                    }
                }
                Observable::VelocityProfile => {
                    out.profile = Some(mean.iter().map(|u| u[0]).collect());
                }
                Observable::WallShearStress => {
                    let [lower, upper] = self.wall_forces();
                    out.scalars.push(("wall_shear_stress_lower".into(), lower));
                    out.scalars.push(("wall_shear_stress_upper".into(), upper));
                }
                Observable::PolymerStressTrace => {
                    let trace = constitutive.as_ref().map_or(f64::NAN, |c| c.1);
                    out.scalars.push(("polymer_stress_trace".into(), trace));
                }
                Observable::ConstitutiveStress => {
                    // σ̄ = −P: η = σ̄_xy/γ̇, N₁ = σ̄_xx − σ̄_yy, N₂ = σ̄_yy − σ̄_zz.
                    let s = constitutive.as_ref().map_or(&[][..], |c| &c.0[..]);
                    let c = |a: usize, b: usize| s.get(a * D + b).copied().unwrap_or(f64::NAN);
                    let values = [
                        c(0, 1) / self.sim_box.shear_rate,
                        c(0, 0) - c(1, 1),
                        c(1, 1) - c(2, 2),
                    ];
                    let names = crate::config::observables::constitutive_names(D);
                    for (name, v) in names.iter().zip(values) {
                        out.scalars.push(((*name).into(), v));
                    }
                }
                Observable::CompositeViscosity => {
                    let (stress, torque) = self.composite_stress();
                    out.scalars.push((
                        "composite_viscosity".into(),
                        stress / self.sim_box.shear_rate,
                    ));
                    out.scalars.push(("inclusion_torque".into(), torque));
                }
                Observable::ShearStressProfile => {
                    // τ_xy(b) = −[Σ_{i∈b} m V_x V_y + W_xy(b)]/V_b ([`crate::models::stress_profile`]),
                    // V about the local mean velocity of the temperature.
                    let nb = case.diagnostics.profile_bins;
                    let mut sums = match &self.shear_virial_profile {
                        Some((step, w)) if *step == self.step => w.clone(),
                        _ => vec![FixedSum::ZERO; nb],
                    };
                    for (k, (x, v)) in pos.iter().zip(vel).enumerate() {
                        if k % 2048 == 2047 {
                            sums.iter_mut().for_each(FixedSum::normalize);
                        }
                        if !fluid(k) {
                            continue;
                        }
                        let m = species[particles.species_of(k) as usize].mass;
                        let u = local_mean(x[GRADIENT]);
                        sums[profile_bin(x[GRADIENT], ly, nb)]
                            .add(m * (v[0] - u[0]) * (v[1] - u[1]));
                    }
                    sums.iter_mut().for_each(FixedSum::normalize);
                    FixedSum::allreduce(self.comm, &mut sums);
                    let bin_volume = self.sim_box.volume() / nb as f64;
                    for (b, w) in sums.iter().enumerate() {
                        out.scalars.push((
                            format!("{SHEAR_STRESS_PROFILE_PREFIX}{b:04}"),
                            -w.value() / bin_volume,
                        ));
                    }
                }
                Observable::DensityProfile => {
                    for (b, rho) in self.density_profile().into_iter().enumerate() {
                        out.scalars
                            .push((format!("{DENSITY_PROFILE_PREFIX}{b:04}"), rho));
                    }
                }
            }
        }
        out
    }

    /// The force along x per unit area on the lower and the upper wall (the sums of the
    /// forces on their boundary particles, which the SPH momentum pass fills with the
    /// reactions of their fluid neighbours), exact and reduced over the ranks (collective).
    fn wall_forces(&self) -> [f64; 2] {
        use crate::models::sph::{LOWER_WALL, UPPER_WALL};
        let Some(w) = &self.case.walls else {
            return [f64::NAN; 2];
        };
        let p = &self.particles;
        let mut sums = [FixedSum::ZERO; 2];
        for i in 0..p.n_owned {
            match p.species_of(i) {
                LOWER_WALL => sums[0].add(p.force[i][0]),
                UPPER_WALL => sums[1].add(p.force[i][0]),
                _ => {}
            }
            if i % 2048 == 2047 {
                sums.iter_mut().for_each(FixedSum::normalize);
            }
        }
        FixedSum::allreduce(self.comm, &mut sums);
        let axis = w.axis.index();
        let area: f64 = (0..D)
            .filter(|&d| d != axis)
            .map(|d| self.sim_box.lengths[d])
            .product();
        [sums[0].value() / area, sums[1].value() / area]
    }

    /// A hash of the complete owned state — id, position, velocity, force, image counts and
    /// every registered field of every particle — combined over particles with an
    /// order-independent wrapping sum and xor, so it is the same for any decomposition
    /// (collective).
    pub fn state_digest(&self) -> String {
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
        let mut sum = [acc[0]];
        let mut xor = [acc[1]];
        self.comm.allreduce_u64(&mut sum, U64Op::Sum);
        self.comm.allreduce_u64(&mut xor, U64Op::Xor);
        format!("{:016x}{:016x}", sum[0], xor[0])
    }

    /// The models' counted warnings (summed over the ranks), the non-zero ones. Collective.
    pub fn counted_warnings(&self) -> Vec<String> {
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
    /// rank, / D), or None without ensembles. Collective.
    pub fn dumbbell_count(&self) -> Option<u64> {
        let p = &self.particles;
        let k = p
            .var
            .iter()
            .position(|f| f.name == crate::models::dumbbell_ensemble::CONNECTORS)?;
        let mine: usize = (0..p.n_owned).map(|i| p.var[k].data.row_len(i)).sum();
        let mut total = [(mine / D) as u64];
        self.comm.allreduce_u64(&mut total, U64Op::Sum);
        Some(total[0])
    }

    /// Runs `steps` steps, sampling on schedule and calling `progress` every step (rank-local).
    pub fn run_steps(
        &mut self,
        steps: u64,
        mut progress: impl FnMut(&Self),
    ) -> Result<Duration, String> {
        let start = Instant::now();
        for _ in 0..steps {
            self.advance()?;
            if self.is_sample_step() {
                self.sample()?;
            }
            progress(self);
        }
        Ok(start.elapsed())
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

/// The bin of coordinate `y` among `bins` equal bins across [0, `ly`) (clamped to the ends).
fn profile_bin(y: f64, ly: f64, bins: usize) -> usize {
    ((y / ly * bins as f64).floor().max(0.0) as usize).min(bins - 1)
}

/// Observables at one instant.
#[derive(Clone, Debug, Default)]
pub struct Measurement {
    /// Scalar values by name.
    pub scalars: Vec<(String, f64)>,
    /// Σ m|V|²/(degrees of freedom), V about the local mean velocity: k_BT of the fluid,
    /// whether or not the case asked for the temperature (the heating detector reads it).
    pub kinetic_temperature: f64,
    /// Binned u_x(y).
    pub profile: Option<Vec<f64>>,
}

/// The virial components the observables need: all for the stress tensor and the viscosity
/// (off-diagonal), the diagonal for the pressure and the normal stress differences, none for
/// the others.
fn virial_scope(observables: &[Observable]) -> VirialScope {
    let needs = |o: &Observable| match o {
        Observable::Stress
        | Observable::Viscosity
        | Observable::GreenKuboViscosity
        | Observable::ShearStressProfile => VirialScope::Full,
        Observable::Pressure
        | Observable::FirstNormalStressDifference
        | Observable::SecondNormalStressDifference => VirialScope::Diagonal,
        Observable::Temperature
        | Observable::Momentum
        | Observable::VelocityProfile
        | Observable::WallShearStress
        | Observable::DensityProfile
        | Observable::PolymerStressTrace
        | Observable::ConstitutiveStress
        | Observable::CompositeViscosity
        | Observable::TransverseCurrentViscosity => VirialScope::Off,
    };
    let scopes: Vec<VirialScope> = observables.iter().map(needs).collect();
    if scopes.contains(&VirialScope::Full) {
        VirialScope::Full
    } else if scopes.contains(&VirialScope::Diagonal) {
        VirialScope::Diagonal
    } else {
        VirialScope::Off
    }
}

/// Builds the initial particles of the whole system in global-id order — the same on every
/// rank, so nothing depends on the decomposition — and keeps this rank's. Returns them and the
/// total count.
///
/// Velocities: Maxwellian at k_BT from Philox keyed by id, centre-of-mass motion removed and
/// rescaled to exactly k_BT over D(N − 1) degrees of freedom; then the shear profile if asked.
pub fn initial_particles<const D: usize>(
    case: &Case,
    sim_box: &SimBox<D>,
    slab: &Slab,
) -> (Particles<D>, u64) {
    let dim = D;
    let (cells, total) = case.lattice_counts();
    let wall_layers = case.walls.as_ref().map(|w| {
        let axis = w.axis.index();
        (axis, case.wall_layer_count(axis))
    });
    let mut positions: Vec<[f64; D]> = Vec::with_capacity(total as usize);
    match case.particles.lattice {
        Lattice::Random => {
            let key = StreamKey::new(case.seed, Purpose::InitialPosition, 0);
            for g in 0..total {
                let mut x = [0.0; D];
                let (a, b) = key.uniform2(0, g as u32, 0);
                let (c, _) = key.uniform2(0, g as u32, 1);
                let u = [a, b, c];
                for d in 0..D {
                    x[d] = u[d] * sim_box.lengths[d];
                }
                positions.push(x);
            }
        }
        lattice => {
            // Lattice sites at (k + 0.25) spacings; with walls, at (k + ½) along the wall axis,
            // so that the boundary rows mirror the fluid rows about each face.
            let mut offset = [0.25; D];
            if let Some((axis, _)) = wall_layers {
                offset[axis] = 0.5;
            }
            let basis: Vec<[f64; 3]> = match (lattice, dim) {
                (Lattice::Fcc, 3) => vec![
                    [0.0, 0.0, 0.0],
                    [0.5, 0.5, 0.0],
                    [0.5, 0.0, 0.5],
                    [0.0, 0.5, 0.5],
                ],
                (Lattice::Fcc, _) => vec![[0.0, 0.0, 0.0], [0.5, 0.5, 0.0]],
                _ => vec![[0.0; 3]],
            };
            let ncell: usize = cells.iter().product();
            for c in 0..ncell {
                let mut idx = [0usize; 3];
                let mut rem = c;
                for d in 0..D {
                    idx[d] = rem % cells[d];
                    rem /= cells[d];
                }
                for b in &basis {
                    let mut x = [0.0; D];
                    for d in 0..D {
                        let spacing = sim_box.lengths[d] / cells[d] as f64;
                        x[d] = (idx[d] as f64 + b[d] + offset[d]) * spacing;
                    }
                    positions.push(x);
                }
            }
            // Boundary particles: the lattice continued beyond both faces of the wall axis,
            // `layers` rows each side, after every fluid particle in id order.
            if let Some((axis, layers)) = wall_layers {
                let spacing = sim_box.lengths[axis] / cells[axis] as f64;
                let across: usize = (0..D).filter(|&d| d != axis).map(|d| cells[d]).product();
                for side in 0..2 {
                    for layer in 0..layers {
                        let depth = (layer as f64 + 0.5) * spacing;
                        for c in 0..across {
                            let mut x = [0.0; D];
                            let mut rem = c;
                            for d in (0..D).filter(|&d| d != axis) {
                                let sp = sim_box.lengths[d] / cells[d] as f64;
                                x[d] = ((rem % cells[d]) as f64 + offset[d]) * sp;
                                rem /= cells[d];
                            }
                            x[axis] = if side == 0 {
                                -depth
                            } else {
                                sim_box.lengths[axis] + depth
                            };
                            positions.push(x);
                        }
                    }
                }
            }
        }
    }
    let total = positions.len() as u64;
    let key = StreamKey::new(case.seed, Purpose::InitialVelocity, 0);
    let m = case.particles.mass;
    let kt = case.particles.temperature;
    let scale = (kt / m).sqrt();
    let mut velocities: Vec<[f64; D]> = (0..total)
        .map(|g| {
            let (a, b) = key.gaussian2(0, g as u32, 0);
            let (c, _) = key.gaussian2(0, g as u32, 1);
            let gs = [a, b, c];
            let mut v = [0.0; D];
            for d in 0..D {
                v[d] = scale * gs[d];
            }
            v
        })
        .collect();
    if total > 1 {
        let mut com = [0.0; D];
        for v in &velocities {
            for d in 0..D {
                com[d] += v[d];
            }
        }
        for c in &mut com {
            *c /= total as f64;
        }
        let mut ke2 = 0.0;
        for v in &mut velocities {
            for d in 0..D {
                v[d] -= com[d];
                ke2 += m * v[d] * v[d];
            }
        }
        let t_now = ke2 / (D as f64 * (total as f64 - 1.0));
        if t_now > 0.0 {
            let f = (kt / t_now).sqrt();
            for v in &mut velocities {
                for x in v.iter_mut() {
                    *x *= f;
                }
            }
        }
    }
    let shear_profile = match case.particles.velocity_profile {
        VelocityProfile::Auto => sim_box.sheared(),
        VelocityProfile::Shear => true,
        VelocityProfile::Rest | VelocityProfile::HalfSine => false,
    };
    let half_sine = case.particles.velocity_profile == VelocityProfile::HalfSine;
    let (amplitude, ly) = (case.particles.velocity_amplitude, sim_box.lengths[GRADIENT]);
    let mut particles = Particles::default();
    for (g, (x, mut v)) in positions.into_iter().zip(velocities).enumerate() {
        if shear_profile {
            v[0] += sim_box.streaming_velocity(x[GRADIENT]);
        }
        let y = x[GRADIENT];
        if half_sine && (0.0..=ly).contains(&y) {
            v[0] += amplitude * (std::f64::consts::PI * y / ly).sin();
        }
        if slab.owner_of(x[slab.axis]) == slab.rank {
            particles.push_owned(g as u64, x, v);
        }
    }
    (particles, total)
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
