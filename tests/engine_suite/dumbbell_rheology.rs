//! Rheology of dumbbell ensembles beyond the start-up checks of `tests/engine_suite/dumbbells.rs` (issue #5):
//! FENE steady-shear viscometric functions (against the deterministic Fokker–Planck solution of
//! `tools/fene_fokker_planck.py`, the FENE-P closed form and a Δt → 0 Richardson reference), the equilibrium stress autocorrelation of Hookean dumbbells, and Hookean shear
//! reversal against the exact moment recursion of the discrete scheme and the UCM solution.
//!
//! Units as in `src/models/dumbbells.rs`: Q in √(k_BT/H), time in λ (λ = 1 here), τ/G = ⟨QF⟩ − I,
//! Wi = λγ̇. Every comparison is statistical (the random numbers are not pinned: the generator
//! behind `noise_stream` may change). Error bars come from the spread between particles, whose
//! ensembles are driven by independent noise, so they are independent samples whatever the time
//! correlation inside a run. Tolerances: 4σ where many comparisons are made in one test (a
//! Gaussian leaves 4σ with probability 6·10⁻⁵, so ~30 comparisons give a false alarm < 0.2 %),
//! stated separately where the reference itself is approximate (FENE-P).

use crate::common::{self, mean_se};
use mesorheo::comm::SerialComm;
use mesorheo::facade::Ensembles;
use mesorheo::models::dumbbells::{
    DumbbellParams, Scheme, Spring, hookean_discrete_moment, kramers_stress,
};
use mesorheo::models::homogeneous_flow::{EnsembleSpec, Flow, HomogeneousEnsembles};
use mesorheo::particles::tensor_rows;

fn within(got: f64, se: f64, want: f64, k: f64, what: &str) {
    eprintln!(
        "{what}: {got:.5} ± {se:.5}, expected {want:.5} ({:.1} σ)",
        (got - want).abs() / se
    );
    assert!(
        (got - want).abs() <= k * se,
        "{what}: {got:.5} ± {se:.5}, expected {want:.5} ({:.1} σ)",
        (got - want).abs() / se
    );
}

// ---------------------------------------------------------------------------------------------
// 2. Equilibrium stress autocorrelation of Hookean dumbbells
// ---------------------------------------------------------------------------------------------
//
// At rest dQ = −Q/(2λ) dt + √(1/λ) dW, so Q(t) = Q(0) e^{−t/2λ} + η(t) with η independent of
// Q(0), zero mean and Gaussian. For one dumbbell (components independent, unit variance)
//   ⟨Q_xQ_y(0) Q_xQ_y(t)⟩ = ⟨Q_x(0)Q_x(t)⟩⟨Q_y(0)Q_y(t)⟩ = e^{−t/λ}
// (the cross terms vanish: ⟨Q_xQ_y η_xη_y⟩ = ⟨Q_xQ_y⟩⟨η_x⟩⟨η_y⟩ = 0 …): the connector decorrelates
// as e^{−t/2λ}, the product — the stress — as e^{−t/λ}. A particle's τ_xy/G is the mean over
// N_d independent dumbbells, so C(t) = ⟨τ_xy(0)τ_xy(t)⟩/G² = e^{−t/λ}/N_d, and Green–Kubo with
// V/k_BT = N_d/G (G = N_d k_BT/V) returns η_p = (N_d/G) ∫ G² e^{−t/λ}/N_d dt = Gλ.
//
// Discrete schemes (h = Δt/λ, κ = 0): Q' = a Q + n √h ξ, with a = 1 − h/2 (Euler–Maruyama),
// a = 1 − h/2 + h²/8 (Heun); so after l steps the lag factor is a^{2l}, a decay time
// τ_d = −Δt / ln a² (Euler at Δt = 0.2λ: 0.9491 λ; Heun at 0.05λ: 1.00008 λ), and the amplitude is
// v(n)²/N_d with v(n) = ⟨Q_x²⟩ after n steps (the exact discrete oracle, which starts from 1).

struct Autocorrelation {
    tau: (f64, f64),
    amplitude: (f64, f64),
    green_kubo: (f64, f64),
    /// The same three numbers for the exact discrete process.
    exact: (f64, f64, f64),
}

fn stress_autocorrelation(scheme: Scheme, dt: f64, seed: u64) -> Autocorrelation {
    let p = DumbbellParams {
        spring: Spring::Hookean,
        scheme,
        lambda: 1.0,
        dt,
    };
    // 1500 particles × 10 dumbbells for 150 λ: the three off-diagonal components (isotropy at
    // rest: same autocorrelation, uncorrelated with each other) give 4.5·10³ series.
    let (particles, n_d, t_run) = (1500usize, 10usize, 150.0);
    let steps = (t_run / dt).round() as usize;
    let fit_lags = (2.0 / dt).round() as usize; // fit on t ∈ [0, 2λ]
    let gk_lags = (8.0 / dt).round() as usize; // Green–Kubo to 8λ (e^{−8} = 3·10⁻⁴)
    let comm = SerialComm::new();
    let mut e = HomogeneousEnsembles::<3>::new(
        &comm,
        EnsembleSpec {
            threads: 1,
            total: particles as u64,
            n_d,
            params: p,
            flow: Flow::Rest,
            seed,
        },
    )
    .expect("ensembles");
    // series[(particle·3 + component)·(steps+1) + n]
    let len = steps + 1;
    let mut series = vec![0.0; particles * 3 * len];
    let record = |e: &HomogeneousEnsembles<3>, n: usize, series: &mut [f64]| {
        for (j, q) in e.q.iter().enumerate() {
            let s = kramers_stress::<3>(q, Spring::Hookean);
            for (c, idx) in [1usize, 2, 5].into_iter().enumerate() {
                series[(j * 3 + c) * len + n] = s[idx];
            }
        }
    };
    record(&e, 0, &mut series);
    for n in 1..=steps {
        e.advance().expect("a stable step");
        record(&e, n, &mut series);
    }
    // Lag sums per particle group (for the jackknife): C_g(l) = Σ s(n)s(n+l), counts Σ 1.
    let groups = 20;
    let per_group = particles / groups;
    let mut sums = vec![vec![0.0; gk_lags + 1]; groups];
    for (g, sum) in sums.iter_mut().enumerate() {
        for j in g * per_group..(g + 1) * per_group {
            for c in 0..3 {
                let s = &series[(j * 3 + c) * len..(j * 3 + c + 1) * len];
                for (l, acc) in sum.iter_mut().enumerate() {
                    let mut a = 0.0;
                    for n in 0..len - l {
                        a += s[n] * s[n + l];
                    }
                    *acc += a;
                }
            }
        }
    }
    let count = |l: usize| ((len - l) * 3 * per_group) as f64;
    // The three estimators from lag sums over a set of groups.
    let estimate = |skip: Option<usize>| -> (f64, f64, f64) {
        let k = if skip.is_some() { groups - 1 } else { groups } as f64;
        let c: Vec<f64> = (0..=gk_lags)
            .map(|l| {
                let s: f64 = (0..groups)
                    .filter(|&g| Some(g) != skip)
                    .map(|g| sums[g][l])
                    .sum();
                s / (count(l) * k) * n_d as f64
            })
            .collect();
        // Least squares of ln C against t on [0, 2λ].
        let xs: Vec<f64> = (0..=fit_lags).map(|l| l as f64 * dt).collect();
        let ys: Vec<f64> = (0..=fit_lags).map(|l| c[l].ln()).collect();
        let (slope, icpt) = line_fit(&xs, &ys);
        let gk = dt * (0.5 * c[0] + c[1..].iter().sum::<f64>());
        (-1.0 / slope, icpt.exp(), gk)
    };
    let full = estimate(None);
    let jk: Vec<(f64, f64, f64)> = (0..groups).map(|g| estimate(Some(g))).collect();
    let jk_se = |f: fn(&(f64, f64, f64)) -> f64| {
        let m = jk.iter().map(f).sum::<f64>() / groups as f64;
        let v = jk.iter().map(|x| (f(x) - m).powi(2)).sum::<f64>();
        (v * (groups as f64 - 1.0) / groups as f64).sqrt()
    };
    // The exact discrete process through the same estimators.
    let h = dt;
    let a = match scheme {
        Scheme::EulerMaruyama => 1.0 - h / 2.0,
        Scheme::Heun => 1.0 - h / 2.0 + h * h / 8.0,
        Scheme::SemiImplicit => (1.0 - h / 4.0) / (1.0 + h / 4.0),
    };
    // v(n) = ⟨Q_x²⟩ after n steps, from the library's oracle propagated step by step.
    let mut v = Vec::with_capacity(len);
    let mut c_prev = 1.0;
    let one = hookean_discrete_moment::<1>(&[[0.0]], &p, 1)[0][0]; // a² + noise
    let noise = one - a * a;
    for _ in 0..len {
        v.push(c_prev);
        c_prev = a * a * c_prev + noise;
    }
    let exact_c: Vec<f64> = (0..=gk_lags)
        .map(|l| {
            let m: f64 = (0..len - l).map(|n| v[n] * v[n]).sum::<f64>() / (len - l) as f64;
            m * a.powi(2 * l as i32)
        })
        .collect();
    let xs: Vec<f64> = (0..=fit_lags).map(|l| l as f64 * dt).collect();
    let ys: Vec<f64> = (0..=fit_lags).map(|l| exact_c[l].ln()).collect();
    let (slope, icpt) = line_fit(&xs, &ys);
    let gk = dt * (0.5 * exact_c[0] + exact_c[1..].iter().sum::<f64>());
    Autocorrelation {
        tau: (full.0, jk_se(|x| x.0)),
        amplitude: (full.1, jk_se(|x| x.1)),
        green_kubo: (full.2, jk_se(|x| x.2)),
        exact: (-1.0 / slope, icpt.exp(), gk),
    }
}

fn line_fit(xs: &[f64], ys: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let (mx, my) = (xs.iter().sum::<f64>() / n, ys.iter().sum::<f64>() / n);
    let sxy: f64 = xs.iter().zip(ys).map(|(x, y)| (x - mx) * (y - my)).sum();
    let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
    let slope = sxy / sxx;
    (slope, my - slope * mx)
}

#[test]
fn hookean_equilibrium_stress_autocorrelation_decays_as_exp_minus_t_over_lambda() {
    // Heun at Δt = 0.05λ: the discrete decay time is λ to 10⁻⁴, so this tests the continuum
    // result; Euler at Δt = 0.2λ: the discrete decay time 0.9491λ is 5.1 % short of λ, and the
    // measurement must follow the discrete value, not λ (the bias is resolved: ≈ 10σ expected;
    // at Δt = 0.1λ the 2.5 % bias was only 4.3–9σ across seeds, too close to the 4σ line).
    for (scheme, dt, seed) in [(Scheme::Heun, 0.05, 11), (Scheme::EulerMaruyama, 0.2, 12)] {
        let r = stress_autocorrelation(scheme, dt, seed);
        let what = format!("{scheme:?} Δt {dt}");
        // The exact discrete process: decay time from a, amplitude v², Green–Kubo sum.
        eprintln!(
            "{what}: exact discrete τ {:.5}, N_d·C(0) {:.5}, η_GK {:.5}",
            r.exact.0, r.exact.1, r.exact.2
        );
        within(
            r.tau.0,
            r.tau.1,
            r.exact.0,
            4.0,
            &format!("{what} decay time / λ"),
        );
        within(
            r.amplitude.0,
            r.amplitude.1,
            r.exact.1,
            4.0,
            &format!("{what} N_d·C(0) (fit)"),
        );
        within(
            r.green_kubo.0,
            r.green_kubo.1,
            r.exact.2,
            4.0,
            &format!("{what} Green–Kubo η_p/(Gλ)"),
        );
        // The decay time is measured to better than 1 %, else the test would not mean much.
        assert!(r.tau.1 < 0.01, "{what}: σ(τ) = {}", r.tau.1);
        if scheme == Scheme::EulerMaruyama {
            assert!(
                (r.tau.0 - 1.0).abs() > 4.0 * r.tau.1,
                "{what}: Euler's 5 % decay-time bias is not resolved ({:.4} ± {:.4})",
                r.tau.0,
                r.tau.1
            );
        } else {
            within(
                r.tau.0,
                r.tau.1,
                1.0,
                4.0,
                &format!("{what} decay time vs λ"),
            );
            within(
                r.green_kubo.0,
                r.green_kubo.1,
                1.0,
                4.0,
                &format!("{what} Green–Kubo vs Gλ"),
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Shear reversal of Hookean dumbbells
// ---------------------------------------------------------------------------------------------
//
// Continuum (UCM/Oldroyd-B; c = ⟨QQ⟩, dc/dt = κc + cκᵀ − (c − I)/λ, λ = 1): with κ_xy = γ̇(t),
// c_yy = 1, ċ_xy = γ̇ − c_xy, u̇ = 2γ̇ c_xy − u (u = c_xx − 1 = N₁/G). Start-up at γ̇ = W from
// equilibrium: c_xy = W(1 − e^{−t}), u = 2W²[1 − (1 + t)e^{−t}]. After the reversal at t_r
// (γ̇ = −W, s = t − t_r, B = c_xy(t_r) + W, u_r = u(t_r)):
//   c_xy(s) = −W + B e^{−s},   u(s) = 2W² + (u_r − 2W²) e^{−s} − 2W B s e^{−s}
// (check: u̇ + u = 2W² − 2WB e^{−s} = −2W c_xy ✓).
//
// Oracle for the ensembles: every scheme is linear for Hookean springs, Q' = M(κ)Q + N(κ)ξ, so the
// second moment of the discrete scheme obeys c' = M c Mᵀ + (Δt/λ) N Nᵀ exactly, with κ frozen at
// the start of each step as in `HomogeneousEnsembles::advance`; unlike `hookean_discrete_moment`
// (constant κ) this propagator takes κ(t) step by step.

fn ucm_reversal(w: f64, t_r: f64, t: f64) -> (f64, f64) {
    let start_up = |t: f64| {
        let e = (-t).exp();
        (w * (1.0 - e), 2.0 * w * w * (1.0 - (1.0 + t) * e))
    };
    if t < t_r {
        return start_up(t);
    }
    let (xy_r, u_r) = start_up(t_r);
    let b = xy_r + w;
    let s = t - t_r;
    let e = (-s).exp();
    (
        -w + b * e,
        2.0 * w * w + (u_r - 2.0 * w * w) * e - 2.0 * w * b * s * e,
    )
}

type M3 = [[f64; 3]; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            for l in 0..3 {
                m[i][j] += a[i][l] * b[l][j];
            }
        }
    }
    m
}

fn lin(a: &M3, b: &M3, s: f64) -> M3 {
    let mut m = *a;
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] += s * b[i][j];
        }
    }
    m
}

fn transpose(a: &M3) -> M3 {
    let mut t = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            t[i][j] = a[j][i];
        }
    }
    t
}

/// M(κ), N(κ) of the linear Hookean schemes (derived from the update formulas in
/// `src/models/dumbbells.rs`; K = κ − I/2λ, h = Δt, e = Δt/4λ):
/// Euler M = I + hK, N = I; Heun M = I + hK + ½h²K², N = I + ½hK; semi-implicit below.
fn scheme_matrices(scheme: Scheme, kappa: &M3, dt: f64) -> (M3, M3) {
    let id = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let k = lin(kappa, &id, -0.5);
    match scheme {
        Scheme::EulerMaruyama => (lin(&id, &k, dt), id),
        Scheme::Heun => (
            lin(&lin(&id, &k, dt), &mul(&k, &k), 0.5 * dt * dt),
            lin(&id, &k, 0.5 * dt),
        ),
        // Q' (1 + e) = Q + [½κ(Q + Q̃) − Q/4λ] h + ξ, Q̃ = Q + hKQ + ξ (λ = 1, e = h/4):
        // M = (I + hκ + ½h²κK − eI)/(1 + e), N = (I + ½hκ)/(1 + e).
        Scheme::SemiImplicit => {
            let e = 0.25 * dt;
            let m = lin(
                &lin(&lin(&id, kappa, dt), &mul(kappa, &k), 0.5 * dt * dt),
                &id,
                -e,
            );
            let n = lin(&id, kappa, 0.5 * dt);
            (
                lin(&m, &m, 1.0 / (1.0 + e) - 1.0),
                lin(&n, &n, 1.0 / (1.0 + e) - 1.0),
            )
        }
    }
}

/// c = ⟨QQ⟩ after every step 0..=steps of the discrete scheme under κ(t) (c₀ = I).
fn discrete_moment_path(flow: Flow, p: &DumbbellParams, steps: u64) -> Vec<M3> {
    let mut c = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut out = vec![c];
    for n in 0..steps {
        let kappa = tensor_rows(&flow.kappa::<3>(n as f64 * p.dt));
        let (m, nn) = scheme_matrices(p.scheme, &kappa, p.dt);
        let noise = mul(&nn, &transpose(&nn));
        c = lin(&mul(&mul(&m, &c), &transpose(&m)), &noise, p.dt / p.lambda);
        out.push(c);
    }
    out
}

#[test]
fn hookean_shear_reversal_follows_the_exact_moments_and_ucm_at_wi_1_and_5() {
    let t_r = 3.0; // not yet steady at reversal: the general formula (B, u_r) is exercised
    let after = [0.25, 0.5, 1.0, 2.0, 3.0];
    let comm = SerialComm::new();
    for (wi, seed) in [(1.0, 41), (5.0, 42)] {
        let dt = 0.01 / f64::max(wi, 1.0);
        let p = DumbbellParams {
            spring: Spring::Hookean,
            scheme: Scheme::Heun,
            lambda: 1.0,
            dt,
        };
        let flow = Flow::ShearReversal { rate: wi, at: t_r };
        let last = ((t_r + after[after.len() - 1]) / dt).round() as u64;
        let path = discrete_moment_path(flow, &p, last);
        // The propagator agrees with the library's constant-κ oracle before the reversal.
        let r_steps = (t_r / dt).round() as u64;
        let c_lib = hookean_discrete_moment::<3>(&tensor_rows(&flow.kappa::<3>(0.0)), &p, r_steps);
        for i in 0..3 {
            for j in 0..3 {
                assert!((c_lib[i][j] - path[r_steps as usize][i][j]).abs() < 1e-12);
            }
        }
        // The propagator's matrices of the other two schemes agree with the library's too.
        for scheme in [Scheme::EulerMaruyama, Scheme::SemiImplicit] {
            let q = DumbbellParams { scheme, ..p };
            let mine = discrete_moment_path(flow, &q, r_steps);
            let lib =
                hookean_discrete_moment::<3>(&tensor_rows(&flow.kappa::<3>(0.0)), &q, r_steps);
            for i in 0..3 {
                for j in 0..3 {
                    let d = (lib[i][j] - mine[r_steps as usize][i][j]).abs();
                    assert!(d < 1e-10, "{scheme:?}: c[{i}][{j}] differs by {d}");
                }
            }
        }
        let mut e = HomogeneousEnsembles::<3>::new(
            &comm,
            EnsembleSpec {
                threads: 1,
                total: 400,
                n_d: 100,
                params: p,
                flow,
                seed,
            },
        )
        .expect("ensembles");
        while e.step < r_steps {
            e.advance().expect("a stable step");
        }
        let before = e.stress();
        let mut dip = None;
        for &s in &after {
            let steps = ((t_r + s) / dt).round() as u64;
            while e.step < steps {
                e.advance().expect("a stable step");
            }
            let st = e.stress();
            if s == 1.0 {
                dip = Some(st.n1);
            }
            let c = path[steps as usize];
            let (xy, n1) = ucm_reversal(wi, t_r, t_r + s);
            let what = format!("Wi {wi}, {s} λ after the reversal");
            // The discrete oracle vs the continuum: Heun's O(Δt²) error, Δt = 0.01λ/max(1, Wi);
            // measured ≤ 5·10⁻⁶ in τ_xy/G and ≤ 1.7·10⁻⁵ in N₁/G; asserted ≤ 5·10⁻⁵ and 10⁻⁴ —
            // far below the statistical error bars (≥ 6·10⁻³), so comparing the ensembles with
            // the oracle is comparing them with UCM.
            eprintln!(
                "{what}: oracle − UCM: τ_xy {:.2e}, N₁ {:.2e}",
                c[0][1] - xy,
                c[0][0] - c[1][1] - n1
            );
            assert!(
                (c[0][1] - xy).abs() < 5e-5,
                "{what}: c_xy {} vs {xy}",
                c[0][1]
            );
            assert!(
                (c[0][0] - c[1][1] - n1).abs() < 1e-4,
                "{what}: N₁ {} vs {n1}",
                c[0][0] - c[1][1]
            );
            within(
                st.mean[0][1],
                st.stderr[0][1],
                c[0][1],
                4.0,
                &format!("{what} τ_xy/G"),
            );
            within(
                st.n1.0,
                st.n1.1,
                c[0][0] - c[1][1],
                4.0,
                &format!("{what} N₁/G"),
            );
            within(
                st.mean[1][1],
                st.stderr[1][1],
                c[1][1] - 1.0,
                4.0,
                &format!("{what} τ_yy/G"),
            );
            within(
                st.n2.0,
                st.n2.1,
                c[1][1] - c[2][2],
                4.0,
                &format!("{what} N₂/G"),
            );
            // The error bar is small on the scale of the signal (σ ≤ 2 % of W for τ_xy) …
            assert!(st.stderr[0][1] < 0.02 * wi, "{what}: σ {}", st.stderr[0][1]);
            // … and the reversal is resolved: τ_xy has left its pre-reversal value by ≫ σ
            // (UCM: by B(1 − e^{−s}) with B = W(2 − e^{−3}), ≥ 0.43 W at s = 0.25, > 20σ).
            assert!(
                before.mean[0][1] - st.mean[0][1] > 10.0 * st.stderr[0][1],
                "{what}: τ_xy {} did not move from {}",
                st.mean[0][1],
                before.mean[0][1]
            );
        }
        // N₁ dips after the reversal (u = 2W²(1 − 4e⁻³) at t_r, minimum near s = 1: 0.26× that at
        // Wi = 1): the ensemble reads lower at s = 1 than before the reversal by > 10σ.
        let (n1_before, n1_dip) = (before.n1, dip.expect("s = 1 visited"));
        assert!(
            n1_before.0 - n1_dip.0 > 10.0 * n1_before.1.hypot(n1_dip.1),
            "Wi {wi}: N₁ dip not seen ({n1_before:?} → {n1_dip:?})"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 1. FENE steady shear
// ---------------------------------------------------------------------------------------------
//
// FENE-P closed form, in the units of the code (Q in √(k_BT/H), λ = ζ/4H = 1, 3D), with the
// *same* b as the FENE spring (Bird, Dotson & Johnson 1980;
// docs/theory/polymer_particle_and_bddfs.md §2.1, Eqs. 5.5–5.6 — no b-correction): F = Z Q with
// Z = 1/(1 − tr A/b), A = ⟨QQ⟩,
//   dA/dt = κA + Aκᵀ + I − Z A,     τ/G = Z A − I.
// Steady shear at Wi: A_yy = A_zz = 1/Z, A_xy = Wi/Z², A_xx = 1/Z + 2Wi²/Z³, and
// Z = 1/(1 − tr A/b) gives the cubic  b Z³ − (b + 3) Z² − 2 Wi² = 0  (one root > 1), whence
//   η_p/(Gλ) = τ_xy/(G Wi) = 1/Z,     Ψ₁/(2Gλ²) = N₁/(2G Wi²) = 1/Z²,     Ψ₂ = 0.
// At Wi → 0: Z = 1 + 3/b, η_p0 = b/(b + 3)Gλ, Ψ₁₀ = 2(b/(b + 3))² Gλ².
//
// FENE itself is known exactly only at Wi → 0 (Bird et al., DPL vol. 2, general spring laws:
// η_p0 = nζ⟨Q²⟩_eq/12, Ψ₁₀ = nζ²⟨Q⁴⟩_eq/(120 k_BT); with ⟨Q²⟩ = 3b/(b + 5),
// ⟨Q⁴⟩ = 15b²/((b + 5)(b + 7)) for ψ_eq ∝ (1 − Q²/b)^{b/2}):
//   η_p0/(Gλ) = b/(b + 5),     Ψ₁₀/(2Gλ²) = b²/((b + 5)(b + 7)).
// So FENE-P over-predicts FENE already at Wi → 0 by the exact factors (b + 5)/(b + 3) in η_p
// (+3.8 % at b = 50, +15 % at b = 10) and (b + 5)(b + 7)/(b + 3)² in Ψ₁ (+12 %, +51 %): the
// closure ⟨QQ/(1 − Q²/b)⟩ → ⟨QQ⟩/(1 − ⟨Q²⟩/b) is not a small correction for Ψ₁ at small b. Hence
// the FENE-P comparison is one-sided and loose (bounds below, scaled by these exact gaps), and the
// quantitative checks are the exact Wi → 0 limit and the Δt → 0 Richardson reference.

/// FENE-P steady shear: (η_p/(Gλ), Ψ₁/(2Gλ²)).
fn fene_p_shear(b: f64, wi: f64) -> (f64, f64) {
    // g(Z) = bZ³ − (b+3)Z² − 2Wi² is increasing and convex for Z ≥ 1 + 3/b, so Newton converges
    // monotonically from any start above the root; at the root x = Z − 1 − 3/b = 2Wi²/(bZ²) and
    // Z ≥ x give x ≤ (2Wi²/b)^{1/3}, so this start is above it.
    let mut z = 1.0 + 3.0 / b + (2.0 * wi * wi / b).cbrt();
    for _ in 0..100 {
        let g = b * z * z * z - (b + 3.0) * z * z - 2.0 * wi * wi;
        let dg = 3.0 * b * z * z - 2.0 * (b + 3.0) * z;
        z -= g / dg;
    }
    assert!(z > 1.0 + 3.0 / b - 1e-12);
    (1.0 / z, 1.0 / (z * z))
}

/// Steady-shear (η_p/(Gλ), Ψ₁/(2Gλ²)) with standard errors: each particle's stress averaged
/// over t ∈ [t_warm, t_warm + t_avg] (every 0.1λ), then mean and error over the particles
/// (independent noise, so independent samples). With `cv`, each particle's estimate is
/// τ(Q) − τ(Q_eq) for its equilibrium copy driven by the same noise — unbiased for τ_xy and N₁
/// whatever the spring and Δt, since the (discrete) equilibrium is isotropic.
#[allow(clippy::too_many_arguments)]
fn steady_shear(
    p: DumbbellParams,
    wi: f64,
    particles: u64,
    n_d: usize,
    t_warm: f64,
    t_avg: f64,
    seed: u64,
    cv: bool,
) -> ((f64, f64), (f64, f64), (f64, f64)) {
    let comm = SerialComm::new();
    let mut e = HomogeneousEnsembles::<3>::new(
        &comm,
        EnsembleSpec {
            threads: 1,
            total: particles,
            n_d,
            params: p,
            flow: Flow::SimpleShear { rate: wi },
            seed,
        },
    )
    .expect("ensembles");
    if cv {
        e = e.with_control_variates();
    }
    let warm = (t_warm / p.dt).round() as u64;
    let avg = (t_avg / p.dt).round() as u64;
    let every = ((0.1 / p.dt).round() as u64).max(1);
    while e.step < warm {
        e.advance().expect("a stable step");
    }
    let np = particles as usize;
    let (mut xy, mut n1, mut k) = (vec![0.0; np], vec![0.0; np], 0.0);
    let mut q2 = vec![0.0; np];
    for i in 1..=avg {
        e.advance().expect("a stable step");
        if i % every == 0 {
            // ⟨|Q|²⟩ as the scene reports it (with control variates when they are on).
            for (j, x) in e.particle_mean_square_lengths().iter().enumerate() {
                q2[j] += x;
            }
            for j in 0..np {
                let mut s = kramers_stress::<3>(&e.q[j], p.spring);
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
        }
    }
    let eta: Vec<f64> = xy.iter().map(|x| x / k / wi).collect();
    let psi: Vec<f64> = n1.iter().map(|x| x / k / (2.0 * wi * wi)).collect();
    let q2: Vec<f64> = q2.iter().map(|x| x / k).collect();
    (mean_se(&eta), mean_se(&psi), mean_se(&q2))
}

/// The FENE steady-shear (η_p/(Gλ), Ψ₁/(2Gλ²), ⟨|Q|²⟩/(k_BT/H)) in 3D from the independent Fokker–Planck solver
/// `tools/fene_fokker_planck.py` (a Galerkin solution of the dumbbell's configuration-space
/// equation, converged in the polynomial degree to ~10⁻⁸, written apart from the Brownian
/// dynamics). `None` (with a note) when no Python is given, unless MESORHEO_REQUIRE_PYTHON is
/// set (`./run test` sets both).
fn fokker_planck(b: f64, wi: f64) -> Option<(f64, f64, f64)> {
    let python = common::python_or_skip(
        "the Fokker–Planck comparison",
        "set MESORHEO_PYTHON (./run test does)",
    )?;
    let tool = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/fene_fokker_planck.py");
    let o = std::process::Command::new(python)
        .arg(tool)
        .args(["--dim", "3", "--b", &b.to_string(), "--wi", &wi.to_string()])
        .output()
        .expect("run the Fokker–Planck solver");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let value = |key: &str| -> f64 {
        let line = text.lines().find(|l| l.starts_with(key)).expect(key);
        line.split('=')
            .nth(1)
            .expect("= value")
            .trim()
            .parse()
            .expect("a number")
    };
    Some((
        value("eta_p/(G lambda)"),
        value("Psi1/(G lambda^2)") / 2.0,
        value("<|Q|^2>"),
    ))
}

fn fene_params(b: f64, dt: f64) -> DumbbellParams {
    DumbbellParams {
        spring: Spring::Fene { b },
        scheme: Scheme::SemiImplicit,
        lambda: 1.0,
        dt,
    }
}

fn fene_steady_shear(b: f64) {
    // (a) Wi → 0: the exact FENE limits, with control variates, η_p at Wi = 0.1 and Ψ₁ at
    // Wi = 0.2 (N₁ ∝ Wi² is too small to resolve at 0.1 in this budget). The O(Wi²) shear
    // thinning there, scaled from the thinning measured at Wi = 1 (η_p −4 % (b = 50) … −7 %
    // (b = 10), Ψ₁ −10 % … −14 %), is ≤ 0.07 % in η_p and ≤ 0.6 % in Ψ₁ (≈ 0.5σ), inside the 4σ.
    // Δt = 0.1λ: the time-step bias measured at Wi = 1 is ≤ 0.2 % (below).
    let (eta0, psi0) = (b / (b + 5.0), b * b / ((b + 5.0) * (b + 7.0)));
    let (eta, _, q2) = steady_shear(fene_params(b, 0.1), 0.1, 200, 100, 3.0, 60.0, 51, true);
    let (_, psi, _) = steady_shear(fene_params(b, 0.1), 0.2, 200, 100, 3.0, 120.0, 52, true);
    within(
        eta.0,
        eta.1,
        eta0,
        4.0,
        &format!("FENE b {b} Wi 0.1: η_p/(Gλ) vs b/(b+5)"),
    );
    within(
        psi.0,
        psi.1,
        psi0,
        4.0,
        &format!("FENE b {b} Wi 0.2: Ψ₁/(2Gλ²) vs b²/((b+5)(b+7))"),
    );
    // ⟨|Q|²⟩ with control variates (their known mean is the continuum equilibrium D b/(b + D + 2))
    // against the Fokker–Planck value at the same Wi = 0.1.
    if let Some(fp) = fokker_planck(b, 0.1) {
        within(
            q2.0,
            q2.1,
            fp.2,
            4.0,
            &format!("FENE b {b} Wi 0.1: ⟨|Q|²⟩ (control variates) vs Fokker–Planck"),
        );
    }
    // Meaningful error bars: σ ≤ 0.5 % (η_p), ≤ 2 % (Ψ₁) — at b = 10 the FENE-P value and
    // (b/(b+5))² are 51 % and 13 % away from b²/((b+5)(b+7)), i.e. > 6σ.
    assert!(eta.1 < 0.005 * eta0, "σ(η_p) {} too large", eta.1);
    assert!(psi.1 < 0.02 * psi0, "σ(Ψ₁) {} too large", psi.1);

    // (b) Wi = 1 and 10: a converged reference by Richardson extrapolation of the two finest
    // steps (the semi-implicit scheme is weak order 2, checked for Hookean springs in
    // tests/engine_suite/dumbbells.rs): X_ref = (4X(h) − X(2h))/3, σ_ref = √(16σ_h² + σ_2h²)/3. Three steps h,
    // 2h, 4h with h = 0.1λ (Wi = 1) and 0.02λ (Wi = 10, γ̇h = 0.2).
    for (wi, h, t_warm, t_avg) in [(1.0, 0.1, 5.0, 100.0), (10.0, 0.02, 3.0, 20.0)] {
        let runs: Vec<_> = [4.0 * h, 2.0 * h, h]
            .iter()
            .enumerate()
            .map(|(k, &dt)| {
                steady_shear(
                    fene_params(b, dt),
                    wi,
                    400,
                    100,
                    t_warm,
                    t_avg,
                    60 + k as u64,
                    false,
                )
            })
            .collect();
        let (fp_eta, fp_psi) = fene_p_shear(b, wi);
        let exact = fokker_planck(b, wi);
        for (name, pick, fp, gap0) in [
            ("η_p/(Gλ)", 0usize, fp_eta, 1.0 - (b + 3.0) / (b + 5.0)),
            (
                "Ψ₁/(2Gλ²)",
                1,
                fp_psi,
                1.0 - (b + 3.0).powi(2) / ((b + 5.0) * (b + 7.0)),
            ),
            // ⟨|Q|²⟩: no FENE-P comparison (below).
            ("⟨|Q|²⟩/(k_BT/H)", 2, f64::NAN, f64::NAN),
        ] {
            let x = |k: usize| match pick {
                0 => runs[k].0,
                1 => runs[k].1,
                _ => runs[k].2,
            };
            let richardson = |c: (f64, f64), f: (f64, f64)| {
                (
                    (4.0 * f.0 - c.0) / 3.0,
                    (16.0 * f.1 * f.1 + c.1 * c.1).sqrt() / 3.0,
                )
            };
            let reference = richardson(x(1), x(2));
            let what = format!("FENE b {b} Wi {wi} {name}");
            eprintln!(
                "{what}: Δt {}: {:.5} ± {:.5}, {}: {:.5} ± {:.5}, {}: {:.5} ± {:.5}; \
                 Richardson {:.5} ± {:.5}; FENE-P {fp:.5} (none for ⟨|Q|²⟩)",
                4.0 * h,
                x(0).0,
                x(0).1,
                2.0 * h,
                x(1).0,
                x(1).1,
                h,
                x(2).0,
                x(2).1,
                reference.0,
                reference.1
            );
            // Order 2: extrapolating from the coarser pair gives the same limit (4σ). The
            // difference is (5X(2h) − X(4h) − 4X(h))/3 (the 2h run enters both).
            let coarse = richardson(x(0), x(1));
            let sd = (25.0 * x(1).1.powi(2) + x(0).1.powi(2) + 16.0 * x(2).1.powi(2)).sqrt() / 3.0;
            within(
                coarse.0,
                sd,
                reference.0,
                4.0,
                &format!("{what}: Richardson (4h, 2h) vs (2h, h)"),
            );
            // The finest step is within 1 % of the converged value (the docs' claim), and the
            // reference is sharp enough for that to mean something (σ_ref ≤ 0.5 %).
            assert!(
                reference.1 < 0.005 * reference.0,
                "{what}: σ_ref {}",
                reference.1
            );
            let err = (x(2).0 - reference.0).abs() / reference.0;
            assert!(err < 0.01, "{what}: Δt = {h} is {:.2} % off", 100.0 * err);
            // The Fokker–Planck solution (independent of this code): the Richardson value
            // within 3σ, and 3σ ≤ 1 % so that the agreement means something.
            if let Some(fp_exact) = exact {
                let want = match pick {
                    0 => fp_exact.0,
                    1 => fp_exact.1,
                    _ => fp_exact.2,
                };
                within(
                    reference.0,
                    reference.1,
                    want,
                    3.0,
                    &format!("{what}: Richardson vs Fokker–Planck"),
                );
                assert!(
                    3.0 * reference.1 <= 0.01 * want,
                    "{what}: 3σ_ref = {:.3} % > 1 %",
                    300.0 * reference.1 / want
                );
            }
            if pick == 2 {
                continue;
            }
            // FENE-P, approximate: FENE-P lies above FENE (as the exact Wi → 0 limits do) and
            // 1 − FENE/FENE-P is below a loose bound: 15 % for η_p, 40 % for Ψ₁. The scale of the
            // bounds is set by the exact Wi → 0 gaps (3.6 % / 13.3 % in η_p, 10.4 % / 33.7 % in
            // Ψ₁ at b = 50 / 10): a 10–15 % bound is impossible for Ψ₁ at b = 10, where the
            // closure is 34 % off already at rest. Measured: η_p 5.2 / 8.1 % (b = 50, Wi 1 / 10),
            // 13.1 / 8.1 % (b = 10); Ψ₁ 14.7 / 30.0 %, 33.9 / 34.4 %.
            let gap = 1.0 - reference.0 / fp;
            let bound = if pick == 0 { 0.15 } else { 0.40 };
            eprintln!(
                "{what}: 1 − FENE/FENE-P = {:.1} % (exact at Wi → 0: {:.1} %; bound {:.0} %)",
                100.0 * gap,
                100.0 * gap0,
                100.0 * bound
            );
            assert!(
                gap > 0.0 && gap < bound,
                "{what}: FENE {:.4} vs FENE-P {fp:.4}",
                reference.0
            );
        }
    }
}
#[test]
fn fene_b50_steady_shear() {
    fene_steady_shear(50.0);
}

#[test]
fn fene_b10_steady_shear() {
    fene_steady_shear(10.0);
}
