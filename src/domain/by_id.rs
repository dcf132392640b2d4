//! Redistribution of owned particles by an arbitrary destination rule, and the global-id blocks
//! that output and checkpoints use: rank r of P holds ids `[N r / P, N (r + 1) / P)` when it
//! writes, so every file is in global-id order whatever the decomposition, and each rank writes
//! one contiguous hyperslab.

use super::tags;
use crate::comm::Comm;
use crate::particles::Particles;
use std::ops::Range;

/// The ids rank `rank` of `size` holds in a file of `total` particles (balanced blocks).
pub fn id_block(total: u64, size: usize, rank: usize) -> Range<u64> {
    let at = |r: usize| (u128::from(total) * r as u128 / size as u128) as u64;
    at(rank)..at(rank + 1)
}

/// Sends every owned particle (with all registered fields) to rank `dest(i)`; returns the
/// particles this rank receives, owned only, in rank-of-origin order (collective).
pub fn redistribute<const D: usize>(
    particles: &Particles<D>,
    comm: &dyn Comm,
    mut dest: impl FnMut(usize) -> usize,
) -> Particles<D> {
    let mut send = vec![Vec::new(); comm.size()];
    for i in 0..particles.n_owned {
        particles.pack_owned(i, &mut send[dest(i)]);
    }
    let received = comm.alltoallv(send, tags::REDISTRIBUTE);
    let mut out = particles.empty_like();
    for buf in &received {
        out.unpack_owned(buf);
    }
    out
}

/// Sorts owned particles by global id (no ghosts).
pub fn sort_by_id<const D: usize>(particles: &mut Particles<D>) {
    let mut order: Vec<u32> = (0..particles.n_owned as u32).collect();
    order.sort_unstable_by_key(|&i| particles.gid[i as usize]);
    particles.permute_owned(&order);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::comm::local_universe;

    #[test]
    fn blocks_tile_the_ids() {
        for total in [0u64, 1, 7, 1000] {
            for size in 1..6 {
                let mut next = 0;
                for r in 0..size {
                    let b = id_block(total, size, r);
                    assert_eq!(b.start, next);
                    next = b.end;
                }
                assert_eq!(next, total);
            }
        }
    }

    #[test]
    fn redistribution_by_id_keeps_every_particle_and_field() {
        let size = 3;
        let handles: Vec<_> = local_universe(size)
            .into_iter()
            .map(|comm| {
                std::thread::spawn(move || {
                    let mut p = Particles::<2>::default();
                    p.register_extra("t", 4);
                    p.register_var("e");
                    // rank r holds ids r, r + 3, r + 6, … (interleaved)
                    for g in (comm.rank() as u64..20).step_by(size) {
                        let i = p.n_owned;
                        p.push_owned(g, [g as f64, 0.5], [0.0, -(g as f64)]);
                        p.extra[0].data[4 * i + 3] = g as f64 * 2.0;
                        p.var[0].data.double_mut().expect("f64")[i] =
                            vec![g as f64; g as usize % 4];
                    }
                    let mut q = redistribute(&p, &comm, |i| {
                        let g = p.gid[i];
                        (0..size)
                            .find(|&r| id_block(20, size, r).contains(&g))
                            .expect("block")
                    });
                    sort_by_id(&mut q);
                    let block = id_block(20, size, comm.rank());
                    assert_eq!(q.gid, block.clone().collect::<Vec<_>>());
                    for (i, g) in block.enumerate() {
                        assert_eq!(q.pos[i], [g as f64, 0.5]);
                        assert_eq!(q.vel[i], [0.0, -(g as f64)]);
                        assert_eq!(q.extra[0].data[4 * i + 3], g as f64 * 2.0);
                        assert_eq!(
                            q.var[0].data.double().expect("f64")[i],
                            vec![g as f64; g as usize % 4]
                        );
                    }
                })
            })
            .collect();
        for h in handles {
            h.join().expect("rank");
        }
    }
}
