//! Pass 1b: the velocity-gradient estimate G_i = Σ_j (m_j/ρ_j)(v_j − v_i) ⊗ ∇W_ij, and its
//! correction by the kernel moment matrix (G_i M_i⁻¹, exact for a linear field).

#[allow(unused_imports)]
use super::*;

/// Pass: the velocity gradient G_i^{ab} = Σ_j (m_j/ρ_j)(v_j^a − v_i^a) W'_ij x_ij^b / r_ij and,
/// when `corrected`, the lattice sum M_i^{cb} = Σ_j (m_j/ρ_j)(x_j − x_i)^c W'_ij x_ij^b / r_ij
/// (D × D more outputs) that the finish inverts.
pub(super) struct GradientKernel<'a, K, const D: usize> {
    pub(super) kernel: K,
    pub(super) mass: f64,
    pub(super) density: &'a [f64],
    pub(super) boundaries: Boundaries<D>,
    pub(super) corrected: bool,
    pub(super) scales: Vec<Scale>,
}

impl<K: Kernel, const D: usize> GatherKernel<D> for GradientKernel<'_, K, D> {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }
    fn cutoff(&self) -> f64 {
        self.kernel.support()
    }
    #[inline(always)]
    fn pair(&self, p: &Particles<D>, i: usize, j: usize, x: &[f64; D], r: f64, out: &mut [f64]) {
        let vj = if self.boundaries.any() && p.species_of(i) == FLUID && p.species_of(j) != FLUID {
            self.boundaries.seen_velocity(p, i, j, p.species_of(j), x)
        } else {
            p.vel[j]
        };
        let s = self.mass / self.density[j] * self.kernel.dw_over_r(r);
        for a in 0..D {
            let dv = s * (vj[a] - p.vel[i][a]);
            for b in 0..D {
                out[a * D + b] = dv * x[b];
            }
        }
        if self.corrected {
            for c in 0..D {
                let dx = -s * x[c];
                for b in 0..D {
                    out[D * D + c * D + b] = dx * x[b];
                }
            }
        }
    }
}

/// Smallest det M_i with which the corrected gradient G_i M_i⁻¹ is formed (M_i ≈ I inside a
/// complete neighbourhood; a particle that sees few neighbours keeps its uncorrected G_i).
pub(crate) const MIN_CORRECTION_DETERMINANT: f64 = 1e-3;

/// Replaces each particle's G_i (the first D² numbers of every `width`-wide row of `sums`) by
/// G_i M_i⁻¹, with M_i the next D² numbers; returns how many rows kept G_i because M_i was
/// nearly singular.
pub(super) fn apply_gradient_correction<const D: usize>(sums: &mut [f64], width: usize) -> usize {
    let mut kept = 0;
    for row in sums.chunks_exact_mut(width) {
        let m: [[f64; D]; D] =
            std::array::from_fn(|c| std::array::from_fn(|b| row[D * D + c * D + b]));
        let (det, inv) = determinant_and_inverse(&m);
        if !(det > MIN_CORRECTION_DETERMINANT && det.is_finite()) {
            kept += 1;
            continue;
        }
        let g: [[f64; D]; D] = std::array::from_fn(|a| std::array::from_fn(|b| row[a * D + b]));
        for a in 0..D {
            for b in 0..D {
                row[a * D + b] = (0..D).map(|c| g[a][c] * inv[c][b]).sum();
            }
        }
    }
    kept
}

/// det m and m⁻¹ (by cofactors) of a 1 × 1, 2 × 2 or 3 × 3 matrix.
pub(crate) fn determinant_and_inverse<const D: usize>(m: &[[f64; D]; D]) -> (f64, [[f64; D]; D]) {
    let mut inv = [[0.0; D]; D];
    let det = match D {
        1 => {
            inv[0][0] = 1.0 / m[0][0];
            return (m[0][0], inv);
        }
        2 => m[0][0] * m[1][1] - m[0][1] * m[1][0],
        3 => {
            m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
        }
        _ => unreachable!("SPH runs in 2 or 3 dimensions"),
    };
    for a in 0..D {
        for b in 0..D {
            // inv[a][b] = cofactor(b, a) / det.
            let cof = if D == 2 {
                let s = if (a + b) % 2 == 0 { 1.0 } else { -1.0 };
                s * m[1 - b][1 - a]
            } else {
                let (r0, r1) = ((b + 1) % 3, (b + 2) % 3);
                let (c0, c1) = ((a + 1) % 3, (a + 2) % 3);
                m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
            };
            inv[a][b] = cof / det;
        }
    }
    (det, inv)
}
