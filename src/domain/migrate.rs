//! Migration: owned particles that left their slab move to the neighbouring rank, with every
//! registered per-particle field. Before that, each owned particle is wrapped back into the box
//! (periodic wrap with the Lees–Edwards remap x ∓ s, v_x ∓ γ̇ L_y; reflection at walls).

use super::slab::Slab;
use super::tags;
use crate::comm::Comm;
use crate::geometry::SimBox;
use crate::particles::Particles;
use rayon::prelude::*;

/// Wraps and migrates the owned particles (ghosts must have been dropped). Errors, on every
/// rank alike, if a particle moved further than one slab since the last call.
pub fn migrate<const D: usize>(
    particles: &mut Particles<D>,
    sim_box: &SimBox<D>,
    slab: &Slab,
    comm: &dyn Comm,
    offset: f64,
) -> Result<(), String> {
    let owners = wrap_owned(particles, sim_box, slab, offset, &[]);
    send_leavers(particles, slab, comm, &owners)
}

/// Drops the ghosts, wraps every owned particle back into the box and returns the rank that
/// owns each. `reflected[s]` says whether particles of species s are reflected at walls
/// (boundary particles, which live beyond the wall faces, are not; empty: all are). Per
/// particle and independent, so parallel (on the current rayon pool).
pub fn wrap_owned<const D: usize>(
    particles: &mut Particles<D>,
    sim_box: &SimBox<D>,
    slab: &Slab,
    offset: f64,
    reflected: &[bool],
) -> Vec<usize> {
    particles.clear_ghosts();
    let n = particles.n_owned;
    let Particles {
        pos,
        vel,
        vel_half,
        image,
        species,
        ..
    } = &mut *particles;
    let species = species.as_deref();
    pos[..n]
        .par_iter_mut()
        .zip(vel[..n].par_iter_mut())
        .zip(vel_half[..n].par_iter_mut())
        .zip(image[..n].par_iter_mut())
        .enumerate()
        .with_min_len(2048)
        .map(|(i, (((p, v), vh), im))| {
            let s = species.map_or(0, |s| s[i] as usize);
            let reflect = reflected.get(s).copied().unwrap_or(true);
            sim_box.wrap(p, &mut [v, vh], im, offset, reflect);
            slab.owner_of(p[slab.axis])
        })
        .collect()
}

/// Sends the owned particles whose owner (from [`wrap_owned`]) is another rank to it, in index
/// order, and receives the arrivals. Errors, on every rank alike, if a particle moved further
/// than one slab.
pub fn send_leavers<const D: usize>(
    particles: &mut Particles<D>,
    slab: &Slab,
    comm: &dyn Comm,
    owners: &[usize],
) -> Result<(), String> {
    let n = particles.n_owned;
    let mut keep = vec![true; n];
    let mut to_up = Vec::new();
    let mut to_down = Vec::new();
    let mut lost: Option<(u64, [f64; D])> = None;
    for (i, &owner) in owners.iter().enumerate() {
        if owner == slab.rank {
            continue;
        }
        keep[i] = false;
        if owner == slab.up() {
            particles.pack_owned(i, &mut to_up);
        } else if owner == slab.down() {
            particles.pack_owned(i, &mut to_down);
        } else {
            lost.get_or_insert((particles.gid[i], particles.pos[i]));
            keep[i] = true;
        }
    }
    let mut flag = [if lost.is_some() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut flag);
    if flag[0] > 0.0 {
        return Err(match lost {
            Some((gid, pos)) => format!(
                "particle {gid} at {pos:?} moved more than one slab width between neighbour-list \
                 rebuilds; reduce the time step or use fewer ranks"
            ),
            None => "a particle on another rank moved more than one slab width between \
                     neighbour-list rebuilds; reduce the time step or use fewer ranks"
                .to_owned(),
        });
    }
    particles.retain_owned(&keep);
    let from_down = comm.sendrecv(to_up, slab.up(), slab.down(), tags::MIGRATE_UP);
    let from_up = comm.sendrecv(to_down, slab.down(), slab.up(), tags::MIGRATE_DOWN);
    particles.unpack_owned(&from_down);
    particles.unpack_owned(&from_up);
    Ok(())
}
