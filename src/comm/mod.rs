//! Transport between ranks. Physics never sees it: the domain layer (halo exchange, migration)
//! and the diagnostics are the only users.
//!
//! Three implementations share one trait:
//! - [`SerialComm`]: one rank that exchanges with itself, so a serial run builds its periodic and
//!   Lees–Edwards images through the same halo code as a parallel one;
//! - [`LocalComm`]: P ranks as threads of one process, used by the tests to check P = 1…4
//!   without `mpirun`;
//! - `MpiComm` (feature `mpi`): real processes through rsmpi.
//!
//! All payloads are `f64` words; integers (global ids, image counts) travel as exact bit patterns
//! (`f64::from_bits`) or small exactly-representable values.

mod local;
#[cfg(feature = "mpi")]
mod mpi_comm;

pub use local::{LocalComm, local_universe};
#[cfg(feature = "mpi")]
pub use mpi_comm::MpiComm;

/// Bitwise or arithmetic reductions on 64-bit unsigned integers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum U64Op {
    /// Wrapping sum.
    Sum,
    /// Bitwise exclusive or.
    Xor,
    /// Maximum.
    Max,
}

/// Message transport. Every call is collective over the ranks that take part and is made from
/// the rank's main thread (MPI "funneled").
pub trait Comm {
    /// This rank's index, `0..size`.
    fn rank(&self) -> usize;
    /// Number of ranks.
    fn size(&self) -> usize;
    /// Sends `send` to `dest` and receives the message that `src` sent with the same `tag`.
    fn sendrecv(&self, send: Vec<f64>, dest: usize, src: usize, tag: u32) -> Vec<f64>;
    /// Element-wise sum over ranks, in rank order (identical result on every rank; the rounding
    /// depends on the rank count, so only diagnostics use it).
    fn allreduce_sum(&self, values: &mut [f64]);
    /// Element-wise maximum over ranks (exact).
    fn allreduce_max(&self, values: &mut [f64]);
    /// Element-wise exact integer reduction.
    fn allreduce_u64(&self, values: &mut [u64], op: U64Op);
    /// Every rank's buffer, in rank order, on every rank.
    fn allgather(&self, mine: &[f64]) -> Vec<Vec<f64>>;
    /// Waits for every rank.
    fn barrier(&self);
    /// Personalised all-to-all: `send[d]` goes to rank `d`; returns what every rank sent to this
    /// one, in rank order. Built from [`Self::sendrecv`] in `size − 1` rounds (round k: to
    /// rank + k, from rank − k), so each pair of ranks exchanges exactly one message per call.
    fn alltoallv(&self, mut send: Vec<Vec<f64>>, tag: u32) -> Vec<Vec<f64>> {
        let (rank, size) = (self.rank(), self.size());
        assert_eq!(send.len(), size, "alltoallv needs one buffer per rank");
        let mut received = vec![Vec::new(); size];
        received[rank] = std::mem::take(&mut send[rank]);
        for k in 1..size {
            let dest = (rank + k) % size;
            let src = (rank + size - k) % size;
            received[src] = self.sendrecv(std::mem::take(&mut send[dest]), dest, src, tag);
        }
        received
    }
    /// The raw MPI communicator of a real MPI run (for parallel HDF5), else `None`.
    #[cfg(feature = "mpi")]
    fn raw_mpi(&self) -> Option<mpi::ffi::MPI_Comm> {
        None
    }
    /// Whether this is a real multi-process MPI run.
    fn is_mpi(&self) -> bool {
        false
    }
}

/// The one-rank communicator: every message goes to itself.
#[derive(Default)]
pub struct SerialComm {
    pending: std::cell::RefCell<Vec<(u32, Vec<f64>)>>,
}

impl SerialComm {
    /// A new serial communicator.
    pub fn new() -> Self {
        Self::default()
    }
}

impl Comm for SerialComm {
    fn rank(&self) -> usize {
        0
    }
    fn size(&self) -> usize {
        1
    }
    fn sendrecv(&self, send: Vec<f64>, dest: usize, src: usize, tag: u32) -> Vec<f64> {
        assert!(dest == 0 && src == 0, "serial communicator has only rank 0");
        let mut pending = self.pending.borrow_mut();
        pending.push((tag, send));
        let pos = pending
            .iter()
            .position(|(t, _)| *t == tag)
            .expect("message just queued");
        pending.remove(pos).1
    }
    fn allreduce_sum(&self, _values: &mut [f64]) {}
    fn allreduce_max(&self, _values: &mut [f64]) {}
    fn allreduce_u64(&self, _values: &mut [u64], _op: U64Op) {}
    fn allgather(&self, mine: &[f64]) -> Vec<Vec<f64>> {
        vec![mine.to_vec()]
    }
    fn barrier(&self) {}
}

/// Combines per-rank integer vectors with `op` (shared by the thread and serial paths).
pub(crate) fn reduce_u64(acc: &mut [u64], other: &[u64], op: U64Op) {
    for (a, b) in acc.iter_mut().zip(other) {
        *a = match op {
            U64Op::Sum => a.wrapping_add(*b),
            U64Op::Xor => *a ^ *b,
            U64Op::Max => (*a).max(*b),
        };
    }
}

/// Runs `job` on `ranks` in-process ranks (threads connected by channels) and returns rank 0's
/// result — what the tests use to check that results do not depend on the decomposition
/// without launching `mpirun`.
///
/// Only this shell is generic: the threads are started and joined by [`run_rank_threads`],
/// compiled once here. A generic function is compiled again in every crate that calls it, per
/// closure (release builds do not share generics across crates), and the tests call this one
/// with dozens of closures; see [`crate::facade`].
pub fn in_process<T: Send + 'static, E: From<&'static str> + Send + 'static>(
    ranks: usize,
    job: impl Fn(&dyn Comm) -> Result<T, E> + Send + Sync + 'static,
) -> Result<T, E> {
    type Slot<T, E> = std::sync::Mutex<Option<Result<T, E>>>;
    let slots: std::sync::Arc<Vec<Slot<T, E>>> =
        std::sync::Arc::new((0..ranks).map(|_| Slot::default()).collect());
    let filled = slots.clone();
    run_rank_threads(
        ranks,
        std::sync::Arc::new(move |rank, comm: &dyn Comm| {
            let result = job(comm);
            *filled[rank].lock().unwrap_or_else(|e| e.into_inner()) = Some(result);
        }),
    );
    // Every rank has finished; one that panicked left its slot empty. The other ranks'
    // results are dropped with the slots.
    let first = slots[0].lock().unwrap_or_else(|e| e.into_inner()).take();
    first.unwrap_or_else(|| Err(E::from("a rank thread panicked")))
}

/// The job of one in-process rank: its rank number and communicator.
type RankJob = std::sync::Arc<dyn Fn(usize, &dyn Comm) + Send + Sync>;

/// Runs `job(rank, comm)` of every rank of a fresh [`local_universe`] of `ranks` on its own
/// thread and waits for all of them (the non-generic part of [`in_process`]).
fn run_rank_threads(ranks: usize, job: RankJob) {
    let comms = local_universe(ranks);
    let handles: Vec<_> = comms
        .into_iter()
        .enumerate()
        .map(|(rank, comm)| {
            let job = job.clone();
            std::thread::spawn(move || job(rank, &comm))
        })
        .collect();
    for h in handles {
        // A panicked rank is reported by its empty slot.
        let _ = h.join();
    }
}
