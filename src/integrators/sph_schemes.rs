//! The SPH integrators: symplectic kick–drift–kick and three two-stage predictor–correctors
//! (docs/theory/sph_maxwell.md §1.12). The state is u = (x, v, s) with s the integrated fields
//! (a continuity density, a stress), its rate S(u) = (v, a, ṡ) with a = F/m.
//!
//! **Kick–drift–kick** (velocity Verlet; one force evaluation per step):
//!
//! ```text
//! v½ = v + ½Δt a(t)          s½ = s + ½Δt ṡ(t)
//! x(t+Δt) = x + Δt v½
//! v̂ = v + Δt a(t)            ŝ = s + Δt ṡ(t)       (what the new forces see: viscous forces
//!                                                    depend on velocities, the EOS on ρ)
//! v(t+Δt) = v½ + ½Δt a(t+Δt) s(t+Δt) = s½ + ½Δt ṡ(t+Δt)
//! ```
//!
//! Symplectic, hence neutrally stable, for the conservative (pressure) part: no growth of the
//! undamped sound modes that two-stage schemes amplify by 1 + θ⁴/4 per step (θ = ωΔt,
//! docs/theory/sph_maxwell.md §1.12 stability note).
//!
//! **Two-stage schemes** (two force evaluations per step), with c the predictor fraction:
//!
//! ```text
//! predictor   ũ = uⁿ + c Δt S(uⁿ)
//! corrector   thesis (c = ½), Heun (c = 1):  uⁿ⁺¹ = uⁿ + ½Δt [S(uⁿ) + S(ũ)]
//!             midpoint (c = ½):               uⁿ⁺¹ = uⁿ + Δt S(ũ)
//! ```
//!
//! The thesis prints the first line with c = ½ and the averaged corrector and calls it second
//! order (Eqs. 2.49–2.50). It is **first order**: for u' = −u one step multiplies by
//! (1 − z/2)² = 1 − z + z²/4, not 1 − z + z²/2 (docs/theory/sph_maxwell.md §1.12 erratum). It is
//! offered only to reproduce the text; Heun and midpoint are its second-order repairs.
//!
//! The corrector moves positions by the difference from the predicted ones,
//! x ← x̃ + [Δt/2 (vⁿ + ṽ) − cΔt vⁿ], so a periodic wrap or a migration between the stages
//! (the predicted particle may cross a slab or box face) is carried over unchanged.
//!
//! Boundary particles ([`crate::species`]) are not integrated: frozen ones never move,
//! prescribed ones move at their velocity.

use super::{IntegratedField, Integrator};
use crate::particles::{ExtraField, FieldFlags, Particles};
use crate::species::{Motion, Species};
use serde::{Deserialize, Serialize};

/// `[integrator] kind = "kick_drift_kick"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct KickDriftKickCfg {
    /// Time step Δt.
    pub dt: f64,
}

/// `[integrator] kind = "heun" | "midpoint" | "thesis_predictor_corrector"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct TwoStageCfg {
    /// Time step Δt.
    pub dt: f64,
}

/// Which two-stage scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TwoStageVariant {
    /// Ellero 2004 Eqs. 2.49–2.50 as printed: first order.
    ThesisPrinted,
    /// Heun: second order.
    Heun,
    /// Explicit midpoint: second order.
    Midpoint,
}

/// Scratch fields migrate with their particle (a rebuild can fall between stages) and are
/// neither checkpointed nor digested (they are dead between steps).
const SCRATCH: FieldFlags = FieldFlags {
    migrates: true,
    checkpointed: false,
    digested: false,
    velocity_like: false,
};

/// 1/m and motion of each species (one free species of the case's mass when the table is
/// empty).
fn species_table(mass: f64, table: &[Species]) -> Vec<(f64, Motion)> {
    if table.is_empty() {
        vec![(1.0 / mass, Motion::Free)]
    } else {
        table.iter().map(|s| (1.0 / s.mass, s.motion)).collect()
    }
}

/// Calls `update(fields, c)` for every component c of the owned free (fluid) particles' rows
/// of the integrated field `f`, and of the boundary particles' rows too when the field says
/// so ([`IntegratedField::boundary_particles`]).
fn for_free_components<const D: usize>(
    table: &[(f64, Motion)],
    p: &mut Particles<D>,
    f: &IntegratedField,
    mut update: impl FnMut(&mut [ExtraField], usize),
) {
    let w = p.extra[f.state].width;
    let species = p.species.as_deref();
    for i in 0..p.n_owned {
        let s = species.map_or(0, |s| s[i] as usize);
        if f.boundary_particles || table[s].1 == Motion::Free {
            for c in i * w..(i + 1) * w {
                update(&mut p.extra, c);
            }
        }
    }
}

/// 1/m if every particle is a free particle of the one species (a fluid-only scene): the
/// integrators then update flat arrays in loops the compiler vectorises, with the same
/// arithmetic, so the same bits, as the per-particle loops.
fn one_free_species(table: &[(f64, Motion)]) -> Option<f64> {
    match table {
        [(inv_m, Motion::Free)] => Some(*inv_m),
        _ => None,
    }
}

/// `update(state, rate, half)` on the first `len` components of an integrated field's state,
/// rate and half-step arrays (three distinct fields), taken out of `extra` for the call.
fn with_field_arrays(
    extra: &mut [ExtraField],
    (state, rate, half): (usize, usize, usize),
    len: usize,
    update: impl FnOnce(&mut [f64], &[f64], &mut [f64]),
) {
    debug_assert!(state != rate && state != half && rate != half);
    let mut s = std::mem::take(&mut extra[state].data);
    let mut h = std::mem::take(&mut extra[half].data);
    update(&mut s[..len], &extra[rate].data[..len], &mut h[..len]);
    extra[state].data = s;
    extra[half].data = h;
}

/// Kick–drift–kick (module documentation).
#[derive(Clone, Debug)]
pub struct KickDriftKick {
    dt: f64,
    species: Vec<(f64, Motion)>,
    integrated: Vec<IntegratedField>,
    /// Per integrated field, the index of its half-step value s½.
    half: Vec<usize>,
    /// The drift correction c (XSPH): r ← r + Δt (v½ + c).
    drift_correction: Option<usize>,
}

impl KickDriftKick {
    /// With the case's particle mass and species table (empty: one species).
    pub fn new(cfg: &KickDriftKickCfg, mass: f64, species: &[Species]) -> Self {
        Self {
            dt: cfg.dt,
            species: species_table(mass, species),
            integrated: Vec::new(),
            half: Vec::new(),
            drift_correction: None,
        }
    }
}

impl<const D: usize> Integrator<D> for KickDriftKick {
    fn name(&self) -> &'static str {
        "kick_drift_kick"
    }

    fn dt(&self) -> f64 {
        self.dt
    }

    fn bind(&mut self, p: &mut Particles<D>, integrated: &[IntegratedField]) {
        self.integrated = integrated.to_vec();
        self.half = integrated
            .iter()
            .map(|f| {
                let name = format!("{}_half_step", p.extra[f.state].name);
                let width = p.extra[f.state].width;
                p.register_field(&name, width, SCRATCH)
                    .expect("a new scratch field")
            })
            .collect();
    }

    fn bind_drift_correction(&mut self, field: usize) -> Result<(), String> {
        self.drift_correction = Some(field);
        Ok(())
    }

    fn before_forces(&self, p: &mut Particles<D>, _stage: usize) {
        let dt = self.dt;
        let n = p.n_owned;
        if let Some(inv_m) = one_free_species(&self.species) {
            let m = n * D;
            let pos = &mut p.pos.as_flattened_mut()[..m];
            let vel = &mut p.vel.as_flattened_mut()[..m];
            let vel_half = &mut p.vel_half.as_flattened_mut()[..m];
            let force = &p.force.as_flattened()[..m];
            let correction = self.drift_correction.map(|c| &p.extra[c].data[..m]);
            for k in 0..m {
                let a = force[k] * inv_m;
                let vh = vel[k] + 0.5 * dt * a;
                vel_half[k] = vh;
                pos[k] += match correction {
                    None => dt * vh,
                    Some(c) => dt * (vh + c[k]),
                };
                vel[k] += dt * a;
            }
            for (f, &h) in self.integrated.iter().zip(&self.half) {
                let len = n * p.extra[f.state].width;
                with_field_arrays(&mut p.extra, (f.state, f.rate, h), len, |s, r, half| {
                    for c in 0..len {
                        half[c] = s[c] + 0.5 * dt * r[c];
                        s[c] += dt * r[c];
                    }
                });
            }
            return;
        }
        for i in 0..n {
            match self.species[p.species_of(i) as usize] {
                (inv_m, Motion::Free) => {
                    for d in 0..D {
                        let a = p.force[i][d] * inv_m;
                        let vh = p.vel[i][d] + 0.5 * dt * a;
                        p.vel_half[i][d] = vh;
                        p.pos[i][d] += match self.drift_correction {
                            None => dt * vh,
                            Some(c) => dt * (vh + p.extra[c].data[i * D + d]),
                        };
                        p.vel[i][d] += dt * a;
                    }
                }
                (_, Motion::Prescribed(u)) => {
                    for d in 0..D {
                        p.pos[i][d] += dt * u[d];
                    }
                    p.vel[i].copy_from_slice(&u[..D]);
                    p.vel_half[i].copy_from_slice(&u[..D]);
                }
                (_, Motion::Frozen) => {}
            }
        }
        for (f, &h) in self.integrated.iter().zip(&self.half) {
            for_free_components(&self.species, p, f, |x, c| {
                let (s, r) = (x[f.state].data[c], x[f.rate].data[c]);
                x[h].data[c] = s + 0.5 * dt * r;
                x[f.state].data[c] = s + dt * r;
            });
        }
    }

    fn after_forces(&self, p: &mut Particles<D>, _stage: usize) {
        let dt = self.dt;
        let n = p.n_owned;
        if let Some(inv_m) = one_free_species(&self.species) {
            let m = n * D;
            let vel = &mut p.vel.as_flattened_mut()[..m];
            let vel_half = &p.vel_half.as_flattened()[..m];
            let force = &p.force.as_flattened()[..m];
            for k in 0..m {
                vel[k] = vel_half[k] + 0.5 * dt * force[k] * inv_m;
            }
            for (f, &h) in self.integrated.iter().zip(&self.half) {
                let len = n * p.extra[f.state].width;
                with_field_arrays(&mut p.extra, (f.state, f.rate, h), len, |s, r, half| {
                    for c in 0..len {
                        s[c] = half[c] + 0.5 * dt * r[c];
                    }
                });
            }
            return;
        }
        for i in 0..n {
            if let (inv_m, Motion::Free) = self.species[p.species_of(i) as usize] {
                for d in 0..D {
                    p.vel[i][d] = p.vel_half[i][d] + 0.5 * dt * p.force[i][d] * inv_m;
                }
            }
        }
        for (f, &h) in self.integrated.iter().zip(&self.half) {
            for_free_components(&self.species, p, f, |x, c| {
                x[f.state].data[c] = x[h].data[c] + 0.5 * dt * x[f.rate].data[c];
            });
        }
    }
}

/// A two-stage predictor–corrector (module documentation).
#[derive(Clone, Debug)]
pub struct TwoStage {
    dt: f64,
    variant: TwoStageVariant,
    species: Vec<(f64, Motion)>,
    integrated: Vec<IntegratedField>,
    /// Scratch: vⁿ and aⁿ (D each), then sⁿ and ṡⁿ of every integrated field.
    v0: usize,
    a0: usize,
    saved: Vec<(usize, usize)>,
}

impl TwoStage {
    /// With the case's particle mass and species table (empty: one species).
    pub fn new(
        cfg: &TwoStageCfg,
        variant: TwoStageVariant,
        mass: f64,
        species: &[Species],
    ) -> Self {
        Self {
            dt: cfg.dt,
            variant,
            species: species_table(mass, species),
            integrated: Vec::new(),
            v0: usize::MAX,
            a0: usize::MAX,
            saved: Vec::new(),
        }
    }

    /// The predictor fraction c.
    fn c(&self) -> f64 {
        match self.variant {
            TwoStageVariant::Heun => 1.0,
            TwoStageVariant::ThesisPrinted | TwoStageVariant::Midpoint => 0.5,
        }
    }

    /// The corrector's update uⁿ⁺¹ − uⁿ from the rate `r0` at the stage start and the rate
    /// `r1` at the predicted stage.
    #[inline(always)]
    fn increment(&self, r0: f64, r1: f64) -> f64 {
        match self.variant {
            TwoStageVariant::Midpoint => self.dt * r1,
            _ => 0.5 * self.dt * (r0 + r1),
        }
    }
}

impl<const D: usize> Integrator<D> for TwoStage {
    fn name(&self) -> &'static str {
        match self.variant {
            TwoStageVariant::ThesisPrinted => "thesis_predictor_corrector",
            TwoStageVariant::Heun => "heun",
            TwoStageVariant::Midpoint => "midpoint",
        }
    }

    fn dt(&self) -> f64 {
        self.dt
    }

    fn stages(&self) -> usize {
        2
    }

    fn bind(&mut self, p: &mut Particles<D>, integrated: &[IntegratedField]) {
        self.integrated = integrated.to_vec();
        self.v0 = p
            .register_field("stage_velocity", D, SCRATCH)
            .expect("a new scratch field");
        self.a0 = p
            .register_field("stage_acceleration", D, SCRATCH)
            .expect("a new scratch field");
        self.saved = integrated
            .iter()
            .map(|f| {
                let (name, width) = (p.extra[f.state].name.clone(), p.extra[f.state].width);
                let s = p.register_field(&format!("stage_{name}"), width, SCRATCH);
                let r = p.register_field(&format!("stage_{name}_rate"), width, SCRATCH);
                (s.expect("new"), r.expect("new"))
            })
            .collect();
    }

    fn before_forces(&self, p: &mut Particles<D>, stage: usize) {
        if stage != 0 {
            return;
        }
        let cdt = self.c() * self.dt;
        let n = p.n_owned;
        for i in 0..n {
            match self.species[p.species_of(i) as usize] {
                (inv_m, Motion::Free) => {
                    for d in 0..D {
                        let (v, a) = (p.vel[i][d], p.force[i][d] * inv_m);
                        p.extra[self.v0].data[i * D + d] = v;
                        p.extra[self.a0].data[i * D + d] = a;
                        p.pos[i][d] += cdt * v;
                        p.vel[i][d] = v + cdt * a;
                    }
                }
                (_, Motion::Prescribed(u)) => {
                    for d in 0..D {
                        p.pos[i][d] += cdt * u[d];
                    }
                    p.vel[i].copy_from_slice(&u[..D]);
                }
                (_, Motion::Frozen) => {}
            }
        }
        for (f, &(s0, r0)) in self.integrated.iter().zip(&self.saved) {
            for_free_components(&self.species, p, f, |x, c| {
                let (s, r) = (x[f.state].data[c], x[f.rate].data[c]);
                x[s0].data[c] = s;
                x[r0].data[c] = r;
                x[f.state].data[c] = s + cdt * r;
            });
        }
    }

    fn after_forces(&self, p: &mut Particles<D>, stage: usize) {
        if stage != 0 {
            return;
        }
        let (dt, cdt) = (self.dt, self.c() * self.dt);
        let n = p.n_owned;
        for i in 0..n {
            match self.species[p.species_of(i) as usize] {
                (inv_m, Motion::Free) => {
                    for d in 0..D {
                        let v0 = p.extra[self.v0].data[i * D + d];
                        let a0 = p.extra[self.a0].data[i * D + d];
                        let (v1, a1) = (p.vel[i][d], p.force[i][d] * inv_m);
                        p.pos[i][d] += self.increment(v0, v1) - cdt * v0;
                        p.vel[i][d] = v0 + self.increment(a0, a1);
                    }
                }
                (_, Motion::Prescribed(u)) => {
                    for d in 0..D {
                        p.pos[i][d] += (dt - cdt) * u[d];
                    }
                }
                (_, Motion::Frozen) => {}
            }
        }
        for (f, &(s0, r0)) in self.integrated.iter().zip(&self.saved) {
            for_free_components(&self.species, p, f, |x, c| {
                x[f.state].data[c] =
                    x[s0].data[c] + self.increment(x[r0].data[c], x[f.rate].data[c]);
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One particle on a spring (a = −ω²x) and one integrated field decaying as ṡ = −s,
    /// stepped with the scheme by hand (the step loop's stage protocol): returns the error of
    /// x and s at t = 1 against cos t and e^{−t}.
    fn errors<I: Integrator<1>>(mut integrator: I, steps: usize) -> (f64, f64) {
        let mut p = Particles::<1>::default();
        p.push_owned(0, [1.0], [0.0]);
        let state = p.register_field("s", 1, FieldFlags::STATE).expect("new");
        let rate = p
            .register_field("s_rate", 1, FieldFlags::STATE)
            .expect("new");
        p.extra[state].data[0] = 1.0;
        let evaluate = |p: &mut Particles<1>| {
            p.force[0][0] = -p.pos[0][0];
            p.extra[rate].data[0] = -p.extra[state].data[0];
        };
        evaluate(&mut p);
        integrator.bind(
            &mut p,
            &[IntegratedField {
                state,
                rate,
                boundary_particles: false,
            }],
        );
        for _ in 0..steps {
            for stage in 0..integrator.stages() {
                integrator.before_forces(&mut p, stage);
                evaluate(&mut p);
                integrator.after_forces(&mut p, stage);
            }
        }
        (
            (p.pos[0][0] - 1f64.cos()).abs(),
            (p.extra[state].data[0] - (-1f64).exp()).abs(),
        )
    }

    /// The measured order of every scheme from the error ratio at Δt and Δt/2: ≈ 2 for
    /// kick–drift–kick, Heun and midpoint, ≈ 1 for the thesis's scheme as printed (its
    /// erratum). A first-order Heun (e.g. the corrector dropping S(uⁿ)) fails it.
    #[test]
    fn schemes_have_their_order() {
        let order = |e1: f64, e2: f64| (e1 / e2).log2();
        let kdk = |dt| KickDriftKick::new(&KickDriftKickCfg { dt }, 1.0, &[]);
        let two = |dt, v| TwoStage::new(&TwoStageCfg { dt }, v, 1.0, &[]);
        let (x1, s1) = errors(kdk(0.02), 50);
        let (x2, s2) = errors(kdk(0.01), 100);
        assert!(
            (order(x1, x2) - 2.0).abs() < 0.1,
            "kdk x: {}",
            order(x1, x2)
        );
        assert!(
            (order(s1, s2) - 2.0).abs() < 0.1,
            "kdk s: {}",
            order(s1, s2)
        );
        for (variant, want) in [
            (TwoStageVariant::Heun, 2.0),
            (TwoStageVariant::Midpoint, 2.0),
            (TwoStageVariant::ThesisPrinted, 1.0),
        ] {
            let (x1, s1) = errors(two(0.02, variant), 50);
            let (x2, s2) = errors(two(0.01, variant), 100);
            assert!(
                (order(x1, x2) - want).abs() < 0.1,
                "{variant:?} x: {}",
                order(x1, x2)
            );
            assert!(
                (order(s1, s2) - want).abs() < 0.1,
                "{variant:?} s: {}",
                order(s1, s2)
            );
        }
    }
}
