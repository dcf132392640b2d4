//! The simulation box: periodic and wall axes, and Lees–Edwards sliding boundaries.
//!
//! Lees–Edwards (flow axis x = 0, gradient axis y = 1, shear rate γ̇): the periodic image of the
//! box above (y + L_y) slides with velocity +γ̇ L_y along x and is displaced by the offset
//!
//! ```text
//! s(t) = (γ̇ L_y t) mod L_x,      t = step · Δt   (computed from the step count, never accumulated)
//! ```
//!
//! so an image with y-shift k L_y (k = ±1) has x-shift k s and x-velocity shift k γ̇ L_y. A particle
//! leaving through y ≥ L_y re-enters at y − L_y with x − s and v_x − γ̇ L_y (and the mirror rule at
//! y < 0). These shifts are applied in exactly two places, the halo packing and the migration,
//! through [`SimBox::apply_image`] — physics never sees them.

use serde::{Deserialize, Serialize};

/// Treatment of one box axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Boundary {
    /// Periodic images along this axis.
    Periodic,
    /// Specular reflecting walls at 0 and L (no images).
    Wall,
}

/// Axis-aligned box `[0, L_0) × … × [0, L_{D−1})`.
#[derive(Clone, Debug, PartialEq)]
pub struct SimBox<const D: usize> {
    /// Edge lengths.
    pub lengths: [f64; D],
    /// Boundary treatment per axis.
    pub boundaries: [Boundary; D],
    /// Lees–Edwards shear rate γ̇ (0: no shear). Flow along x, gradient along y.
    pub shear_rate: f64,
}

/// Flow axis of the Lees–Edwards shear.
pub const FLOW: usize = 0;
/// Gradient axis of the Lees–Edwards shear.
pub const GRADIENT: usize = 1;

impl<const D: usize> SimBox<D> {
    /// Volume (area in 2D).
    pub fn volume(&self) -> f64 {
        self.lengths.iter().product()
    }

    /// Whether Lees–Edwards shear is on.
    pub fn sheared(&self) -> bool {
        self.shear_rate != 0.0
    }

    /// Velocity jump between a periodic image and the box, γ̇ L_y.
    pub fn le_velocity_jump(&self) -> f64 {
        self.shear_rate * self.lengths[GRADIENT]
    }

    /// Lees–Edwards offset at `step`: s = (γ̇ L_y · step · Δt) mod L_x.
    pub fn le_offset(&self, step: u64, dt: f64) -> f64 {
        if !self.sheared() {
            return 0.0;
        }
        (self.le_velocity_jump() * dt * step as f64).rem_euclid(self.lengths[FLOW])
    }

    /// Imposed streaming velocity along x at height y: γ̇ (y − L_y/2).
    pub fn streaming_velocity(&self, y: f64) -> f64 {
        self.shear_rate * (y - 0.5 * self.lengths[GRADIENT])
    }

    /// Moves a copy of a particle to its image `k` boxes along `axis` (k L added to the
    /// coordinate); across the Lees–Edwards plane also shifts x by k s and v_x by k γ̇ L_y.
    /// The one formula every rank uses for every image (docs/architecture.md, determinism rule 3).
    #[inline]
    pub fn apply_image(
        &self,
        pos: &mut [f64; D],
        vel: &mut [f64; D],
        axis: usize,
        k: i32,
        offset: f64,
    ) {
        self.shift_position(pos, axis, k, offset);
        self.shift_velocity(vel, axis, k);
    }

    /// Position part of [`Self::apply_image`].
    #[inline]
    pub fn shift_position(&self, pos: &mut [f64; D], axis: usize, k: i32, offset: f64) {
        let kf = f64::from(k);
        pos[axis] += kf * self.lengths[axis];
        if axis == GRADIENT && self.sheared() {
            pos[FLOW] += kf * offset;
        }
    }

    /// Velocity part of [`Self::apply_image`]: v_x + k γ̇ L_y across the Lees–Edwards plane.
    #[inline]
    pub fn shift_velocity(&self, vel: &mut [f64; D], axis: usize, k: i32) {
        if axis == GRADIENT && self.sheared() {
            vel[FLOW] += f64::from(k) * self.le_velocity_jump();
        }
    }

    /// Brings an owned particle back into the box: periodic wrap (with the Lees–Edwards remap,
    /// gradient axis first so the x-shift is wrapped too) and specular reflection at walls.
    /// `image` counts the periodic crossings so trajectories can be unfolded.
    /// Every velocity-like array of the particle (`vels`) gets the same shift or reflection.
    /// A particle with `reflect` false (a boundary particle beyond a wall face) is left where
    /// it is along wall axes.
    pub fn wrap(
        &self,
        pos: &mut [f64; D],
        vels: &mut [&mut [f64; D]],
        image: &mut [i32; D],
        offset: f64,
        reflect: bool,
    ) {
        let order = axis_order::<D>();
        for &axis in &order {
            let length = self.lengths[axis];
            match self.boundaries[axis] {
                Boundary::Periodic => {
                    while pos[axis] >= length {
                        self.shift_position(pos, axis, -1, offset);
                        vels.iter_mut()
                            .for_each(|v| self.shift_velocity(v, axis, -1));
                        image[axis] += 1;
                    }
                    while pos[axis] < 0.0 {
                        self.shift_position(pos, axis, 1, offset);
                        vels.iter_mut()
                            .for_each(|v| self.shift_velocity(v, axis, 1));
                        image[axis] -= 1;
                        if pos[axis] >= length {
                            // −tiny + L rounded up to L: keep the image (and its LE shift) and
                            // put the particle just below the upper face.
                            pos[axis] = length.next_down();
                        }
                    }
                }
                Boundary::Wall if !reflect => {}
                Boundary::Wall => {
                    if pos[axis] < 0.0 {
                        pos[axis] = -pos[axis];
                        vels.iter_mut().for_each(|v| v[axis] = -v[axis]);
                    } else if pos[axis] >= length {
                        pos[axis] = 2.0 * length - pos[axis];
                        vels.iter_mut().for_each(|v| v[axis] = -v[axis]);
                    }
                    pos[axis] = pos[axis].clamp(0.0, length.next_down());
                }
            }
        }
    }
}

/// Order in which axes are wrapped and imaged: the gradient axis y before the flow axis x,
/// because a Lees–Edwards crossing moves x.
pub fn axis_order<const D: usize>() -> [usize; D] {
    let mut order = [0usize; D];
    for (i, o) in order.iter_mut().enumerate() {
        *o = (i + 1) % D;
    }
    order
}

/// Volume of the D-ball of radius r.
pub fn ball_volume(dimension: usize, r: f64) -> f64 {
    if dimension == 2 {
        std::f64::consts::PI * r * r
    } else {
        4.0 / 3.0 * std::f64::consts::PI * r * r * r
    }
}

/// Axis names.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    /// x
    X,
    /// y
    #[default]
    Y,
    /// z
    Z,
}

impl Axis {
    /// Axis index.
    pub fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }
}

/// Initial arrangement.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Lattice {
    /// Simple cubic (square in 2D), one particle per cell.
    Cubic,
    /// Face-centred cubic (centred square in 2D).
    Fcc,
    /// Uniformly random positions.
    Random,
}

/// Initial velocity field.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum VelocityProfile {
    /// The linear shear profile γ̇ (y − L_y/2) when sheared, else at rest.
    #[default]
    Auto,
    /// Maxwellian only.
    Rest,
    /// Maxwellian plus γ̇ (y − L_y/2) along x.
    Shear,
    /// Maxwellian plus A sin(πy/L_y) along x inside 0 ≤ y ≤ L_y (a channel's lowest mode; the
    /// viscoelastic relaxation test), A = `particles.velocity_amplitude`.
    HalfSine,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sheared() -> SimBox<2> {
        SimBox {
            lengths: [10.0, 8.0],
            boundaries: [Boundary::Periodic; 2],
            shear_rate: 0.5,
        }
    }

    #[test]
    fn offset_is_modulo_box_length() {
        let b = sheared();
        // γ̇ L_y t = 0.5 · 8 · 0.1 · 30 = 12 → 12 mod 10 = 2
        assert!((b.le_offset(30, 0.1) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn crossing_the_top_shifts_x_and_velocity() {
        let b = sheared();
        let s = 3.0;
        let mut x = [9.5, 8.25];
        let mut v = [2.0, 0.1];
        let mut img = [0, 0];
        b.wrap(&mut x, &mut [&mut v], &mut img, s, true);
        assert!((x[1] - 0.25).abs() < 1e-12);
        assert!((x[0] - 6.5).abs() < 1e-12); // 9.5 − 3
        assert!((v[0] - (2.0 - 4.0)).abs() < 1e-12); // v_x − γ̇ L_y
        assert_eq!(img, [0, 1]);
        // and back through the bottom
        x[1] -= 0.5;
        b.wrap(&mut x, &mut [&mut v], &mut img, s, true);
        assert!((x[0] - 9.5).abs() < 1e-12 && (v[0] - 2.0).abs() < 1e-12);
        assert_eq!(img, [0, 0]);
    }

    #[test]
    fn walls_reflect() {
        let b = SimBox::<2> {
            lengths: [4.0, 4.0],
            boundaries: [Boundary::Periodic, Boundary::Wall],
            shear_rate: 0.0,
        };
        let mut x = [1.0, -0.1];
        let mut v = [0.0, -1.0];
        let mut img = [0; 2];
        b.wrap(&mut x, &mut [&mut v], &mut img, 0.0, true);
        assert!((x[1] - 0.1).abs() < 1e-15 && v[1] == 1.0);
    }
}
