//! Stable counting sorts on the rank's threads, with the same result on any number of them.
//!
//! The items are cut into contiguous chunks, one histogram per chunk:
//!
//! ```text
//! count[c][b] = #{ keys equal to b emitted by chunk c }
//! start[b]    = Σ_{b' < b} Σ_c count[c][b']                 (bin b's first slot)
//! base[c][b]  = start[b] + Σ_{c' < c} count[c'][b]          (chunk c's first slot in bin b)
//! ```
//!
//! Chunk c then writes its keys of bin b, in its own order, to `base[c][b]`, `base[c][b] + 1`,
//! … . The slots of bin b are taken chunk by chunk and, within a chunk, in item order: the
//! order of a serial stable counting sort, whatever the chunking. Every slot is written by
//! exactly one chunk ([`DisjointSlots`]). The prefix over the bins runs in blocks of bins on
//! the threads too, so no step is serial in the number of items or of bins beyond one sum per
//! block.

use rayon::prelude::*;
use std::marker::PhantomData;

/// Fewest items per chunk: below this the histograms cost more than they save.
const MIN_CHUNK: usize = 16_384;

/// Bins per block of the parallel prefix.
const BIN_BLOCK: usize = 8_192;

/// How many chunks to cut `items` into on the current rayon pool (1 when small).
pub fn chunk_count(items: usize) -> usize {
    rayon::current_num_threads().min(items / MIN_CHUNK).max(1)
}

/// The bin starts (`bins + 1` numbers, the last the total) and, per chunk, its first slot in
/// every bin (`base[c][b]` above), from the per-chunk histograms `counts[c][b]`. The histograms
/// are turned into the bases in place.
pub fn bases(mut counts: Vec<Vec<u32>>, bins: usize) -> (Vec<usize>, Vec<Vec<u32>>) {
    debug_assert!(counts.iter().all(|c| c.len() == bins));
    let mut start = vec![0usize; bins + 1];
    let blocks = bins.div_ceil(BIN_BLOCK);
    // Each block's total over its bins and every chunk.
    let block_totals: Vec<usize> = (0..blocks)
        .into_par_iter()
        .map(|k| {
            let bins = k * BIN_BLOCK..((k + 1) * BIN_BLOCK).min(bins);
            (counts.iter())
                .map(|c| c[bins.clone()].iter().map(|&n| n as usize).sum::<usize>())
                .sum()
        })
        .collect();
    let mut block_start = Vec::with_capacity(blocks);
    let mut total = 0usize;
    for t in &block_totals {
        block_start.push(total);
        total += t;
    }
    start[bins] = total;
    assert!(
        total <= u32::MAX as usize,
        "{total} entries in one counting sort: at most 2^32 − 1 are supported"
    );
    // Per block: the slices of every chunk's histogram over the block's bins.
    let mut per_block: Vec<Vec<&mut [u32]>> = (0..blocks).map(|_| Vec::new()).collect();
    for c in counts.iter_mut() {
        for (k, s) in c.chunks_mut(BIN_BLOCK).enumerate() {
            per_block[k].push(s);
        }
    }
    per_block
        .into_par_iter()
        .zip(start[..bins].par_chunks_mut(BIN_BLOCK))
        .zip(block_start.into_par_iter())
        .for_each(|((mut chunks, starts), first)| {
            let mut next = first;
            for (b, s) in starts.iter_mut().enumerate() {
                *s = next;
                for c in chunks.iter_mut() {
                    let n = c[b] as usize;
                    c[b] = next as u32;
                    next += n;
                }
            }
        });
    (start, counts)
}

/// A slice that threads write at disjoint indices: each index is written by at most one
/// thread, and nothing reads the slice while they write (the slice is borrowed mutably for
/// the writer's lifetime).
pub struct DisjointSlots<'a, T> {
    ptr: *mut T,
    len: usize,
    _slice: PhantomData<&'a mut [T]>,
}

// SAFETY: a `DisjointSlots` is a `&mut [T]` whose writes the callers of the unsafe `write`
// promise never to overlap; sending `T` values to other threads needs `T: Send`.
unsafe impl<T: Send> Sync for DisjointSlots<'_, T> {}
// SAFETY: as above.
unsafe impl<T: Send> Send for DisjointSlots<'_, T> {}

impl<'a, T: Copy> DisjointSlots<'a, T> {
    /// Borrows `slice` for disjoint writes.
    pub fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _slice: PhantomData,
        }
    }

    /// Writes `value` at `index` (bounds-checked: an index out of range panics).
    ///
    /// # Safety
    /// No other thread writes `index` during the writer's life. (The counting sorts of this
    /// module guarantee it: the bases give every (chunk, bin) its own run of slots, exactly
    /// as long as the chunk's count in that bin.)
    #[inline(always)]
    pub unsafe fn write(&self, index: usize, value: T) {
        assert!(index < self.len, "slot {index} beyond {}", self.len);
        // SAFETY: in bounds (asserted); the borrow of the slice is exclusive to this writer and
        // no other thread writes this index (the caller's promise), so there is no data race.
        // `T: Copy`: the overwritten value needs no drop.
        unsafe { self.ptr.add(index).write(value) };
    }
}

/// The stable order of `keys` (each below `bins`) by key: `start` (bins + 1 entries) and
/// `order`, with `order[start[b]..start[b + 1]]` the indices of the keys equal to b,
/// ascending. The same on any number of threads.
pub fn sort_indices(keys: &[u32], bins: usize) -> (Vec<usize>, Vec<u32>) {
    let chunks = chunk_count(keys.len());
    let per = keys.len().div_ceil(chunks).max(1);
    let counts = histograms(keys, bins, per);
    let (start, mut base) = bases(counts, bins);
    let mut order = vec![0u32; keys.len()];
    let slots = DisjointSlots::new(&mut order);
    keys.par_chunks(per)
        .zip(base.par_iter_mut())
        .enumerate()
        .for_each(|(c, (ks, next))| {
            for (i, &k) in ks.iter().enumerate() {
                let slot = next[k as usize] as usize;
                next[k as usize] += 1;
                // SAFETY: chunk c's keys of bin k take the slots base[c][k] .. base[c][k] +
                // count[c][k], a run no other chunk and no other bin is given ([`bases`]).
                unsafe { slots.write(slot, (c * per + i) as u32) };
            }
        });
    (start, order)
}

/// One histogram over `bins` per chunk of `per` keys.
pub fn histograms(keys: &[u32], bins: usize, per: usize) -> Vec<Vec<u32>> {
    keys.par_chunks(per.max(1))
        .map(|ks| {
            let mut h = vec![0u32; bins];
            for &k in ks {
                h[k as usize] += 1;
            }
            h
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn serial(keys: &[u32], bins: usize) -> (Vec<usize>, Vec<u32>) {
        let mut start = vec![0usize; bins + 1];
        for &k in keys {
            start[k as usize + 1] += 1;
        }
        for b in 0..bins {
            start[b + 1] += start[b];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; keys.len()];
        for (i, &k) in keys.iter().enumerate() {
            order[fill[k as usize]] = i as u32;
            fill[k as usize] += 1;
        }
        (start, order)
    }

    /// The parallel sort equals the serial stable counting sort on 1, 2, 3 and 8 threads, for
    /// more bins than one prefix block and with empty bins.
    #[test]
    fn the_parallel_sort_is_the_serial_stable_sort_on_any_number_of_threads() {
        let n = 200_003;
        let bins = 3 * BIN_BLOCK + 17;
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let keys: Vec<u32> = (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                // Every third bin stays empty.
                let k = (x % bins as u64) as u32;
                if k.is_multiple_of(3) { k + 1 } else { k }.min(bins as u32 - 1)
            })
            .collect();
        let want = serial(&keys, bins);
        for threads in [1, 2, 3, 8] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool");
            assert!(pool.install(|| chunk_count(n)) == threads.min(n / MIN_CHUNK));
            let got = pool.install(|| sort_indices(&keys, bins));
            assert_eq!(got, want, "{threads} threads");
        }
    }
}
