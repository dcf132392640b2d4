//! Dumbbell-steps per second per core (`cargo bench --bench dumbbells`): Hookean Euler–Maruyama
//! (2D, 3D), Heun/SRK2, FENE semi-implicit, on 1 and 2 threads, with the generator limit (the
//! same number of normals drawn and summed, nothing else) beside them. Prints a Markdown table;
//! medians of 5 repetitions.

use mesorheo::comm::SerialComm;
use mesorheo::models::dumbbells::{DumbbellParams, Scheme, Spring, noise_stream};
use mesorheo::models::homogeneous_flow::{Flow, HomogeneousEnsembles};
use std::time::Instant;

fn rate<const D: usize>(spring: Spring, scheme: Scheme, threads: usize) -> f64 {
    let comm = SerialComm::new();
    let p = DumbbellParams {
        spring,
        scheme,
        lambda: 1.0,
        dt: 0.01,
    };
    let (particles, n_d, steps) = (600u64, 1000usize, 20u64);
    let mut e = HomogeneousEnsembles::<D>::new(
        &comm,
        threads,
        particles,
        n_d,
        p,
        Flow::SimpleShear { rate: 1.0 },
        1,
    )
    .expect("ensembles");
    let mut times = Vec::new();
    for _ in 0..5 {
        let t = Instant::now();
        for _ in 0..steps {
            e.advance();
        }
        times.push(t.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    (particles * n_d as u64 * steps) as f64 / times[2]
}

fn generator_limit(dim: usize) -> f64 {
    let n = 600u64 * 1000 * dim as u64;
    let mut times = Vec::new();
    let mut sink = 0.0;
    for _ in 0..5 {
        let t = Instant::now();
        let mut buf = vec![0.0; 1000 * dim];
        for g in 0..600u64 {
            noise_stream(1, g, 0).fill_normals(&mut buf);
            sink += buf.iter().sum::<f64>();
        }
        times.push(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(sink);
    times.sort_by(f64::total_cmp);
    (n / dim as u64) as f64 / times[2]
}

fn main() {
    println!("| model | scheme | D | threads | dumbbell-steps/s | per core |");
    println!("|---|---|---|---|---|---|");
    let rows: [(&str, Spring, Scheme, usize); 5] = [
        ("Hookean", Spring::Hookean, Scheme::EulerMaruyama, 2),
        ("Hookean", Spring::Hookean, Scheme::EulerMaruyama, 3),
        ("Hookean", Spring::Hookean, Scheme::Heun, 3),
        (
            "FENE b = 50",
            Spring::Fene { b: 50.0 },
            Scheme::SemiImplicit,
            3,
        ),
        ("Hookean", Spring::Hookean, Scheme::SemiImplicit, 3),
    ];
    for (name, spring, scheme, dim) in rows {
        for threads in [1, 2] {
            let r = if dim == 2 {
                rate::<2>(spring, scheme, threads)
            } else {
                rate::<3>(spring, scheme, threads)
            };
            println!(
                "| {name} | {scheme:?} | {dim} | {threads} | {r:.3e} | {:.3e} |",
                r / threads as f64
            );
        }
    }
    for dim in [2, 3] {
        println!(
            "| generator only (keyed SplitMix64 + ziggurat, {dim} normals per dumbbell) | – | {dim} | 1 | {:.3e} | |",
            generator_limit(dim)
        );
    }
}
