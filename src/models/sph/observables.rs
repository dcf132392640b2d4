//! The observables only an SPH fluid can measure, from its own fields: the particles' mean
//! constitutive stress and polymer trace, the density profile, the forces on the walls, and
//! the composite stress and torque of a suspension. Each is a set of exact sums over the owned
//! particles ([`FixedSum`]); the engine reduces them over the ranks
//! ([`crate::models::interface::ParticleModel::observable_sums`]), so every value is bitwise
//! the same on any decomposition.

use super::model::SphModel;
use super::polymer::{packed_index, packed_width};
use super::{DENSITY, INCLUSION, INCLUSION_TRACTION_MOMENT, LOWER_WALL, POLYMER_STRESS};
use super::{UPPER_WALL, VISCOUS_STRESS};
use crate::fixed_sum::FixedSum;
use crate::geometry::GRADIENT;
use crate::models::interface::MeasureContext;
use crate::observable::{DENSITY_PROFILE_PREFIX, Observable, constitutive_names};
use crate::particles::Particles;

/// Sums over this many particles before renormalising the fixed-point sums.
const NORMALIZE_EVERY: usize = 2048;

/// Where an SPH particle's deviatoric stress lives: the Newtonian (viscous) stress, D×D, and
/// the polymer stress, packed symmetric; either may be absent.
struct ParticleStress {
    viscous: Option<usize>,
    polymer: Option<usize>,
}

impl ParticleStress {
    fn of<const D: usize>(p: &Particles<D>) -> Self {
        Self {
            viscous: p.extra_index(VISCOUS_STRESS),
            polymer: p.extra_index(POLYMER_STRESS),
        }
    }

    /// σ_ab of particle k, viscous + polymer.
    #[inline]
    fn component<const D: usize>(&self, p: &Particles<D>, k: usize, a: usize, b: usize) -> f64 {
        let mut s = self
            .viscous
            .map_or(0.0, |v| p.extra[v].data[k * D * D + a * D + b]);
        if let Some(t) = self.polymer {
            s += p.extra[t].data[k * packed_width(D) + packed_index::<D>(a, b)];
        }
        s
    }
}

/// The bin of coordinate `y` among `bins` equal bins across [0, `ly`) (clamped to the ends).
fn profile_bin(y: f64, ly: f64, bins: usize) -> usize {
    ((y / ly * bins as f64).floor().max(0.0) as usize).min(bins - 1)
}

/// Adds `f(k, sums)` for every owned particle k, renormalising on the way and at the end.
fn sum_owned<const D: usize>(
    p: &Particles<D>,
    width: usize,
    mut f: impl FnMut(usize, &mut [FixedSum]),
) -> Vec<FixedSum> {
    let mut sums = vec![FixedSum::ZERO; width];
    for k in 0..p.n_owned {
        f(k, &mut sums);
        if k % NORMALIZE_EVERY == NORMALIZE_EVERY - 1 {
            sums.iter_mut().for_each(FixedSum::normalize);
        }
    }
    sums.iter_mut().for_each(FixedSum::normalize);
    sums
}

impl<const D: usize> SphModel<D> {
    /// The observables an SPH fluid measures itself.
    pub(super) fn measures_observable(&self, o: Observable) -> bool {
        matches!(
            o,
            Observable::ConstitutiveStress
                | Observable::PolymerStressTrace
                | Observable::DensityProfile
                | Observable::WallShearStress
                | Observable::CompositeViscosity
        )
    }

    /// This rank's sums of observable `o`.
    pub(super) fn sums_of(
        &self,
        o: Observable,
        p: &Particles<D>,
        ctx: &MeasureContext<'_, D>,
    ) -> Vec<FixedSum> {
        match o {
            Observable::ConstitutiveStress | Observable::PolymerStressTrace => {
                self.mean_stress_sums(p, ctx)
            }
            Observable::DensityProfile => self.density_profile_sums(p, ctx),
            Observable::WallShearStress => self.wall_force_sums(p),
            Observable::CompositeViscosity => self.composite_stress_sums(p, ctx),
            _ => Vec::new(),
        }
    }

    /// The named values of observable `o` from its reduced sums.
    pub(super) fn values_of(
        &self,
        o: Observable,
        sums: &[f64],
        ctx: &MeasureContext<'_, D>,
    ) -> Vec<(String, f64)> {
        let dd = D * D;
        match o {
            Observable::ConstitutiveStress => {
                // σ̄ = −P: η = σ̄_xy/γ̇, N₁ = σ̄_xx − σ̄_yy, N₂ = σ̄_yy − σ̄_zz.
                let n = sums[0];
                let c = |a: usize, b: usize| {
                    if a < D && b < D {
                        sums[1 + a * D + b] / n
                    } else {
                        f64::NAN
                    }
                };
                let values = [
                    c(0, 1) / ctx.shear_rate,
                    c(0, 0) - c(1, 1),
                    c(1, 1) - c(2, 2),
                ];
                constitutive_names(D)
                    .iter()
                    .zip(values)
                    .map(|(name, v)| ((*name).to_string(), v))
                    .collect()
            }
            // 0 for a fluid without a polymer stress.
            Observable::PolymerStressTrace => {
                vec![("polymer_stress_trace".into(), sums[dd + 1] / sums[0])]
            }
            Observable::DensityProfile => (0..ctx.profile_bins)
                .map(|b| {
                    (
                        format!("{DENSITY_PROFILE_PREFIX}{b:04}"),
                        sums[2 * b + 1] / sums[2 * b],
                    )
                })
                .collect(),
            Observable::WallShearStress => {
                let [lower, upper] = match &self.boundaries.walls {
                    Some(w) => {
                        let area: f64 = (0..D)
                            .filter(|&d| d != w.axis)
                            .map(|d| ctx.lengths[d])
                            .product();
                        [sums[0] / area, sums[1] / area]
                    }
                    None => [f64::NAN; 2],
                };
                vec![
                    ("wall_shear_stress_lower".into(), lower),
                    ("wall_shear_stress_upper".into(), upper),
                ]
            }
            Observable::CompositeViscosity => {
                // No sums without the traction moments (no inclusions).
                let (stress, torque) = if sums.len() == 3 {
                    let inclusions = self.inclusions.as_ref().map_or(1, |i| i.centres.len());
                    (
                        (sums[0] + sums[1]) / ctx.volume(),
                        sums[2] / inclusions as f64,
                    )
                } else {
                    (f64::NAN, f64::NAN)
                };
                vec![
                    ("composite_viscosity".into(), stress / ctx.shear_rate),
                    ("inclusion_torque".into(), torque),
                ]
            }
            _ => Vec::new(),
        }
    }

    /// The mean deviatoric stress of the fluid particles, σ̄ = viscous stress (nested
    /// summation) + polymer stress τ, D×D row-major (the thesis's unweighted particle mean,
    /// Eq. 3.18), and the mean |tr τ|: count, D² components, Σ|tr τ|.
    fn mean_stress_sums(&self, p: &Particles<D>, ctx: &MeasureContext<'_, D>) -> Vec<FixedSum> {
        let dd = D * D;
        let stress = ParticleStress::of(p);
        let polymer = p.extra_index(POLYMER_STRESS);
        let w = packed_width(D);
        sum_owned(p, dd + 2, |k, sums| {
            if !ctx.is_fluid(p, k) {
                return;
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
        })
    }

    /// The mean density of the fluid particles in each of `diagnostics.profile_bins` bins
    /// across the box along y (NaN for an empty bin): count and Σρ per bin.
    fn density_profile_sums(&self, p: &Particles<D>, ctx: &MeasureContext<'_, D>) -> Vec<FixedSum> {
        let bins = ctx.profile_bins;
        let ly = ctx.lengths[GRADIENT];
        let rho = p.extra_index(DENSITY).map(|i| &p.extra[i].data);
        sum_owned(p, 2 * bins, |k, sums| {
            if let Some(density) = rho.filter(|_| ctx.is_fluid(p, k)) {
                let b = profile_bin(p.pos[k][GRADIENT], ly, bins);
                sums[2 * b].add(1.0);
                sums[2 * b + 1].add(density[k]);
            }
        })
    }

    /// The force along x on the lower and the upper wall: the sums of the forces on their
    /// boundary particles, which the momentum pass fills with the reactions of their fluid
    /// neighbours (divided by the wall's area in [`Self::values_of`]).
    fn wall_force_sums(&self, p: &Particles<D>) -> Vec<FixedSum> {
        sum_owned(p, 2, |k, sums| match p.species_of(k) {
            LOWER_WALL => sums[0].add(p.force[k][0]),
            UPPER_WALL => sums[1].add(p.force[k][0]),
            _ => {}
        })
    }

    /// The composite shear stress of a suspension, [Σ_fluid (m/ρ_i) σ_i,xy + Σ_inclusion
    /// particles M_j^{xy}] / V with M the traction moments F ⊗ (x − c) (Batchelor 1970: the
    /// cell average of the stress, the inclusions' share from their surface tractions), and
    /// the mean torque per inclusion about z, Σ_j (M_j^{yx} − M_j^{xy}) / N_inclusions: the
    /// fluid's Σ V_i σ_i,xy, the inclusions' Σ M^{xy} and Σ (M^{yx} − M^{xy}).
    fn composite_stress_sums(
        &self,
        p: &Particles<D>,
        ctx: &MeasureContext<'_, D>,
    ) -> Vec<FixedSum> {
        let dd = D * D;
        let (Some(density), Some(moment)) = (
            p.extra_index(DENSITY),
            p.extra_index(INCLUSION_TRACTION_MOMENT),
        ) else {
            return Vec::new();
        };
        let stress = ParticleStress::of(p);
        sum_owned(p, 3, |k, sums| {
            let species = p.species_of(k);
            if ctx.is_fluid(p, k) {
                let s = stress.component(p, k, 0, 1);
                sums[0].add(ctx.species[species as usize].mass / p.extra[density].data[k] * s);
            } else if species == INCLUSION {
                let m = &p.extra[moment].data[k * dd..(k + 1) * dd];
                sums[1].add(m[1]);
                sums[2].add(m[D] - m[1]);
            }
        })
    }
}
