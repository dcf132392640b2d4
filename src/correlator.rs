//! The multiple-tau correlator (Ramírez, Sukumaran, Vorselaars & Likhtman, J. Chem. Phys. 133,
//! 154103 (2010)): time autocorrelations C(τ) = ⟨x(t)·x(t + τ)⟩ of a vector signal, summed over
//! its channels, at every lag τ = 0 … p − 1 samples exactly and at geometrically spaced longer
//! lags from block averages, in O(p log T) memory and O(p) work per sample.
//!
//! Level 0 keeps the last p samples and accumulates x(t)·x(t − j) for j = 0 … p − 1. Level
//! k ≥ 1 receives the average of m consecutive values of level k − 1 (resolution m^k samples),
//! keeps its last p, and accumulates only the lags j = p/m … p − 1 (τ = j m^k): the shorter ones
//! are already resolved more finely below. At long lags the correlation of block averages
//! stands for the correlation of the signal, which is exact when C varies little over m^k
//! samples (the multiple-tau approximation; the Green–Kubo integrals here take the level-0 lags
//! exactly, where C varies fastest).
//!
//! Everything is a deterministic function of the sample sequence (plain sums in a fixed order),
//! so identical inputs on every rank give bitwise identical correlators, and the state
//! ([`MultipleTauCorrelator::state`]) restores a run exactly.

/// Lags per level of [`MultipleTauCorrelator::reaching`].
pub const STANDARD_POINTS: usize = 16;
/// Values averaged into one of the next level in [`MultipleTauCorrelator::reaching`].
pub const STANDARD_AVERAGING: usize = 2;

/// A multiple-tau autocorrelator of a signal with `channels` components.
#[derive(Clone, Debug, PartialEq)]
pub struct MultipleTauCorrelator {
    points: usize,
    averaging: usize,
    channels: usize,
    levels: Vec<Level>,
}

#[derive(Clone, Debug, PartialEq)]
struct Level {
    /// The last `points` values, row `(head − j) mod points` holds the value j samples ago.
    history: Vec<f64>,
    /// Values received so far (saturates the history at `points`).
    filled: usize,
    /// Row of the newest value.
    head: usize,
    /// Running sum of the values not yet passed on, and how many.
    pending: Vec<f64>,
    pending_count: usize,
    /// Σ x(t)·x(t − j) over the channels, and the number of products, per lag index j.
    sums: Vec<f64>,
    counts: Vec<u64>,
}

impl Level {
    fn new(points: usize, channels: usize) -> Self {
        Self {
            history: vec![0.0; points * channels],
            filled: 0,
            head: points - 1,
            pending: vec![0.0; channels],
            pending_count: 0,
            sums: vec![0.0; points],
            counts: vec![0; points],
        }
    }
}

impl MultipleTauCorrelator {
    /// `points` lags per level (p, a multiple of `averaging`), `averaging` values averaged into
    /// one of the next level (m ≥ 2), `levels` levels: the longest lag is (p − 1) m^(levels−1)
    /// samples.
    pub fn new(points: usize, averaging: usize, levels: usize, channels: usize) -> Self {
        assert!(averaging >= 2 && points >= averaging && points.is_multiple_of(averaging));
        assert!(levels >= 1 && channels >= 1);
        Self {
            points,
            averaging,
            channels,
            levels: (0..levels).map(|_| Level::new(points, channels)).collect(),
        }
    }

    /// The shape the viscosity estimators use ([`STANDARD_POINTS`] lags per level, pairs
    /// averaged) with the fewest levels that reach `lag` samples.
    pub fn reaching(lag: f64, channels: usize) -> Self {
        let levels = Self::levels_for(STANDARD_POINTS, STANDARD_AVERAGING, lag);
        Self::new(STANDARD_POINTS, STANDARD_AVERAGING, levels, channels)
    }

    /// The fewest levels whose longest lag reaches `lag` samples.
    pub fn levels_for(points: usize, averaging: usize, lag: f64) -> usize {
        let mut levels = 1;
        let mut reach = (points - 1) as f64;
        while reach < lag {
            levels += 1;
            reach *= averaging as f64;
        }
        levels
    }

    /// Adds the next sample (`channels` values).
    pub fn add(&mut self, x: &[f64]) {
        assert_eq!(x.len(), self.channels);
        self.add_at(0, x);
    }

    fn add_at(&mut self, k: usize, x: &[f64]) {
        let (p, m, c) = (self.points, self.averaging, self.channels);
        let passed: Option<Vec<f64>> = {
            let level = &mut self.levels[k];
            level.head = (level.head + 1) % p;
            let row = level.head * c;
            level.history[row..row + c].copy_from_slice(x);
            level.filled = (level.filled + 1).min(p);
            let first = if k == 0 { 0 } else { p / m };
            for j in first..level.filled {
                let other = ((level.head + p - j) % p) * c;
                let product: f64 = (0..c).map(|i| x[i] * level.history[other + i]).sum();
                level.sums[j] += product;
                level.counts[j] += 1;
            }
            for (acc, v) in level.pending.iter_mut().zip(x) {
                *acc += v;
            }
            level.pending_count += 1;
            if level.pending_count == m {
                let mean: Vec<f64> = level.pending.iter().map(|s| s / m as f64).collect();
                level.pending.fill(0.0);
                level.pending_count = 0;
                Some(mean)
            } else {
                None
            }
        };
        if let Some(mean) = passed
            && k + 1 < self.levels.len()
        {
            self.add_at(k + 1, &mean);
        }
    }

    /// The estimated correlation, (lag in samples, Σ_channels ⟨x(t)·x(t + τ)⟩, products
    /// averaged), in increasing lag order; lags with no product yet are left out.
    pub fn correlation(&self) -> Vec<(f64, f64)> {
        let (p, m) = (self.points, self.averaging);
        let mut out = Vec::new();
        let mut resolution = 1.0;
        for (k, level) in self.levels.iter().enumerate() {
            let first = if k == 0 { 0 } else { p / m };
            for j in first..p {
                if level.counts[j] > 0 {
                    out.push((
                        j as f64 * resolution,
                        level.sums[j] / level.counts[j] as f64,
                    ));
                }
            }
            resolution *= m as f64;
        }
        out
    }

    /// The whole state as numbers (for checkpoints): see [`Self::from_state`].
    pub fn state(&self) -> (Vec<f64>, Vec<u64>) {
        let mut reals = Vec::new();
        let mut counts = vec![
            self.points as u64,
            self.averaging as u64,
            self.levels.len() as u64,
            self.channels as u64,
        ];
        for level in &self.levels {
            reals.extend(&level.history);
            reals.extend(&level.pending);
            reals.extend(&level.sums);
            counts.extend([
                level.filled as u64,
                level.head as u64,
                level.pending_count as u64,
            ]);
            counts.extend(&level.counts);
        }
        (reals, counts)
    }

    /// The correlator [`Self::state`] returned; `None` when the numbers do not form one.
    pub fn from_state(reals: &[f64], counts: &[u64]) -> Option<Self> {
        let header = counts.get(..4)?;
        let [p, m, levels, c] = [0, 1, 2, 3].map(|i| header[i] as usize);
        if m < 2 || p < m || !p.is_multiple_of(m) || levels == 0 || c == 0 {
            return None;
        }
        let (per_real, per_count) = (p * c + c + p, 3 + p);
        if reals.len() != levels * per_real || counts.len() != 4 + levels * per_count {
            return None;
        }
        let mut out = Self::new(p, m, levels, c);
        for (k, level) in out.levels.iter_mut().enumerate() {
            let r = &reals[k * per_real..(k + 1) * per_real];
            level.history.copy_from_slice(&r[..p * c]);
            level.pending.copy_from_slice(&r[p * c..p * c + c]);
            level.sums.copy_from_slice(&r[p * c + c..]);
            let n = &counts[4 + k * per_count..4 + (k + 1) * per_count];
            let [filled, head, pending] = [0, 1, 2].map(|i| n[i] as usize);
            if filled > p || head >= p || pending >= m {
                return None;
            }
            (level.filled, level.head, level.pending_count) = (filled, head, pending);
            level.counts.copy_from_slice(&n[3..]);
        }
        Some(out)
    }
}

/// ∫₀^τ_max C dτ by the trapezoid rule over the given (τ, C) points (increasing τ), the last
/// panel cut at τ_max (C linear in between).
pub fn trapezoid_integral(points: &[(f64, f64)], tau_max: f64) -> f64 {
    let mut total = 0.0;
    for w in points.windows(2) {
        let ((t0, c0), (t1, c1)) = (w[0], w[1]);
        if t0 >= tau_max {
            break;
        }
        if t1 <= tau_max {
            total += 0.5 * (c0 + c1) * (t1 - t0);
        } else {
            let c_cut = c0 + (c1 - c0) * (tau_max - t0) / (t1 - t0);
            total += 0.5 * (c0 + c_cut) * (tau_max - t0);
        }
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic AR(1) signal x_{n+1} = a x_n + noise, two channels.
    fn signal(n: usize) -> Vec<[f64; 2]> {
        let mut state = 0x9e37_79b9_7f4a_7c15_u64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut x = [0.0; 2];
        (0..n)
            .map(|_| {
                x = [0.9 * x[0] + uniform(), 0.7 * x[1] + uniform()];
                x
            })
            .collect()
    }

    #[test]
    fn level_zero_lags_equal_the_direct_correlation_to_rounding() {
        let xs = signal(5000);
        let mut c = MultipleTauCorrelator::new(16, 2, 6, 2);
        for x in &xs {
            c.add(x);
        }
        let corr = c.correlation();
        for j in 0..16 {
            let direct: f64 = (j..xs.len())
                .map(|t| xs[t][0] * xs[t - j][0] + xs[t][1] * xs[t - j][1])
                .sum::<f64>()
                / (xs.len() - j) as f64;
            let (lag, got) = corr[j];
            assert_eq!(lag, j as f64);
            assert!((got - direct).abs() < 1e-12 * direct.abs().max(1e-3), "{j}");
        }
    }

    #[test]
    fn higher_levels_correlate_block_averages_at_their_lags() {
        // Level 1 at lag j (2j samples) is the mean of ȳ(s)·ȳ(s − j) over the pair averages
        // ȳ(s) = (x(2s) + x(2s + 1))/2.
        let xs = signal(4001);
        let mut c = MultipleTauCorrelator::new(8, 2, 2, 2);
        for x in &xs {
            c.add(x);
        }
        let ys: Vec<[f64; 2]> = xs
            .chunks_exact(2)
            .map(|w| [(w[0][0] + w[1][0]) / 2.0, (w[0][1] + w[1][1]) / 2.0])
            .collect();
        let corr = c.correlation();
        assert_eq!(corr.len(), 8 + 4);
        for (k, j) in (4..8).enumerate() {
            let direct: f64 = (j..ys.len())
                .map(|s| ys[s][0] * ys[s - j][0] + ys[s][1] * ys[s - j][1])
                .sum::<f64>()
                / (ys.len() - j) as f64;
            let (lag, got) = corr[8 + k];
            assert_eq!(lag, 2.0 * j as f64);
            assert!((got - direct).abs() < 1e-12, "{j}: {got} vs {direct}");
        }
    }

    #[test]
    fn an_ar1_signal_has_its_exponential_correlation_at_long_lags() {
        // C(τ) = Σ_i a_i^τ σ²/(1 − a_i²), σ² = 1/12: the multiple-tau estimate at τ ≤ 60 within
        // the statistical error of 200 000 samples (~2 % of C(0)) and the block-average smoothing.
        let xs = signal(200_000);
        let mut c = MultipleTauCorrelator::new(16, 2, 4, 2);
        for x in &xs {
            c.add(x);
        }
        let exact = |t: f64| {
            [0.9_f64, 0.7]
                .iter()
                .map(|a| a.powf(t) / 12.0 / (1.0 - a * a))
                .sum::<f64>()
        };
        for (lag, got) in c.correlation() {
            if lag <= 60.0 {
                assert!(
                    (got - exact(lag)).abs() < 0.03 * exact(0.0),
                    "τ = {lag}: {got} vs {}",
                    exact(lag)
                );
            }
        }
    }

    #[test]
    fn a_restored_state_continues_bitwise() {
        let xs = signal(3000);
        let mut whole = MultipleTauCorrelator::new(16, 4, 3, 2);
        let mut first = whole.clone();
        for x in &xs {
            whole.add(x);
        }
        for x in &xs[..1234] {
            first.add(x);
        }
        let (reals, counts) = first.state();
        let mut resumed = MultipleTauCorrelator::from_state(&reals, &counts).expect("state");
        for x in &xs[1234..] {
            resumed.add(x);
        }
        assert_eq!(resumed, whole);
        assert!(MultipleTauCorrelator::from_state(&reals[1..], &counts).is_none());
    }

    #[test]
    fn the_trapezoid_integral_is_exact_for_a_linear_function_and_cuts_the_last_panel() {
        let points: Vec<(f64, f64)> = [0.0, 1.0, 2.0, 4.0, 8.0]
            .iter()
            .map(|&t| (t, 10.0 - t))
            .collect();
        assert_eq!(trapezoid_integral(&points, 8.0), 80.0 - 32.0);
        assert_eq!(trapezoid_integral(&points, 3.0), 30.0 - 4.5);
        assert_eq!(levels_check(), 4);
    }

    fn levels_check() -> usize {
        // (16 − 1)·2³ = 120 ≥ 100 > (16 − 1)·2² = 60.
        MultipleTauCorrelator::levels_for(16, 2, 100.0)
    }
}
