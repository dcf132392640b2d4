//! The momentum flux of the SPH pair forces: the configurational (virial) part of the
//! Irving–Kirkwood pressure tensor, from the very pair forces the momentum equation applies.
//!
//! ```text
//! P_ab V = Σ_i m_i V_i^a V_i^b  +  Σ_pairs F_ij^a ℓ_ij^b          (V = box volume)
//! σ_ab   = −P_ab,   η = −P_xy/γ̇,   N₁ = P_yy − P_xx,   N₂ = P_zz − P_yy
//! ```
//!
//! F_ij is the force on i from j, as [`GatherKernel::pair`] forms it (pressure, Morris's or the
//! nested summation's viscous term, the polymer stress τ, the wall repulsion); V_i the velocity
//! about the local streaming profile (the engine's kinetic part). P_ab is the flux of
//! a-momentum across planes normal to b: Morris's viscous force is along v_ij, not along x_ij,
//! so the tensor is not symmetric, and its shear component is Σ F^x ℓ^y (the x-momentum
//! crossing planes y = const), the one `viscosity` reads. For central forces (pressure, DPD) the
//! order does not matter.
//!
//! The lever ℓ_ij:
//! - fluid–fluid and fluid–wall pairs: ℓ = x_ij = x_i − x_j (the segment the momentum crosses);
//! - fluid particle f and inclusion particle b: ℓ = x_f − c, c the centre of b's inclusion,
//!   with the force on the fluid end. This is the whole cell's flux, the rigid body's interior
//!   included: with the constraint forces f_bk that hold an inclusion rigid and the external
//!   forces F_b^e that hold it fixed, F_b^fluid + Σ_k f_bk + F_b^e = 0 per body particle, so
//!   Σ_bb x_bk ⊗ f_bk + Σ_b (x_b − c) ⊗ F_b^e = −Σ_b (x_b − c) ⊗ F_b^fluid, which joins the
//!   pair term x_fb ⊗ F_fb into (x_f − c) ⊗ F_fb (the term c ⊗ Σ_b F_b^e, the mean force on
//!   a fixed inclusion, vanishes on average). The external couple that keeps the inclusion
//!   from turning is in it: the antisymmetric part of the cell stress (Batchelor 1970).
//! - two boundary particles: no force, nothing.
//!
//! The pair sum is [`half_list_virial`]: every pair adds ½ of its term once per owned end,
//! exactly (the pair terms being exactly antisymmetric), so the sum is the same integer on any
//! rank and thread count.
//!
//! The parts (the `stress` observable's `pressure`, `viscous`, `polymer` parts): the pressure
//! (with the background pressure and the wall repulsion), the polymer stress term, and the rest
//! of the pair force (Morris's term or the nested summation's σ̄), so that the parts add up to
//! the force actually applied.

use super::{FLUID, INCLUSION, MomentumKernel};
use crate::models::gather::GatherKernel;
use crate::models::gather::PairError;
use crate::models::pair_loop::Virial;
use crate::models::pair_virial::half_list_virial;
use crate::neighbour::NeighbourList;
use crate::particles::Particles;

use super::kernels::Kernel;

/// Names of the three parts of the SPH virial, in [`Virial`] order.
pub const SPH_STRESS_PARTS: [&str; 3] = ["pressure", "viscous", "polymer"];

impl<K: Kernel, const D: usize> MomentumKernel<'_, K, D> {
    /// The momentum equation's pair force F_ij on i, split into [pressure, viscous, polymer]
    /// (see the module doc), and the lever ℓ_ij; `None` for a pair that exchanges nothing.
    fn flux_terms(
        &self,
        p: &Particles<D>,
        i: usize,
        j: usize,
        x: &[f64; D],
        r: f64,
    ) -> Option<([[f64; D]; 3], [f64; D])> {
        let (si, sj) = (p.species_of(i), p.species_of(j));
        if si != FLUID && sj != FLUID {
            return None;
        }
        let mut total = [0.0; crate::models::gather::MAX_SCATTER_WIDTH];
        let width = self.scales().len();
        self.pair(p, i, j, x, r, &mut total[..width]);
        let boundary_pair = si != sj;
        let fluid_end = if si == FLUID { i } else { j };
        let inclusion_pair = boundary_pair && (si == INCLUSION || sj == INCLUSION);
        let mm = self.mass * self.mass;
        let gw = self.kernel.dw_over_r(r);
        let (ri2, rj2) = (
            self.density[i] * self.density[i],
            self.density[j] * self.density[j],
        );
        let mut pressure = [0.0; D];
        let mut polymer = [0.0; D];
        if self.pairwise_stress {
            let p_sum = self.pressure_sum(i, j, fluid_end, inclusion_pair, ri2, rj2);
            for a in 0..D {
                pressure[a] = -p_sum * gw * x[a];
            }
            if self.polymer.is_some() {
                let ends =
                    self.stress_ends(i, j, fluid_end, boundary_pair, inclusion_pair, [ri2, rj2]);
                let t = self.stress_on_pair(&ends, x, false);
                for a in 0..D {
                    polymer[a] = mm * gw * t[a];
                }
            }
        }
        if let Some(s) = self.wall_repulsion(boundary_pair && !inclusion_pair, r) {
            for a in 0..D {
                pressure[a] += s * x[a];
            }
        }
        let mut parts = [[0.0; D]; 3];
        for a in 0..D {
            parts[0][a] = mm * pressure[a];
            parts[2][a] = polymer[a];
            parts[1][a] = total[a] - parts[0][a] - parts[2][a];
        }
        let lever = match self.boundaries.inclusions {
            Some(inc) if inclusion_pair => {
                if si == FLUID {
                    inc.centre_to_fluid(p, j, x).0
                } else {
                    // The force on the fluid end j is −F_ij: the lever's sign carries it.
                    let xji: [f64; D] = std::array::from_fn(|d| -x[d]);
                    let lever = inc.centre_to_fluid(p, i, &xji).0;
                    std::array::from_fn(|d| -lever[d])
                }
            }
            _ => *x,
        };
        Some((parts, lever))
    }
}

/// Σ_pairs F_ij ⊗ ℓ_ij per part over the half list (component a·D + b = Σ F^a ℓ^b), an
/// owned–ghost pair at half weight ([`half_list_virial`]); exact, and the same on any number of
/// threads and ranks.
pub(super) fn momentum_virial<K: Kernel, const D: usize>(
    kernel: &MomentumKernel<'_, K, D>,
    p: &Particles<D>,
    list: &NeighbourList<D>,
) -> Result<Virial, PairError> {
    half_list_virial(p, list, kernel.cutoff(), |i, j, x, r| {
        kernel.flux_terms(p, i, j, x, r)
    })
}
