//! Micro-benchmarks of the hot kernels (single rank): the DPD pair force with its noise, the
//! neighbour-list build, the exact accumulator and the random-number generators.
//! Run with `cargo bench --features bench --bench kernels` (or `./run bench`); figures in docs/performance.md.

use criterion::{Criterion, criterion_group, criterion_main};
use mesorheo::comm::SerialComm;
use mesorheo::config;
use mesorheo::facade::Engine;
use mesorheo::fixed_sum::FixedSum;
use mesorheo::neighbour::NeighbourList;
use mesorheo::rng::{HashStream, Purpose, StreamKey};
use mesorheo::sim::Simulation;
use std::hint::black_box;
use std::path::Path;

fn bench_case() -> config::Case {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/bench_dpd_32k.toml");
    config::load(&path).expect("stock case").case
}

fn rng(c: &mut Criterion) {
    let key = StreamKey::new(1, Purpose::Test, 0);
    c.bench_function("philox4x32_10 gaussian (Box–Muller)", |b| {
        let mut i = 0u32;
        b.iter(|| {
            i = i.wrapping_add(1);
            black_box(key.gaussian(7, i, 3))
        })
    });
    c.bench_function("keyed hash stream + ziggurat normal", |b| {
        let mut i = 0u64;
        b.iter(|| {
            i = i.wrapping_add(1);
            black_box(HashStream::new(1, Purpose::DpdPair, 7, i, i + 1).normal())
        })
    });
    c.bench_function("FixedSum::add ×3", |b| {
        let mut acc = FixedSum::ZERO;
        let mut x = 0.123_456_789f64;
        b.iter(|| {
            x += 1.000_001;
            acc.add(black_box(x));
            acc.add(black_box(-x * 0.5));
            acc.add(black_box(x * 1e-3));
        });
        black_box(acc.value());
    });
}

fn dpd(c: &mut Criterion) {
    let case = bench_case();
    let comm = SerialComm::new();
    let mut sim = Simulation::<3>::new(&case, &comm, 1).expect("setup");
    let radius = sim.list.radius;
    let cutoff = case.cutoff();
    let mut group = c.benchmark_group("dpd_32k");
    group.sample_size(10);
    group.bench_function("neighbour list build (32k + ghosts, 1 thread)", |b| {
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .expect("a one-thread pool");
        b.iter(|| {
            one.install(|| black_box(NeighbourList::build(&sim.particles, radius, cutoff).len()))
        })
    });
    group.bench_function("pair forces (1 thread)", |b| {
        b.iter(|| sim.recompute_forces(false).expect("forces"))
    });
    group.bench_function("pair forces with virial (1 thread)", |b| {
        b.iter(|| sim.recompute_forces(true).expect("forces"))
    });
    group.bench_function("one time step (1 thread)", |b| {
        b.iter(|| sim.advance().expect("step"))
    });
    group.finish();
}

criterion_group!(benches, rng, dpd);
criterion_main!(benches);
