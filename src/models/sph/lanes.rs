//! The momentum (and continuity) sums of the fluid-only weakly compressible scheme, gathered
//! [`LANES`] particles at a time: the fast path of the momentum pass.
//!
//! ```text
//! F_i   = Σ_j m² [ −(p_i/ρ_i² + p_j/ρ_j²) F_ij x_ij + 2η/(ρ_i ρ_j) F_ij v_ij ]
//! dρ_i/dt = Σ_j m F_ij (v_ij · x_ij)                     F_ij = W′(r_ij)/r_ij
//! ```
//!
//! (Morris's viscous term, optionally regularised by r²/(r² + 0.01h²); continuity optional.)
//! These are the terms of `MomentumKernel::fluid_batch`, the same IEEE operations in the same
//! order, accumulated in the same fixed-point words ([`crate::fixed_sum`]): the sums are the
//! very bits that the scatter from the half list gives, so nothing downstream can tell the two
//! paths apart (a unit test compares them on every instruction set).
//!
//! Why it is faster: the scatter evaluates each pair once but must compact the pairs within
//! the support, gather both ends' data and add its words to both ends, one pair after another.
//! Here each vector lane is one particle walking its own row of the full list
//! ([`LaneRows`]): its own data stay in registers, one load per neighbour brings the other
//! end, the pairs beyond the support are masked to zero instead of compacted, and the words are
//! added to the lanes' accumulators without a store. Each pair is evaluated from both ends
//! (twice the arithmetic), which the eight-wide AVX-512 lanes more than repay: on the SPH
//! benchmark the pass takes 0.34 s against the AVX2 scatter's 0.58 s (docs/performance.md).
//! Without AVX-512 the scatter is faster, so the lanes run only where the CPU has it. Momentum is
//! still conserved to the bit: the term from j's end is the exact negative of the term from
//! i's end (x_ji = −x_ij, v_ji = −v_ij, the sums and products commute), and symmetric rounding
//! gives it the negated words.
//!
//! The velocity-gradient pass of the nested summation (the thesis's two-pass scheme) has its
//! lanes too, `GradientKernel::gather_lanes`, with `GradientKernel::pair`'s arithmetic:
//!
//! ```text
//! G_i = Σ_j (m/ρ_j) F_ij (v_j − v_i) ⊗ x_ij          M_i = Σ_j (m/ρ_j) F_ij (−x_ij) ⊗ x_ij
//! ```
//!
//! (M_i with the corrected gradient). They run in fluid-only scenes on CPUs with AVX-512;
//! elsewhere the pass takes the generic lanes of [`crate::models::gather::gather_in_lanes`]
//! (scalar pair terms, vector fixed-point words), and those failing, the gather pair by pair.

use super::MomentumKernel;
use super::kernels::Kernel;
use crate::fixed_sum::{LaneFactor, LaneSums};
use crate::models::gather::{LANES, LaneRows};
use crate::particles::Particles;
use crate::simd::Isa;
use rayon::prelude::*;

/// Accumulated quantities at most: D forces and the density rate.
const MAX_WIDTH: usize = 4;

/// Stress components per particle at most (D² in 3D).
const MAX_STRESS: usize = 9;

impl<K: Kernel, const D: usize> MomentumKernel<'_, K, D> {
    /// Whether [`Self::gather_lanes`] computes this pass: fluid particles only, pressure,
    /// Morris's term and the nested summation's stress (given as σ̄/ρ² per particle) in pair
    /// form, nothing else accumulated.
    pub(super) fn lanes_apply(&self, p: &Particles<D>) -> bool {
        let stress = match (self.stress, self.stress_over_rho2) {
            (None, _) => true,
            (Some(_), Some(s)) => s.len() >= p.len() * D * D && D * D <= MAX_STRESS,
            (Some(_), None) => false,
        };
        !(self.boundaries.any()
            || self.polymer.is_some()
            || p.species.is_some()
            || self.drift_corrected()
            || !self.pairwise_stress)
            && stress
            && self.scales.len() == D + usize::from(self.continuity)
            && self.scales.len() <= MAX_WIDTH
    }

    /// The sums [`crate::models::gather::scatter`] gives, gathered along `rows` (which must
    /// be the rows of the current list) into `out` (n_owned × width), or false if
    /// [`Self::lanes_apply`] does not hold, the rows do not fit the particles, or a term was
    /// not representable (then `out` is meaningless, and the caller scatters, which names
    /// the term).
    pub(super) fn gather_lanes(
        &self,
        isa: Isa,
        p: &Particles<D>,
        rows: &LaneRows,
        out: &mut Vec<f64>,
    ) -> bool {
        let n = p.n_owned;
        let width = self.scales.len();
        if !self.lanes_apply(p) || rows.groups() != n.div_ceil(LANES) || n == 0 {
            return false;
        }
        // Every index a group loads must be a particle with its data: then the unchecked
        // loads in `group` are in bounds.
        let len = p.pos.len();
        if rows.max_index() >= len
            || p.vel.len() != len
            || self.p_over_rho2.len() < len
            || self.inv_density.len() < len
        {
            return false;
        }
        out.clear();
        out.resize(n * width, 0.0);
        let rc2 = self.kernel.support() * self.kernel.support();
        let morris = self.two_eta_morris != 0.0;
        let regular = self.regulariser != 0.0;
        let avx512 = isa.has_avx512();
        out.par_chunks_mut(LANES * width)
            .enumerate()
            .with_min_len(16)
            .map(|(g, chunk)| {
                let group = Group {
                    kernel: self,
                    p,
                    rows,
                    g,
                    rc2,
                };
                #[cfg(target_arch = "x86_64")]
                if avx512 {
                    // SAFETY: an `Isa` has AVX-512 only when the CPU reports every subset that
                    // `group_avx512` enables (`Isa::avx512`), the one requirement of a
                    // target-feature function.
                    return unsafe { group_avx512(&group, morris, regular, chunk) };
                }
                let _ = avx512;
                group_portable(&group, morris, regular, chunk)
            })
            .reduce(|| true, |a, b| a && b)
    }

    /// One group's sums into `out` (its lanes × width, the last group's only as many lanes as
    /// it has particles); false if a term was not representable.
    #[inline(always)]
    fn group<
        const MORRIS: bool,
        const REGULAR: bool,
        const CONTINUITY: bool,
        const STRESS: bool,
    >(
        &self,
        p: &Particles<D>,
        rows: &LaneRows,
        g: usize,
        rc2: f64,
        out: &mut [f64],
    ) -> bool {
        const L: usize = LANES;
        let n = p.n_owned;
        let own: [usize; L] = std::array::from_fn(|l| (g * L + l).min(n - 1));
        let (pos, vel) = (&p.pos, &p.vel);
        let xi: [[f64; L]; D] = std::array::from_fn(|d| std::array::from_fn(|l| pos[own[l]][d]));
        let vi: [[f64; L]; D] = std::array::from_fn(|d| std::array::from_fn(|l| vel[own[l]][d]));
        let p_i: [f64; L] = std::array::from_fn(|l| self.p_over_rho2[own[l]]);
        let inv_i: [f64; L] = std::array::from_fn(|l| self.inv_density[own[l]]);
        let own_u32: [u32; L] = std::array::from_fn(|l| own[l] as u32);
        let stress = self.stress_over_rho2.unwrap_or(&[]);
        let s_i: [[f64; L]; MAX_STRESS] = std::array::from_fn(|c| {
            std::array::from_fn(|l| {
                if STRESS && c < D * D {
                    stress[own[l] * D * D + c]
                } else {
                    0.0
                }
            })
        });
        let (mass, mm) = (self.mass, self.mass * self.mass);
        let (two_eta, regulariser, kernel) = (self.two_eta_morris, self.regulariser, &self.kernel);
        let (p_over_rho2, inv_density) = (self.p_over_rho2, self.inv_density);
        let scales = &self.scales;
        let width = scales.len();
        // The scales' factors, loaded once (unused entries are never added to).
        let factors: [LaneFactor; MAX_WIDTH] =
            std::array::from_fn(|q| scales[q.min(width - 1)].lane_factor());
        let mut sums = [LaneSums::<L>::ZERO; MAX_WIDTH];
        for entries in rows.group(g).chunks_exact(L) {
            let mut x = [[0.0; L]; D];
            let mut v = [[0.0; L]; D];
            let mut r2 = [0.0; L];
            let mut p_j = [0.0; L];
            let mut inv_j = [0.0; L];
            let mut s_j = [[0.0; L]; MAX_STRESS];
            for l in 0..L {
                let j = entries[l] as usize;
                if STRESS {
                    for c in 0..D * D {
                        // SAFETY: j < p.pos.len() (as below) and `lanes_apply` checked that
                        // σ̄/ρ² holds D² numbers for each of those particles.
                        s_j[c][l] = unsafe { *stress.get_unchecked(j * D * D + c) };
                    }
                }
                // SAFETY: j ≤ rows.max_index() < p.pos.len() = p.vel.len(), and the two
                // per-particle arrays are at least that long (all checked by `gather_lanes`
                // before any group runs).
                let (xj, vj, pj, ij) = unsafe {
                    (
                        pos.get_unchecked(j),
                        vel.get_unchecked(j),
                        *p_over_rho2.get_unchecked(j),
                        *inv_density.get_unchecked(j),
                    )
                };
                let mut s = 0.0;
                for d in 0..D {
                    let xd = xi[d][l] - xj[d];
                    x[d][l] = xd;
                    s += xd * xd;
                    v[d][l] = vi[d][l] - vj[d];
                }
                r2[l] = s;
                p_j[l] = pj;
                inv_j[l] = ij;
            }
            let mut f = [[0.0; L]; D];
            let mut rate = [0.0; L];
            for l in 0..L {
                // Not `r2 < rc2`: a NaN distance is kept, and its term stops the gather.
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                let keep = !(r2[l] >= rc2) && entries[l] != own_u32[l];
                // All ones to keep a term, zero to drop it: an AND instead of a select, so
                // that the terms stay in registers. A dropped term becomes +0, as with a select.
                let mask = u64::from(keep).wrapping_neg();
                let r = r2[l].sqrt();
                let gw = kernel.dw_over_r(r);
                let pressure = -(p_i[l] + p_j[l]) * gw;
                let mut s = two_eta * (inv_i[l] * inv_j[l]) * gw;
                if REGULAR {
                    let rr = r * r;
                    s = s * rr / (rr + regulariser);
                }
                let mut vdotx = 0.0;
                for a in 0..D {
                    let mut fa = pressure * x[a][l];
                    if STRESS {
                        // (σ̄_i/ρ_i² + σ̄_j/ρ_j²) · x_ij, row a, in `pair`'s order.
                        let mut t = 0.0;
                        for b in 0..D {
                            t += (s_i[a * D + b][l] + s_j[a * D + b][l]) * x[b][l];
                        }
                        fa += gw * t;
                    }
                    if MORRIS {
                        fa += s * v[a][l];
                    }
                    f[a][l] = f64::from_bits((mm * fa).to_bits() & mask);
                    vdotx += v[a][l] * x[a][l];
                }
                rate[l] = f64::from_bits((mass * gw * vdotx).to_bits() & mask);
            }
            for a in 0..D {
                factors[a].add(&f[a], &mut sums[a]);
            }
            if CONTINUITY {
                factors[D].add(&rate, &mut sums[D]);
            }
        }
        let representable = sums[..width].iter().all(LaneSums::representable);
        for (l, row) in out.chunks_exact_mut(width).enumerate() {
            for (q, o) in row.iter_mut().enumerate() {
                *o = scales[q].value(&sums[q].lane(l));
            }
        }
        representable
    }
}

/// One group's work, for the compiled versions below.
struct Group<'a, 'k, K, const D: usize> {
    kernel: &'a MomentumKernel<'k, K, D>,
    p: &'a Particles<D>,
    rows: &'a LaneRows,
    g: usize,
    rc2: f64,
}

#[inline(always)]
fn group_portable<K: Kernel, const D: usize>(
    w: &Group<'_, '_, K, D>,
    morris: bool,
    regular: bool,
    out: &mut [f64],
) -> bool {
    let Group {
        kernel,
        p,
        rows,
        g,
        rc2,
    } = *w;
    if kernel.stress.is_some() {
        group_with::<K, D, true>(kernel, p, rows, g, rc2, (morris, regular), out)
    } else {
        group_with::<K, D, false>(kernel, p, rows, g, rc2, (morris, regular), out)
    }
}

#[inline(always)]
fn group_with<K: Kernel, const D: usize, const STRESS: bool>(
    kernel: &MomentumKernel<'_, K, D>,
    p: &Particles<D>,
    rows: &LaneRows,
    g: usize,
    rc2: f64,
    (morris, regular): (bool, bool),
    out: &mut [f64],
) -> bool {
    match (morris, regular, kernel.continuity) {
        (true, false, true) => kernel.group::<true, false, true, STRESS>(p, rows, g, rc2, out),
        (true, false, false) => kernel.group::<true, false, false, STRESS>(p, rows, g, rc2, out),
        (true, true, true) => kernel.group::<true, true, true, STRESS>(p, rows, g, rc2, out),
        (true, true, false) => kernel.group::<true, true, false, STRESS>(p, rows, g, rc2, out),
        (false, _, true) => kernel.group::<false, false, true, STRESS>(p, rows, g, rc2, out),
        (false, _, false) => kernel.group::<false, false, false, STRESS>(p, rows, g, rc2, out),
    }
}

/// [`group_portable`] compiled for AVX-512 (no FMA: the same IEEE operations, so the same
/// bits as the portable build).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
fn group_avx512<K: Kernel, const D: usize>(
    w: &Group<'_, '_, K, D>,
    morris: bool,
    regular: bool,
    out: &mut [f64],
) -> bool {
    group_portable(w, morris, regular, out)
}

impl<K: Kernel, const D: usize> super::GradientKernel<'_, K, D> {
    /// The sums [`crate::models::gather::gather`] gives for the velocity-gradient pass (G_i,
    /// and M_i when corrected), gathered along `rows` into `out` (n_owned × width), or false
    /// when the pass has boundary particles (their seen velocities), the rows do not fit the
    /// particles, or a term was not representable (then `out` is meaningless, and the caller
    /// gathers pair by pair, which names the term). The arithmetic is `GradientKernel::pair`'s:
    ///
    /// ```text
    /// s = (m/ρ_j) F_ij,   G_i += s (v_j − v_i) ⊗ x_ij,   M_i += (−s x_ij) ⊗ x_ij
    /// ```
    pub(super) fn gather_lanes(
        &self,
        isa: Isa,
        p: &Particles<D>,
        rows: &LaneRows,
        out: &mut Vec<f64>,
    ) -> bool {
        let n = p.n_owned;
        let width = self.scales.len();
        let expected = if self.corrected { 2 * D * D } else { D * D };
        if self.boundaries.any()
            || width != expected
            || width > MAX_GRADIENT_WIDTH
            || rows.groups() != n.div_ceil(LANES)
            || n == 0
        {
            return false;
        }
        let len = p.pos.len();
        if rows.max_index() >= len || p.vel.len() != len || self.density.len() < len {
            return false;
        }
        out.clear();
        out.resize(n * width, 0.0);
        let rc2 = self.kernel.support() * self.kernel.support();
        let avx512 = isa.has_avx512();
        out.par_chunks_mut(LANES * width)
            .enumerate()
            .with_min_len(16)
            .map(|(g, chunk)| {
                #[cfg(target_arch = "x86_64")]
                if avx512 {
                    // SAFETY: as in `MomentumKernel::gather_lanes`: an `Isa` has AVX-512 only
                    // when the CPU reports every subset `gradient_group_avx512` enables.
                    return unsafe { gradient_group_avx512(self, p, rows, g, rc2, chunk) };
                }
                let _ = avx512;
                gradient_group_portable(self, p, rows, g, rc2, chunk)
            })
            .reduce(|| true, |a, b| a && b)
    }

    /// One group's gradient sums into `out`; false if a term was not representable.
    #[inline(always)]
    fn gradient_group<const CORRECTED: bool>(
        &self,
        p: &Particles<D>,
        rows: &LaneRows,
        g: usize,
        rc2: f64,
        out: &mut [f64],
    ) -> bool {
        const L: usize = LANES;
        let n = p.n_owned;
        let own: [usize; L] = std::array::from_fn(|l| (g * L + l).min(n - 1));
        let (pos, vel, density) = (&p.pos, &p.vel, self.density);
        let xi: [[f64; L]; D] = std::array::from_fn(|d| std::array::from_fn(|l| pos[own[l]][d]));
        let vi: [[f64; L]; D] = std::array::from_fn(|d| std::array::from_fn(|l| vel[own[l]][d]));
        let own_u32: [u32; L] = std::array::from_fn(|l| own[l] as u32);
        let (mass, kernel, scales) = (self.mass, &self.kernel, &self.scales);
        let width = scales.len();
        let factors: [LaneFactor; MAX_GRADIENT_WIDTH] =
            std::array::from_fn(|q| scales[q.min(width - 1)].lane_factor());
        let mut sums = [LaneSums::<L>::ZERO; MAX_GRADIENT_WIDTH];
        for entries in rows.group(g).chunks_exact(L) {
            let mut x = [[0.0; L]; D];
            let mut dv = [[0.0; L]; D];
            let mut r2 = [0.0; L];
            let mut rho_j = [0.0; L];
            for l in 0..L {
                let j = entries[l] as usize;
                // SAFETY: j ≤ rows.max_index() < p.pos.len() = p.vel.len() ≤ density.len(),
                // all checked by `gather_lanes` before any group runs.
                let (xj, vj, rho) = unsafe {
                    (
                        pos.get_unchecked(j),
                        vel.get_unchecked(j),
                        *density.get_unchecked(j),
                    )
                };
                let mut s = 0.0;
                for d in 0..D {
                    let xd = xi[d][l] - xj[d];
                    x[d][l] = xd;
                    s += xd * xd;
                    dv[d][l] = vj[d] - vi[d][l];
                }
                r2[l] = s;
                rho_j[l] = rho;
            }
            let mut coeff = [0.0; L];
            for l in 0..L {
                // Not `r2 < rc2`: a NaN distance is kept, and its term stops the gather.
                #[allow(clippy::neg_cmp_op_on_partial_ord)]
                let keep = !(r2[l] >= rc2) && entries[l] != own_u32[l];
                let mask = u64::from(keep).wrapping_neg();
                let s = mass / rho_j[l] * kernel.dw_over_r(r2[l].sqrt());
                // A dropped pair's every term is s·(…)·(…) = +0 or −0 with s = ±0: +0 words.
                coeff[l] = f64::from_bits(s.to_bits() & mask);
            }
            for a in 0..D {
                let mut d = [0.0; L];
                for l in 0..L {
                    d[l] = coeff[l] * dv[a][l];
                }
                for b in 0..D {
                    let mut t = [0.0; L];
                    for l in 0..L {
                        t[l] = d[l] * x[b][l];
                    }
                    factors[a * D + b].add(&t, &mut sums[a * D + b]);
                }
            }
            if CORRECTED {
                for c in 0..D {
                    let mut d = [0.0; L];
                    for l in 0..L {
                        d[l] = -coeff[l] * x[c][l];
                    }
                    for b in 0..D {
                        let mut t = [0.0; L];
                        for l in 0..L {
                            t[l] = d[l] * x[b][l];
                        }
                        let q = D * D + c * D + b;
                        factors[q].add(&t, &mut sums[q]);
                    }
                }
            }
        }
        let representable = sums[..width].iter().all(LaneSums::representable);
        for (l, row) in out.chunks_exact_mut(width).enumerate() {
            for (q, o) in row.iter_mut().enumerate() {
                *o = scales[q].value(&sums[q].lane(l));
            }
        }
        representable
    }
}

/// Gradient sums at most: G and M in 3D.
const MAX_GRADIENT_WIDTH: usize = 18;

#[inline(always)]
fn gradient_group_portable<K: Kernel, const D: usize>(
    k: &super::GradientKernel<'_, K, D>,
    p: &Particles<D>,
    rows: &LaneRows,
    g: usize,
    rc2: f64,
    out: &mut [f64],
) -> bool {
    if k.corrected {
        k.gradient_group::<true>(p, rows, g, rc2, out)
    } else {
        k.gradient_group::<false>(p, rows, g, rc2, out)
    }
}

/// [`gradient_group_portable`] compiled for AVX-512 (no FMA: the same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
fn gradient_group_avx512<K: Kernel, const D: usize>(
    k: &super::GradientKernel<'_, K, D>,
    p: &Particles<D>,
    rows: &LaneRows,
    g: usize,
    rc2: f64,
    out: &mut [f64],
) -> bool {
    gradient_group_portable(k, p, rows, g, rc2, out)
}
