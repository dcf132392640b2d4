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

use super::bddfs::{QGrid, Workspace, histogram_of, step_histogram};
use super::dumbbell_settings::EnsembleNoise;
use super::dumbbells::{
    DumbbellParams, Spring, init_stream, kramers_stress, noise_stream, outside_domain,
    sample_equilibrium, step_ensemble,
};
use super::homogeneous_flow::Flow;
use super::interface::{FieldKind, FieldSpec, ParticleModel, StateBlowUp};
use super::sph::polymer::{PolymerCfg, packed_index, packed_width};
use crate::error::Error;
use crate::particles::{FieldFlags, Particles, Precision, VarData, VarStorage, tensor_rows};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

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
/// The histogram field's name (BDDFS storage): per particle its occupied cells, packed
/// (cell << 32 | count) by increasing cell ([`super::bddfs`]).
pub const HISTOGRAMS: &str = "histograms";
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
    /// BDDFS storage ([`super::bddfs`]): each particle keeps the histogram of its connectors
    /// on this grid, and every step regenerates them, advances them and histograms them again.
    grid: Option<QGrid>,
    /// BDDFS: connectors found outside the grid and counted in a boundary cell, and FENE
    /// reconstructions that fell back to the cell's point nearest the origin (this rank,
    /// since the process started).
    clipped: AtomicU64,
    fallbacks: AtomicU64,
    /// Field indices: connectors or histograms (var), stress, κ (extra, when a field is the
    /// source).
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
            grid: None,
            clipped: AtomicU64::new(0),
            fallbacks: AtomicU64::new(0),
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
        e.grid = cfg.histogram_grid();
        Ok(e)
    }

    /// The same ensembles stored as histograms on `grid` (BDDFS): the same initial connectors
    /// (binned), the same scheme and noise keys, the Kramers stress of the regenerated and
    /// advanced connectors.
    pub fn with_histograms(mut self, grid: QGrid) -> Result<Self, String> {
        grid.check(D, self.params.spring)?;
        self.grid = Some(grid);
        Ok(self)
    }

    /// The name of the field that holds the state.
    fn state_field(&self) -> &'static str {
        if self.grid.is_some() {
            HISTOGRAMS
        } else {
            CONNECTORS
        }
    }

    /// τ_p (packed) of the Kramers stress s = ⟨QF(Q)⟩ − I (D × D row-major) into `out`.
    fn write_stress(&self, s: &[f64; 9], out: &mut [f64]) {
        for a in 0..D {
            for b in a..D {
                out[packed_index::<D>(a, b)] = self.modulus * s[a * D + b];
            }
        }
    }

    /// τ_p of every owned particle from its connectors (0 for an empty ensemble).
    fn update_stress(&self, p: &mut Particles<D>) {
        let spring = self.params.spring;
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
                self.write_stress(&kramers_stress::<D>(wide, spring), out);
            });
    }
}

impl<const D: usize> ParticleModel<D> for DumbbellEnsemble<D> {
    fn name(&self) -> &'static str {
        "dumbbell ensembles"
    }

    fn fields(&self) -> Vec<FieldSpec> {
        if self.grid.is_some() {
            return vec![
                FieldSpec {
                    name: HISTOGRAMS,
                    kind: FieldKind::Ensemble(VarStorage::Words),
                    flags: FieldFlags::STATE,
                },
                FieldSpec {
                    name: POLYMER_STRESS,
                    kind: FieldKind::Values(packed_width(D)),
                    // Measured on the advanced connectors of the last step, which the histogram
                    // no longer holds: state (migrated, checkpointed, digested).
                    flags: FieldFlags::STATE,
                },
            ];
        }
        vec![
            FieldSpec {
                name: CONNECTORS,
                kind: FieldKind::Ensemble(self.precision.into()),
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

    /// `conformation`: the mean ⟨QQ⟩ over each owned particle's explicit dumbbells (packed
    /// upper triangle; 0 for a particle without dumbbells); `polymer_stress`: their Kramers τ_p.
    fn snapshot_values(&self, name: &str, p: &Particles<D>) -> Option<Vec<f64>> {
        let n = p.n_owned;
        let w = packed_width(D);
        match name {
            "conformation" if self.grid.is_none() => {
                let rows = &p.var[self.connectors].data;
                let mut out = vec![0.0; n * w];
                let mut q = Vec::new();
                for (i, o) in out.chunks_mut(w).enumerate().take(rows.len()) {
                    q.clear();
                    rows.extend_f64(i, &mut q);
                    let count = q.len() / D;
                    if count == 0 {
                        continue;
                    }
                    for a in 0..D {
                        for b in a..D {
                            let sum: f64 = q.chunks_exact(D).map(|v| v[a] * v[b]).sum();
                            o[packed_index::<D>(a, b)] = sum / count as f64;
                        }
                    }
                }
                Some(out)
            }
            "polymer_stress" => Some(p.extra[self.stress].data[..n * w].to_vec()),
            _ => None,
        }
    }

    fn attach(&mut self, p: &mut Particles<D>, restarted: bool) -> Result<(), Error> {
        let state = self.state_field();
        self.connectors = (p.var.iter().position(|f| f.name == state))
            .ok_or_else(|| format!("the field `{state}` is not registered"))?;
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
            if let Some(grid) = self.grid {
                // The histograms of the same initial connectors, and their stress.
                let (rows, stress): (Vec<Vec<u64>>, Vec<Option<[f64; 9]>>) = (0..n)
                    .into_par_iter()
                    .map(|i| {
                        let q = fresh(i);
                        if q.is_empty() {
                            return (Vec::new(), None);
                        }
                        let (row, clipped) = histogram_of::<D>(&q, &grid);
                        self.clipped.fetch_add(clipped, Ordering::Relaxed);
                        (row, Some(kramers_stress::<D>(&q, spring)))
                    })
                    .unzip();
                var[self.connectors].data = VarData::Words(rows);
                let out = &mut p.extra[self.stress].data;
                let w = packed_width(D);
                for (i, s) in stress.iter().enumerate() {
                    match s {
                        Some(s) => self.write_stress(s, &mut out[i * w..(i + 1) * w]),
                        None => out[i * w..(i + 1) * w].fill(0.0),
                    }
                }
                return Ok(());
            }
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
        if self.grid.is_some() {
            // Restarted: the stress of the last step came with the checkpoint (the histogram
            // no longer holds the connectors it was measured on).
            return Ok(());
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
        // Every branch writes τ_p of the advanced ensemble during the step, while its connectors
        // are in cache (a second pass copied and read all of them again: 8 % of a CONNFFESSIT
        // channel's step, 2026-11-28); BDDFS measures it on connectors it does not keep. The
        // field is taken out (κ may be read from `extra` meanwhile) and put back below.
        let mut measured = std::mem::take(&mut extra[self.stress].data);
        let w = packed_width(D);
        let spring = params.spring;
        // Zipped below with the rows: a shorter field would leave ensembles unadvanced.
        assert!(
            measured.len() >= var[self.connectors].data.len() * w,
            "the polymer-stress field is shorter than the ensembles"
        );
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
                .zip(measured.par_chunks_mut(w))
                .enumerate()
                .filter_map(|(i, (q, out))| {
                    if q.is_empty() {
                        out.fill(0.0);
                        return None;
                    }
                    let mut noise = noise_stream(seed, streams.stream_owner(gid[i]), n, 0);
                    step_ensemble::<D>(q, &kappa_of(i), &params, &mut noise);
                    self.write_stress(&kramers_stress::<D>(q, spring), out);
                    outside_domain::<D, f64>(q, limit).map(|(k, q2)| (gid[i], k, q2))
                })
                .min_by_key(|v| (v.0, v.1)),
            VarData::Single(rows) => {
                // Widened to f64, advanced with the same arithmetic, rounded back.
                rows.par_iter_mut()
                    .zip(measured.par_chunks_mut(w))
                    .enumerate()
                    .map_init(Vec::new, |wide: &mut Vec<f64>, (i, (q, out))| {
                        if q.is_empty() {
                            out.fill(0.0);
                            return None;
                        }
                        wide.clear();
                        wide.extend(q.iter().map(|&x| f64::from(x)));
                        let mut noise = noise_stream(seed, streams.stream_owner(gid[i]), n, 0);
                        step_ensemble::<D>(wide, &kappa_of(i), &params, &mut noise);
                        // τ_p of what is stored: the rounded connectors, widened again.
                        for (s, x) in q.iter_mut().zip(wide.iter_mut()) {
                            *s = *x as f32;
                            *x = f64::from(*s);
                        }
                        self.write_stress(&kramers_stress::<D>(wide, spring), out);
                        outside_domain::<D, f32>(q, limit).map(|(k, q2)| (gid[i], k, q2))
                    })
                    .flatten()
                    .min_by_key(|v| (v.0, v.1))
            }
            VarData::Words(rows) => {
                // BDDFS: regenerate, advance, measure, histogram (super::bddfs), the noise
                // keyed by the same (seed, owner, step) as the connectors' above.
                let grid = self.grid.expect("histogram storage has a grid");
                rows.par_iter_mut()
                    .zip(measured.par_chunks_mut(w))
                    .enumerate()
                    .map_init(Workspace::default, |ws, (i, (row, out))| {
                        if row.is_empty() {
                            return None;
                        }
                        let owner = streams.stream_owner(gid[i]);
                        let m = step_histogram::<D>(
                            row,
                            &grid,
                            &kappa_of(i),
                            &params,
                            limit,
                            seed,
                            owner,
                            n,
                            ws,
                        );
                        self.write_stress(&m.stress, out);
                        self.clipped.fetch_add(m.clipped, Ordering::Relaxed);
                        self.fallbacks.fetch_add(m.fallbacks, Ordering::Relaxed);
                        m.outside.map(|(k, q2)| (gid[i], k, q2))
                    })
                    .flatten()
                    .min_by_key(|v| (v.0, v.1))
            }
        };
        extra[self.stress].data = measured;
        blow_up.map(|(gid, k, q2)| StateBlowUp {
            gid,
            item: k as u64,
            value: if q2.is_finite() { q2 } else { f64::INFINITY },
        })
    }

    fn counted_warnings(&self) -> Vec<(u64, &'static str)> {
        if self.grid.is_none() {
            return Vec::new();
        }
        vec![
            (
                self.clipped.load(Ordering::Relaxed),
                "{n} BDDFS connectors (dumbbell × step) lay outside the histogram grid and were \
                 counted in its boundary cell: raise fluid.polymer.q_max",
            ),
            (
                self.fallbacks.load(Ordering::Relaxed),
                "{n} FENE reconstructions (dumbbell × step) found no point of their cell inside \
                 |Q|² < b in 64 draws and took the cell's point nearest the origin",
            ),
        ]
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
