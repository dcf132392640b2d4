//! Exact, order-independent accumulation of f64 contributions in two-word fixed point.
//!
//! Determinism across rank and thread counts needs every per-particle sum to give the same bits
//! whatever order its terms arrive in. Floating-point addition is not associative; integer
//! addition is. Each term x is split exactly into
//!
//! ```text
//! y = x · 2^24,   h = trunc(y) (i64),   l = trunc((y − h) · 2^52) (i64, |l| < 2^52)
//! ```
//!
//! (y − h is exact: for |y| ≥ 1 by Sterbenz's lemma, for |y| < 1 because h = 0; truncation is a
//! single SSE2 instruction, unlike floor.)
//!
//! and the two words are summed as integers. The sum is exact down to 2^-76 ≈ 1.3·10⁻²³ per term
//! and the range is |Σ| < 2^39 ≈ 5·10¹¹ — far beyond the forces and virials of any stable run.
//! The final conversion rounds once. So the accumulated value is the exact sum correctly
//! rounded (up to the 2^-76 truncation per term), *more* accurate than sequential f64 addition,
//! and independent of the order of the terms, of the number of threads and of the
//! decomposition. Pair forces can therefore be scattered from half neighbour lists in any order.

/// Scale of the high word.
const HIGH_SHIFT: f64 = (1u64 << 24) as f64;
/// Scale of the low word relative to the high word.
const LOW_SHIFT: f64 = (1u64 << 52) as f64;

/// A fixed-point accumulator.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedSum {
    high: i64,
    low: i64,
}

impl FixedSum {
    /// Zero.
    pub const ZERO: Self = Self { high: 0, low: 0 };

    /// Adds `x` (|x| < 2^39).
    #[inline(always)]
    pub fn add(&mut self, x: f64) {
        let y = x * HIGH_SHIFT;
        let h = y as i64;
        let l = ((y - h as f64) * LOW_SHIFT) as i64;
        self.high = self.high.wrapping_add(h);
        self.low = self.low.wrapping_add(l);
    }

    /// Adds another accumulator.
    #[inline(always)]
    pub fn merge(&mut self, other: &Self) {
        self.high = self.high.wrapping_add(other.high);
        self.low = self.low.wrapping_add(other.low);
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
}
