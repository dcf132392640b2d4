//! Real multi-process transport through rsmpi. All calls come from the main thread
//! (`Threading::Funneled`); rayon workers only compute.

use super::{Comm, U64Op};
use mpi::collective::SystemOperation;
use mpi::topology::SimpleCommunicator;
use mpi::traits::{Communicator as _, CommunicatorCollectives as _, Destination as _, Source as _};

/// An MPI communicator (normally `MPI_COMM_WORLD`).
pub struct MpiComm {
    world: SimpleCommunicator,
}

impl MpiComm {
    /// Wraps a communicator.
    pub fn new(world: SimpleCommunicator) -> Self {
        Self { world }
    }
}

impl Comm for MpiComm {
    fn rank(&self) -> usize {
        self.world.rank() as usize
    }
    fn size(&self) -> usize {
        self.world.size() as usize
    }
    fn sendrecv(&self, send: Vec<f64>, dest: usize, src: usize, tag: u32) -> Vec<f64> {
        let tag = (tag & 0x7fff) as i32;
        mpi::request::scope(|scope| {
            let request = self
                .world
                .process_at_rank(dest as i32)
                .immediate_send_with_tag(scope, &send[..], tag);
            let (data, _status) = self
                .world
                .process_at_rank(src as i32)
                .receive_vec_with_tag::<f64>(tag);
            request.wait();
            data
        })
    }
    fn allreduce_sum(&self, values: &mut [f64]) {
        let local = values.to_vec();
        self.world
            .all_reduce_into(&local[..], values, SystemOperation::sum());
    }
    fn allreduce_max(&self, values: &mut [f64]) {
        let local = values.to_vec();
        self.world
            .all_reduce_into(&local[..], values, SystemOperation::max());
    }
    fn allreduce_u64(&self, values: &mut [u64], op: U64Op) {
        let local = values.to_vec();
        let op = match op {
            U64Op::Sum => SystemOperation::sum(),
            U64Op::Xor => SystemOperation::bitwise_xor(),
            U64Op::Max => SystemOperation::max(),
        };
        self.world.all_reduce_into(&local[..], values, op);
    }
    fn allgather(&self, mine: &[f64]) -> Vec<Vec<f64>> {
        let size = self.size();
        let count = [mine.len() as i32];
        let mut counts = vec![0i32; size];
        self.world.all_gather_into(&count[..], &mut counts[..]);
        let displs: Vec<i32> = counts
            .iter()
            .scan(0i32, |acc, &c| {
                let d = *acc;
                *acc += c;
                Some(d)
            })
            .collect();
        let total: i32 = counts.iter().sum();
        let mut buffer = vec![0.0f64; total as usize];
        {
            let mut partition =
                mpi::datatype::PartitionMut::new(&mut buffer[..], &counts[..], &displs[..]);
            self.world.all_gather_varcount_into(mine, &mut partition);
        }
        counts
            .iter()
            .zip(&displs)
            .map(|(&c, &d)| buffer[d as usize..(d + c) as usize].to_vec())
            .collect()
    }
    fn barrier(&self) {
        self.world.barrier();
    }
    fn is_mpi(&self) -> bool {
        true
    }
    fn raw_mpi(&self) -> Option<mpi::ffi::MPI_Comm> {
        use mpi::raw::AsRaw as _;
        Some(self.world.as_raw())
    }
}
