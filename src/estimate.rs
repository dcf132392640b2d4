//! Block estimates of time averages: a mean (or any statistic of a series) with the standard
//! error s_B / √n_B from the spread over equal blocks.
//!
//! A leaf module (it uses nothing of the crate), so that models, rigid bodies and diagnostics
//! can all share one block-error routine without a dependency cycle
//! (`tools/module_graph.py --check`).

/// Mean, standard error and sample count of a time series.
#[derive(Clone, Copy, Debug, serde::Serialize, PartialEq)]
pub struct Estimate {
    /// Time average.
    pub mean: f64,
    /// Block-averaged standard error of the mean.
    pub stderr: f64,
    /// Number of samples.
    pub samples: usize,
}

/// Block average: the series is cut into `blocks` equal blocks (dropping the oldest remainder)
/// and the standard error is the spread of the block means, s_B / √n_B.
pub fn block_average(series: &[f64], blocks: usize) -> Estimate {
    let mean_over = |r: std::ops::Range<usize>| {
        let len = r.len() as f64;
        series[r].iter().sum::<f64>() / len
    };
    block_estimate(series.len(), blocks, mean_over)
}

/// The block estimate of a statistic of a series of `n` samples: `statistic(0..n)` with the
/// standard error s_B / √n_B of `statistic` over `blocks` equal blocks (the oldest remainder
/// dropped). [`block_average`] is it for the mean; a statistic that is not linear in the samples
/// (the exclusion radius of a g(r), [`crate::rigid_bodies::rdf::exclusion_estimate`]) is read
/// from each block's samples. Fewer than two blocks give no error bar (NaN).
pub fn block_estimate(
    n: usize,
    blocks: usize,
    statistic: impl Fn(std::ops::Range<usize>) -> f64,
) -> Estimate {
    if n == 0 {
        return Estimate {
            mean: f64::NAN,
            stderr: f64::NAN,
            samples: 0,
        };
    }
    let mean = statistic(0..n);
    let nb = blocks.min(n);
    let size = n / nb.max(1);
    if nb < 2 || size == 0 {
        return Estimate {
            mean,
            stderr: f64::NAN,
            samples: n,
        };
    }
    let start = n - nb * size;
    let values: Vec<f64> = (0..nb)
        .map(|k| statistic(start + k * size..start + (k + 1) * size))
        .collect();
    let bm = values.iter().sum::<f64>() / nb as f64;
    let var = values.iter().map(|v| (v - bm) * (v - bm)).sum::<f64>() / (nb - 1) as f64;
    Estimate {
        mean,
        stderr: (var / nb as f64).sqrt(),
        samples: n,
    }
}
