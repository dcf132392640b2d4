//! Dumbbell-steps per second per core (`cargo bench --features bench --bench dumbbells`): Hookean Euler–Maruyama
//! (2D, 3D), Heun/SRK2, semi-implicit (Hookean, FENE), on 1 and 2 threads, OLD against NEW in
//! the same run, repetitions interleaved (the machine is shared: ratios of interleaved medians
//! are what to quote; the best repetition is the least disturbed), plus the generators alone.
//! Prints a Markdown table, rates per core in dumbbell-steps/s.
//!
//! - NEW: `step_ensemble` with `noise_stream` (one `NormalStream` per particle and step:
//!   xoshiro256++ seeded from the keyed SplitMix64, static-table ziggurat; scheme dispatched once
//!   per call, normals drawn inline for Hookean Euler–Maruyama, via a stack buffer otherwise), over the particles exactly as
//!   `HomogeneousEnsembles::advance` does (rayon `par_iter_mut` in a pool of `threads`).
//! - OLD: the previous kernel, kept here verbatim as the reference row (one `HashStream` per
//!   particle and step, keyed SplitMix64 + ziggurat with the lazily built table, all normals
//!   into a `vec!` first, scheme matched per dumbbell).
//! - `advance`: NEW through `HomogeneousEnsembles::advance` itself (end-to-end check).

use mesorheo::comm::SerialComm;
use mesorheo::facade::Ensembles;
use mesorheo::models::dumbbells::{
    DumbbellParams, Scheme, Spring, noise_stream, sample_equilibrium, step_ensemble,
};
use mesorheo::models::homogeneous_flow::{EnsembleSpec, Flow, HomogeneousEnsembles};
use mesorheo::rng::{HashStream, NormalStream, Purpose};
use rayon::prelude::*;
use std::time::Instant;

const PARTICLES: u64 = 600;
const N_D: usize = 1000;
const STEPS: u64 = 10;
const REPS: usize = 9;

mod old {
    //! The kernel before the NormalStream change (commit 2230c7d), verbatim but for names.
    use super::*;

    #[inline(always)]
    fn drift<const D: usize>(
        q: &[f64; D],
        kappa: &[[f64; D]; D],
        spring: Spring,
        lambda: f64,
    ) -> [f64; D] {
        let q2: f64 = q.iter().map(|x| x * x).sum();
        let f = spring.factor(q2) / (2.0 * lambda);
        let mut a = [0.0; D];
        for al in 0..D {
            let mut s = 0.0;
            for be in 0..D {
                s += kappa[al][be] * q[be];
            }
            a[al] = s - f * q[al];
        }
        a
    }

    fn fene_length(r: f64, b: f64, eps: f64) -> f64 {
        let g = |l: f64| l * l * l - r * l * l - b * (1.0 + eps) * l + b * r;
        let dg = |l: f64| 3.0 * l * l - 2.0 * r * l - b * (1.0 + eps);
        let (mut lo, mut hi) = (0.0, b.sqrt());
        let mut l = (r / (1.0 + eps)).min(0.5 * hi);
        for _ in 0..200 {
            let v = g(l);
            if v == 0.0 {
                break;
            }
            if v > 0.0 {
                lo = l;
            } else {
                hi = l;
            }
            let d = dg(l);
            let newton = l - v / d;
            let next = if newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            let converged = (next - l).abs() <= 4.0 * f64::EPSILON * l.max(1e-300);
            l = next;
            if converged || hi - lo <= 4.0 * f64::EPSILON * hi {
                break;
            }
        }
        l.min(b.sqrt() * (1.0 - f64::EPSILON))
    }

    pub fn noise_stream(seed: u64, gid: u64, step: u64) -> HashStream {
        HashStream::new(seed, Purpose::DumbbellNoise, step, gid, 0)
    }

    pub fn step_ensemble<const D: usize>(
        q: &mut [f64],
        kappa: &[[f64; D]; D],
        p: &DumbbellParams,
        noise: &mut HashStream,
    ) {
        let amp = (p.dt / p.lambda).sqrt();
        let dt = p.dt;
        let mut normals = vec![0.0; q.len()];
        noise.fill_normals(&mut normals);
        for (c, g) in q.chunks_exact_mut(D).zip(normals.chunks_exact(D)) {
            let mut x = [0.0; D];
            x.copy_from_slice(c);
            let mut xi = [0.0; D];
            for d in 0..D {
                xi[d] = amp * g[d];
            }
            let a0 = drift(&x, kappa, p.spring, p.lambda);
            match p.scheme {
                Scheme::EulerMaruyama => {
                    for d in 0..D {
                        c[d] = x[d] + a0[d] * dt + xi[d];
                    }
                }
                Scheme::Heun => {
                    let mut pred = [0.0; D];
                    for d in 0..D {
                        pred[d] = x[d] + a0[d] * dt + xi[d];
                    }
                    let a1 = drift(&pred, kappa, p.spring, p.lambda);
                    for d in 0..D {
                        c[d] = x[d] + 0.5 * (a0[d] + a1[d]) * dt + xi[d];
                    }
                }
                Scheme::SemiImplicit => {
                    let mut pred = [0.0; D];
                    for d in 0..D {
                        pred[d] = x[d] + a0[d] * dt + xi[d];
                    }
                    let q2: f64 = x.iter().map(|v| v * v).sum();
                    let fq = p.spring.factor(q2) / (4.0 * p.lambda);
                    let mut r = [0.0; D];
                    for al in 0..D {
                        let mut s = 0.0;
                        for be in 0..D {
                            s += kappa[al][be] * (x[be] + pred[be]);
                        }
                        r[al] = x[al] + (0.5 * s - fq * x[al]) * dt + xi[al];
                    }
                    let eps = dt / (4.0 * p.lambda);
                    let scale = match p.spring {
                        Spring::Hookean => 1.0 / (1.0 + eps),
                        Spring::Fene { b } => {
                            let rn = r.iter().map(|v| v * v).sum::<f64>().sqrt();
                            if rn == 0.0 {
                                0.0
                            } else {
                                fene_length(rn, b, eps) / rn
                            }
                        }
                    };
                    for d in 0..D {
                        c[d] = r[d] * scale;
                    }
                }
            }
        }
    }
}

fn params(spring: Spring, scheme: Scheme) -> DumbbellParams {
    DumbbellParams {
        spring,
        scheme,
        lambda: 1.0,
        dt: 0.01,
    }
}

/// (median, best) of the repetition times.
fn median_and_best(mut t: Vec<f64>) -> (f64, f64) {
    t.sort_by(f64::total_cmp);
    (t[t.len() / 2], t[0])
}

/// Dumbbell-steps/s of OLD, NEW and `advance` (median and best of `REPS` interleaved
/// repetitions).
fn rates<const D: usize>(spring: Spring, scheme: Scheme, threads: usize) -> [(f64, f64); 3]
where
    for<'c> HomogeneousEnsembles<'c, D>: Ensembles<'c, D>,
{
    let p = params(spring, scheme);
    let kappa = mesorheo::particles::tensor_rows(&Flow::SimpleShear { rate: 1.0 }.kappa::<D>(0.0));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    let start: Vec<Vec<f64>> = (0..PARTICLES)
        .map(|g| {
            let mut q = vec![0.0; N_D * D];
            sample_equilibrium::<D>(
                &mut q,
                spring,
                &mut NormalStream::new(1, Purpose::Test, 0, g, 0),
            );
            q
        })
        .collect();
    let (mut q_old, mut q_new) = (start.clone(), start);
    let comm = SerialComm::new();
    let mut e = HomogeneousEnsembles::<D>::new(
        &comm,
        EnsembleSpec {
            threads,
            total: PARTICLES,
            n_d: N_D,
            params: p,
            flow: Flow::SimpleShear { rate: 1.0 },
            seed: 1,
        },
    )
    .expect("ensembles");
    let mut times = [Vec::new(), Vec::new(), Vec::new()];
    let mut step = 0u64;
    for _ in 0..REPS {
        let t = Instant::now();
        for s in step..step + STEPS {
            pool.install(|| {
                q_old.par_iter_mut().enumerate().for_each(|(g, q)| {
                    old::step_ensemble::<D>(q, &kappa, &p, &mut old::noise_stream(1, g as u64, s));
                })
            });
        }
        times[0].push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        for s in step..step + STEPS {
            pool.install(|| {
                q_new.par_iter_mut().enumerate().for_each(|(g, q)| {
                    step_ensemble::<D>(q, &kappa, &p, &mut noise_stream(1, g as u64, s, 0));
                })
            });
        }
        times[1].push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        for _ in 0..STEPS {
            e.advance().expect("a stable step");
        }
        times[2].push(t.elapsed().as_secs_f64());
        step += STEPS;
    }
    std::hint::black_box((&q_old, &q_new));
    let work = (PARTICLES * N_D as u64 * STEPS) as f64;
    times.map(|t| {
        let (m, b) = median_and_best(t);
        (work / m, work / b)
    })
}

/// The generators alone: the same number of normals drawn into a buffer, one stream per particle.
fn generator_rates(dim: usize) -> [(f64, f64); 2] {
    let mut times = [Vec::new(), Vec::new()];
    let mut sink = 0.0;
    let mut buf = vec![0.0; N_D * dim];
    for rep in 0..REPS as u64 {
        let t = Instant::now();
        for g in 0..PARTICLES {
            old::noise_stream(1, g, rep).fill_normals(&mut buf);
            sink += std::hint::black_box(&buf)[g as usize];
        }
        times[0].push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        for g in 0..PARTICLES {
            noise_stream(1, g, rep, 0).fill_normals(&mut buf);
            sink += std::hint::black_box(&buf)[g as usize];
        }
        times[1].push(t.elapsed().as_secs_f64());
    }
    std::hint::black_box(sink);
    let work = (PARTICLES * N_D as u64) as f64;
    times.map(|t| {
        let (m, b) = median_and_best(t);
        (work / m, work / b)
    })
}

fn main() {
    println!(
        "{PARTICLES} particles × {N_D} dumbbells, {STEPS} steps per repetition, simple shear γ̇λ = 1, Δt = 0.01λ; medians of {REPS} interleaved repetitions"
    );
    println!(
        "| model | scheme | D | threads | OLD median | NEW median | NEW/OLD | OLD best | NEW best | NEW/OLD best | `advance` median |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let rows: [(&str, Spring, Scheme, usize); 6] = [
        ("Hookean", Spring::Hookean, Scheme::EulerMaruyama, 2),
        ("Hookean", Spring::Hookean, Scheme::EulerMaruyama, 3),
        ("Hookean", Spring::Hookean, Scheme::Heun, 2),
        ("Hookean", Spring::Hookean, Scheme::Heun, 3),
        ("Hookean", Spring::Hookean, Scheme::SemiImplicit, 3),
        (
            "FENE b = 50",
            Spring::Fene { b: 50.0 },
            Scheme::SemiImplicit,
            3,
        ),
    ];
    for (name, spring, scheme, dim) in rows {
        for threads in [1, 2] {
            let r = if dim == 2 {
                rates::<2>(spring, scheme, threads)
            } else {
                rates::<3>(spring, scheme, threads)
            };
            let c = threads as f64;
            println!(
                "| {name} | {scheme:?} | {dim} | {threads} | {:.3e} | {:.3e} | {:.2} | {:.3e} | {:.3e} | {:.2} | {:.3e} |",
                r[0].0 / c,
                r[1].0 / c,
                r[1].0 / r[0].0,
                r[0].1 / c,
                r[1].1 / c,
                r[1].1 / r[0].1,
                r[2].0 / c
            );
        }
    }
    for dim in [2, 3] {
        let r = generator_rates(dim);
        println!(
            "| generator only ({dim} normals per dumbbell; OLD HashStream, NEW NormalStream) | – | {dim} | 1 | {:.3e} | {:.3e} | {:.2} | {:.3e} | {:.3e} | {:.2} | |",
            r[0].0,
            r[1].0,
            r[1].0 / r[0].0,
            r[0].1,
            r[1].1,
            r[1].1 / r[0].1
        );
    }
}
