//! Standard normals: the hand-written 256-layer ziggurats of `src/rng.rs` against rand_distr's
//! `StandardNormal` (the same method, Doornik's variant) drawn from the same keyed generators
//! through `rand_core::RngCore` (`cargo bench --features bench --bench normals`).
//!
//! Both sides draw from identical bit streams (the newtypes below forward `next_u64`), so the
//! comparison isolates the normal transform. The drawn values differ — rand_distr splits the
//! 64 bits differently — which is why the code keeps its own (every digest would move).

use criterion::{Criterion, criterion_group, criterion_main};
use mesorheo::rng::{HashStream, NormalStream, Purpose};
use rand_distr::{Distribution, StandardNormal};
use std::hint::black_box;

/// The keyed streams' 64-bit output.
trait Bits {
    fn bits(&mut self) -> u64;
}

impl Bits for NormalStream {
    fn bits(&mut self) -> u64 {
        self.next_u64()
    }
}

impl Bits for HashStream {
    fn bits(&mut self) -> u64 {
        self.next_u64()
    }
}

/// A keyed stream — the dumbbell noise (xoshiro256++ keyed by SplitMix64) or the DPD pair
/// noise (keyed SplitMix64) — as a `rand_core` generator.
struct Keyed<S>(S);

impl<S: Bits> rand_core::RngCore for Keyed<S> {
    fn next_u32(&mut self) -> u32 {
        (self.0.bits() >> 32) as u32
    }
    fn next_u64(&mut self) -> u64 {
        self.0.bits()
    }
    fn fill_bytes(&mut self, dst: &mut [u8]) {
        rand_core::impls::fill_bytes_via_next(self, dst)
    }
}

/// Normals per timed call: one particle's ensemble of 1 000 3D dumbbells, one step.
const N: usize = 3000;

fn normals(c: &mut Criterion) {
    let mut out = vec![0.0; N];
    let mut g = c.benchmark_group("3000 normals");
    g.bench_function("NormalStream::fill_normals (hand-written)", |b| {
        let mut step = 0;
        b.iter(|| {
            step += 1;
            let mut s = NormalStream::new(7, Purpose::DumbbellNoise, step, 3, 0);
            s.fill_normals(&mut out);
            black_box(&out);
        })
    });
    g.bench_function("rand_distr StandardNormal on the same xoshiro256++", |b| {
        let mut step = 0;
        b.iter(|| {
            step += 1;
            let mut s = Keyed(NormalStream::new(7, Purpose::DumbbellNoise, step, 3, 0));
            for o in out.iter_mut() {
                *o = StandardNormal.sample(&mut s);
            }
            black_box(&out);
        })
    });
    g.bench_function("HashStream::fill_normals (hand-written)", |b| {
        let mut step = 0;
        b.iter(|| {
            step += 1;
            let mut s = HashStream::new(7, Purpose::DpdPair, step, 3, 0);
            s.fill_normals(&mut out);
            black_box(&out);
        })
    });
    g.bench_function("rand_distr StandardNormal on the same SplitMix64", |b| {
        let mut step = 0;
        b.iter(|| {
            step += 1;
            let mut s = Keyed(HashStream::new(7, Purpose::DpdPair, step, 3, 0));
            for o in out.iter_mut() {
                *o = StandardNormal.sample(&mut s);
            }
            black_box(&out);
        })
    });
    g.finish();
    // DPD draws one normal per pair from a fresh stream: the per-key cost matters there.
    let mut g = c.benchmark_group("one normal per fresh key (DPD pair noise), ×1000");
    g.bench_function("HashStream::normal (hand-written)", |b| {
        let prefix = HashStream::prefix(7, Purpose::DpdPair, 11);
        b.iter(|| {
            let mut acc = 0.0;
            for j in 0..1000u64 {
                acc += HashStream::from_prefix(prefix, 5, j).normal();
            }
            black_box(acc)
        })
    });
    g.bench_function("rand_distr StandardNormal", |b| {
        let prefix = HashStream::prefix(7, Purpose::DpdPair, 11);
        b.iter(|| {
            let mut acc = 0.0;
            for j in 0..1000u64 {
                let x: f64 =
                    StandardNormal.sample(&mut Keyed(HashStream::from_prefix(prefix, 5, j)));
                acc += x;
            }
            black_box(acc)
        })
    });
    g.finish();
}

criterion_group!(benches, normals);
criterion_main!(benches);
