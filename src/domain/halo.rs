//! Halo (ghost) exchange with periodic and Lees–Edwards images.
//!
//! A plan is built when the neighbour list is rebuilt ("borders"); between rebuilds the same
//! ghosts are refreshed every step ("forward communication") with the current image shifts.
//! Ghost velocities carry the Lees–Edwards jump ±γ̇ L_y, so dissipative forces and velocity
//! gradients see the sliding images without knowing about them.

use super::slab::Slab;
use super::tags;
use crate::comm::Comm;
use crate::geometry::{SimBox, axis_order};
use crate::particles::Particles;

/// A local periodic image: ghost = image `k` of particle `src` along `axis`.
#[derive(Clone, Copy, Debug)]
struct LocalImage {
    src: u32,
    axis: u8,
    k: i8,
}

/// Who gets which ghost, fixed between neighbour-list rebuilds.
#[derive(Clone, Debug, Default)]
pub struct HaloPlan {
    send_up: Vec<u32>,
    send_down: Vec<u32>,
    /// Image shift (boxes along the slab axis) of what goes up / down: −1 / +1 when the message
    /// crosses the periodic boundary, else 0.
    k_up: i32,
    k_down: i32,
    recv_from_down: usize,
    recv_from_up: usize,
    local: Vec<LocalImage>,
    /// Lees–Edwards offset when the plan was built.
    offset_at_build: f64,
    step_at_build: u64,
    /// Whether the fixed-width extra fields travel with the ghosts.
    with_extra: bool,
}

impl HaloPlan {
    /// Number of ghosts the plan creates.
    pub fn ghost_count(&self) -> usize {
        self.recv_from_down + self.recv_from_up + self.local.len()
    }

    /// Step at which the plan was built.
    pub fn step_at_build(&self) -> u64 {
        self.step_at_build
    }

    /// Lees–Edwards offset to apply to images at `step`: the build-time offset plus the
    /// continuous drift since, so a ghost never jumps by L_x between rebuilds.
    pub fn offset_at<const D: usize>(&self, sim_box: &SimBox<D>, step: u64, dt: f64) -> f64 {
        if !sim_box.sheared() {
            return 0.0;
        }
        self.offset_at_build + sim_box.le_velocity_jump() * dt * (step - self.step_at_build) as f64
    }

    /// Builds the plan for the current owned particles (all inside this rank's slab) and
    /// creates the ghosts. `range` is the halo width (cutoff + skin).
    #[allow(clippy::too_many_arguments)]
    pub fn build<const D: usize>(
        particles: &mut Particles<D>,
        sim_box: &SimBox<D>,
        slab: &Slab,
        comm: &dyn Comm,
        range: f64,
        step: u64,
        dt: f64,
        with_extra: bool,
    ) -> Self {
        particles.clear_ghosts();
        let offset = sim_box.le_offset(step, dt);
        let a = slab.axis;
        let n = particles.n_owned;
        let crossing_up = slab.rank + 1 == slab.size;
        let crossing_down = slab.rank == 0;
        let mut plan = HaloPlan {
            k_up: if crossing_up { -1 } else { 0 },
            k_down: if crossing_down { 1 } else { 0 },
            offset_at_build: offset,
            step_at_build: step,
            with_extra,
            ..Default::default()
        };
        let (lo, hi) = (slab.lo(), slab.hi());
        for i in 0..n {
            let x = particles.pos[i][a];
            if x >= hi - range && (slab.periodic || !crossing_up) {
                plan.send_up.push(i as u32);
            }
            if x < lo + range && (slab.periodic || !crossing_down) {
                plan.send_down.push(i as u32);
            }
        }
        let (from_down, from_up) = plan.exchange(particles, sim_box, slab, comm, offset);
        plan.recv_from_down = from_down.len();
        plan.recv_from_up = from_up.len();
        plan.unpack(particles, &from_down, &from_up);

        // Local images along the other periodic axes, in the fixed axis order.
        for axis in axis_order::<D>() {
            if axis == a || sim_box.boundaries[axis] != crate::geometry::Boundary::Periodic {
                continue;
            }
            let length = sim_box.lengths[axis];
            let existing = particles.len();
            for src in 0..existing {
                for k in [-2i32, -1, 1, 2] {
                    let c = particles.pos[src][axis] + f64::from(k) * length;
                    if c >= -range && c < length + range {
                        plan.local.push(LocalImage {
                            src: src as u32,
                            axis: axis as u8,
                            k: k as i8,
                        });
                        let mut p = particles.pos[src];
                        let mut v = particles.vel[src];
                        sim_box.apply_image(&mut p, &mut v, axis, k, offset);
                        let mut extra = Vec::new();
                        if with_extra {
                            particles.extra_of(src, &mut extra);
                        } else {
                            extra.resize(particles.extra_width(), 0.0);
                        }
                        particles.push_ghost(particles.gid[src], p, v, &extra);
                    }
                }
            }
        }
        plan
    }

    fn pack<const D: usize>(
        &self,
        particles: &Particles<D>,
        list: &[u32],
        sim_box: &SimBox<D>,
        axis: usize,
        k: i32,
        offset: f64,
    ) -> Vec<f64> {
        let width = 1
            + 2 * D
            + if self.with_extra {
                particles.extra_width()
            } else {
                0
            };
        let mut buf = Vec::with_capacity(list.len() * width);
        for &i in list {
            let i = i as usize;
            let mut p = particles.pos[i];
            let mut v = particles.vel[i];
            if k != 0 {
                sim_box.apply_image(&mut p, &mut v, axis, k, offset);
            }
            buf.push(f64::from_bits(particles.gid[i]));
            buf.extend_from_slice(&p);
            buf.extend_from_slice(&v);
            if self.with_extra {
                particles.extra_of(i, &mut buf);
            }
        }
        buf
    }

    fn exchange<const D: usize>(
        &self,
        particles: &Particles<D>,
        sim_box: &SimBox<D>,
        slab: &Slab,
        comm: &dyn Comm,
        offset: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let a = slab.axis;
        let up = self.pack(particles, &self.send_up, sim_box, a, self.k_up, offset);
        let from_down = comm.sendrecv(up, slab.up(), slab.down(), tags::HALO_UP);
        let down = self.pack(particles, &self.send_down, sim_box, a, self.k_down, offset);
        let from_up = comm.sendrecv(down, slab.down(), slab.up(), tags::HALO_DOWN);
        (from_down, from_up)
    }

    fn record_width<const D: usize>(&self, particles: &Particles<D>) -> usize {
        1 + 2 * D
            + if self.with_extra {
                particles.extra_width()
            } else {
                0
            }
    }

    /// Appends received ghosts (build time).
    fn unpack<const D: usize>(&self, particles: &mut Particles<D>, a: &[f64], b: &[f64]) {
        let width = self.record_width(particles);
        let ew = particles.extra_width();
        let zeros = vec![0.0; ew];
        for buf in [a, b] {
            for rec in buf.chunks_exact(width) {
                let (p, v) = split_record::<D>(rec);
                let extra = if self.with_extra {
                    &rec[1 + 2 * D..]
                } else {
                    &zeros[..]
                };
                particles.push_ghost(rec[0].to_bits(), p, v, extra);
            }
        }
    }

    /// Refreshes every ghost's position and velocity (and extra fields when the plan carries
    /// them) from its original, with the image shifts of `step`.
    pub fn forward<const D: usize>(
        &self,
        particles: &mut Particles<D>,
        sim_box: &SimBox<D>,
        slab: &Slab,
        comm: &dyn Comm,
        step: u64,
        dt: f64,
    ) {
        let offset = self.offset_at(sim_box, step, dt);
        let (from_down, from_up) = self.exchange(particles, sim_box, slab, comm, offset);
        let width = self.record_width(particles);
        let mut slot = particles.n_owned;
        for buf in [&from_down, &from_up] {
            for rec in buf.chunks_exact(width) {
                let (p, v) = split_record::<D>(rec);
                particles.pos[slot] = p;
                particles.vel[slot] = v;
                if self.with_extra {
                    let mut off = 1 + 2 * D;
                    for f in &mut particles.extra {
                        f.data[slot * f.width..(slot + 1) * f.width]
                            .copy_from_slice(&rec[off..off + f.width]);
                        off += f.width;
                    }
                }
                slot += 1;
            }
        }
        for img in &self.local {
            let src = img.src as usize;
            let mut p = particles.pos[src];
            let mut v = particles.vel[src];
            sim_box.apply_image(&mut p, &mut v, img.axis as usize, i32::from(img.k), offset);
            particles.pos[slot] = p;
            particles.vel[slot] = v;
            if self.with_extra {
                for f in &mut particles.extra {
                    let w = f.width;
                    f.data.copy_within(src * w..(src + 1) * w, slot * w);
                }
            }
            slot += 1;
        }
    }
}

fn split_record<const D: usize>(rec: &[f64]) -> ([f64; D], [f64; D]) {
    let mut p = [0.0; D];
    let mut v = [0.0; D];
    p.copy_from_slice(&rec[1..1 + D]);
    v.copy_from_slice(&rec[1 + D..1 + 2 * D]);
    (p, v)
}
