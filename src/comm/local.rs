//! P ranks as threads of one process, connected by channels. Used by the tests to prove that a
//! result does not depend on the rank count without launching `mpirun`.

use super::{Comm, U64Op, reduce_u64};
use std::cell::RefCell;
use std::sync::mpsc::{Receiver, Sender, channel};

struct Message {
    from: usize,
    tag: u32,
    data: Vec<f64>,
}

/// One rank of an in-process universe; see [`local_universe`].
pub struct LocalComm {
    rank: usize,
    senders: Vec<Sender<Message>>,
    receiver: Receiver<Message>,
    pending: RefCell<Vec<Message>>,
}

/// Builds `size` connected ranks; move each into its own thread.
pub fn local_universe(size: usize) -> Vec<LocalComm> {
    assert!(size > 0, "a universe needs at least one rank");
    let (senders, receivers): (Vec<_>, Vec<_>) = (0..size).map(|_| channel()).unzip();
    receivers
        .into_iter()
        .enumerate()
        .map(|(rank, receiver)| LocalComm {
            rank,
            senders: senders.clone(),
            receiver,
            pending: RefCell::new(Vec::new()),
        })
        .collect()
}

const TAG_COLLECTIVE: u32 = u32::MAX;

impl LocalComm {
    fn send(&self, dest: usize, tag: u32, data: Vec<f64>) {
        self.senders[dest]
            .send(Message {
                from: self.rank,
                tag,
                data,
            })
            .expect("peer rank thread ended early");
    }

    fn receive(&self, src: usize, tag: u32) -> Vec<f64> {
        {
            let mut pending = self.pending.borrow_mut();
            if let Some(pos) = pending.iter().position(|m| m.from == src && m.tag == tag) {
                return pending.remove(pos).data;
            }
        }
        loop {
            let msg = self.receiver.recv().expect("peer rank thread ended early");
            if msg.from == src && msg.tag == tag {
                return msg.data;
            }
            self.pending.borrow_mut().push(msg);
        }
    }
}

impl Comm for LocalComm {
    fn rank(&self) -> usize {
        self.rank
    }
    fn size(&self) -> usize {
        self.senders.len()
    }
    fn sendrecv(&self, send: Vec<f64>, dest: usize, src: usize, tag: u32) -> Vec<f64> {
        self.send(dest, tag, send);
        self.receive(src, tag)
    }
    fn allreduce_sum(&self, values: &mut [f64]) {
        let all = self.allgather(values);
        values.iter_mut().for_each(|v| *v = 0.0);
        for part in &all {
            for (v, p) in values.iter_mut().zip(part) {
                *v += p;
            }
        }
    }
    fn allreduce_max(&self, values: &mut [f64]) {
        let all = self.allgather(values);
        for part in &all {
            for (v, p) in values.iter_mut().zip(part) {
                *v = v.max(*p);
            }
        }
    }
    fn allreduce_u64(&self, values: &mut [u64], op: U64Op) {
        let words: Vec<f64> = values.iter().map(|v| f64::from_bits(*v)).collect();
        let all = self.allgather(&words);
        let mut acc: Vec<u64> = all[0].iter().map(|w| w.to_bits()).collect();
        for part in &all[1..] {
            let other: Vec<u64> = part.iter().map(|w| w.to_bits()).collect();
            reduce_u64(&mut acc, &other, op);
        }
        values.copy_from_slice(&acc);
    }
    fn allgather(&self, mine: &[f64]) -> Vec<Vec<f64>> {
        for dest in 0..self.size() {
            if dest != self.rank {
                self.send(dest, TAG_COLLECTIVE, mine.to_vec());
            }
        }
        (0..self.size())
            .map(|src| {
                if src == self.rank {
                    mine.to_vec()
                } else {
                    self.receive(src, TAG_COLLECTIVE)
                }
            })
            .collect()
    }
    fn barrier(&self) {
        self.allgather(&[]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ring_exchange_and_reductions() {
        let comms = local_universe(3);
        let handles: Vec<_> = comms
            .into_iter()
            .map(|c| {
                std::thread::spawn(move || {
                    let (r, p) = (c.rank(), c.size());
                    let got = c.sendrecv(vec![r as f64], (r + 1) % p, (r + p - 1) % p, 7);
                    assert_eq!(got, vec![((r + p - 1) % p) as f64]);
                    let mut s = [r as f64, 1.0];
                    c.allreduce_sum(&mut s);
                    assert_eq!(s, [3.0, 3.0]);
                    let mut m = [r as f64];
                    c.allreduce_max(&mut m);
                    assert_eq!(m, [2.0]);
                    let mut x = [1u64 << r, u64::MAX];
                    c.allreduce_u64(&mut x, U64Op::Xor);
                    assert_eq!(x, [7, u64::MAX]);
                })
            })
            .collect();
        for h in handles {
            h.join().expect("rank thread panicked");
        }
    }
}
