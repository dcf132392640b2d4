//! Where the boundary particles are: the geometry of the walls and the inclusions, and the
//! image velocities a fluid particle sees for them (module doc of `super`).

#[allow(unused_imports)]
use super::*;

/// The walls as the pair kernels see them.
#[derive(Clone, Copy, Debug)]
pub(super) struct WallGeometry<const D: usize> {
    pub(super) axis: usize,
    /// Coordinates of the lower and upper wall planes.
    pub(super) planes: [f64; 2],
    /// Velocities of the lower and upper walls.
    pub(super) velocity: [[f64; D]; 2],
    pub(super) morris: bool,
    /// Index of the [`MIRROR_VELOCITY`] field with mirror walls (else `usize::MAX`).
    pub(super) mirror_velocity: usize,
    pub(super) beta_max: f64,
    /// Floor of a fluid particle's distance to the wall (Δ/2).
    pub(super) min_distance: f64,
    /// D and r₀ of the repulsion.
    pub(super) strength: f64,
    pub(super) range: f64,
}

/// The inclusions as the pair kernels see them.
#[derive(Clone, Copy, Debug)]
pub(super) struct InclusionGeometry {
    pub(super) radius: f64,
    /// Whether the momentum pass accumulates the traction moments (only when measured).
    pub(super) traction_moments: bool,
    pub(super) mirror_pressure: bool,
    pub(super) beta_max: f64,
    /// Floor of a fluid particle's distance to the surface (Δ/2).
    pub(super) min_distance: f64,
    /// Index of the [`INCLUSION_OFFSET`] field.
    pub(super) offset: usize,
}

impl InclusionGeometry {
    /// For fluid particle i and inclusion particle j with x_ij = x_i − x_j: the vector from
    /// the centre to i, x_ij + o_j, and its length.
    #[inline(always)]
    pub(super) fn centre_to_fluid<const D: usize>(
        &self,
        p: &Particles<D>,
        j: usize,
        x: &[f64; D],
    ) -> ([f64; D], f64) {
        let o = &p.extra[self.offset].data[j * D..(j + 1) * D];
        let ric: [f64; D] = std::array::from_fn(|d| x[d] + o[d]);
        let dist = ric.iter().map(|v| v * v).sum::<f64>().sqrt();
        (ric, dist)
    }

    /// The surface point R n_i (relative to the centre) nearest fluid particle i, for the
    /// pair of i and inclusion particle j with x_ij = x_i − x_j.
    #[inline(always)]
    pub(super) fn surface_point<const D: usize>(
        &self,
        p: &Particles<D>,
        j: usize,
        x: &[f64; D],
    ) -> [f64; D] {
        let (ric, dist) = self.centre_to_fluid(p, j, x);
        std::array::from_fn(|d| self.radius * ric[d] / dist)
    }
}

/// Every boundary the pair kernels know: walls and inclusions.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Boundaries<const D: usize> {
    pub(super) walls: Option<WallGeometry<D>>,
    pub(super) inclusions: Option<InclusionGeometry>,
}

impl<const D: usize> Boundaries<D> {
    pub(super) fn any(&self) -> bool {
        self.walls.is_some() || self.inclusions.is_some()
    }

    /// The velocity fluid particle i sees for boundary particle j of species `sj`, with
    /// x_ij = x_i − x_j.
    ///
    /// Inclusion (docs/theory/sph_maxwell.md §2.3, a circle of centre c and radius R): with
    /// o_j = x_j − c, n = (x_ij + o_j)/|x_ij + o_j|, d_i = |x_ij + o_j| − R ≥ Δ/2, d_j = R − o_j·n,
    /// v_j = U − (d_j/d_i)(v_i − U), i.e. v_i − v_j = β (v_i − U), β = min(1 + d_j/d_i, β_max),
    /// with U = v_j as stored: the inclusion's velocity (0 in the box, the Lees–Edwards image
    /// velocity for an image across the sheared boundary).
    #[inline(always)]
    pub(super) fn seen_velocity(
        &self,
        p: &Particles<D>,
        i: usize,
        j: usize,
        sj: u8,
        x: &[f64; D],
    ) -> [f64; D] {
        if sj == INCLUSION {
            let Some(inc) = &self.inclusions else {
                return p.vel[j];
            };
            let (ric, dist) = inc.centre_to_fluid(p, j, x);
            let o = &p.extra[inc.offset].data[j * D..(j + 1) * D];
            let o_dot_n = (0..D).map(|d| o[d] * ric[d]).sum::<f64>() / dist;
            let (di, dj) = (dist - inc.radius, inc.radius - o_dot_n);
            let beta = (1.0 + dj / di.max(inc.min_distance)).min(inc.beta_max);
            let u = p.vel[j];
            return std::array::from_fn(|d| p.vel[i][d] - beta * (p.vel[i][d] - u[d]));
        }
        match &self.walls {
            Some(w) => w.seen_velocity(p, i, j, sj),
            None => p.vel[j],
        }
    }
}

impl<const D: usize> WallGeometry<D> {
    /// The velocity fluid particle i sees for boundary particle j (species `sj`).
    #[inline(always)]
    pub(super) fn seen_velocity(&self, p: &Particles<D>, i: usize, j: usize, sj: u8) -> [f64; D] {
        if self.mirror_velocity != usize::MAX {
            let v = &p.extra[self.mirror_velocity].data[j * D..(j + 1) * D];
            return std::array::from_fn(|d| v[d]);
        }
        if !self.morris {
            return p.vel[j];
        }
        let w = (sj - LOWER_WALL) as usize;
        let u = self.velocity[w];
        let (di, dj) = if w == 0 {
            (
                p.pos[i][self.axis] - self.planes[0],
                self.planes[0] - p.pos[j][self.axis],
            )
        } else {
            (
                self.planes[1] - p.pos[i][self.axis],
                p.pos[j][self.axis] - self.planes[1],
            )
        };
        let beta = (1.0 + dj / di.max(self.min_distance)).min(self.beta_max);
        std::array::from_fn(|d| p.vel[i][d] - beta * (p.vel[i][d] - u[d]))
    }
}
