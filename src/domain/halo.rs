//! Halo (ghost) exchange with periodic and Lees–Edwards images.
//!
//! A plan is built when the neighbour list is rebuilt ("borders"); between rebuilds the same
//! ghosts are refreshed every step ("forward communication") with the current image shifts.
//! Ghost velocities carry the Lees–Edwards jump ±γ̇ L_y, so dissipative forces and velocity
//! gradients see the sliding images without knowing about them.
//!
//! Registered per-particle fields reach the ghosts only when a model's pass asks for them
//! ([`HaloPlan::refresh_fields`]), over the same send lists and local images, in a message of
//! their own; a field flagged velocity-like gets the same Lees–Edwards shift as the velocity.

use super::slab::Slab;
use super::tags;
use crate::comm::Comm;
use crate::geometry::{SimBox, axis_order};
use crate::particles::{Ghost, Particles};
use rayon::prelude::*;

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
        pool: &rayon::ThreadPool,
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
        let with_species = particles.species.is_some();
        let (from_down, from_up) =
            plan.exchange(particles, sim_box, slab, comm, offset, with_species);
        let width = 1 + 2 * D + usize::from(with_species);
        plan.recv_from_down = from_down.len() / width;
        plan.recv_from_up = from_up.len() / width;
        plan.unpack(particles, &from_down, &from_up);

        // Local images along the other periodic axes, in the fixed axis order; each axis's
        // images are found and made on the rank's threads, in the order of a serial loop over
        // the particles (owned, then the ghosts made so far) and k = −2, −1, 1, 2.
        for axis in axis_order::<D>() {
            if axis == a || sim_box.boundaries[axis] != crate::geometry::Boundary::Periodic {
                continue;
            }
            let length = sim_box.lengths[axis];
            let existing = &*particles;
            let (images, ghosts) = pool.install(|| {
                let images: Vec<LocalImage> = (0..existing.len())
                    .into_par_iter()
                    .with_min_len(4096)
                    .flat_map_iter(|src| {
                        let x = existing.pos[src][axis];
                        [-2i32, -1, 1, 2].into_iter().filter_map(move |k| {
                            let c = x + f64::from(k) * length;
                            (c >= -range && c < length + range).then_some(LocalImage {
                                src: src as u32,
                                axis: axis as u8,
                                k: k as i8,
                            })
                        })
                    })
                    .collect();
                let ghosts: Vec<Ghost<D>> = images
                    .par_iter()
                    .with_min_len(4096)
                    .map(|img| {
                        let src = img.src as usize;
                        let mut p = existing.pos[src];
                        let mut v = existing.vel[src];
                        sim_box.apply_image(&mut p, &mut v, axis, i32::from(img.k), offset);
                        Ghost {
                            gid: existing.gid[src],
                            pos: p,
                            vel: v,
                            species: existing.species_of(src),
                        }
                    })
                    .collect();
                (images, ghosts)
            });
            particles.push_ghosts(&ghosts);
            plan.local.extend(images);
        }
        plan
    }

    /// The records of the particles `list` imaged by `k` boxes along `axis`: id, position,
    /// velocity, and at a build (`with_species`) the species of a many-species scene.
    #[allow(clippy::too_many_arguments)]
    fn pack<const D: usize>(
        &self,
        particles: &Particles<D>,
        list: &[u32],
        sim_box: &SimBox<D>,
        axis: usize,
        k: i32,
        offset: f64,
        with_species: bool,
    ) -> Vec<f64> {
        let mut buf = Vec::with_capacity(list.len() * (2 + 2 * D));
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
            if with_species {
                buf.push(f64::from(particles.species_of(i)));
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
        with_species: bool,
    ) -> (Vec<f64>, Vec<f64>) {
        let a = slab.axis;
        let w = with_species;
        let up = self.pack(particles, &self.send_up, sim_box, a, self.k_up, offset, w);
        let from_down = comm.sendrecv(up, slab.up(), slab.down(), tags::HALO_UP);
        let down = self.pack(
            particles,
            &self.send_down,
            sim_box,
            a,
            self.k_down,
            offset,
            w,
        );
        let from_up = comm.sendrecv(down, slab.down(), slab.up(), tags::HALO_DOWN);
        (from_down, from_up)
    }

    /// Appends received ghosts (build time).
    fn unpack<const D: usize>(&self, particles: &mut Particles<D>, a: &[f64], b: &[f64]) {
        let with_species = particles.species.is_some();
        for buf in [a, b] {
            for rec in buf.chunks_exact(1 + 2 * D + usize::from(with_species)) {
                let (p, v) = split_record::<D>(rec);
                let species = if with_species {
                    rec[1 + 2 * D] as u8
                } else {
                    0
                };
                particles.push_ghost(rec[0].to_bits(), p, v, species);
            }
        }
    }

    /// Refreshes every ghost's position and velocity from its original, with the image shifts
    /// of `step`.
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
        let (from_down, from_up) = self.exchange(particles, sim_box, slab, comm, offset, false);
        let mut slot = particles.n_owned;
        for buf in [&from_down, &from_up] {
            for rec in buf.chunks_exact(1 + 2 * D) {
                let (p, v) = split_record::<D>(rec);
                particles.pos[slot] = p;
                particles.vel[slot] = v;
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
            slot += 1;
        }
    }

    /// Refreshes the ghost copies of the registered fields `fields` (indices into
    /// `particles.extra`) from their originals: the values of the send lists travel to the
    /// neighbouring ranks in one message each way, then the local images copy theirs, in the
    /// order the ghosts were created. A velocity-like field (width D) gets the Lees–Edwards
    /// velocity shift of its image, as the velocity does; every other field is copied
    /// unchanged. Collective.
    pub fn refresh_fields<const D: usize>(
        &self,
        particles: &mut Particles<D>,
        fields: &[usize],
        sim_box: &SimBox<D>,
        slab: &Slab,
        comm: &dyn Comm,
    ) {
        if fields.is_empty() {
            return;
        }
        let width: usize = fields.iter().map(|&k| particles.extra[k].width).sum();
        let pack = |list: &[u32], k: i32| -> Vec<f64> {
            let mut buf = Vec::with_capacity(list.len() * width);
            for &i in list {
                let i = i as usize;
                for &f in fields {
                    let field = &particles.extra[f];
                    let at = buf.len();
                    buf.extend_from_slice(&field.data[i * field.width..(i + 1) * field.width]);
                    if k != 0 && field.flags.velocity_like {
                        shift_velocity_like(&mut buf[at..], sim_box, slab.axis, k);
                    }
                }
            }
            buf
        };
        let up = pack(&self.send_up, self.k_up);
        let from_down = comm.sendrecv(up, slab.up(), slab.down(), tags::HALO_FIELDS_UP);
        let down = pack(&self.send_down, self.k_down);
        let from_up = comm.sendrecv(down, slab.down(), slab.up(), tags::HALO_FIELDS_DOWN);
        let mut slot = particles.n_owned;
        for buf in [&from_down, &from_up] {
            for rec in buf.chunks_exact(width) {
                let mut off = 0;
                for &f in fields {
                    let field = &mut particles.extra[f];
                    let w = field.width;
                    field.data[slot * w..(slot + 1) * w].copy_from_slice(&rec[off..off + w]);
                    off += w;
                }
                slot += 1;
            }
        }
        for img in &self.local {
            let src = img.src as usize;
            for &f in fields {
                let field = &mut particles.extra[f];
                let w = field.width;
                field.data.copy_within(src * w..(src + 1) * w, slot * w);
                if field.flags.velocity_like {
                    let (axis, k) = (img.axis as usize, i32::from(img.k));
                    shift_velocity_like(
                        &mut field.data[slot * w..(slot + 1) * w],
                        sim_box,
                        axis,
                        k,
                    );
                }
            }
            slot += 1;
        }
    }
}

/// The Lees–Edwards velocity shift of image `k` along `axis` applied to a velocity-like field
/// value (D numbers), by the same formula as the ghosts' velocities.
fn shift_velocity_like<const D: usize>(
    value: &mut [f64],
    sim_box: &SimBox<D>,
    axis: usize,
    k: i32,
) {
    let mut v = [0.0; D];
    v.copy_from_slice(value);
    sim_box.shift_velocity(&mut v, axis, k);
    value.copy_from_slice(&v);
}

fn split_record<const D: usize>(rec: &[f64]) -> ([f64; D], [f64; D]) {
    let mut p = [0.0; D];
    let mut v = [0.0; D];
    p.copy_from_slice(&rec[1..1 + D]);
    v.copy_from_slice(&rec[1 + D..1 + 2 * D]);
    (p, v)
}
