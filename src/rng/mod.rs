//! Counter-based random numbers: Philox4x32-10 (Salmon et al., SC'11 "Parallel random numbers:
//! as easy as 1, 2, 3"), the generator behind Random123 and HOOMD-blue.
//!
//! A random number is a pure function of a key and a counter, so a draw depends only on *what*
//! it is for — `(seed, purpose, step, ids)` — and never on which rank or thread evaluates it.
//! That is what makes trajectories bitwise identical for any decomposition (docs/architecture.md,
//! "Determinism"). No generator state exists, so a checkpoint needs none.
//!
//! Layout of one draw:
//! - key `= [seed_lo, seed_hi]` (the case's 64-bit seed),
//! - counter `= [step (low 32 bits), purpose << 24 | stage, id_a, id_b]`.
//!
//! Pair noise uses `(id_a, id_b) = (min gid, max gid)` so θ_ij = θ_ji on every rank.

/// What a draw is used for; each purpose gets disjoint counters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Purpose {
    /// DPD pair noise θ_ij.
    DpdPair = 1,
    /// Initial Maxwellian velocities.
    InitialVelocity = 2,
    /// Random initial positions.
    InitialPosition = 3,
    /// Brownian noise of dumbbell ensembles (keyed by particle id and step).
    DumbbellNoise = 4,
    /// Equilibrium initial state of dumbbell ensembles.
    DumbbellInit = 5,
    /// Uniform positions of the dumbbells BDDFS regenerates within their histogram cells (keyed
    /// by particle id and step).
    BddfsReconstruction = 6,
    /// The GENERIC polymer fluid's pair noise on the velocities (keyed by step and the pair's
    /// sorted ids).
    GenericPolymerPair = 7,
    /// The GENERIC polymer fluid's Brownian noise on the conformation vectors (keyed by step
    /// and particle id).
    GenericPolymerConformation = 8,
    /// The GENERIC polymer fluid's equilibrium initial conformations (keyed by particle id).
    GenericPolymerInit = 9,
    /// Random initial centres of rigid bodies (keyed by body and try).
    RigidBodyPlacement = 10,
    /// Test-only uses.
    Test = 255,
}

const PHILOX_M0: u32 = 0xD251_1F53;
const PHILOX_M1: u32 = 0xCD9E_8D57;
const PHILOX_W0: u32 = 0x9E37_79B9;
const PHILOX_W1: u32 = 0xBB67_AE85;

#[inline(always)]
fn mulhilo(a: u32, b: u32) -> (u32, u32) {
    let p = u64::from(a) * u64::from(b);
    ((p >> 32) as u32, p as u32)
}

#[inline(always)]
fn philox_round(ctr: [u32; 4], key: [u32; 2]) -> [u32; 4] {
    let (hi0, lo0) = mulhilo(PHILOX_M0, ctr[0]);
    let (hi1, lo1) = mulhilo(PHILOX_M1, ctr[2]);
    [hi1 ^ ctr[1] ^ key[0], lo1, hi0 ^ ctr[3] ^ key[1], lo0]
}

/// Philox4x32 with 10 rounds: the bijection `ctr ↦ out` selected by `key`.
#[inline]
pub fn philox4x32_10(mut ctr: [u32; 4], mut key: [u32; 2]) -> [u32; 4] {
    for round in 0..10 {
        if round > 0 {
            key[0] = key[0].wrapping_add(PHILOX_W0);
            key[1] = key[1].wrapping_add(PHILOX_W1);
        }
        ctr = philox_round(ctr, key);
    }
    ctr
}

/// Key of a draw: everything that identifies *what* the number is for.
#[derive(Clone, Copy, Debug)]
pub struct StreamKey {
    key: [u32; 2],
    purpose_stage: u32,
}

impl StreamKey {
    /// A stream for `purpose` under the case seed; `stage` distinguishes sub-steps.
    pub fn new(seed: u64, purpose: Purpose, stage: u8) -> Self {
        Self {
            key: [seed as u32, (seed >> 32) as u32],
            purpose_stage: ((purpose as u32) << 24) | u32::from(stage),
        }
    }

    /// Four 32-bit words for `(step, a, b)`.
    #[inline]
    pub fn words(&self, step: u64, a: u32, b: u32) -> [u32; 4] {
        philox4x32_10([step as u32, self.purpose_stage, a, b], self.key)
    }

    /// Two uniform numbers in the open interval (0, 1) with 53 random bits each.
    #[inline]
    pub fn uniform2(&self, step: u64, a: u32, b: u32) -> (f64, f64) {
        let w = self.words(step, a, b);
        let u0 = (u64::from(w[0]) << 32) | u64::from(w[1]);
        let u1 = (u64::from(w[2]) << 32) | u64::from(w[3]);
        (open_unit(u0), open_unit(u1))
    }

    /// One standard normal number (Box–Muller, cosine branch).
    #[inline]
    pub fn gaussian(&self, step: u64, a: u32, b: u32) -> f64 {
        let (u0, u1) = self.uniform2(step, a, b);
        box_muller(u0, u1).0
    }

    /// Two independent standard normal numbers.
    #[inline]
    pub fn gaussian2(&self, step: u64, a: u32, b: u32) -> (f64, f64) {
        let (u0, u1) = self.uniform2(step, a, b);
        box_muller(u0, u1)
    }

    /// A uniform number with zero mean and unit variance: √3 (2u − 1).
    #[inline]
    pub fn unit_variance_uniform(&self, step: u64, a: u32, b: u32) -> f64 {
        let w = self.words(step, a, b);
        let u = open_unit((u64::from(w[0]) << 32) | u64::from(w[1]));
        SQRT_3 * (2.0 * u - 1.0)
    }
}

const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// Maps 64 random bits to (0, 1): the top 53 bits plus one half ulp, never 0 or 1.
#[inline(always)]
pub fn open_unit(bits: u64) -> f64 {
    ((bits >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64)
}

/// Box–Muller transform of two uniforms in (0, 1).
#[inline(always)]
pub fn box_muller(u0: f64, u1: f64) -> (f64, f64) {
    let radius = (-2.0 * u0.ln()).sqrt();
    let (s, c) = (std::f64::consts::TAU * u1).sin_cos();
    (radius * c, radius * s)
}

/// SplitMix64's finaliser (Stafford's mix 13): a bijection of u64 with full avalanche.
#[inline(always)]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

pub(super) const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;

mod hash_stream;
mod normal_stream;
mod ziggurat;
pub use hash_stream::HashStream;
pub use normal_stream::NormalStream;
#[allow(unused_imports)]
use normal_stream::{normal_from, normal_slow, xoshiro256pp};
#[allow(unused_imports)]
use ziggurat::*;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_normals_gives_the_numbers_of_repeated_normal_calls() {
        for key in 0..50u64 {
            let mut a = HashStream::new(3, Purpose::Test, key, 1, 2);
            let mut b = a;
            let mut buf = vec![0.0; 4000];
            a.fill_normals(&mut buf);
            for (k, x) in buf.iter().enumerate() {
                assert_eq!(x.to_bits(), b.normal().to_bits(), "key {key} draw {k}");
            }
        }
    }

    /// Known-answer vectors of Random123 (`tests/kat_vectors`, philox4x32 10 rounds).
    #[test]
    fn philox_matches_random123_known_answers() {
        assert_eq!(
            philox4x32_10([0, 0, 0, 0], [0, 0]),
            [0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8]
        );
        assert_eq!(
            philox4x32_10([u32::MAX; 4], [u32::MAX; 2]),
            [0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd]
        );
        assert_eq!(
            philox4x32_10(
                [0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344],
                [0xa4093822, 0x299f31d0]
            ),
            [0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1]
        );
    }

    /// Moments of the Gaussian stream over 4·10⁵ keyed draws: mean, variance, 4th moment
    /// within 5 standard errors of N(0, 1) (σ of the sample mean is 1/√n, of the variance √(2/n),
    /// of the 4th moment √(96/n)).
    #[test]
    fn gaussian_moments() {
        let key = StreamKey::new(12345, Purpose::Test, 0);
        let n = 400_000u32;
        let (mut m1, mut m2, mut m4) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let g = key.gaussian(7, i, i.wrapping_mul(2_654_435_761));
            m1 += g;
            m2 += g * g;
            m4 += g * g * g * g;
        }
        let nf = f64::from(n);
        let (m1, m2, m4) = (m1 / nf, m2 / nf, m4 / nf);
        assert!(m1.abs() < 5.0 / nf.sqrt(), "mean {m1}");
        assert!((m2 - 1.0).abs() < 5.0 * (2.0 / nf).sqrt(), "variance {m2}");
        assert!(
            (m4 - 3.0).abs() < 5.0 * (96.0 / nf).sqrt(),
            "fourth moment {m4}"
        );
    }

    /// Pair keys are symmetric by construction and neighbouring keys are uncorrelated:
    /// the correlation of θ(step, i, j) with θ(step, i, j+1) and θ(step+1, i, j) is below 5/√n.
    #[test]
    fn neighbouring_keys_are_uncorrelated() {
        let key = StreamKey::new(99, Purpose::DpdPair, 0);
        let n = 200_000u32;
        let (mut c_id, mut c_step) = (0.0, 0.0);
        for i in 0..n {
            let g = key.gaussian(3, i, i + 1);
            c_id += g * key.gaussian(3, i, i + 2);
            c_step += g * key.gaussian(4, i, i + 1);
        }
        let nf = f64::from(n);
        assert!((c_id / nf).abs() < 5.0 / nf.sqrt());
        assert!((c_step / nf).abs() < 5.0 / nf.sqrt());
    }

    #[test]
    fn uniform_noise_has_unit_variance() {
        let key = StreamKey::new(5, Purpose::Test, 1);
        let n = 200_000u32;
        let (mut m1, mut m2) = (0.0, 0.0);
        for i in 0..n {
            let u = key.unit_variance_uniform(0, i, 0);
            assert!(u.abs() <= SQRT_3);
            m1 += u;
            m2 += u * u;
        }
        let nf = f64::from(n);
        assert!((m1 / nf).abs() < 5.0 / nf.sqrt());
        // Var(u²) for the uniform is 4/5 → standard error of the variance is √(0.8/n).
        assert!((m2 / nf - 1.0).abs() < 5.0 * (0.8 / nf).sqrt());
    }

    /// Moments of the pair-noise stream (ziggurat normals from the keyed hash): mean, variance,
    /// skewness and kurtosis within 5 standard errors, and the tail mass beyond 3 and 4 σ
    /// within 5 binomial standard errors of the normal values.
    #[test]
    fn hash_stream_normals_have_normal_moments_and_tails() {
        let n = 1_000_000u64;
        let (mut m1, mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0, 0.0);
        let (mut t3, mut t4) = (0u64, 0u64);
        for i in 0..n {
            let g = HashStream::new(42, Purpose::DpdPair, 17, i, i + 1).normal();
            m1 += g;
            m2 += g * g;
            m3 += g * g * g;
            m4 += g * g * g * g;
            t3 += u64::from(g.abs() > 3.0);
            t4 += u64::from(g.abs() > 4.0);
        }
        let nf = n as f64;
        let (m1, m2, m3, m4) = (m1 / nf, m2 / nf, m3 / nf, m4 / nf);
        assert!(m1.abs() < 5.0 / nf.sqrt(), "mean {m1}");
        assert!((m2 - 1.0).abs() < 5.0 * (2.0 / nf).sqrt(), "variance {m2}");
        assert!(m3.abs() < 5.0 * (15.0 / nf).sqrt(), "third moment {m3}");
        assert!(
            (m4 - 3.0).abs() < 5.0 * (96.0 / nf).sqrt(),
            "fourth moment {m4}"
        );
        for (count, p) in [(t3, 2.699_796_063e-3), (t4, 6.334_248_4e-5)] {
            let expected = p * nf;
            assert!(
                (count as f64 - expected).abs() < 5.0 * (expected * (1.0 - p)).sqrt(),
                "tail count {count} vs {expected}"
            );
        }
    }

    /// Neighbouring keys — the next pair id, the next step, the swapped ids, another seed —
    /// give uncorrelated numbers (|ρ| < 5/√n).
    #[test]
    fn hash_stream_neighbouring_keys_are_uncorrelated() {
        let n = 300_000u64;
        let mut c = [0.0f64; 4];
        for i in 0..n {
            let g = HashStream::new(7, Purpose::DpdPair, 100, i, i + 5).normal();
            let others = [
                HashStream::new(7, Purpose::DpdPair, 100, i, i + 6).normal(),
                HashStream::new(7, Purpose::DpdPair, 101, i, i + 5).normal(),
                HashStream::new(7, Purpose::DpdPair, 100, i + 5, i).normal(),
                HashStream::new(8, Purpose::DpdPair, 100, i, i + 5).normal(),
            ];
            for (acc, o) in c.iter_mut().zip(others) {
                *acc += g * o;
            }
        }
        for acc in c {
            let rho = acc / n as f64;
            assert!(rho.abs() < 5.0 / (n as f64).sqrt(), "correlation {rho}");
        }
    }

    /// The `static` ziggurat table is the one `ziggurat()` computes from R and V (to 4 ulp: the
    /// literals were printed from that computation; libm may differ in the last bit elsewhere).
    #[test]
    fn static_ziggurat_table_matches_its_formula() {
        let z = ziggurat();
        for i in 0..=ZIG_LAYERS {
            for (a, b) in [(ZIG_X[i], z.x[i]), (ZIG_F[i], z.f[i])] {
                assert!(
                    (a - b).abs() <= 4.0 * f64::EPSILON * b.abs(),
                    "entry {i}: {a} vs {b}"
                );
            }
        }
    }

    /// Standard normal tail mass P(|x| > t) = erfc(t/√2).
    fn normal_two_sided_tail(t: f64) -> f64 {
        // erfc by its continued fraction (Lentz), accurate to ~1e-15 for t/√2 ≥ 2.
        let z = t / std::f64::consts::SQRT_2;
        let mut f = z;
        let (mut c, mut d) = (z, 0.0);
        for k in 1..200 {
            let a = f64::from(k) / 2.0;
            d = 1.0 / (z + a * d);
            c = z + a / c;
            let delta = c * d;
            f *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-z * z).exp() / (f * std::f64::consts::PI.sqrt())
    }

    #[test]
    fn normal_tail_formula_is_right() {
        // Tabulated P(|x| > 3) and P(|x| > 4).
        assert!((normal_two_sided_tail(3.0) / 2.699_796_063_260_2e-3 - 1.0).abs() < 1e-9);
        assert!((normal_two_sided_tail(4.0) / 6.334_248_366_623_98e-5 - 1.0).abs() < 1e-9);
    }

    /// Standard normal CDF Φ(t) = ½ erfc(−t/√2) (series for |t| < 3, tail beyond).
    fn normal_cdf(t: f64) -> f64 {
        if t.abs() >= 3.0 {
            let tail = 0.5 * normal_two_sided_tail(t.abs());
            return if t > 0.0 { 1.0 - tail } else { tail };
        }
        // Φ(t) = ½ + φ(t) Σ t^{2k+1} / (1·3·…·(2k+1)).
        let (mut term, mut sum) = (t, t);
        for k in 1..200 {
            term *= t * t / f64::from(2 * k + 1);
            sum += term;
            if term.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        0.5 + sum * (-0.5 * t * t).exp() / (2.0 * std::f64::consts::PI).sqrt()
    }

    /// Moment and tail checks shared by the normal-generator tests; tolerance `K_SIGMA`
    /// standard errors (σ of the sample mean 1/√n, variance √(2/n), 3rd moment √(15/n), 4th
    /// √(96/n); binomial for tail counts).
    const K_SIGMA: f64 = 5.0;

    fn assert_normal_sample(xs: &[f64]) {
        let nf = xs.len() as f64;
        let (mut m1, mut m2, mut m3, mut m4) = (0.0, 0.0, 0.0, 0.0);
        let (mut t3, mut t4, mut t_r) = (0u64, 0u64, 0u64);
        for &g in xs {
            m1 += g;
            m2 += g * g;
            m3 += g * g * g;
            m4 += g * g * g * g;
            t3 += u64::from(g.abs() > 3.0);
            t4 += u64::from(g.abs() > 4.0);
            t_r += u64::from(g.abs() > ZIG_R);
        }
        let (m1, m2, m3, m4) = (m1 / nf, m2 / nf, m3 / nf, m4 / nf);
        let k = K_SIGMA;
        assert!(m1.abs() < k / nf.sqrt(), "mean {m1}");
        assert!((m2 - 1.0).abs() < k * (2.0 / nf).sqrt(), "variance {m2}");
        assert!(m3.abs() < k * (15.0 / nf).sqrt(), "third moment {m3}");
        assert!(
            (m4 - 3.0).abs() < k * (96.0 / nf).sqrt(),
            "fourth moment {m4}"
        );
        // |x| > 3 (wedges), > R (the base strip's tail path) and > 4 (deep tail).
        for (count, t) in [(t3, 3.0), (t_r, ZIG_R), (t4, 4.0)] {
            let p = normal_two_sided_tail(t);
            let expected = p * nf;
            assert!(
                (count as f64 - expected).abs() < k * (expected * (1.0 - p)).sqrt(),
                "P(|x| > {t}): count {count} vs {expected}"
            );
        }
        // χ² of a 64-bin histogram on [−4, 4] plus two tail bins (equal widths 1/8): every
        // layer's rectangle and wedge show up here. dof = 65; bound dof + K_SIGMA √(2 dof).
        let bins = 64usize;
        let mut hist = vec![0u64; bins + 2];
        for &g in xs {
            let b = if g < -4.0 {
                0
            } else if g >= 4.0 {
                bins + 1
            } else {
                1 + (((g + 4.0) * 8.0) as usize).min(bins - 1)
            };
            hist[b] += 1;
        }
        let mut chi2 = 0.0;
        for (b, &count) in hist.iter().enumerate() {
            // The two tail bins have the same mass Φ(−4) by symmetry.
            let p = if b == 0 || b == bins + 1 {
                normal_cdf(-4.0)
            } else {
                let lo = -4.0 + (b - 1) as f64 / 8.0;
                normal_cdf(lo + 0.125) - normal_cdf(lo)
            };
            let e = p * nf;
            chi2 += (count as f64 - e).powi(2) / e;
        }
        let dof = (bins + 1) as f64;
        assert!(
            chi2 < dof + k * (2.0 * dof).sqrt(),
            "χ² {chi2} for {dof} dof"
        );
    }

    /// Many short keyed streams, as the dumbbells use them (3 000 normals per particle and step).
    #[test]
    fn normal_stream_has_normal_moments_tails_and_histogram() {
        let mut xs = Vec::with_capacity(4_000_000);
        let mut buf = vec![0.0; 3000];
        for gid in 0..1334u64 {
            NormalStream::new(42, Purpose::DumbbellNoise, 9, gid, 0).fill_normals(&mut buf);
            xs.extend_from_slice(&buf);
        }
        assert_normal_sample(&xs);
    }

    /// The first number of many different keys (the start of a stream, right after seeding).
    #[test]
    fn normal_stream_first_draws_over_keys_are_normal() {
        let xs: Vec<f64> = (0..1_000_000u64)
            .map(|gid| NormalStream::new(3, Purpose::DumbbellNoise, 1000, gid, 0).normal())
            .collect();
        assert_normal_sample(&xs);
    }

    /// Lag-1 (and lag-2, lag-3: one dumbbell's D components) correlation within a stream, and
    /// correlation between the streams of neighbouring keys — particle id ± 1, step ± 1, another
    /// seed, another purpose — position by position: |ρ| < K_SIGMA/√n each.
    #[test]
    fn normal_stream_is_uncorrelated_within_and_between_neighbouring_keys() {
        let len = 300usize;
        let (particles, step) = (4000u64, 77u64);
        let stream = |seed, purpose, step, gid| {
            let mut v = vec![0.0; len];
            NormalStream::new(seed, purpose, step, gid, 0).fill_normals(&mut v);
            v
        };
        let mut lag = [0.0f64; 3];
        let mut lag_n = 0usize;
        let mut cross = [0.0f64; 6];
        let mut cross_n = 0usize;
        for gid in 1..=particles {
            let me = stream(11, Purpose::DumbbellNoise, step, gid);
            for (l, acc) in lag.iter_mut().enumerate() {
                *acc += me.iter().zip(&me[l + 1..]).map(|(a, b)| a * b).sum::<f64>();
            }
            lag_n += len - 1; // (lags 2, 3 have a few fewer pairs: negligible)
            let others = [
                stream(11, Purpose::DumbbellNoise, step, gid + 1),
                stream(11, Purpose::DumbbellNoise, step, gid - 1),
                stream(11, Purpose::DumbbellNoise, step + 1, gid),
                stream(11, Purpose::DumbbellNoise, step - 1, gid),
                stream(12, Purpose::DumbbellNoise, step, gid),
                stream(11, Purpose::DumbbellInit, step, gid),
            ];
            for (acc, o) in cross.iter_mut().zip(&others) {
                *acc += me.iter().zip(o).map(|(a, b)| a * b).sum::<f64>();
            }
            cross_n += len;
        }
        for (l, acc) in lag.iter().enumerate() {
            let rho = acc / lag_n as f64;
            assert!(
                rho.abs() < K_SIGMA / (lag_n as f64).sqrt(),
                "lag-{} correlation {rho}",
                l + 1
            );
        }
        let names = ["gid+1", "gid-1", "step+1", "step-1", "seed+1", "purpose"];
        for (acc, name) in cross.iter().zip(names) {
            let rho = acc / cross_n as f64;
            assert!(
                rho.abs() < K_SIGMA / (cross_n as f64).sqrt(),
                "{name}: correlation {rho}"
            );
        }
        // Position by position across particles (e.g. the first draw after seeding of
        // neighbouring ids): correlation of draw k of gid with draw k of gid + 1.
        for k in [0usize, 1, 2, 299] {
            let mut acc = 0.0;
            for gid in 0..particles * 25 {
                let a = NormalStream::new(11, Purpose::DumbbellNoise, step, gid, 0);
                let b = NormalStream::new(11, Purpose::DumbbellNoise, step, gid + 1, 0);
                let nth = |mut s: NormalStream| {
                    for _ in 0..k {
                        s.normal();
                    }
                    s.normal()
                };
                acc += nth(a) * nth(b);
            }
            let n = (particles * 25) as f64;
            assert!(
                (acc / n).abs() < K_SIGMA / n.sqrt(),
                "draw {k}: {}",
                acc / n
            );
        }
    }

    #[test]
    fn normal_stream_is_a_function_of_its_key() {
        let mut a = NormalStream::new(5, Purpose::DumbbellNoise, 3, 8, 0);
        let mut b = a.clone();
        let mut buf = vec![0.0; 1000];
        a.fill_normals(&mut buf);
        for (k, x) in buf.iter().enumerate() {
            assert_eq!(x.to_bits(), b.normal().to_bits(), "draw {k}");
        }
        let mut c = NormalStream::new(5, Purpose::DumbbellNoise, 3, 8, 0);
        let mut again = vec![0.0; 1000];
        c.fill_normals(&mut again);
        assert_eq!(buf, again);
        // u ∈ (−1, 1) is symmetric and never ±1 or 0.
        for bits in [0u64, u64::MAX, 1 << 63, (1 << 63) - 1] {
            let (_, u) = ziggurat_layer_and_u(bits);
            assert!(u.abs() < 1.0 && u != 0.0, "{bits:x}: {u}");
        }
        assert_eq!(ziggurat_layer_and_u(0).1, -ziggurat_layer_and_u(u64::MAX).1);
    }

    /// xoshiro256++ reference output (Vigna's C code, state {1, 2, 3, 4}).
    #[test]
    fn xoshiro256plusplus_matches_the_reference() {
        let mut s = NormalStream { s: [1, 2, 3, 4] };
        let want = [41943041u64, 58720359, 3588806011781223, 3591011842654386];
        for w in want {
            assert_eq!(s.next_u64(), w);
        }
    }

    #[test]
    fn ziggurat_table_is_consistent() {
        let z = ziggurat();
        // Every layer has area V: x_i (f(x_{i+1}) − f(x_i)) = V (checked for the inner layers).
        for i in 1..ZIG_LAYERS - 1 {
            let area = z.x[i] * (z.f[i + 1] - z.f[i]);
            assert!((area - ZIG_V).abs() < 1e-9, "layer {i}: {area}");
        }
        assert!(z.x[ZIG_LAYERS - 1] > 0.0 && z.x[ZIG_LAYERS - 1] < 0.3);
    }
}
