//! Standard normals: the hand-written 256-layer ziggurats of `src/rng.rs` against rand_distr's
//! `StandardNormal` (the same method, Doornik's variant) drawn from the same keyed generators
//! through `rand_core::RngCore` (`cargo bench --bench normals`).
//!
//! Both sides draw from identical bit streams (the newtypes below forward `next_u64`), so the
//! comparison isolates the normal transform. The drawn values differ — rand_distr splits the
//! 64 bits differently — which is why the code keeps its own (every digest would move).

use criterion::{Criterion, criterion_group, criterion_main};
use mesorheo::rng::{HashStream, NormalStream, Purpose};
use rand_distr::{Distribution, StandardNormal};
use std::hint::black_box;

/// The dumbbell noise stream (xoshiro256++ keyed by SplitMix64) as a `rand_core` generator.
struct Xoshiro(NormalStream);

impl rand_core::RngCore for Xoshiro {
    fn next_u32(&mut self) -> u32 {
        (self.0.next_u64() >> 32) as u32
    }
    fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }
    fn fill_bytes(&mut self, dst: &mut [u8]) {
        rand_core::impls::fill_bytes_via_next(self, dst)
    }
}

/// The DPD pair-noise stream (keyed SplitMix64) as a `rand_core` generator.
struct SplitMix(HashStream);

impl rand_core::RngCore for SplitMix {
    fn next_u32(&mut self) -> u32 {
        (self.0.next_u64() >> 32) as u32
    }
    fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
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
            let mut s = Xoshiro(NormalStream::new(7, Purpose::DumbbellNoise, step, 3, 0));
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
            let mut s = SplitMix(HashStream::new(7, Purpose::DpdPair, step, 3, 0));
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
                    StandardNormal.sample(&mut SplitMix(HashStream::from_prefix(prefix, 5, j)));
                acc += x;
            }
            black_box(acc)
        })
    });
    g.finish();
}

criterion_group!(benches, normals);
criterion_main!(benches);
