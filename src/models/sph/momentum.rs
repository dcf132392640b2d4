//! Pass 2: the pair forces of the momentum equation (pressure, Morris or nested-summation
//! viscous term, polymer stress, wall repulsion), and the stress ends their flux sums.

#[allow(unused_imports)]
use super::*;

/// Pass: the momentum equation (and dρ/dt under continuity), per unit mass times m_i.
pub(super) struct MomentumKernel<'a, K, const D: usize> {
    pub(super) kernel: K,
    pub(super) mass: f64,
    pub(super) density: &'a [f64],
    /// 1/ρ of every particle.
    pub(super) inv_density: &'a [f64],
    /// p/ρ² of every particle (owned and ghosts).
    pub(super) p_over_rho2: &'a [f64],
    /// σ̄ (D² per particle) with the nested summation.
    pub(super) stress: Option<&'a [f64]>,
    /// σ̄/ρ² (D² per particle, each σ̄ component divided by ρ·ρ), for the lanes
    /// ([`Self::gather_lanes`]) of the nested summation: the very quotients the pair term
    /// forms, formed once per particle.
    pub(super) stress_over_rho2: Option<&'a [f64]>,
    /// The polymer stress τ (packed, [`packed_width`] per particle).
    pub(super) polymer: Option<&'a [f64]>,
    /// 2η (Morris's term), or 0.
    pub(super) two_eta_morris: f64,
    /// 0.01 h².
    pub(super) regulariser: f64,
    pub(super) continuity: bool,
    /// ε m (XSPH), or 0.
    pub(super) xsph_eps_mass: f64,
    /// −½Δt m p_t (the transport velocity's ½Δt a_t per (1/ρ_i² + 1/ρ_j²) ∇W_ij), or 0.
    pub(super) transport: f64,
    /// Whether the pressure and the stresses enter in pair form (not with MSPH derivatives,
    /// whose divergence pass adds them).
    pub(super) pairwise_stress: bool,
    pub(super) boundaries: Boundaries<D>,
    pub(super) scales: Vec<Scale>,
    pub(super) parities: Vec<Parity>,
}

impl<K: Kernel, const D: usize> SymmetricKernel<D> for MomentumKernel<'_, K, D> {
    fn parities(&self) -> &[Parity] {
        &self.parities
    }

    /// Fluid–fluid batches without a stress field (no walls, no nested summation: the common
    /// weakly compressible scheme) in loops over the batch; anything else pair by pair.
    #[inline(always)]
    fn pair_batch(&self, p: &Particles<D>, batch: &PairBatch<D>, out: &mut BatchTerms) {
        if !self.fluid_only(p) {
            pair_by_pair(self, p, batch, out);
            return;
        }
        let morris = self.two_eta_morris != 0.0;
        let regular = self.regulariser != 0.0;
        match (morris, regular, self.continuity) {
            (true, false, true) => self.fluid_batch::<true, false, true>(p, batch, out),
            (true, false, false) => self.fluid_batch::<true, false, false>(p, batch, out),
            (true, true, true) => self.fluid_batch::<true, true, true>(p, batch, out),
            (true, true, false) => self.fluid_batch::<true, true, false>(p, batch, out),
            (false, _, true) => self.fluid_batch::<false, false, true>(p, batch, out),
            (false, _, false) => self.fluid_batch::<false, false, false>(p, batch, out),
        }
    }
}

impl<K: Kernel, const D: usize> MomentumKernel<'_, K, D> {
    /// Whether every pair of this pass is a fluid–fluid pair with only the pressure, Morris's
    /// term and the density rate (no walls, inclusions, stress fields or XSPH): the scheme that
    /// [`Self::fluid_batch`] and the lanes (`lanes.rs`) compute in vector loops.
    #[inline(always)]
    pub(super) fn fluid_only(&self, p: &Particles<D>) -> bool {
        !(self.boundaries.any()
            || self.stress.is_some()
            || self.polymer.is_some()
            || p.species.is_some()
            || self.drift_corrected()
            || !self.pairwise_stress)
    }

    /// Whether the pass accumulates the drift correction v̂ − v (XSPH, transport velocity).
    #[inline(always)]
    pub(super) fn drift_corrected(&self) -> bool {
        self.xsph_eps_mass != 0.0 || self.transport != 0.0
    }

    /// [`GatherKernel::pair`] for a batch of fluid–fluid pairs without a stress field, in
    /// loops over the batch (the same operations in the same order: the same bits).
    #[inline(always)]
    pub(super) fn fluid_batch<const MORRIS: bool, const REGULAR: bool, const CONTINUITY: bool>(
        &self,
        p: &Particles<D>,
        batch: &PairBatch<D>,
        out: &mut BatchTerms,
    ) {
        let n = batch.len.min(BATCH);
        let mut p_sum = [0.0; BATCH];
        let mut inv_product = [0.0; BATCH];
        let mut v = [[0.0; BATCH]; D];
        for k in 0..n {
            let (i, j) = (batch.i[k] as usize, batch.j[k] as usize);
            p_sum[k] = self.p_over_rho2[i] + self.p_over_rho2[j];
            inv_product[k] = self.inv_density[i] * self.inv_density[j];
            for d in 0..D {
                v[d][k] = p.vel[i][d] - p.vel[j][d];
            }
        }
        // Everything the arithmetic loop reads, in locals (so that the compiler sees no
        // aliasing with `out` and vectorises it).
        let (mass, mm) = (self.mass, self.mass * self.mass);
        let (two_eta, regulariser, kernel) = (self.two_eta_morris, self.regulariser, &self.kernel);
        let mut gw = [0.0; BATCH];
        for k in 0..n {
            gw[k] = kernel.dw_over_r(batch.r[k]);
        }
        let mut f = [[0.0; BATCH]; D];
        let mut rate = [0.0; BATCH];
        for k in 0..n {
            let gw = gw[k];
            let pressure = -p_sum[k] * gw;
            let mut s = two_eta * inv_product[k] * gw;
            if REGULAR {
                let r = batch.r[k];
                let r2 = r * r;
                s = s * r2 / (r2 + regulariser);
            }
            let mut vdotx = 0.0;
            for a in 0..D {
                let x = batch.x[a][k];
                let mut fa = pressure * x;
                if MORRIS {
                    fa += s * v[a][k];
                }
                f[a][k] = mm * fa;
                vdotx += v[a][k] * x;
            }
            rate[k] = mass * gw * vdotx;
        }
        for a in 0..D {
            out[a][..n].copy_from_slice(&f[a][..n]);
        }
        if CONTINUITY {
            out[D][..n].copy_from_slice(&rate[..n]);
        }
    }
}

/// The two ends of a pair as the stress terms of the momentum equation see them.
pub(super) struct StressEnds {
    pub(super) i: usize,
    pub(super) j: usize,
    /// The fluid end of a boundary pair (i otherwise).
    pub(super) fluid_end: usize,
    pub(super) inclusion_pair: bool,
    /// Whether the boundary end carries the fluid end's polymer stress (Morris's images).
    pub(super) mirror: bool,
    /// ρ_i², ρ_j².
    pub(super) rho2: [f64; 2],
}

impl<K: Kernel, const D: usize> MomentumKernel<'_, K, D> {
    /// p_i/ρ_i² + p_j/ρ_j² of a pair, with an inclusion particle carrying its fluid
    /// neighbour's pressure when the inclusions mirror it
    /// (zero normal gradient, docs/theory/sph_maxwell.md §2.3: p_j := p_i).
    #[inline(always)]
    pub(super) fn pressure_sum(
        &self,
        i: usize,
        j: usize,
        fluid_end: usize,
        inclusion_pair: bool,
        ri2: f64,
        rj2: f64,
    ) -> f64 {
        let mirror_pressure = inclusion_pair
            && self
                .boundaries
                .inclusions
                .is_some_and(|g| g.mirror_pressure);
        if mirror_pressure {
            let pf =
                self.p_over_rho2[fluid_end] * self.density[fluid_end] * self.density[fluid_end];
            pf * (1.0 / ri2 + 1.0 / rj2)
        } else {
            self.p_over_rho2[i] + self.p_over_rho2[j]
        }
    }

    /// The coefficient s of the wall repulsion s x_ij (per m_i m_j) of a fluid–wall pair at
    /// distance r, when it acts: an acceleration of the fluid particle (Eq. 2.48 adds it
    /// without a mass), so the force m_i a_i, divided by the m_j that the common factor
    /// m_i m_j of the pair force brings.
    #[inline(always)]
    pub(super) fn wall_repulsion(&self, fluid_wall_pair: bool, r: f64) -> Option<f64> {
        let w = self.boundaries.walls.as_ref().filter(|_| fluid_wall_pair)?;
        (r < w.range).then(|| {
            let q2 = (w.range / r) * (w.range / r);
            w.strength * (q2 * q2 - q2) / (r * r) / self.mass
        })
    }

    /// The pair's ends as [`Self::pair_stress`] reads them. Morris's images (walls or
    /// inclusions) carry the fluid end's stress (zero normal gradient, docs/theory/sph_maxwell.md
    /// §2.3): σ̄_j := σ̄_i, τ_j := τ_i; method-B walls carry their own.
    #[inline(always)]
    pub(super) fn stress_ends(
        &self,
        i: usize,
        j: usize,
        fluid_end: usize,
        boundary_pair: bool,
        inclusion_pair: bool,
        rho2: [f64; 2],
    ) -> StressEnds {
        let mirror =
            inclusion_pair || (boundary_pair && self.boundaries.walls.is_some_and(|w| w.morris));
        StressEnds {
            i,
            j,
            fluid_end,
            inclusion_pair,
            mirror,
            rho2,
        }
    }

    /// Σ_b S^{ab} x_b for every a, S the pair's stress sum of [`Self::pair_stress`] (the
    /// nested summation's σ̄ when `viscous`, and τ): the bits the momentum equation multiplies
    /// by ∂W/r.
    #[inline(always)]
    pub(super) fn stress_on_pair(&self, e: &StressEnds, x: &[f64; D], viscous: bool) -> [f64; D] {
        std::array::from_fn(|a| {
            let mut t = 0.0;
            for b in 0..D {
                t += self.pair_stress(e, a, b, viscous, true) * x[b];
            }
            t
        })
    }

    /// Component (a, b) of σ̄_i/ρ_i² + σ̄_j/ρ_j² (the nested summation's viscous stress, when
    /// `viscous`) plus τ_i/ρ_i² + τ_j/ρ_j² (the polymer stress, when `polymer`), with the
    /// images' stresses of [`GatherKernel::pair`]. With both parts: the very bits the
    /// momentum equation uses.
    #[inline(always)]
    pub(super) fn pair_stress(
        &self,
        e: &StressEnds,
        a: usize,
        b: usize,
        viscous: bool,
        polymer: bool,
    ) -> f64 {
        let [ri2, rj2] = e.rho2;
        let mut sab = match self.stress.filter(|_| viscous) {
            Some(s) if e.inclusion_pair => {
                s[e.fluid_end * D * D + a * D + b] * (1.0 / ri2 + 1.0 / rj2)
            }
            Some(s) => s[e.i * D * D + a * D + b] / ri2 + s[e.j * D * D + a * D + b] / rj2,
            None => 0.0,
        };
        if let Some(tau) = self.polymer.filter(|_| polymer) {
            let (w, c) = (packed_width(D), packed_index::<D>(a, b));
            sab += if e.mirror {
                tau[e.fluid_end * w + c] * (1.0 / ri2 + 1.0 / rj2)
            } else {
                tau[e.i * w + c] / ri2 + tau[e.j * w + c] / rj2
            };
        }
        sab
    }
}

impl<K: Kernel, const D: usize> GatherKernel<D> for MomentumKernel<'_, K, D> {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }
    fn cutoff(&self) -> f64 {
        self.kernel.support()
    }
    #[inline(always)]
    fn pair(&self, p: &Particles<D>, i: usize, j: usize, x: &[f64; D], r: f64, out: &mut [f64]) {
        let (si, sj) = (p.species_of(i), p.species_of(j));
        if si != FLUID && sj != FLUID {
            // Two boundary particles: nothing the fluid feels, nothing a wall reports.
            out.fill(0.0);
            return;
        }
        let boundary_pair = si != sj;
        // The fluid end of a boundary pair; whether the boundary end is an inclusion particle.
        let fluid_end = if si == FLUID { i } else { j };
        let inclusion_pair = boundary_pair && (si == INCLUSION || sj == INCLUSION);
        // v_ij, with the velocity the fluid end sees for a boundary end.
        let vij: [f64; D] = if boundary_pair && self.boundaries.any() {
            if si == FLUID {
                let vj = self.boundaries.seen_velocity(p, i, j, sj, x);
                std::array::from_fn(|d| p.vel[i][d] - vj[d])
            } else {
                let xji: [f64; D] = std::array::from_fn(|d| -x[d]);
                let vi = self.boundaries.seen_velocity(p, j, i, si, &xji);
                std::array::from_fn(|d| vi[d] - p.vel[j][d])
            }
        } else {
            std::array::from_fn(|d| p.vel[i][d] - p.vel[j][d])
        };
        let mm = self.mass * self.mass;
        let gw = self.kernel.dw_over_r(r); // ∇_i W_ij = gw x_ij
        // Both ends' 1/ρ², for the stresses an inclusion mirrors.
        let (ri2, rj2) = (
            self.density[i] * self.density[i],
            self.density[j] * self.density[j],
        );
        let p_sum = self.pressure_sum(i, j, fluid_end, inclusion_pair, ri2, rj2);
        let pressure = if self.pairwise_stress {
            -p_sum * gw
        } else {
            0.0
        };
        let mut f = [0.0; D];
        for a in 0..D {
            f[a] = pressure * x[a];
        }
        if self.pairwise_stress && (self.stress.is_some() || self.polymer.is_some()) {
            let ends = self.stress_ends(i, j, fluid_end, boundary_pair, inclusion_pair, [ri2, rj2]);
            let t = self.stress_on_pair(&ends, x, true);
            for a in 0..D {
                f[a] += gw * t[a];
            }
        }
        if self.two_eta_morris != 0.0 {
            let mut s = self.two_eta_morris * (self.inv_density[i] * self.inv_density[j]) * gw;
            if self.regulariser != 0.0 {
                let r2 = r * r;
                s = s * r2 / (r2 + self.regulariser);
            }
            for a in 0..D {
                f[a] += s * vij[a];
            }
        }
        if let Some(s) = self.wall_repulsion(boundary_pair && !inclusion_pair, r) {
            for a in 0..D {
                f[a] += s * x[a];
            }
        }
        for a in 0..D {
            out[a] = mm * f[a];
        }
        if self.continuity {
            let mut vdotx = 0.0;
            for a in 0..D {
                vdotx += vij[a] * x[a];
            }
            out[D] = self.mass * gw * vdotx;
        }
        if self.drift_corrected() {
            let first = D + usize::from(self.continuity);
            let c = &mut out[first..first + D];
            c.fill(0.0);
            if self.xsph_eps_mass != 0.0 {
                // −ε m W_ij v_ij / ρ̄_ij: odd under i ↔ j to the bit (ρ_i + ρ_j commutes).
                let rho_bar = 0.5 * (self.density[i] + self.density[j]);
                let s = self.xsph_eps_mass * self.kernel.w(r) / rho_bar;
                for a in 0..D {
                    c[a] = -s * vij[a];
                }
            }
            if self.transport != 0.0 {
                // −½Δt m p_t (1/ρ_i² + 1/ρ_j²) ∇_i W_ij: odd under i ↔ j to the bit (x_ji =
                // −x_ij, and the sum of the two 1/ρ² commutes).
                let s = self.transport
                    * (self.inv_density[i] * self.inv_density[i]
                        + self.inv_density[j] * self.inv_density[j])
                    * gw;
                for a in 0..D {
                    c[a] += s * x[a];
                }
            }
        }
        if let Some(inc) = self.boundaries.inclusions.filter(|g| g.traction_moments) {
            // The traction moment F^a s^b of the pair force on the inclusion end, acting at the
            // surface point s = R n nearest the fluid end (relative to the centre): odd, so
            // the inclusion end receives F_j ⊗ s whichever end i is (n is the same bits from
            // both ends: x_ji = −x_ij exactly).
            let first =
                D + usize::from(self.continuity) + if self.drift_corrected() { D } else { 0 };
            let moment = &mut out[first..first + D * D];
            if inclusion_pair {
                let (incl, x_fi): (usize, [f64; D]) = if si == FLUID {
                    (j, *x)
                } else {
                    (i, std::array::from_fn(|d| -x[d]))
                };
                let sp = inc.surface_point(p, incl, &x_fi);
                for a in 0..D {
                    for b in 0..D {
                        moment[a * D + b] = mm * f[a] * sp[b];
                    }
                }
            } else {
                moment.fill(0.0);
            }
        }
    }
}
