//! Exact, order-independent accumulation of f64 contributions in two-word fixed point.
//!
//! Determinism across rank and thread counts needs every per-particle sum to give the same bits
//! whatever order its terms arrive in. Floating-point addition is not associative; integer
//! addition is. Each term x is split exactly into
//!
//! ```text
//! y = x · 2^24,   h = round(y),   l = round((y − h) · 2^52)        (both i64)
//! ```
//!
//! and the two words are summed as integers. y − h is exact (Sterbenz), and the roundings are
//! done with the 1.5·2^52 "magic number" (adding it leaves the rounded integer in the low
//! mantissa bits: a float add and an integer subtract, no conversion instruction). Rounding to
//! nearest is symmetric, so −x accumulates exactly the negative of x. The sum is exact down to
//! 2^-77 ≈ 7·10⁻²⁴ per term; a term must satisfy |x| < 2^26 ≈ 6.7·10⁷ (callers check
//! [`FixedSum::representable`]) and the sum |Σ| < 2^39 ≈ 5·10¹¹ — far beyond the forces and
//! virials of any stable run. The final conversion rounds once. So the accumulated value is
//! the exact sum correctly rounded (up to the 2^-77 rounding per term), *more* accurate than
//! sequential f64 addition, and independent of the order of the terms, of the number of threads
//! and of the decomposition. Pair forces can therefore be scattered from half neighbour lists in
//! any order.

/// Scale of the high word.
const HIGH_SHIFT: f64 = (1u64 << 24) as f64;
/// Scale of the low word relative to the high word.
const LOW_SHIFT: f64 = (1u64 << 52) as f64;

/// 1.5 · 2^52: adding it to |v| < 2^51 rounds v to an integer held in the low mantissa bits.
const MAGIC: f64 = 6_755_399_441_055_744.0;

/// round(v) as i64 and as f64, for |v| < 2^51.
#[inline(always)]
fn round_to_i64(v: f64) -> (i64, f64) {
    let shifted = v + MAGIC;
    let as_int = (shifted.to_bits() as i64).wrapping_sub(MAGIC.to_bits() as i64);
    (as_int, shifted - MAGIC)
}

/// A term split into its two fixed-point words (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Split {
    high: i64,
    low: i64,
}

impl Split {
    /// The words of zero.
    pub const ZERO: Self = Self { high: 0, low: 0 };

    /// The two words of `x` (|x| < 2^26; see [`FixedSum::representable`]).
    #[inline(always)]
    pub fn of(x: f64) -> Self {
        let y = x * HIGH_SHIFT;
        let (high, hf) = round_to_i64(y);
        let (low, _) = round_to_i64((y - hf) * LOW_SHIFT);
        Self { high, low }
    }
}

/// A fixed-point accumulator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedSum {
    high: i64,
    low: i64,
}

impl FixedSum {
    /// Zero.
    pub const ZERO: Self = Self { high: 0, low: 0 };

    /// Largest magnitude a single term may have.
    pub const MAX_TERM: f64 = (1u64 << 26) as f64;

    /// Whether `x` can be added exactly (finite and |x| < 2^26).
    #[inline(always)]
    pub fn representable(x: f64) -> bool {
        x.abs() < Self::MAX_TERM
    }

    /// Adds `x` (|x| < 2^26; see [`Self::representable`]).
    #[inline(always)]
    pub fn add(&mut self, x: f64) {
        self.add_split(Split::of(x));
    }

    /// Adds a term split once with [`Split::of`].
    #[inline(always)]
    pub fn add_split(&mut self, s: Split) {
        self.high = self.high.wrapping_add(s.high);
        self.low = self.low.wrapping_add(s.low);
    }

    /// Subtracts a term split once with [`Split::of`]: the same bits as `add(-x)`, because the
    /// rounding is symmetric (round(−y) = −round(y)), so a pair force split once serves both
    /// ends of the pair.
    #[inline(always)]
    pub fn sub_split(&mut self, s: Split) {
        self.high = self.high.wrapping_sub(s.high);
        self.low = self.low.wrapping_sub(s.low);
    }

    /// Adds another accumulator.
    #[inline(always)]
    pub fn merge(&mut self, other: &Self) {
        self.high = self.high.wrapping_add(other.high);
        self.low = self.low.wrapping_add(other.low);
    }

    /// The exact sum of `xs` (each |x| < 2^26, at most 2^11 of them, so that the low words
    /// cannot wrap): the words of every term summed as integers, which the compiler
    /// vectorises; the same value as adding the terms one by one, in any order.
    #[inline(always)]
    pub fn sum_of(xs: &[f64]) -> Self {
        debug_assert!(xs.len() <= 1 << 11);
        let (mut high, mut low) = (0i64, 0i64);
        for &x in xs {
            let s = Split::of(x);
            high = high.wrapping_add(s.high);
            low = low.wrapping_add(s.low);
        }
        Self { high, low }
    }

    /// Moves the carry of the low word into the high word, leaving low in [0, 2^52): call it
    /// every few thousand terms in long accumulations (each term adds |l| ≤ 2^51 to the low
    /// word, which would wrap after ~2^12 worst-case or ~2^26 random terms).
    #[inline]
    pub fn normalize(&mut self) {
        let carry = self.low >> 52;
        self.high = self.high.wrapping_add(carry);
        self.low -= carry << 52;
    }

    /// Exact element-wise sum over every rank (collective): the same bits on every rank and for
    /// every rank count. Each accumulator travels as three integer words (the high word and the
    /// normalised low word split in two 26-bit halves), so the integer sums cannot wrap below
    /// 2^37 ranks.
    pub fn allreduce(comm: &dyn crate::comm::Comm, sums: &mut [FixedSum]) {
        let mut words = Vec::with_capacity(3 * sums.len());
        for s in sums.iter_mut() {
            s.normalize();
            words.push(s.high as u64);
            words.push((s.low >> 26) as u64);
            words.push((s.low & ((1 << 26) - 1)) as u64);
        }
        comm.allreduce_u64(&mut words, crate::comm::U64Op::Sum);
        for (s, w) in sums.iter_mut().zip(words.chunks_exact(3)) {
            // Σlow = A·2^26 + B with A = a1·2^26 + a0: a1 carries into the high word.
            s.high = w[0] as i64;
            let hi = w[1] as i64;
            s.low = (hi & ((1 << 26) - 1)) << 26;
            s.high = s.high.wrapping_add(hi >> 26);
            s.low += w[2] as i64;
            s.normalize();
        }
    }

    /// The sum, rounded once to f64.
    #[inline]
    pub fn value(&self) -> f64 {
        let carry = self.low >> 52;
        let high = self.high.wrapping_add(carry);
        let low = self.low - (carry << 52);
        (high as f64 + low as f64 / LOW_SHIFT) / HIGH_SHIFT
    }
}

/// The power-of-two scale 2^e under which one accumulated quantity is summed: a term x enters a
/// [`FixedSum`] as x · 2^−e (exact: a power-of-two product), and the value comes back × 2^e.
/// So the quantity may take terms up to |x| < 2^(26+e) and is resolved to 2^(e−77) per term.
/// A model states the scale of each quantity it accumulates ([`Scale::covering`] its largest
/// plausible term): SPH densities, pressures, Maxwell stresses and MSPH moments span very
/// different ranges, and one fixed scale would either overflow or lose their small terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale {
    exponent: i32,
    down: f64,
    up: f64,
}

impl Default for Scale {
    fn default() -> Self {
        Self::UNIT
    }
}

impl Scale {
    /// The scale of the DPD forces and virials: terms below 2^26, resolution 2^−77.
    pub const UNIT: Self = Self {
        exponent: 0,
        down: 1.0,
        up: 1.0,
    };

    /// The scale 2^e with e the smallest exponent ≥ −60 for which a term of magnitude
    /// `max_term` is representable with a factor 2 to spare (|x| < 2^(25+e)).
    pub fn covering(max_term: f64) -> Self {
        let need = if max_term.is_finite() && max_term > 0.0 {
            (max_term.log2().floor() as i32 + 1) - 25
        } else {
            0
        };
        Self::of_exponent(need.clamp(-60, 900))
    }

    /// The scale 2^`exponent`.
    pub fn of_exponent(exponent: i32) -> Self {
        Self {
            exponent,
            down: 2f64.powi(-exponent),
            up: 2f64.powi(exponent),
        }
    }

    /// The exponent e.
    pub fn exponent(&self) -> i32 {
        self.exponent
    }

    /// The largest magnitude a term may have under this scale (exclusive).
    pub fn max_term(&self) -> f64 {
        FixedSum::MAX_TERM * self.up
    }

    /// The words of `x` under this scale, or `None` if x is not finite or |x| ≥
    /// [`Self::max_term`] (the caller reports it: a term is never wrapped).
    #[inline(always)]
    pub fn split(&self, x: f64) -> Option<Split> {
        let y = x * self.down;
        FixedSum::representable(y).then(|| Split::of(y))
    }

    /// The words of every `xs[k]` under this scale into `out[k]` (as [`Self::split`], in one
    /// loop the compiler vectorises), and the index of the first term that is not finite or
    /// beyond [`Self::max_term`], if any (its words are meaningless: the caller reports it).
    #[inline(always)]
    pub fn split_batch(&self, xs: &[f64], out: &mut [Split]) -> Option<usize> {
        let mut all = true;
        for (x, o) in xs.iter().zip(out.iter_mut()) {
            let y = x * self.down;
            all &= FixedSum::representable(y);
            *o = Split::of(y);
        }
        if all {
            None
        } else {
            xs.iter()
                .position(|&x| !FixedSum::representable(x * self.down))
        }
    }

    /// The value of `sum` (accumulated under this scale), rounded once.
    #[inline]
    pub fn value(&self, sum: &FixedSum) -> f64 {
        sum.value() * self.up
    }
}

/// [`FixedSum`]s of `L` particles side by side (lane l is particle l of a group), so that a
/// loop over the lanes vectorises: the same words, added in the same way, as `L` separate
/// accumulators.
///
/// To save two integer subtractions per term, a lane adds the raw bits of the two rounded
/// values, `bits(y + MAGIC) = bits(MAGIC) + h` and `bits(r·2^52 + MAGIC) = bits(MAGIC) + l`
/// (see [`round_to_i64`]), and [`Self::lane`] takes `terms · bits(MAGIC)` off each word once:
/// in wrapping (mod 2^64) arithmetic that is exactly Σh and Σl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LaneSums<const L: usize> {
    high: [i64; L],
    low: [i64; L],
    /// Terms added to every lane (each [`Scale::add_lanes`] adds one per lane).
    terms: i64,
    /// The largest |x · 2^(24−e)| added to each lane, as its bits: for non-negative floats
    /// (NaN included) the order of the bits as integers is the order of the values, with NaN
    /// above infinity, so one integer maximum per term replaces a comparison and a mask
    /// operation, and [`Self::representable`] tests them all at the end.
    largest: [u64; L],
}

impl<const L: usize> LaneSums<L> {
    /// Every lane zero.
    pub const ZERO: Self = Self {
        high: [0; L],
        low: [0; L],
        terms: 0,
        largest: [0; L],
    };

    /// Whether every term added so far was finite and within its scale's
    /// [`Scale::max_term`] (otherwise the sums are meaningless).
    #[inline]
    pub fn representable(&self) -> bool {
        self.largest.iter().all(|&b| b < MAX_SHIFTED.to_bits())
    }

    /// The accumulator of lane `l`.
    #[inline]
    pub fn lane(&self, l: usize) -> FixedSum {
        let offset = self.terms.wrapping_mul(MAGIC.to_bits() as i64);
        FixedSum {
            high: self.high[l].wrapping_sub(offset),
            low: self.low[l].wrapping_sub(offset),
        }
    }
}

/// |x · 2^24| must stay below this for |x| < [`FixedSum::MAX_TERM`] = 2^26.
const MAX_SHIFTED: f64 = FixedSum::MAX_TERM * HIGH_SHIFT;

impl Scale {
    /// Adds `xs[l]` under this scale to lane l of `acc`, for every lane (as [`Self::split`]
    /// and [`FixedSum::add_split`], in one loop the compiler vectorises). Returns false if a
    /// term (this one or an earlier one) was not finite or beyond [`Self::max_term`]: the
    /// lanes' sums are then meaningless,
    /// and the caller reports the term another way.
    ///
    /// The words are those of [`Split::of`]`(x · 2^−e)`, computed with one multiplication by
    /// 2^(24−e) instead of two by 2^−e and 2^24: both products of x by a power of two, so
    /// exact and equal, except where x · 2^−e is subnormal, whose words are zero either way.
    #[inline(always)]
    pub fn add_lanes<const L: usize>(&self, xs: &[f64; L], acc: &mut LaneSums<L>) -> bool {
        self.lane_factor().add(xs, acc);
        acc.representable()
    }

    /// The factor 2^(24−e) of [`Self::add_lanes`], to take out of a loop over many terms.
    #[inline(always)]
    pub fn lane_factor(&self) -> LaneFactor {
        LaneFactor(self.down * HIGH_SHIFT)
    }
}

/// A [`Scale`]'s factor 2^(24−e), taken out of a loop: [`LaneFactor::add`] is
/// [`Scale::add_lanes`] without reloading the scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneFactor(f64);

impl LaneFactor {
    /// As [`Scale::add_lanes`] under the scale this factor came from, with the check of the
    /// terms left to [`LaneSums::representable`].
    #[inline(always)]
    pub fn add<const L: usize>(self, xs: &[f64; L], acc: &mut LaneSums<L>) {
        for l in 0..L {
            let y = xs[l] * self.0;
            acc.largest[l] = acc.largest[l].max(y.abs().to_bits());
            let shifted = y + MAGIC;
            let r = y - (shifted - MAGIC);
            let low = r * LOW_SHIFT + MAGIC;
            acc.high[l] = acc.high[l].wrapping_add(shifted.to_bits() as i64);
            acc.low[l] = acc.low[l].wrapping_add(low.to_bits() as i64);
        }
        acc.terms += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_does_not_matter_and_sum_is_accurate() {
        let key = crate::rng::StreamKey::new(1, crate::rng::Purpose::Test, 3);
        let xs: Vec<f64> = (0..1000u32)
            .map(|i| {
                let (g, _) = key.gaussian2(0, i, 0);
                let (u, _) = key.uniform2(0, i, 1);
                g * 10f64.powf(4.0 * u - 2.0) // magnitudes 10⁻²…10²
            })
            .collect();
        let mut forward = FixedSum::ZERO;
        xs.iter().for_each(|&x| forward.add(x));
        let mut backward = FixedSum::ZERO;
        xs.iter().rev().for_each(|&x| backward.add(x));
        assert_eq!(forward, backward);
        // Split in two halves and merged: same bits.
        let (mut a, mut b) = (FixedSum::ZERO, FixedSum::ZERO);
        xs.iter().step_by(2).for_each(|&x| a.add(x));
        xs.iter().skip(1).step_by(2).for_each(|&x| b.add(x));
        a.merge(&b);
        assert_eq!(a, forward);
        // Compared with a compensated (Neumaier) sum.
        let (mut s, mut c) = (0.0f64, 0.0f64);
        for &x in &xs {
            let t = s + x;
            c += if s.abs() >= x.abs() {
                (s - t) + x
            } else {
                (x - t) + s
            };
            s = t;
        }
        let exact = s + c;
        assert!(
            (forward.value() - exact).abs() <= 1e-15 * exact.abs().max(1.0),
            "{} vs {exact}",
            forward.value()
        );
    }

    #[test]
    fn exact_allreduce_equals_the_sum_of_all_terms_on_any_rank_count() {
        let key = crate::rng::StreamKey::new(5, crate::rng::Purpose::Test, 1);
        let xs: Vec<f64> = (0..5000u32)
            .map(|i| key.gaussian2(0, i, 0).0 * 1e3)
            .collect();
        let mut all = FixedSum::ZERO;
        xs.iter().for_each(|&x| all.add(x));
        let want = all.value();
        for ranks in 1..=4 {
            let xs = xs.clone();
            let got = crate::comm::in_process(ranks, move |c| {
                let mut s = [FixedSum::ZERO];
                for x in xs.iter().skip(c.rank()).step_by(c.size()) {
                    s[0].add(*x);
                }
                FixedSum::allreduce(c, &mut s);
                Ok::<_, String>(s[0].value())
            })
            .expect("ranks");
            assert_eq!(got.to_bits(), want.to_bits(), "{ranks} ranks");
        }
        // Normalising keeps the value.
        let mut big = FixedSum::ZERO;
        for _ in 0..100_000 {
            big.add(0.499_999_999_999);
        }
        let before = big.value();
        big.normalize();
        assert_eq!(big.value(), before);
    }

    #[test]
    fn subtracting_a_split_equals_adding_the_negative() {
        let key = crate::rng::StreamKey::new(2, crate::rng::Purpose::Test, 9);
        let (mut by_add, mut by_sub) = (FixedSum::ZERO, FixedSum::ZERO);
        for i in 0..10_000u32 {
            let (g, _) = key.gaussian2(0, i, 0);
            // Include exact ties of the high-word rounding (multiples of 2^-25).
            let x = if i % 7 == 0 {
                f64::from(i as i32 - 5000) * 2f64.powi(-25)
            } else {
                g * 1e3
            };
            assert_eq!(Split::of(-x), {
                let s = Split::of(x);
                Split {
                    high: -s.high,
                    low: -s.low,
                }
            });
            by_add.add(-x);
            by_sub.sub_split(Split::of(x));
        }
        assert_eq!(by_add, by_sub);
    }

    #[test]
    fn cancelling_terms_give_zero() {
        let mut acc = FixedSum::ZERO;
        for x in [1.5e3, -0.1, 3.25e-7, -1.5e3, 0.1, -3.25e-7] {
            acc.add(x);
        }
        assert!(acc.value().abs() < 1e-20);
        let mut neg = FixedSum::ZERO;
        neg.add(-2.75);
        assert_eq!(neg.value(), -2.75);
    }

    #[test]
    fn a_scale_covers_its_range_keeps_order_independence_and_refuses_beyond() {
        for (max, big) in [(1e-6, 9e-7), (1.0, 0.9), (3e9, 2.9e9), (1e30, 7e29)] {
            let scale = Scale::covering(max);
            assert!(
                scale.max_term() > max && scale.max_term() <= 4.0 * max,
                "{max}"
            );
            let terms = [big, -0.5 * big, 1e-3 * big, -big, 0.25 * big];
            let (mut fwd, mut back) = (FixedSum::ZERO, FixedSum::ZERO);
            terms
                .iter()
                .for_each(|&x| fwd.add_split(scale.split(x).expect("in range")));
            terms
                .iter()
                .rev()
                .for_each(|&x| back.add_split(scale.split(x).expect("in range")));
            assert_eq!(fwd, back);
            let want = -0.249 * big;
            assert!(
                (scale.value(&fwd) - want).abs() <= 1e-15 * want.abs(),
                "{max}"
            );
            assert!(scale.split(2.0 * scale.max_term()).is_none());
            assert!(scale.split(f64::NAN).is_none());
        }
        // The unit scale is the plain FixedSum.
        let mut a = FixedSum::ZERO;
        a.add(1.25);
        let mut b = FixedSum::ZERO;
        b.add_split(Scale::UNIT.split(1.25).expect("in range"));
        assert_eq!(a, b);
    }

    /// Lanes hold the words of [`Scale::split`] exactly, for terms of either sign across the
    /// range (down to subnormal ones), many of them (the raw-bit offsets wrap many times),
    /// and refuse what `split` refuses.
    #[test]
    fn lanes_add_the_words_of_split() {
        for exponent in [-60, -20, 0, 7, 900] {
            let scale = Scale::of_exponent(exponent);
            let top = 0.99 * scale.max_term();
            let mut lanes = LaneSums::<4>::ZERO;
            let mut each = [FixedSum::ZERO; 4];
            let mut x = [top, -0.37 * top, 3e-300, -top * 1e-19];
            for _ in 0..3000 {
                assert!(scale.add_lanes(&x, &mut lanes));
                for (acc, &v) in each.iter_mut().zip(&x) {
                    acc.add_split(scale.split(v).expect("in range"));
                }
                x = [-0.5 * x[1], x[0] * 0.999, -x[2], x[3] * 1.01];
            }
            for (l, acc) in each.iter().enumerate() {
                assert_eq!(lanes.lane(l), *acc, "lane {l}, exponent {exponent}");
            }
            let mut refused = LaneSums::<4>::ZERO;
            assert!(!scale.add_lanes(&[0.0, scale.max_term(), 0.0, 0.0], &mut refused));
            let mut refused = LaneSums::<4>::ZERO;
            assert!(!scale.add_lanes(&[f64::NAN, 0.0, 0.0, 0.0], &mut refused));
            let mut refused = LaneSums::<4>::ZERO;
            assert!(!scale.add_lanes(&[0.0, 0.0, f64::NEG_INFINITY, 0.0], &mut refused));
            let mut refused = LaneSums::<4>::ZERO;
            assert!(!scale.add_lanes(&[0.0, 0.0, 0.0, -scale.max_term()], &mut refused));
            let mut kept = LaneSums::<4>::ZERO;
            let below = scale.max_term() * (1.0 - f64::EPSILON);
            assert!(kept.representable() && scale.add_lanes(&[below, -below, 0.0, 0.0], &mut kept));
        }
    }
}
