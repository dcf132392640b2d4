//! Dumbbell ensembles carried by particles (the micro part of CONNFFESSIT; Laso & Öttinger
//! 1993; docs/theory/msph_dumbbells.md §1.5–§1.6): every particle holds N_d connector vectors
//! Q, advanced once per step with *that particle's* velocity gradient κ, and reports its Kramers
//! stress
//!
//! ```text
//! dQ = [κ·Q − F(Q)/(2λ)] dt + √(dt/λ) dW,      τ_p = G (⟨Q F(Q)⟩ − I)
//! ```
//!
//! (Hookean F = Q; FENE F = Q/(1 − Q²/b); the schemes of [`super::dumbbells`]). κ comes from a
//! [`VelocityGradient`] source: imposed (a homogeneous flow, the same for every particle) or a
//! tensor field of the particle that another model computes (the SPH or MSPH estimate of ∇v:
//! the coupling of issue #16).
//!
//! The stress is stored packed, the upper triangle row by row ((xx, xy, yy) in 2D, (xx, xy,
//! xz, yy, yz, zz) in 3D), in the field the SPH momentum equation reads
//! ([`crate::models::sph::POLYMER_STRESS`]). In a scene with species, only the carrier
//! species (the fluid) holds dumbbells: a wall or inclusion particle has an empty ensemble and
//! zero polymer stress, and costs nothing.
//!
//! Keys: the initial ensemble of particle g is drawn from the stream (seed, g) and the noise of
//! step n from (seed, g, n, stage 0) — the keys of [`super::homogeneous_flow`], so a particle
//! scene with an imposed flow reproduces a homogeneous-flow scene's connectors bit for bit
//! (tested), on any decomposition, however the particles migrate. With
//! `noise = "configuration_fields"` every particle draws from particle 0's streams
//! ([`EnsembleNoise`]: Brownian configuration fields), so a coupled scene in homogeneous
//! flow carries homogeneous-flow particle 0's ensemble at every particle.

use super::dumbbell_settings::EnsembleNoise;
use super::dumbbells::{
    DumbbellParams, Spring, init_stream, kramers_stress, noise_stream, outside_domain,
    sample_equilibrium, step_ensemble,
};
use super::homogeneous_flow::Flow;
use super::interface::{FieldKind, FieldSpec, ParticleModel, StateBlowUp};
use super::sph::polymer::{PolymerCfg, packed_index, packed_width};
use crate::error::Error;
use crate::particles::{FieldFlags, Particles, Precision, VarData, tensor_rows};
use rayon::prelude::*;

/// Where each particle's velocity gradient comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum VelocityGradient {
    /// The same imposed κ(t) for every particle.
    Imposed(Flow),
    /// The particle's own value of this tensor field (κ_αβ = ∂v_α/∂x_β, row-major), written by
    /// another model before the state update.
    Field(&'static str),
}

/// The connector field's name.
pub const CONNECTORS: &str = "connectors";
/// The polymer stress field's name (τ_p, packed symmetric): derived from the connectors after
/// every update, for the momentum equation of a coupled fluid.
pub const POLYMER_STRESS: &str = crate::models::sph::POLYMER_STRESS;

/// Ensembles of `n_d` dumbbells per particle.
pub struct DumbbellEnsemble<const D: usize> {
    params: DumbbellParams,
    n_d: usize,
    modulus: f64,
    seed: u64,
    precision: Precision,
    kappa: VelocityGradient,
    /// The only species that carries dumbbells (none: every particle).
    carrier: Option<u8>,
    /// Whether a field κ is used without its trace (κ − (tr κ/D) I).
    deviatoric: bool,
    /// Whose streams each particle draws its connectors and increments from.
    noise: EnsembleNoise,
    /// Field indices: connectors (var), stress, κ (extra, when a field is the source).
    connectors: usize,
    stress: usize,
    kappa_field: Option<usize>,
}

impl<const D: usize> DumbbellEnsemble<D> {
    /// Ensembles of `n_d` dumbbells per particle with modulus G = `modulus`.
    pub fn new(
        params: DumbbellParams,
        n_d: usize,
        modulus: f64,
        seed: u64,
        precision: Precision,
        kappa: VelocityGradient,
    ) -> Result<Self, String> {
        params.check()?;
        Ok(Self {
            params,
            n_d,
            modulus,
            seed,
            precision,
            kappa,
            carrier: None,
            deviatoric: false,
            noise: EnsembleNoise::Independent,
            connectors: usize::MAX,
            stress: usize::MAX,
            kappa_field: None,
        })
    }

    /// The ensembles of a `[fluid.polymer] model = "dumbbells"` table, at time step `dt`,
    /// stepping with the velocity-gradient field `kappa_field`, carried by the species
    /// `carrier` only (none: every particle).
    ///
    /// The dumbbells see the traceless part κ − (tr κ/D) I of the fluid's estimate: the
    /// polymer lives in an incompressible solvent, and the weakly compressible fluid's ∇·v is
    /// acoustic, O(M²). On the disordered arrangement the ensembles' own noise makes, the
    /// corrected SPH estimate's trace also has a spurious mean (+0.004γ̇ measured in
    /// `connffessit_shear_2d.toml`, N_d = 100) that would stretch every dumbbell: N₁ +0.9 %
    /// with it, −0.1 % without.
    pub fn of_fluid(
        cfg: &PolymerCfg,
        dt: f64,
        seed: u64,
        kappa_field: &'static str,
        carrier: Option<u8>,
    ) -> Result<Self, String> {
        let mut e = Self::new(
            cfg.dumbbell_params(dt),
            cfg.per_particle.unwrap_or(0),
            cfg.modulus(),
            seed,
            cfg.connector_precision(),
            VelocityGradient::Field(kappa_field),
        )?;
        e.carrier = carrier;
        e.deviatoric = true;
        e.noise = cfg.ensemble_noise();
        Ok(e)
    }

    /// τ_p of every owned particle from its connectors (0 for an empty ensemble).
    fn update_stress(&self, p: &mut Particles<D>) {
        let (g, spring) = (self.modulus, self.params.spring);
        let Particles { var, extra, .. } = p;
        let rows = &var[self.connectors].data;
        let stress = &mut extra[self.stress].data;
        let w = packed_width(D);
        stress
            .par_chunks_mut(w)
            .take(rows.len())
            .enumerate()
            .for_each_init(Vec::new, |wide: &mut Vec<f64>, (i, out)| {
                wide.clear();
                rows.extend_f64(i, wide);
                if wide.is_empty() {
                    out.fill(0.0);
                    return;
                }
                let s = kramers_stress::<D>(wide, spring);
                for a in 0..D {
                    for b in a..D {
                        out[packed_index::<D>(a, b)] = g * s[a * D + b];
                    }
                }
            });
    }
}

impl<const D: usize> ParticleModel<D> for DumbbellEnsemble<D> {
    fn name(&self) -> &'static str {
        "dumbbell ensembles"
    }

    fn fields(&self) -> Vec<FieldSpec> {
        vec![
            FieldSpec {
                name: CONNECTORS,
                kind: FieldKind::Ensemble(self.precision),
                flags: FieldFlags::STATE,
            },
            FieldSpec {
                name: POLYMER_STRESS,
                kind: FieldKind::Values(packed_width(D)),
                // Formed from the connectors in `update_state`, which runs before the step's
                // neighbour rebuild: a particle that migrates then must carry its τ_p to its
                // new rank, where the momentum pass reads it. (As a derived field it arrived
                // without it, and its neighbours' forces differed from a one-rank run's.) Not
                // checkpointed: `attach` forms it again from the connectors.
                flags: FieldFlags {
                    migrates: true,
                    ..FieldFlags::DERIVED
                },
            },
        ]
    }

    fn attach(&mut self, p: &mut Particles<D>, restarted: bool) -> Result<(), Error> {
        self.connectors = (p.var.iter().position(|f| f.name == CONNECTORS))
            .ok_or("the connector field is not registered")?;
        self.stress = p.extra_index(POLYMER_STRESS).ok_or("no stress field")?;
        self.kappa_field = match &self.kappa {
            VelocityGradient::Imposed(_) => None,
            VelocityGradient::Field(name) => {
                let k = p.extra_index(name).ok_or_else(|| {
                    format!("the velocity-gradient field `{name}` is not registered")
                })?;
                if p.extra[k].width != D * D {
                    return Err(format!("the velocity-gradient field `{name}` is not D × D").into());
                }
                Some(k)
            }
        };
        if !restarted {
            let (n_d, seed, spring, noise) = (self.n_d, self.seed, self.params.spring, self.noise);
            let carrier = self.carrier;
            let Particles {
                var, gid, species, ..
            } = p;
            let species = species.as_deref();
            let fresh = |i: usize| {
                if carrier.is_some_and(|c| species.is_some_and(|s| s[i] != c)) {
                    return Vec::new();
                }
                let mut q = vec![0.0; n_d * D];
                sample_equilibrium::<D>(
                    &mut q,
                    spring,
                    &mut init_stream(seed, noise.stream_owner(gid[i])),
                );
                q
            };
            let n = var[self.connectors].data.len();
            var[self.connectors].data = match self.precision {
                Precision::Double => VarData::Double((0..n).into_par_iter().map(fresh).collect()),
                Precision::Single => VarData::Single(
                    (0..n)
                        .into_par_iter()
                        .map(|i| fresh(i).into_iter().map(|x| x as f32).collect())
                        .collect(),
                ),
            };
        }
        self.update_stress(p);
        Ok(())
    }

    /// One step of every owned particle's ensemble, with κ frozen at the start of the step
    /// (time (step − 1) Δt) and the noise of step − 1, as in a homogeneous-flow scene. A
    /// connector left outside the spring's domain (|Q|² ≥ b for FENE, not finite for either
    /// spring; checked on what is stored, after any rounding to single precision) is returned,
    /// the lowest particle id and dumbbell index first.
    fn update_state(&self, p: &mut Particles<D>, step: u64) -> Option<StateBlowUp> {
        let n = step - 1;
        let (params, seed, streams) = (self.params, self.seed, self.noise);
        let imposed = match &self.kappa {
            VelocityGradient::Imposed(flow) => {
                Some(tensor_rows(&flow.kappa::<D>(n as f64 * params.dt)))
            }
            VelocityGradient::Field(_) => None,
        };
        let Particles {
            var, extra, gid, ..
        } = p;
        let kappa_of = |i: usize| -> [[f64; D]; D] {
            match (imposed, self.kappa_field) {
                (Some(k), _) => k,
                (None, Some(f)) => {
                    let v = &extra[f].data[i * D * D..(i + 1) * D * D];
                    let mut k: [[f64; D]; D] =
                        std::array::from_fn(|a| std::array::from_fn(|b| v[a * D + b]));
                    if self.deviatoric {
                        let mean = (0..D).map(|a| k[a][a]).sum::<f64>() / D as f64;
                        for (a, row) in k.iter_mut().enumerate() {
                            row[a] -= mean;
                        }
                    }
                    k
                }
                (None, None) => unreachable!("attach resolved the source"),
            }
        };
        let limit = self.domain_limit();
        let gid = &*gid;
        let blow_up = match &mut var[self.connectors].data {
            VarData::Double(rows) => rows
                .par_iter_mut()
                .enumerate()
                .filter_map(|(i, q)| {
                    if q.is_empty() {
                        return None;
                    }
                    let mut noise = noise_stream(seed, streams.stream_owner(gid[i]), n, 0);
                    step_ensemble::<D>(q, &kappa_of(i), &params, &mut noise);
                    outside_domain::<D, f64>(q, limit).map(|(k, q2)| (gid[i], k, q2))
                })
                .min_by_key(|v| (v.0, v.1)),
            VarData::Single(rows) => {
                // Widened to f64, advanced with the same arithmetic, rounded back.
                rows.par_iter_mut()
                    .enumerate()
                    .map_init(Vec::new, |wide: &mut Vec<f64>, (i, q)| {
                        if q.is_empty() {
                            return None;
                        }
                        wide.clear();
                        wide.extend(q.iter().map(|&x| f64::from(x)));
                        let mut noise = noise_stream(seed, streams.stream_owner(gid[i]), n, 0);
                        step_ensemble::<D>(wide, &kappa_of(i), &params, &mut noise);
                        for (s, w) in q.iter_mut().zip(wide.iter()) {
                            *s = *w as f32;
                        }
                        outside_domain::<D, f32>(q, limit).map(|(k, q2)| (gid[i], k, q2))
                    })
                    .flatten()
                    .min_by_key(|v| (v.0, v.1))
            }
        };
        self.update_stress(p);
        blow_up.map(|(gid, k, q2)| StateBlowUp {
            gid,
            item: k as u64,
            value: if q2.is_finite() { q2 } else { f64::INFINITY },
        })
    }

    fn state_quantity(&self) -> crate::error::Quantity {
        crate::error::Quantity::Connector
    }

    fn describe_state_blow_up(&self, b: &StateBlowUp) -> String {
        format!(
            "dumbbell {} of particle {} has |Q|² = {:.6e}{} (the connector left the spring's \
             domain{})",
            b.item,
            b.gid,
            b.value,
            match self.params.spring {
                Spring::Fene { b: limit } if b.value.is_finite() => format!(" ≥ b = {limit}"),
                _ => " (not finite)".into(),
            },
            if self.precision == Precision::Single {
                "; or store the connectors in double precision"
            } else {
                ""
            }
        )
    }
}

impl<const D: usize> DumbbellEnsemble<D> {
    /// |Q|² at which a connector has left its spring's domain: b for FENE; for Hookean only a
    /// value that is not finite (the flow in a particle scene is not known in advance, so no
    /// runaway bound as in a homogeneous flow).
    fn domain_limit(&self) -> f64 {
        match self.params.spring {
            Spring::Fene { b } => b,
            Spring::Hookean => f64::INFINITY,
        }
    }
}
