//! What every part of a rank shares and that is no part of the physics: its worker-thread pool
//! (started collectively) and the word hash of digests and checksums.

use crate::comm::Comm;

/// This rank's `threads` rayon workers (0: all cores it may use). Collective: a rank that
/// cannot start its threads stops every rank, so none waits for it in a later collective.
///
/// The calling thread (the rank's main thread, the one that talks to MPI) joins the pool as
/// worker 0 when it can: `install` from it then runs the work in place, where a pool of
/// other threads would hand it over and put the caller to sleep until it is done. On one
/// thread that is two wake-ups per pass, about 7 % of a fluid-only SPH step
/// (docs/performance.md); on more threads the caller works instead of waiting. A thread joins
/// one pool in its life (rayon keeps it marked as that pool's worker), so a second simulation
/// on the same thread, as in the tests, gets a pool of its own threads. Which threads do the
/// work changes no bit (the determinism rules of docs/architecture.md).
pub fn worker_pool(comm: &dyn Comm, threads: usize) -> Result<rayon::ThreadPool, String> {
    let builder = || rayon::ThreadPoolBuilder::new().num_threads(threads);
    let pool = builder()
        .use_current_thread()
        .build()
        .or_else(|_| builder().build());
    let mut failed = [if pool.is_err() { 1.0 } else { 0.0 }];
    comm.allreduce_max(&mut failed);
    match pool {
        Err(e) => Err(format!("cannot start {threads} worker threads: {e}")),
        Ok(_) if failed[0] > 0.0 => Err("another rank could not start its worker threads".into()),
        Ok(p) => Ok(p),
    }
}

/// splitmix64-style mixing of a word sequence.
pub fn hash_words(words: &[u64]) -> u64 {
    let mut h: u64 = 0x6A09_E667_F3BC_C909;
    for &w in words {
        h ^= w;
        h = h.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = h;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        h = z ^ (z >> 31);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    /// The first pool built on a thread runs `install` on that thread (no hand-over); a second
    /// one on the same thread still works, on threads of its own; both compute the same.
    #[test]
    fn the_calling_thread_joins_its_first_pool_and_a_second_pool_still_works() {
        std::thread::spawn(|| {
            let comm = crate::comm::SerialComm::default();
            let here = std::thread::current().id();
            let sum = |pool: &rayon::ThreadPool| {
                pool.install(|| (0..10_000u64).into_par_iter().map(|k| k * k).sum::<u64>())
            };
            let first = worker_pool(&comm, 1).expect("a pool");
            assert_eq!(first.install(|| std::thread::current().id()), here);
            assert_eq!(sum(&first), 333_283_335_000);
            let second = worker_pool(&comm, 2).expect("a second pool");
            assert_ne!(second.install(|| std::thread::current().id()), here);
            assert_eq!(sum(&second), 333_283_335_000);
            drop(first);
            let third = worker_pool(&comm, 1).expect("a pool after the first is dropped");
            assert_eq!(sum(&third), 333_283_335_000);
        })
        .join()
        .expect("the test thread");
    }
}
