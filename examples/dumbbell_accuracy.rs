//! Speed/accuracy sweep of dumbbell ensembles in steady shear (issue #5):
//! `cargo run --release --example dumbbell_accuracy > docs/dumbbell_accuracy.csv`, then
//! `python3 tools/dumbbell_accuracy.py docs/dumbbell_accuracy.csv docs/dumbbell_accuracy.png`.
//!
//! Every point: 3D, λ = 1, one thread, start from equilibrium, shear at Wi = λγ̇, each particle's
//! τ/G sampled every 0.1λ over t ∈ [t_warm, t_warm + t_avg] and time-averaged; estimate = mean over
//! particles, σ = standard error over particles (independent noise ⇒ independent samples);
//! η_p/(Gλ) = τ_xy/(G Wi), Ψ₁/(2Gλ²) = N₁/(2G Wi²). Wall time = the whole point (initial
//! sampling, steps, stress sampling) on one core; `cpu_s` = the process CPU time of the point
//! (the better measure of cost on a shared machine, where wall time also counts waiting).
//!
//! Hookean rows: exact η_p = Gλ, Ψ₁ = 2Gλ² (continuum), so err = |estimate − 1|. `bias` is
//! deterministic: the exact expectation of this very estimator for the discrete scheme (the
//! time average of `hookean_discrete_moment` over the sample times: time-step error plus the
//! start-up transient left at t_warm) minus 1.
//! FENE rows (semi-implicit): the reference is the Richardson extrapolation (4X(h) − X(h'))/3
//! of the two finest steps of the same sweep; err = |estimate − reference|, bias column empty.
//!
//! Knobs: `nd` (N_d at fixed 100 particles, Heun, Δt = 0.02λ); `dt` (Δt × Euler/Heun at 100 ×
//! 1000); `cv` (control variates off/on at Wi = 0.1 and 1, N_d = 100, 1000); `fene` (Δt for
//! b = 50, 10 at Wi = 1, 10); `precision` (f64 vs f32 storage of the connectors, Heun, Wi = 1,
//! Δt = 0.02λ, 100 × 1000; spring column "hookean f32"). Knob names given as arguments run only
//! those points: `cargo run --release --example dumbbell_accuracy -- precision`.

use mesorheo::comm::SerialComm;
use mesorheo::facade::Ensembles;
use mesorheo::models::dumbbells::{
    DumbbellParams, Scheme, Spring, hookean_discrete_moment, kramers_stress,
};
use mesorheo::models::homogeneous_flow::{EnsembleSpec, Flow, HomogeneousEnsembles};
use std::time::Instant;

struct Point {
    knob: &'static str,
    spring: Spring,
    scheme: Scheme,
    wi: f64,
    dt: f64,
    n_d: usize,
    particles: u64,
    cv: bool,
    /// f32 storage of the connectors.
    single: bool,
    t_warm: f64,
    t_avg: f64,
}

struct Result {
    eta: (f64, f64),
    psi: (f64, f64),
    wall: f64,
    cpu: f64,
    /// Exact expectation of the estimator (Hookean only).
    expected: Option<(f64, f64)>,
}

/// CPU seconds of this process (user + system, all threads) from /proc/self/stat: on a shared
/// machine this is the 1-core cost of a point, where the wall time also counts waiting.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')').map(|x| x.1).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| {
        f.get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    (ticks(11) + ticks(12)) / 100.0 // USER_HZ = 100 on Linux
}

fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

fn run(pt: &Point, seed: u64) -> Result {
    let p = DumbbellParams {
        spring: pt.spring,
        scheme: pt.scheme,
        lambda: 1.0,
        dt: pt.dt,
    };
    let flow = Flow::SimpleShear { rate: pt.wi };
    let comm = SerialComm::new();
    let t0 = Instant::now();
    let c0 = cpu_seconds();
    let mut e = HomogeneousEnsembles::<3>::new(
        &comm,
        EnsembleSpec {
            threads: 1,
            total: pt.particles,
            n_d: pt.n_d,
            params: p,
            flow,
            seed,
        },
    )
    .expect("ensembles");
    if pt.cv {
        e = e.with_control_variates();
    }
    if pt.single {
        e = e.with_single_precision();
    }
    let warm = (pt.t_warm / pt.dt).round() as u64;
    let avg = (pt.t_avg / pt.dt).round() as u64;
    let every = ((0.1 / pt.dt).round() as u64).max(1);
    while e.step < warm {
        e.advance().expect("a stable step");
    }
    let np = pt.particles as usize;
    let (mut xy, mut n1, mut k) = (vec![0.0; np], vec![0.0; np], 0.0);
    let mut sample_steps = vec![];
    // Control copy: E[τ_eq] is 0 for τ_xy and N₁ by isotropy (any spring, any Δt), and only
    // those two are used, so τ(Q) − τ(Q_eq) is unbiased.
    for i in 1..=avg {
        e.advance().expect("a stable step");
        if i % every == 0 {
            for j in 0..np {
                let mut s = kramers_stress::<3>(&e.ensemble(j), p.spring);
                if let Some(c) = &e.control {
                    let s0 = kramers_stress::<3>(&c[j], p.spring);
                    for (a, b) in s.iter_mut().zip(s0) {
                        *a -= b;
                    }
                }
                xy[j] += s[1];
                n1[j] += s[0] - s[4];
            }
            k += 1.0;
            sample_steps.push(e.step);
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - c0;
    let eta: Vec<f64> = xy.iter().map(|x| x / k / pt.wi).collect();
    let psi: Vec<f64> = n1.iter().map(|x| x / k / (2.0 * pt.wi * pt.wi)).collect();
    let expected = (pt.spring == Spring::Hookean).then(|| {
        let kappa = mesorheo::particles::tensor_rows(&flow.kappa::<3>(0.0));
        let (mut a, mut b) = (0.0, 0.0);
        for &n in &sample_steps {
            let c = hookean_discrete_moment::<3>(&kappa, &p, n);
            a += c[0][1] / pt.wi;
            b += (c[0][0] - c[1][1]) / (2.0 * pt.wi * pt.wi);
        }
        (a / k, b / k)
    });
    Result {
        eta: mean_se(&eta),
        psi: mean_se(&psi),
        wall,
        cpu,
        expected,
    }
}

fn scheme_name(s: Scheme) -> &'static str {
    match s {
        Scheme::EulerMaruyama => "euler",
        Scheme::Heun => "heun",
        Scheme::SemiImplicit => "semi-implicit",
    }
}

fn main() {
    let hookean = |knob, scheme, wi, dt, n_d, cv| Point {
        knob,
        spring: Spring::Hookean,
        scheme,
        wi,
        dt,
        n_d,
        particles: 100,
        cv,
        single: false,
        t_warm: 8.0,
        t_avg: 20.0,
    };
    let mut points = vec![];
    for n_d in [10, 100, 1000, 10000] {
        points.push(hookean("nd", Scheme::Heun, 1.0, 0.02, n_d, false));
    }
    for scheme in [Scheme::EulerMaruyama, Scheme::Heun] {
        for dt in [0.1, 0.05, 0.02, 0.01] {
            points.push(hookean("dt", scheme, 1.0, dt, 1000, false));
        }
    }
    for wi in [0.1, 1.0] {
        for n_d in [100, 1000] {
            for cv in [false, true] {
                points.push(hookean("cv", Scheme::Heun, wi, 0.02, n_d, cv));
            }
        }
    }
    for single in [false, true] {
        let mut pt = hookean("precision", Scheme::Heun, 1.0, 0.02, 1000, false);
        pt.single = single;
        points.push(pt);
    }
    // Optional knob names on the command line run only those points.
    let only: Vec<String> = std::env::args().skip(1).collect();
    let wanted = |knob: &str| only.is_empty() || only.iter().any(|k| k == knob);
    points.retain(|pt| wanted(pt.knob));
    println!(
        "knob,spring,b,scheme,wi,dt,n_d,particles,cv,eta,eta_se,eta_err,eta_bias,psi1,psi1_se,psi1_err,psi1_bias,wall_s,cpu_s"
    );
    for (i, pt) in points.iter().enumerate() {
        // The two precision points share a seed: they differ by the f32 rounding only.
        let seed = if pt.knob == "precision" {
            900
        } else {
            100 + i as u64
        };
        let r = run(pt, seed);
        let (eb, pb) = r.expected.expect("Hookean");
        println!(
            "{},hookean{},,{},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.3},{:.2}",
            pt.knob,
            if pt.single { " f32" } else { "" },
            scheme_name(pt.scheme),
            pt.wi,
            pt.dt,
            pt.n_d,
            pt.particles,
            pt.cv as u8,
            r.eta.0,
            r.eta.1,
            (r.eta.0 - 1.0).abs(),
            eb - 1.0,
            r.psi.0,
            r.psi.1,
            (r.psi.0 - 1.0).abs(),
            pb - 1.0,
            r.wall,
            r.cpu
        );
    }
    // FENE, semi-implicit: Δt sweep per (b, Wi); reference from the two finest steps.
    for b in [50.0, 10.0] {
        if !wanted("fene") {
            break;
        }
        for (wi, dts, t_warm, t_avg) in [
            (1.0, [0.8, 0.4, 0.2, 0.1, 0.05], 5.0, 100.0),
            (10.0, [0.32, 0.16, 0.08, 0.04, 0.02], 3.0, 20.0),
        ] {
            let rows: Vec<(f64, Result)> = dts
                .iter()
                .enumerate()
                .map(|(k, &dt)| {
                    let pt = Point {
                        knob: "fene",
                        spring: Spring::Fene { b },
                        scheme: Scheme::SemiImplicit,
                        wi,
                        dt,
                        n_d: 100,
                        particles: 400,
                        cv: false,
                        single: false,
                        t_warm,
                        t_avg,
                    };
                    (dt, run(&pt, 200 + k as u64))
                })
                .collect();
            let n = rows.len();
            let rich = |f: fn(&Result) -> f64| (4.0 * f(&rows[n - 1].1) - f(&rows[n - 2].1)) / 3.0;
            let (re, rp) = (rich(|r| r.eta.0), rich(|r| r.psi.0));
            for (dt, r) in &rows {
                println!(
                    "fene,fene,{b},semi-implicit,{wi},{dt},100,400,0,{:.6},{:.6},{:.6},,{:.6},{:.6},{:.6},,{:.3},{:.2}",
                    r.eta.0,
                    r.eta.1,
                    (r.eta.0 - re).abs(),
                    r.psi.0,
                    r.psi.1,
                    (r.psi.0 - rp).abs(),
                    r.wall,
                    r.cpu
                );
            }
            eprintln!("FENE b {b} Wi {wi}: Richardson η_p/(Gλ) {re:.5}, Ψ₁/(2Gλ²) {rp:.5}");
        }
    }
}
