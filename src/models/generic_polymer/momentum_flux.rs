//! The momentum flux of the GENERIC polymer fluid's pair forces: the configurational (virial)
//! part of the Irving–Kirkwood pressure tensor, from the very pair forces the momentum
//! equation applies (issue #43: "polymer stress from the momentum flux").
//!
//! ```text
//! P_ab V = Σ_i m V_i^a V_i^b  +  Σ_pairs F_ij^a r_ij^b          (V = box volume)
//! σ_ab   = −P_ab,   η = −P_xy/γ̇,   N₁ = P_yy − P_xx,   N₂ = P_zz − P_yy
//! ```
//!
//! F_ij is the force on i from j exactly as [`GatherKernel::pair`] forms it for the step (the
//! same pair noise, keyed by the step and the pair's ids), V_i the velocity about the local
//! streaming profile (the engine's kinetic part). The friction term lies along v_ij and the
//! polymer term along Π·ω_ij, so the tensor is not symmetric; `viscosity` reads Σ F^x r^y, the
//! x-momentum crossing planes y = const.
//!
//! The parts (the `stress` observable's `pressure`, `viscous`, `polymer`):
//! - `pressure`: [(c_s²(ρ_i − ρ_sub) + p_b)/d_i² + (same)_j/d_j²] ω_ij, the fluid's pressure
//!   (with the background pressure p_b of the transport-velocity form);
//! - `polymer`: [Π^p_i/d_i² + Π^p_j/d_j²]·ω_ij with Π^p = k_BT n^d 1 − H n^d Q Q (Model A: ⟨QQ⟩_i),
//!   whose flux is the polymer stress the momentum equation transmits; in homogeneous shear
//!   its −P_xy/γ̇ is the flux counterpart of the particle-averaged η_p of `constitutive_stress`
//!   (Eq. 4.68), equal to it when Σ_j r_ij ⊗ ω_ij = 1 per particle (an ordered arrangement);
//! - `viscous`: the rest of the applied pair force, the friction −F_ij/(d_i d_j)[a v_ij +
//!   b e_ij(e_ij·v_ij)] and the pair noise X_ij, so that the parts add up to the force.
//!
//! Not in the flux: the transport velocity's shift ½Δt a^t_i (it moves particles, it is not a
//! force; its momentum flux m V ⊗ ½Δt a^t is O(Δt) and is left out) and the conformation noise
//! (not a force).
//!
//! The pair sum is [`half_list_virial`] (exact, half weight per owned end; the pair force is
//! exactly antisymmetric, unit test `pair_terms_are_bitwise_antisymmetric`), so the flux is the
//! same on any rank and thread count.

use super::PairKernel;
use crate::models::gather::{GatherKernel, PairError};
use crate::models::pair_loop::Virial;
use crate::models::pair_virial::half_list_virial;
use crate::models::sph::kernels::Kernel;
use crate::neighbour::NeighbourList;
use crate::particles::Particles;

/// Names of the GENERIC fluid's stress parts, after the total and the kinetic part, in
/// [`Virial`] order.
pub const GENERIC_STRESS_PARTS: [&str; 5] = ["total", "kinetic", "pressure", "viscous", "polymer"];

/// The widest row [`PairKernel::pair`] writes: 1 + D² + D + D + D² ≤ 25 in 3D.
const MAX_WIDTH: usize = 32;

impl<const D: usize> PairKernel<D> {
    /// Particle i's (isotropic fluid pressure, polymer pressure tensor Π^p) over d_i², the two
    /// parts of [`Self::pressure_over_d2`] (which sums them in one expression for the force).
    fn pressure_parts_over_d2(&self, p: &Particles<D>, i: usize) -> (f64, [[f64; D]; D]) {
        let rho = p.extra[self.density].data[i];
        let d = rho / self.mass;
        let inv_d2 = 1.0 / (d * d);
        let fluid = (self.c2 * (rho - self.subtracted_density) + self.background) * inv_d2;
        let qq = |a: usize, b: usize| {
            if self.moment != usize::MAX {
                p.extra[self.moment].data[i * D * D + a * D + b]
            } else {
                let q = &p.extra[self.conformation].data[i * D..(i + 1) * D];
                q[a] * q[b]
            }
        };
        let polymer = std::array::from_fn(|a| {
            std::array::from_fn(|b| {
                let iso = if a == b { self.osmotic } else { 0.0 };
                (iso - self.spring_n * qq(a, b)) * inv_d2
            })
        });
        (fluid, polymer)
    }

    /// The pair force on i from j that the momentum equation applies, split into [pressure,
    /// viscous, polymer] (module doc); `r_ij` = r_i − r_j, `r` its length.
    fn force_parts(
        &self,
        p: &Particles<D>,
        i: usize,
        j: usize,
        r_ij: &[f64; D],
        r: f64,
    ) -> [[f64; D]; 3] {
        let width = self.scales().len();
        debug_assert!(width <= MAX_WIDTH);
        let mut row = [0.0; MAX_WIDTH];
        self.pair(p, i, j, r_ij, r, &mut row[..width]);
        let total = &row[1 + D * D..1 + D * D + D];
        let f = -self.lucy.dw_over_r(r);
        let omega: [f64; D] = std::array::from_fn(|a| f * r_ij[a]);
        let (fluid_i, polymer_i) = self.pressure_parts_over_d2(p, i);
        let (fluid_j, polymer_j) = self.pressure_parts_over_d2(p, j);
        let mut parts = [[0.0; D]; 3];
        for a in 0..D {
            parts[0][a] = (fluid_i + fluid_j) * omega[a];
            parts[2][a] = (0..D)
                .map(|b| (polymer_i[a][b] + polymer_j[a][b]) * omega[b])
                .sum();
            parts[1][a] = total[a] - parts[0][a] - parts[2][a];
        }
        parts
    }
}

/// Σ_pairs F_ij ⊗ r_ij per part over the half list (component a·D + b = Σ F^a r^b), an
/// owned–ghost pair at half weight ([`half_list_virial`]); exact, and the same on any number of
/// threads and ranks.
pub(super) fn momentum_virial<const D: usize>(
    kernel: &PairKernel<D>,
    p: &Particles<D>,
    list: &NeighbourList<D>,
) -> Result<Virial, PairError> {
    half_list_virial(p, list, kernel.cutoff(), |i, j, x, r| {
        Some((kernel.force_parts(p, i, j, x, r), *x))
    })
}
