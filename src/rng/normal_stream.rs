//! The xoshiro256++ stream of standard normals behind a counter-based key (the dumbbell
//! ensembles).

#[allow(unused_imports)]
use super::*;

/// A fast sequential stream of standard normals behind a counter-based key, for the dumbbell
/// ensembles (docs/architecture.md, "Determinism" item 1: one fast stream per (particle, step)).
///
/// - Key: the [`HashStream`] of `(seed, purpose, step, a, b)` (keyed SplitMix64) produces the
///   four state words, so the stream is a pure function of its key — no state to checkpoint,
///   the same numbers on any rank or thread. SplitMix64 outputs are the seeding Blackman & Vigna
///   recommend; they are distinct (SplitMix64 is a bijection of distinct counters), so the
///   state is never all zero.
/// - Generator: xoshiro256++ (Blackman & Vigna, ACM TOMS 47 (2021) 36), period 2²⁵⁶ − 1, no
///   multiplication on the critical path.
/// - Normals: the same 256-layer ziggurat as [`HashStream::normal`] (Marsaglia & Tsang 2000),
///   with the layer table a `static` (no initialisation check per call) and one 64-bit draw per
///   normal in ~99 % of the calls: 8 bits choose the layer, the top 52 bits give u ∈ (−1, 1)
///   (built by writing them into the mantissa of a float in [2, 4): no integer→float
///   conversion). The rare paths (wedges, tail beyond R) are out of line, on a side stream
///   (see `normal_slow`), so the hot loop keeps the xoshiro state in registers.
///
/// Statistics are tested below (moments, tails, χ² of the histogram, lag-1 and neighbouring-key
/// correlations). Generator alone ≈ 1.3× [`HashStream::fill_normals`] (2.4–2.9 ns per normal
/// against ~3.1 ns, best repetitions on a loaded machine; docs/performance.md); the bits differ
/// from [`HashStream`]'s (the DPD pair noise keeps that one, digests pinned).
#[derive(Clone, Debug)]
pub struct NormalStream {
    pub(super) s: [u64; 4],
}

impl NormalStream {
    /// The stream for `(seed, purpose, step, a, b)`.
    #[inline]
    pub fn new(seed: u64, purpose: Purpose, step: u64, a: u64, b: u64) -> Self {
        let mut key = HashStream::new(seed, purpose, step, a, b);
        Self {
            s: [
                key.next_u64(),
                key.next_u64(),
                key.next_u64(),
                key.next_u64(),
            ],
        }
    }

    /// Next 64 random bits (xoshiro256++).
    #[inline(always)]
    pub fn next_u64(&mut self) -> u64 {
        xoshiro256pp(&mut self.s)
    }

    /// Uniform in (0, 1).
    #[inline(always)]
    pub fn uniform(&mut self) -> f64 {
        open_unit(self.next_u64())
    }

    /// One standard normal (ziggurat; see the type's documentation).
    #[inline]
    pub fn normal(&mut self) -> f64 {
        normal_from(&mut self.s)
    }

    /// Fills `out` with standard normals: the numbers of `out.len()` calls of [`Self::normal`].
    pub fn fill_normals(&mut self, out: &mut [f64]) {
        let mut s = self.s;
        for o in out {
            *o = normal_from(&mut s);
        }
        self.s = s;
    }
}

/// One xoshiro256++ step on the state `s` (Blackman & Vigna's reference code).
#[inline(always)]
pub(super) fn xoshiro256pp(s: &mut [u64; 4]) -> u64 {
    let out = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
    let t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = s[3].rotate_left(45);
    out
}

/// One ziggurat normal from the xoshiro256++ state `s`.
#[inline(always)]
pub(super) fn normal_from(s: &mut [u64; 4]) -> f64 {
    let bits = xoshiro256pp(s);
    let (i, u) = ziggurat_layer_and_u(bits);
    let x = u * ZIG_X[i];
    if x.abs() < ZIG_X[i + 1] {
        return x;
    }
    normal_slow(bits, i, u, x)
}

/// The ziggurat's rare paths (~1 % of the draws: base strip tail, wedges, retries). Their extra
/// random numbers come from a SplitMix64 side stream started at a hash of the rejected draw's 64
/// bits, not from the xoshiro state: so the hot loop never passes its state to a call and keeps
/// it in registers. The side stream is a pure function of the main stream (determinism kept)
/// and, the hash being a bijection with full avalanche, independent of the layer and u that the
/// rejected bits encoded (tested: tails beyond 3, R and 4, χ² of the histogram).
#[cold]
#[inline(never)]
pub(super) fn normal_slow(bits: u64, mut i: usize, mut u: f64, mut x: f64) -> f64 {
    let mut side = HashStream {
        state: mix64(bits ^ 0x5851_F42D_4C95_7F2D),
    };
    loop {
        if i == 0 {
            // Tail beyond R (Marsaglia 1964).
            loop {
                let xt = side.uniform().ln() / ZIG_R;
                let yt = side.uniform().ln();
                if -2.0 * yt >= xt * xt {
                    return if u < 0.0 { xt - ZIG_R } else { ZIG_R - xt };
                }
            }
        }
        if ZIG_F[i + 1] + (ZIG_F[i] - ZIG_F[i + 1]) * side.uniform() < (-0.5 * x * x).exp() {
            return x;
        }
        (i, u) = ziggurat_layer_and_u(side.next_u64());
        x = u * ZIG_X[i];
        if x.abs() < ZIG_X[i + 1] {
            return x;
        }
    }
}
