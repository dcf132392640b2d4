//! The analysis of a study: each point's error against its reference, split into its
//! statistical and systematic parts, the Pareto front and the recommendation.

#[allow(unused_imports)]
use super::*;

/// One observable's error at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorParts {
    pub mean: f64,
    pub stderr: f64,
    /// |A − A*| (relative or absolute).
    pub error: f64,
    /// √(σ² + σ*²) on the same scale.
    pub statistical: f64,
    /// √(max(0, e² − s²)).
    pub systematic: f64,
}

/// The analysed study.
#[derive(Clone, Debug)]
pub struct Analysis {
    pub points: Vec<PointResult>,
    /// Per observable: the reference value and its standard error.
    pub references: Vec<(f64, f64)>,
    /// Per point (None unless done): per observable.
    pub errors: Vec<Option<Vec<ErrorParts>>>,
    /// Per point: core-seconds (NaN unless done).
    pub core_seconds: Vec<f64>,
    /// Per point: stored ensemble bytes per particle (NaN unless done and reported).
    pub bytes_per_particle: Vec<f64>,
    /// On the cost (core-seconds) / error front.
    pub pareto: Vec<bool>,
    /// On the memory (bytes per particle) / error front; all false when no point reports its
    /// memory.
    pub pareto_memory: Vec<bool>,
    /// The point serving as the reference (converged / Richardson), if any.
    pub reference_point: Option<usize>,
    /// Index of the recommended point.
    pub recommended: Option<usize>,
    pub target: Option<f64>,
    /// Human-readable recommendation.
    pub recommendation: String,
}

/// A completed point's values and its cost in core-seconds: the CPU seconds of its processes
/// where the study measured them, else (a record from before the measure) wall × `cores`.
fn done(p: &PointResult, cores: f64) -> Option<(&[(f64, f64)], f64)> {
    match &p.status {
        Status::Done {
            values,
            wall_seconds,
            cpu_seconds,
            ..
        } => Some((values, cpu_seconds.unwrap_or(wall_seconds * cores))),
        _ => None,
    }
}

/// The knobs along which point `i` is the cheapest completed point of its line (the points
/// that differ from it in that knob alone) while its value is the first or last one the sweep
/// lists: the recommendation may be limited by the sweep, not by the tolerance. Knobs with one
/// value, and categorical knobs (values that are not numbers), are not edges.
fn cheap_edges(
    sweep: &Sweep,
    results: &[PointResult],
    core_seconds: &[f64],
    i: usize,
) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (k, knob) in sweep.knobs.iter().enumerate() {
        let value = &results[i].knob_values[k];
        let at_end = knob.values.len() > 1
            && (knob.values.first() == Some(value) || knob.values.last() == Some(value));
        // A categorical knob (a scheme, a bundle of settings) has no "beyond its last value".
        let numeric = knob.values.iter().all(|v| v.trim().parse::<f64>().is_ok());
        if !at_end || !numeric {
            continue;
        }
        let line: Vec<usize> = (0..results.len())
            .filter(|&j| {
                j != i
                    && core_seconds[j].is_finite()
                    && (0..sweep.knobs.len())
                        .all(|m| m == k || results[j].knob_values[m] == results[i].knob_values[m])
            })
            .collect();
        if !line.is_empty() && line.iter().all(|&j| core_seconds[j] > core_seconds[i]) {
            out.push((knob.key.clone(), value.clone()));
        }
    }
    out
}

/// The points no other point beats on both cost and error (at most as costly and as wrong,
/// strictly better in one); points with a non-finite cost or error are off the front.
pub fn pareto_front(cost: &[f64], error: &[f64]) -> Vec<bool> {
    let ok = |i: usize| cost[i].is_finite() && error[i].is_finite();
    (0..cost.len())
        .map(|i| {
            ok(i)
                && !(0..cost.len()).any(|j| {
                    j != i
                        && ok(j)
                        && cost[j] <= cost[i]
                        && error[j] <= error[i]
                        && (cost[j] < cost[i] || error[j] < error[i])
                })
        })
        .collect()
}

/// Errors, Pareto front and recommendation from the points' results.
pub fn analyse(
    sweep: &Sweep,
    results: &[PointResult],
    target: Option<f64>,
) -> Result<Analysis, String> {
    let cores = (sweep.ranks * sweep.threads) as f64;
    let core_seconds: Vec<f64> = results
        .iter()
        .map(|p| done(p, cores).map_or(f64::NAN, |(_, cost)| cost))
        .collect();
    let most_expensive = (0..results.len())
        .filter(|&i| core_seconds[i].is_finite())
        .max_by(|&a, &b| core_seconds[a].total_cmp(&core_seconds[b]))
        .ok_or("no point of the sweep completed (all refused or unstable)")?;
    let mut reference_point = None;
    let mut references = Vec::new();
    for (k, o) in sweep.observables.iter().enumerate() {
        let r = match &o.reference {
            Reference::Value { value, stderr } => (*value, *stderr),
            Reference::Converged => {
                reference_point = Some(most_expensive);
                let (v, _) = done(&results[most_expensive], cores).expect("done");
                v[k]
            }
            Reference::Richardson { knob, order } => {
                richardson(sweep, results, most_expensive, k, knob, *order)?
            }
        };
        references.push(r);
    }
    let mut errors = Vec::new();
    for (i, p) in results.iter().enumerate() {
        errors.push(done(p, cores).map(|(values, _)| {
            values
                .iter()
                .zip(&references)
                .zip(&sweep.observables)
                .map(|((&(mean, stderr), &(r, rs)), o)| {
                    let scale = if o.relative { r.abs() } else { 1.0 };
                    let own = o.reference == Reference::Converged && Some(i) == reference_point;
                    let error = (mean - r).abs() / scale;
                    // The reference point against itself: no error, and the noise it shares
                    // with the reference cancels.
                    let statistical = if own {
                        0.0
                    } else {
                        (stderr * stderr + rs * rs).sqrt() / scale
                    };
                    ErrorParts {
                        mean,
                        stderr,
                        error,
                        statistical,
                        systematic: (error * error - statistical * statistical).max(0.0).sqrt(),
                    }
                })
                .collect()
        }));
    }
    let combined: Vec<f64> = errors
        .iter()
        .map(|e| {
            e.as_ref().map_or(f64::NAN, |e: &Vec<ErrorParts>| {
                e.iter().map(|p| p.error).fold(0.0, f64::max)
            })
        })
        .collect();
    let pareto = pareto_front(&core_seconds, &combined);
    let bytes_per_particle: Vec<f64> = results
        .iter()
        .map(|p| match &p.status {
            Status::Done {
                bytes_per_particle: Some(b),
                ..
            } => *b,
            _ => f64::NAN,
        })
        .collect();
    let pareto_memory = pareto_front(&bytes_per_particle, &combined);
    let recommended = target.and_then(|t| {
        (0..results.len())
            // The reference point's error against itself is 0 by construction: it is no
            // recommendation.
            .filter(|&i| Some(i) != reference_point)
            .filter(|&i| {
                errors[i]
                    .as_ref()
                    .is_some_and(|e| e.iter().all(|p| p.error + 2.0 * p.statistical <= t))
            })
            .min_by(|&a, &b| core_seconds[a].total_cmp(&core_seconds[b]))
    });
    let mut text = String::new();
    let names: Vec<&str> = sweep.knobs.iter().map(|k| k.key.as_str()).collect();
    let show = |i: usize| -> String {
        names
            .iter()
            .zip(&results[i].knob_values)
            .map(|(k, v)| format!("{k}={v}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let _ = writeln!(text, "study: {}", sweep.title);
    for (o, (r, rs)) in sweep.observables.iter().zip(&references) {
        let how = match &o.reference {
            Reference::Value { .. } => "given value".to_string(),
            Reference::Converged => format!("most expensive point ({})", show(most_expensive)),
            Reference::Richardson { knob, order } => {
                format!("Richardson extrapolation in {knob} (order {order})")
            }
        };
        let _ = writeln!(text, "reference {}: {r:.6} ± {rs:.2e} ({how})", o.name);
    }
    match (target, recommended) {
        (None, _) => {
            let _ = writeln!(
                text,
                "no target tolerance given (--target TOL): the Pareto front is marked in the CSV"
            );
        }
        (Some(t), Some(i)) => {
            let e = errors[i].as_ref().expect("done");
            let _ = writeln!(
                text,
                "recommended for a tolerance of {t}: {} — {:.1} core-s; {}",
                show(i),
                core_seconds[i],
                sweep
                    .observables
                    .iter()
                    .zip(e)
                    .map(|(o, p)| format!(
                        "{} error {:.3e} (statistical {:.1e}, systematic {:.1e})",
                        o.name, p.error, p.statistical, p.systematic
                    ))
                    .collect::<Vec<_>>()
                    .join("; ")
            );
        }
        (Some(t), None) => {
            let best = (0..results.len())
                .filter(|&i| combined[i].is_finite() && Some(i) != reference_point)
                .min_by(|&a, &b| combined[a].total_cmp(&combined[b]));
            let _ = writeln!(
                text,
                "no point meets a tolerance of {t} with 2σ to spare{}",
                best.map_or(String::new(), |b| format!(
                    "; the most accurate is {} with error {:.3e} ({:.1} core-s)",
                    show(b),
                    combined[b],
                    core_seconds[b]
                ))
            );
        }
    }
    if let Some(i) = recommended {
        for (key, value) in cheap_edges(sweep, results, &core_seconds, i) {
            let _ = writeln!(
                text,
                "warning: the recommendation sits at the edge of the sweep in {key} ({key}={value}, \
                 the cheapest value swept): a cheaper setting beyond it may meet the tolerance \
                 too; extend the sweep past {value} to find out"
            );
        }
    }
    // The memory knob: of the points that meet the tolerance as the recommendation must, the
    // one that stores the fewest bytes per particle (ties: the cheaper).
    if let Some(t) = target {
        let leanest = (0..results.len())
            .filter(|&i| Some(i) != reference_point && bytes_per_particle[i].is_finite())
            .filter(|&i| {
                errors[i]
                    .as_ref()
                    .is_some_and(|e| e.iter().all(|p| p.error + 2.0 * p.statistical <= t))
            })
            .min_by(|&a, &b| {
                bytes_per_particle[a]
                    .total_cmp(&bytes_per_particle[b])
                    .then(core_seconds[a].total_cmp(&core_seconds[b]))
            });
        if let Some(i) = leanest {
            let _ = writeln!(
                text,
                "least memory for a tolerance of {t}: {} — {:.0} B per particle, {:.1} core-s, \
                 error {:.3e}",
                show(i),
                bytes_per_particle[i],
                core_seconds[i],
                combined[i]
            );
        }
    }
    let unstable = results
        .iter()
        .filter(|p| matches!(p.status, Status::Unstable(_)))
        .count();
    let refused_n = results
        .iter()
        .filter(|p| matches!(p.status, Status::Refused(_)))
        .count();
    if unstable + refused_n > 0 {
        let _ = writeln!(
            text,
            "{unstable} point(s) blew up and {refused_n} were refused by the case validation \
             (see study.csv)"
        );
    }
    Ok(Analysis {
        points: results.to_vec(),
        references,
        errors,
        core_seconds,
        bytes_per_particle,
        pareto,
        pareto_memory,
        reference_point,
        recommended,
        target,
        recommendation: text,
    })
}

fn richardson(
    sweep: &Sweep,
    results: &[PointResult],
    most_expensive: usize,
    k: usize,
    knob: &str,
    order: f64,
) -> Result<(f64, f64), String> {
    let at = sweep
        .knobs
        .iter()
        .position(|kn| kn.key == knob)
        .expect("validated");
    let anchor = &results[most_expensive].knob_values;
    let mut line: Vec<(f64, f64, f64)> = results
        .iter()
        .filter(|p| {
            p.knob_values
                .iter()
                .enumerate()
                .all(|(j, v)| j == at || *v == anchor[j])
        })
        .filter_map(|p| {
            let h = p.knob_values[at].parse::<f64>().ok()?;
            let (v, _) = done(p, 1.0)?;
            Some((h, v[k].0, v[k].1))
        })
        .collect();
    line.sort_by(|a, b| a.0.total_cmp(&b.0));
    if line.len() < 2 || line[0].0 <= 0.0 || line[1].0 <= line[0].0 {
        return Err(format!(
            "Richardson extrapolation of {} in {knob}: fewer than two completed points with \
             distinct positive {knob} at the other knobs of the most expensive point",
            sweep.observables[k].name
        ));
    }
    let (h1, a1, s1) = line[0];
    let (h2, a2, s2) = line[1];
    let c = 1.0 / ((h2 / h1).powf(order) - 1.0);
    Ok((
        a1 + c * (a1 - a2),
        ((1.0 + c).powi(2) * s1 * s1 + c * c * s2 * s2).sqrt(),
    ))
}
