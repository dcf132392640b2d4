//! Dissipative particle dynamics (Groot & Warren, J. Chem. Phys. 107, 4423 (1997);
//! docs/theory/dpd_physical_parameters.md §1, Nguyen 2021 Eq. 2.1–2.4, 3.23–3.29).
//!
//! For a pair at r_ij = r_i − r_j (r = |r_ij| < r_c, e_ij = r_ij / r, v_ij = v_i − v_j):
//!
//! ```text
//! F_ij = [ a w_C(r) − γ w_D(r) (e_ij·v_ij) + σ w_R(r) θ_ij / √Δt ] e_ij
//! w_C = (1 − r/r_c)^s̄,   w_R = (1 − r/r_c)^{s/2},   w_D = w_R²,   σ² = 2 γ k_BT
//! ```
//!
//! θ_ij is a unit-variance random number from the keyed hash stream
//! ([`crate::rng::HashStream`]) of (seed, step, min gid, max gid), so θ_ij = θ_ji wherever the
//! pair is evaluated, on any rank. The default is Gaussian (ziggurat; the thesis, L444);
//! `noise = "uniform"` gives √3(2u − 1), Groot–Warren's choice.
//! With s = 2, s̄ = 1 this is standard DPD; s = 1/2 is the thesis's "modified" weight, and s̄
//! follows from the compressibility when the fluid is given by its physical properties
//! (`[fluid.physical]`, [`crate::dpd_parameters`]).

pub mod colloids;
pub mod keys;
pub mod physical;
pub mod soft_start;
pub mod spec;
pub mod time_step;

use crate::error::Error;
use crate::models::interface::{ParticleModel, PassContext, PassOutput, PassSpec};
use crate::models::pair_loop::{
    BATCH, BlockTerms, PairBlock, PairKernel, PairTerms, PairWorkspace, VirialScope, compute_forces,
};
use crate::rng::{HashStream, Purpose};
use serde::{Deserialize, Serialize};

const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// Distribution of the pair noise θ_ij.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Noise {
    /// Standard normal (ziggurat on the keyed hash stream).
    #[default]
    Gaussian,
    /// Uniform with unit variance, √3 (2u − 1).
    Uniform,
}

/// `[fluid] kind = "dpd"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DpdCfg {
    /// Conservative repulsion a.
    pub a: f64,
    /// Dissipation γ.
    pub gamma: f64,
    /// k_BT.
    pub kt: f64,
    /// Cutoff r_c.
    #[serde(default = "one")]
    pub cutoff: f64,
    /// Exponent s of w_D = (1 − r/r_c)^s.
    #[serde(default = "two")]
    pub weight_exponent: f64,
    /// Exponent s̄ of w_C = (1 − r/r_c)^s̄ (1: Groot–Warren).
    #[serde(default = "one")]
    pub conservative_exponent: f64,
    /// Noise distribution.
    #[serde(default)]
    pub noise: Noise,
    /// The physical properties a, γ, s and s̄ were mapped from, when the case gave them
    /// ([`crate::config::dpd_physical`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub physical: Option<PhysicalDpdCfg>,
    /// A constant acceleration g on every particle (force m g); empty: none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub body_force: Vec<f64>,
    /// How the body force depends on y.
    #[serde(default, skip_serializing_if = "is_uniform")]
    pub body_force_profile: BodyForceProfile,
    /// Suspended rigid colloids of spring-tied constituents (`[fluid.colloids]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub colloids: Option<colloids::ColloidsCfg>,
    /// Sweeps of overlap removal of a random start ([`soft_start`]); `None`: the default
    /// [`soft_start::DEFAULT_SWEEPS`], 0: off. Lattice starts ignore it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub soft_start_sweeps: Option<u32>,
}

impl DpdCfg {
    /// Sweeps of overlap removal a random start gets ([`soft_start`]).
    pub fn soft_start_sweeps(&self) -> u32 {
        self.soft_start_sweeps.unwrap_or(soft_start::DEFAULT_SWEEPS)
    }
}

/// The y-dependence of a DPD body force.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BodyForceProfile {
    /// The same everywhere.
    #[default]
    Uniform,
    /// +g in the upper half of the box (y ≥ L_y/2), −g in the lower: the reverse ("double")
    /// Poiseuille flow of a periodic box (Backer et al. 2005; Nguyen 2021 §3.4).
    Reverse,
}

fn is_uniform(p: &BodyForceProfile) -> bool {
    *p == BodyForceProfile::Uniform
}

/// `[fluid.physical]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PhysicalDpdCfg {
    /// Shear viscosity η, imposed as the kinetic-theory dissipative viscosity η̄_D.
    pub viscosity: f64,
    /// Time-scale ratio α = γ² r_c/(m a); without it the "classical water" repulsion
    /// a = 15(κ⁻¹ − 1)k_BT/(π n r_c⁴) (3D), s̄ = 1, is used.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_scale_ratio: Option<f64>,
    /// Dimensionless inverse compressibility κ⁻¹ (water: 15.9835).
    #[serde(default = "water")]
    pub inverse_compressibility: f64,
    /// Schmidt number Sc = η̄_D/(ρD) to impose (fixes s); exclusive with
    /// `particle_diffusion_time`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub schmidt_number: Option<f64>,
    /// Particle diffusion time τ_P to impose (fixes s; 3D only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub particle_diffusion_time: Option<f64>,
}

fn water() -> f64 {
    crate::dpd_parameters::WATER_INVERSE_COMPRESSIBILITY
}

fn one() -> f64 {
    1.0
}

fn two() -> f64 {
    2.0
}

/// Parameters of a DPD fluid.
#[derive(Clone, Debug)]
pub struct Dpd {
    /// Conservative repulsion a.
    pub a: f64,
    /// Dissipation γ.
    pub gamma: f64,
    /// Temperature k_BT.
    pub kt: f64,
    /// Cutoff r_c.
    pub cutoff: f64,
    /// Weight exponent s of w_D = (1 − r/r_c)^s.
    pub weight_exponent: f64,
    /// Exponent s̄ of w_C = (1 − r/r_c)^s̄.
    pub conservative_exponent: f64,
    /// Noise distribution.
    pub noise: Noise,
    /// σ / √Δt, precomputed.
    sigma_over_sqrt_dt: f64,
    /// 1 / r_c, precomputed (w = 1 − r · (1/r_c): a multiply instead of a divide per pair).
    inv_cutoff: f64,
    seed: u64,
}

impl Dpd {
    /// A DPD fluid for time step `dt` and the case seed.
    pub fn new(cfg: &DpdCfg, dt: f64, seed: u64) -> Self {
        let sigma = (2.0 * cfg.gamma * cfg.kt).sqrt();
        Self {
            a: cfg.a,
            gamma: cfg.gamma,
            kt: cfg.kt,
            cutoff: cfg.cutoff,
            weight_exponent: cfg.weight_exponent,
            conservative_exponent: cfg.conservative_exponent,
            noise: cfg.noise,
            sigma_over_sqrt_dt: sigma / dt.sqrt(),
            inv_cutoff: 1.0 / cfg.cutoff,
            seed,
        }
    }

    /// Noise amplitude σ = √(2 γ k_BT).
    pub fn sigma(&self) -> f64 {
        (2.0 * self.gamma * self.kt).sqrt()
    }
}

impl<const D: usize> PairKernel<D> for Dpd {
    fn cutoff(&self) -> f64 {
        self.cutoff
    }

    #[inline]
    fn eval(
        &self,
        r_vec: &[f64; D],
        v_rel: &[f64; D],
        gids: (u64, u64),
        step: u64,
    ) -> Option<PairTerms<D>> {
        self.eval_keyed(
            r_vec,
            v_rel,
            gids,
            <Self as PairKernel<D>>::step_key(self, step),
        )
    }

    /// The hash-stream prefix of (seed, purpose, step).
    fn step_key(&self, step: u64) -> u64 {
        HashStream::prefix(self.seed, Purpose::DpdPair, step)
    }

    /// The DPD pair force of the module documentation for a block of pairs, in passes over
    /// arrays that the compiler vectorises: geometry and weights, then the noise (scalar: a hash
    /// and the ziggurat), then the forces. A pair with r ≥ r_c or r = 0 is not valid.
    /// Always inlined, so that it is compiled for the caller's instruction set.
    #[inline(always)]
    fn eval_block(&self, block: &PairBlock<D>, step_key: u64, out: &mut BlockTerms<D>) {
        let n = block.len;
        let c2 = self.cutoff * self.cutoff;
        let mut w_r = [0.0; BATCH];
        let mut ev = [0.0; BATCH];
        for k in 0..n {
            let mut r2 = 0.0;
            for d in 0..D {
                r2 += block.r[d][k] * block.r[d][k];
            }
            out.valid[k] = !(r2 >= c2 || r2 == 0.0);
            let r = r2.sqrt();
            let inv_r = 1.0 / r;
            let mut dot = 0.0;
            for d in 0..D {
                let e = block.r[d][k] * inv_r;
                out.e[d][k] = e;
                dot += e * block.v[d][k];
            }
            ev[k] = dot;
            out.r[k] = r;
            let w = 1.0 - r * self.inv_cutoff;
            out.parts[0][k] = self.a * w;
            w_r[k] = w;
        }
        if self.conservative_exponent != 1.0 {
            for k in 0..n {
                out.parts[0][k] = self.a * w_r[k].max(0.0).powf(self.conservative_exponent);
            }
        }
        if self.weight_exponent != 2.0 {
            for w in &mut w_r[..n] {
                *w = w.powf(0.5 * self.weight_exponent);
            }
        }
        let mut theta = [0.0; BATCH];
        for (t, &(a, b)) in theta[..n].iter_mut().zip(&block.ids[..n]) {
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            let mut stream = HashStream::from_prefix(step_key, lo, hi);
            *t = match self.noise {
                Noise::Gaussian => stream.normal(),
                Noise::Uniform => SQRT_3 * (2.0 * stream.uniform() - 1.0),
            };
        }
        for k in 0..n {
            let w_d = w_r[k] * w_r[k];
            out.parts[1][k] = -self.gamma * w_d * ev[k];
            out.parts[2][k] = self.sigma_over_sqrt_dt * w_r[k] * theta[k];
        }
    }

    /// A one-pair [`PairKernel::eval_block`] (used off the hot path).
    #[inline]
    fn eval_keyed(
        &self,
        r_vec: &[f64; D],
        v_rel: &[f64; D],
        gids: (u64, u64),
        step_key: u64,
    ) -> Option<PairTerms<D>> {
        // One pair as a block: the formula lives in `eval_block` only.
        let mut block = PairBlock::<D> {
            len: 1,
            ..Default::default()
        };
        for d in 0..D {
            block.r[d][0] = r_vec[d];
            block.v[d][0] = v_rel[d];
        }
        block.ids[0] = gids;
        let mut out = BlockTerms::<D>::default();
        self.eval_block(&block, step_key, &mut out);
        out.valid[0].then(|| PairTerms {
            e: std::array::from_fn(|d| out.e[d][0]),
            r: out.r[0],
            parts: [out.parts[0][0], out.parts[1][0], out.parts[2][0]],
        })
    }
}

/// DPD as a model of the engine: one pass, the vectorised half-list scatter of
/// [`compute_forces`] (its SIMD fast path), which also accumulates the pair virial, then the
/// body force if any; no fields of its own.
pub struct DpdModel<const D: usize> {
    dpd: Dpd,
    workspace: PairWorkspace<D>,
    /// m g, the profile and L_y.
    body: Option<([f64; D], BodyForceProfile, f64)>,
    /// Bins and L_y of the binned shear virial, when the diagnostics ask for it.
    shear_profile: Option<(usize, f64)>,
    /// Particles of this global id and above are colloid constituents, which the body force
    /// does not drive (it drives the solvent; the thesis's cylinder array, spec §5.3).
    first_constituent: u64,
}

impl<const D: usize> DpdModel<D> {
    /// The model for time step `dt` and the case seed.
    pub fn new(cfg: &DpdCfg, dt: f64, seed: u64) -> Self {
        Self {
            dpd: Dpd::new(cfg, dt, seed),
            workspace: PairWorkspace::default(),
            body: None,
            shear_profile: None,
            first_constituent: u64::MAX,
        }
    }

    /// The same, also computing the pair part of the binned shear virial
    /// ([`crate::models::stress_profile`]) in `bins` bins across `ly` whenever the full virial is asked.
    pub fn with_shear_stress_profile(mut self, bins: usize, ly: f64) -> Self {
        self.shear_profile = Some((bins, ly));
        self
    }

    /// The same with the particles of global id `first` and above exempt from the body force
    /// (colloid constituents).
    pub fn with_constituents_from(mut self, first: u64) -> Self {
        self.first_constituent = first;
        self
    }

    /// The same with the case's body force on particles of mass `mass` in a box of height
    /// `ly` (none when the case has none).
    pub fn with_body_force(mut self, cfg: &DpdCfg, mass: f64, ly: f64) -> Self {
        if cfg.body_force.iter().any(|&g| g != 0.0) {
            let force =
                std::array::from_fn(|d| mass * cfg.body_force.get(d).copied().unwrap_or(0.0));
            self.body = Some((force, cfg.body_force_profile, ly));
        }
        self
    }
}

impl<const D: usize> ParticleModel<D> for DpdModel<D> {
    fn name(&self) -> &'static str {
        "dpd"
    }

    fn cutoff(&self) -> f64 {
        self.dpd.cutoff
    }

    fn passes(&self) -> Vec<PassSpec> {
        vec![PassSpec {
            name: "pair forces",
            ghost_fields: Vec::new(),
        }]
    }

    fn pass(&mut self, _pass: usize, ctx: PassContext<'_, D>) -> Result<PassOutput, Error> {
        let p = ctx.particles;
        let mut force = std::mem::take(&mut p.force);
        let (isa, list, step, scope) = (ctx.isa, ctx.list, ctx.step, ctx.virial);
        let virial = compute_forces(
            isa,
            &self.dpd,
            p,
            list,
            step,
            &mut self.workspace,
            &mut force,
            scope,
        );
        if let Some((mg, profile, ly)) = self.body {
            // Positions may lie up to half the skin outside [0, L_y) between list builds: the
            // half is taken of the wrapped coordinate.
            for ((f, x), &gid) in force.iter_mut().zip(&p.pos).zip(&p.gid).take(p.n_owned) {
                if gid >= self.first_constituent {
                    continue;
                }
                let sign = match profile {
                    BodyForceProfile::Uniform => 1.0,
                    BodyForceProfile::Reverse if x[1].rem_euclid(ly) >= 0.5 * ly => 1.0,
                    BodyForceProfile::Reverse => -1.0,
                };
                for d in 0..D {
                    f[d] += sign * mg[d];
                }
            }
        }
        p.force = force;
        let virial = virial?;
        let shear_virial_profile = match self.shear_profile {
            Some((bins, ly)) if scope == VirialScope::Full => {
                Some(crate::models::stress_profile::pair_shear_virial(
                    &self.dpd, p, list, step, bins, ly,
                ))
            }
            _ => None,
        };
        Ok(PassOutput {
            virial,
            shear_virial_profile,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pair_force_is_antisymmetric_and_matches_hand_values() {
        let cfg = DpdCfg {
            a: 25.0,
            gamma: 4.5,
            kt: 1.0,
            cutoff: 1.0,
            weight_exponent: 2.0,
            noise: Noise::Gaussian,

            conservative_exponent: 1.0,
            physical: None,
            body_force: Vec::new(),
            body_force_profile: BodyForceProfile::Uniform,
            colloids: None,
            soft_start_sweeps: None,
        };
        let dpd = Dpd::new(&cfg, 0.04, 7);
        let r = [0.3, -0.4, 0.0];
        let v = [1.0, 0.5, -0.2];
        let t: PairTerms<3> = dpd.eval(&r, &v, (3, 9), 11).expect("inside the cutoff");
        let rr = [-0.3, 0.4, -0.0];
        let vv = [-1.0, -0.5, 0.2];
        let u: PairTerms<3> = dpd.eval(&rr, &vv, (9, 3), 11).expect("inside the cutoff");
        assert_eq!(t.parts, u.parts);
        for d in 0..3 {
            assert_eq!(t.e[d], -u.e[d]);
        }
        // r = 0.5, w = 0.5: conservative 12.5; e·v = (0.6·1 − 0.8·0.5) = 0.2 → −4.5·0.25·0.2
        assert!((t.parts[0] - 12.5).abs() < 1e-14);
        assert!((t.parts[1] + 0.225).abs() < 1e-14);
        let beyond: Option<PairTerms<3>> = dpd.eval(&[1.0, 0.0, 0.0], &v, (1, 2), 0);
        assert!(beyond.is_none());
    }

    #[test]
    fn generalised_weights_match_hand_values() {
        // Nguyen 2021's weights: w_C = (1 − r/r_c)^s̄, w_D = (1 − r/r_c)^s, r_c = 1.5, r = 0.5:
        // 1 − r/r_c = 2/3; s̄ = 5.0329, s = 0.5.
        let cfg = DpdCfg {
            a: 229.42,
            gamma: 15.1466,
            kt: 1.0,
            cutoff: 1.5,
            weight_exponent: 0.5,
            conservative_exponent: 5.0329,
            noise: Noise::Gaussian,
            physical: None,
            body_force: Vec::new(),
            body_force_profile: BodyForceProfile::Uniform,
            colloids: None,
            soft_start_sweeps: None,
        };
        let dpd = Dpd::new(&cfg, 0.001, 7);
        let (r, v) = ([0.3, -0.4, 0.0], [1.0, 0.5, -0.2]);
        let t: PairTerms<3> = dpd.eval(&r, &v, (3, 9), 11).expect("inside the cutoff");
        let w = 2.0_f64 / 3.0;
        let conservative = 229.42 * w.powf(5.0329);
        let dissipative = -15.1466 * w.sqrt() * 0.2;
        assert!(
            (t.parts[0] - conservative).abs() < 1e-12 * conservative,
            "{:?}",
            t.parts
        );
        assert!((t.parts[1] - dissipative).abs() < 1e-13, "{:?}", t.parts);
    }
}
