//! `summary.json` and the self-validation of stock scenes against their `[[reference]]`.

use crate::config::{Case, Metric, ReferenceCfg, ValueReference};
use crate::diagnostics::Estimate;
use serde::Serialize;
use std::collections::BTreeMap;

/// One reference check.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Validation {
    /// Name from the case.
    pub name: String,
    /// What was compared, e.g. "relative_error(temperature)".
    pub metric: String,
    /// The measured metric.
    pub value: f64,
    /// The largest acceptable metric.
    pub tolerance: f64,
    /// Whether value ≤ tolerance.
    pub pass: bool,
    /// A start-up profile check's bins at its time: [y, u_x, u_exact] each (empty otherwise).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub profile: Vec<[f64; 3]>,
}

/// A point of the velocity profile.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ProfilePoint {
    /// Bin centre along y.
    pub y: f64,
    /// ⟨u_x⟩ in the bin.
    pub mean: f64,
    /// Standard error.
    pub stderr: f64,
    /// γ̇ (y − L_y/2).
    pub expected: f64,
}

/// A point of the density profile.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct DensityPoint {
    /// Bin centre along y.
    pub y: f64,
    /// ⟨ρ⟩ of the fluid particles in the bin.
    pub mean: f64,
    /// Standard error.
    pub stderr: f64,
}

/// A point of the colloid–solvent RDF.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct RdfPoint {
    /// Bin centre r.
    pub r: f64,
    /// ⟨g⟩ in the bin.
    pub mean: f64,
    /// Standard error.
    pub stderr: f64,
}

/// One segment of a run: the first run, or one restart.
#[derive(Clone, Debug, Serialize, serde::Deserialize, PartialEq)]
pub struct Segment {
    /// The case file (first segment) or the checkpoint (a restart) it started from.
    pub started_from: String,
    /// The step it started at.
    pub first_step: u64,
    /// The step it reached.
    pub last_step: u64,
    /// Ranks.
    pub ranks: usize,
    /// Threads per rank.
    pub threads: usize,
    /// Its wall time (set-up, stepping, output).
    pub wall_seconds: f64,
    /// Its wall time of the time-stepping loop only.
    pub loop_seconds: f64,
}

/// The segments of the run that wrote the summary `path` (an earlier segment of the run a
/// restart continues); none when there is no readable summary. A summary written before
/// segments were recorded gives its one run as the first segment, when it was not itself a
/// restart.
pub fn earlier_segments(path: &std::path::Path) -> Vec<Segment> {
    let Some(v) = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
    else {
        return Vec::new();
    };
    if let Some(list) = v.get("segments") {
        return serde_json::from_value(list.clone()).unwrap_or_default();
    }
    if v.get("restarted_from").is_some() {
        return Vec::new();
    }
    let number = |k: &str| v.get(k).and_then(serde_json::Value::as_f64);
    let count = |k: &str| v.get(k).and_then(serde_json::Value::as_u64);
    match (
        v.get("case_file").and_then(serde_json::Value::as_str),
        count("steps"),
    ) {
        (Some(case_file), Some(steps)) => vec![Segment {
            started_from: case_file.to_owned(),
            first_step: 0,
            last_step: steps,
            ranks: count("ranks").unwrap_or(0) as usize,
            threads: count("threads").unwrap_or(0) as usize,
            wall_seconds: number("wall_seconds").unwrap_or(0.0),
            loop_seconds: number("loop_seconds").unwrap_or(0.0),
        }],
        _ => Vec::new(),
    }
}

/// The run summary (the README documents every field).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// mesorheo version.
    pub version: String,
    /// Echo of the case with defaults filled in.
    pub case: serde_json::Value,
    /// The case file the run started from (after restarts, still the first segment's; a
    /// restart's checkpoint when the run directory held no earlier summary).
    pub case_file: String,
    /// The first run and every restart, in order; `wall_seconds` and `loop_seconds` are the
    /// last segment's.
    pub segments: Vec<Segment>,
    /// Wall time of all segments together.
    pub total_wall_seconds: f64,
    /// Ranks.
    pub ranks: usize,
    /// Threads per rank.
    pub threads: usize,
    /// 2 or 3.
    pub dimension: usize,
    /// Particles in the system.
    pub particles: u64,
    /// Step reached (counted from the start of the run, across restarts).
    pub steps: u64,
    /// Whether the run reached its last step (false: stopped by --until-step or a signal).
    pub completed: bool,
    /// Checkpoint this run continued from.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub restarted_from: Option<String>,
    /// Newest checkpoint written.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub last_checkpoint: Option<String>,
    /// Simulated time at the end.
    pub time: f64,
    /// Wall time of this segment (set-up, stepping, output).
    pub wall_seconds: f64,
    /// Wall time of this segment's time-stepping loop only.
    pub loop_seconds: f64,
    /// particles × (steps run in this segment) / loop_seconds.
    pub particle_steps_per_second: f64,
    /// dumbbells × (steps run in this session) / loop_seconds (scenes with ensembles).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dumbbell_steps_per_second: Option<f64>,
    /// Bytes of ensemble storage per particle that carries one, at the end of the run:
    /// N_d × D × 8 for double-precision connectors, 8 per occupied cell for BDDFS histograms
    /// (particle scenes with ensembles).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub ensemble_bytes_per_particle: Option<f64>,
    /// Peak resident memory of the largest rank's process, MiB (VmHWM; absent where /proc is
    /// missing). In-process ranks (tests) share one process, so there it is the whole run's.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub peak_memory_mib: Option<f64>,
    /// Time averages over the steady window.
    pub observables: BTreeMap<String, Estimate>,
    /// Binned mean velocity u_x(y) (sheared runs that ask for it).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub velocity_profile: Vec<ProfilePoint>,
    /// Binned mean SPH density ρ(y) (runs that ask for `density_profile`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub density_profile: Vec<DensityPoint>,
    /// Binned shear stress τ_xy(y) (runs that ask for `shear_stress_profile`); `expected` is
    /// the reverse-Poiseuille stress of a case driven by a reverse body force, else null.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub shear_stress_profile: Vec<ProfilePoint>,
    /// The solvent's g(r) about the colloids' cloud centres (runs that ask for
    /// `colloid_solvent_rdf`); its exclusion radius is the observable
    /// `colloid_exclusion_radius`.
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub colloid_solvent_rdf: Vec<RdfPoint>,
    /// Reference checks.
    pub validation: Vec<Validation>,
    /// Caveats on the results (e.g. block error bars of correlated series that are too small).
    #[serde(skip_serializing_if = "Vec::is_empty", default)]
    pub warnings: Vec<String>,
    /// Hash of the final state in global-id order.
    pub state_digest: String,
    /// Every rank's phase times, their mean and the largest over the ranks (runs on more than
    /// one rank): the spread between the two is load imbalance.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub phase_seconds_over_ranks: Option<PhaseSpread>,
    /// Owned particles, ghosts and listed pairs per rank at the end: mean and largest over
    /// the ranks (particle scenes).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub load: Option<Load>,
    /// Rank 0's wall time per phase of the loop, seconds.
    pub phase_seconds: crate::sim::PhaseTimes,
}

/// The mean and the largest of a per-rank quantity.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct MeanMax {
    pub mean: f64,
    pub max: f64,
}

/// Per-rank counts at the end of a run.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Load {
    pub owned: MeanMax,
    pub ghosts: MeanMax,
    pub pairs: MeanMax,
}

/// Phase times over the ranks.
#[derive(Clone, Debug, Serialize)]
pub struct PhaseSpread {
    pub mean: crate::sim::PhaseTimes,
    pub max: crate::sim::PhaseTimes,
}

/// The instantaneous binned profiles u_x(y) of a run, by step (what a start-up reference reads).
#[derive(Clone, Copy, Debug)]
pub struct ProfileSeries<'a> {
    /// Sampled steps.
    pub steps: &'a [u64],
    /// The profile at each sampled step.
    pub profiles: &'a [Vec<f64>],
    /// Time step.
    pub dt: f64,
}

/// Evaluates a start-up reference: one check per listed time, max_b |u_b − u(y_b, t)| / scale.
fn check_startup(
    case: &Case,
    r: &crate::config::StartupProfileReference,
    series: Option<ProfileSeries<'_>>,
) -> Vec<Validation> {
    use crate::analytic::{
        OldroydB, StartupFlow, couette, couette_oldroyd_b, poiseuille, poiseuille_oldroyd_b,
        relaxation,
    };
    let (Some(s), Some(w)) = (case.fluid.model().continuum(), &case.walls) else {
        return Vec::new();
    };
    let body_force = case.fluid.model().body_force().x();
    let l = case.domain.lengths[w.axis.index()];
    let nu = s.solvent_viscosity / s.density;
    let first = |v: &[f64]| v.first().copied().unwrap_or(0.0);
    let oldroyd_b = s.polymer.as_ref().map(|poly| OldroydB {
        density: s.density,
        solvent_viscosity: s.solvent_viscosity,
        polymer_viscosity: poly.viscosity,
        relaxation_time: poly.relaxation_time,
    });
    let (u_at, scale): (Box<dyn Fn(f64, f64) -> f64>, f64) = match r.solution {
        StartupFlow::Couette => {
            let u = first(&w.upper_velocity);
            match oldroyd_b {
                // With a polymer, the Oldroyd-B start-up: exact for the upper-convected model
                // in unidirectional flow, O(De²) for the corotational one.
                Some(fluid) => (
                    Box::new(move |y, t| couette_oldroyd_b(y, t, l, u, &fluid)),
                    u.abs(),
                ),
                None => (Box::new(move |y, t| couette(y, t, l, u, nu)), u.abs()),
            }
        }
        StartupFlow::Poiseuille => {
            let f = body_force;
            match oldroyd_b {
                // Oldroyd-B (UCM, Hookean dumbbells): the scale is the steady centre velocity
                // or, while a slow fluid's plug overshoots it, the largest velocity reached.
                Some(fluid) => {
                    let nu0 = (fluid.solvent_viscosity + fluid.polymer_viscosity) / fluid.density;
                    let u = move |y, t| poiseuille_oldroyd_b(y, t, l, f, &fluid);
                    let t_max = r.times.iter().copied().fold(0.0, f64::max);
                    let peak = u(0.5 * l, t_max).abs();
                    (Box::new(u), (f * l * l / (8.0 * nu0)).abs().max(peak))
                }
                None => (
                    Box::new(move |y, t| poiseuille(y, t, l, f, nu)),
                    (f * l * l / (8.0 * nu)).abs(),
                ),
            }
        }
        StartupFlow::ViscoelasticRelaxation => {
            let a = case.particles.velocity_amplitude;
            let (rho, eta_s) = (s.density, s.solvent_viscosity);
            let polymer = s.polymer.as_ref().map(|p| (p.viscosity, p.relaxation_time));
            (
                Box::new(move |y, t| {
                    relaxation(t, a, l, rho, eta_s, polymer) * (std::f64::consts::PI * y / l).sin()
                }),
                a.abs(),
            )
        }
    };
    r.times
        .iter()
        .map(|&t| {
            let step = (t / case.integrator.dt()).round() as u64;
            let profile = series.and_then(|s| {
                s.steps
                    .iter()
                    .position(|&k| k == step)
                    .and_then(|k| s.profiles.get(k))
            });
            let value = match profile {
                Some(p) if !p.is_empty() => {
                    let bins = p.len();
                    let wanted = |b: usize| {
                        r.positions.is_empty()
                            || r.positions.iter().any(|&y| {
                                ((y / l * bins as f64).floor().max(0.0) as usize).min(bins - 1) == b
                            })
                    };
                    let deviations =
                        p.iter()
                            .enumerate()
                            .filter(|(b, _)| wanted(*b))
                            .map(|(b, &u)| {
                                let y = (b as f64 + 0.5) * l / bins as f64;
                                (u - u_at(y, t)).abs() / scale
                            });
                    nan_propagating_max(deviations)
                }
                _ => f64::NAN,
            };
            let bins = profile.map_or(0, Vec::len);
            Validation {
                name: format!("{} at t = {t}", r.name),
                metric: "max_bin |u_x − u_exact(y, t)| / scale".into(),
                value,
                tolerance: r.tolerance,
                pass: value <= r.tolerance,
                profile: profile
                    .into_iter()
                    .flatten()
                    .enumerate()
                    .map(|(b, &u)| {
                        let y = (b as f64 + 0.5) * l / bins as f64;
                        [y, u, u_at(y, t)]
                    })
                    .collect(),
            }
        })
        .collect()
}

/// Evaluates the case's references (`series`: the instantaneous profiles, for start-up
/// references; a run that did not keep them fails those).
pub fn check_references(
    case: &Case,
    observables: &BTreeMap<String, Estimate>,
    profile: &[ProfilePoint],
    series: Option<ProfileSeries<'_>>,
) -> Vec<Validation> {
    case.reference
        .iter()
        .flat_map(|r| match r {
            ReferenceCfg::StartupProfile(sp) => check_startup(case, sp, series),
            other => vec![check_one(case, other, observables, profile)],
        })
        .collect()
}

fn check_one(
    case: &Case,
    r: &ReferenceCfg,
    observables: &BTreeMap<String, Estimate>,
    profile: &[ProfilePoint],
) -> Validation {
    {
        match r {
            ReferenceCfg::StartupProfile(_) => unreachable!("handled by the caller"),
            ReferenceCfg::Value(v) => check_value(v, observables),
            ReferenceCfg::DoublePoiseuilleStress(ds) => {
                let points = shear_stress_points(case, observables);
                let tau_max = double_poiseuille_tau_max(case);
                let value = max_profile_deviation(&points, tau_max);
                Validation {
                    name: ds.name.clone(),
                    metric: "max_bin |τ_xy − τ_exact| / τ_max (reverse Poiseuille, τ_max = ρ g \
                             L_y/4)"
                        .into(),
                    value,
                    tolerance: ds.tolerance,
                    pass: value <= ds.tolerance,
                    profile: Vec::new(),
                }
            }
            ReferenceCfg::DoublePoiseuilleProfile(dp) => {
                let (_, u_max) = double_poiseuille_of(case, dp);
                // The expected bin values (the solution plus the box-mean velocity) are the
                // report's (see `double_poiseuille_expected`).
                let value = max_profile_deviation(profile, u_max);
                Validation {
                    name: dp.name.clone(),
                    metric: "max_bin |u_x − ū − u_exact| / u_max (reverse Poiseuille; ū the box \
                             mean)"
                        .into(),
                    value,
                    tolerance: dp.tolerance,
                    pass: value <= dp.tolerance,
                    profile: Vec::new(),
                }
            }
            ReferenceCfg::LinearShearProfile(p) => {
                let scale = (case.domain.shear_rate * case.domain.lengths[1]).abs();
                let value = max_profile_deviation(profile, scale);
                Validation {
                    name: p.name.clone(),
                    metric: "max_bin |u_x − γ̇(y − L_y/2)| / (γ̇ L_y)".into(),
                    value,
                    tolerance: p.tolerance,
                    pass: value <= p.tolerance,
                    profile: Vec::new(),
                }
            }
        }
    }
}

/// max_b |u_b − expected_b| / scale over the profile's bins; NaN for an empty profile or when
/// any bin is NaN, so that such a profile fails (f64::max would skip a NaN bin).
fn max_profile_deviation(profile: &[ProfilePoint], scale: f64) -> f64 {
    if profile.is_empty() {
        return f64::NAN;
    }
    nan_propagating_max(
        profile
            .iter()
            .map(|pt| (pt.mean - pt.expected).abs() / scale),
    )
}

/// The largest of non-negative deviations (0 for none), NaN as soon as one is NaN.
fn nan_propagating_max(deviations: impl Iterator<Item = f64>) -> f64 {
    deviations.fold(0.0, |m: f64, d| {
        if m.is_nan() || d.is_nan() {
            f64::NAN
        } else {
            m.max(d)
        }
    })
}

/// Compares one observable's time average with its reference value.
pub fn check_value(v: &ValueReference, observables: &BTreeMap<String, Estimate>) -> Validation {
    let got = observables.get(&v.observable).map_or(f64::NAN, |e| e.mean);
    let (metric, value) = match v.metric {
        Metric::RelativeError => (
            format!("relative_error({})", v.observable),
            ((got - v.value) / v.value).abs(),
        ),
        Metric::AbsoluteError => (
            format!("absolute_error({})", v.observable),
            (got - v.value).abs(),
        ),
    };
    Validation {
        name: v.name.clone(),
        metric,
        value,
        tolerance: v.tolerance,
        pass: value <= v.tolerance,
        profile: Vec::new(),
    }
}

/// Human-readable end-of-run report.
pub fn render(summary: &Summary) -> String {
    let mut s = String::new();
    let (first, segments) = (
        summary.segments.last().map_or(0, |g| g.first_step),
        summary.segments.len(),
    );
    s.push_str(&format!(
        "{} particles × {} steps on {} rank(s) × {} thread(s): {:.3} s loop, {:.3e} particle-steps/s\n",
        summary.particles,
        summary.steps - first,
        summary.ranks,
        summary.threads,
        summary.loop_seconds,
        summary.particle_steps_per_second
    ));
    if segments > 1 {
        s.push_str(&format!(
            "  steps {first} → {} in this restart; the run: {} steps in {segments} segments, \
             {:.1} s wall in all (summary.json `segments`)\n",
            summary.steps, summary.steps, summary.total_wall_seconds
        ));
    }
    if let Some(r) = summary.dumbbell_steps_per_second {
        s.push_str(&format!(
            "  {r:.3e} dumbbell-steps/s ({:.3e} per thread)\n",
            r / (summary.ranks * summary.threads).max(1) as f64
        ));
    }
    if let Some(b) = summary.ensemble_bytes_per_particle {
        s.push_str(&format!(
            "  ensemble storage: {b:.1} B per carrying particle at the end of the run\n"
        ));
    }
    for (k, e) in &summary.observables {
        s.push_str(&format!(
            "  {k:<40} {:>14.6} ± {:<10.3e} ({} samples)\n",
            e.mean, e.stderr, e.samples
        ));
    }
    for v in &summary.validation {
        s.push_str(&format!(
            "  [{}] {}: {} = {:.4e} (tolerance {:.4e})\n",
            if v.pass { "PASS" } else { "FAIL" },
            v.name,
            v.metric,
            v.value,
            v.tolerance
        ));
    }
    for w in &summary.warnings {
        s.push_str(&format!("  warning: {w}\n"));
    }
    if !summary.completed {
        s.push_str(&format!(
            "  stopped at step {} before the end of the run; continue with `mesorheo restart {}`\n",
            summary.steps,
            summary
                .last_checkpoint
                .as_deref()
                .unwrap_or("OUT/checkpoints")
        ));
    }
    s.push_str(&format!("  state digest {}\n", summary.state_digest));
    s
}

/// The expected bins of a reverse-Poiseuille profile with bin means `means` (`bins` equal bins
/// across L_y): the solution's bin mean plus the box-mean velocity ū = mean of the bins. In a
/// periodic box the centre-of-mass velocity is not pinned: the net force m g (N_upper −
/// N_lower) fluctuates with the particle counts of the two halves, so the mean velocity
/// random-walks, and the solution holds in the frame moving with it.
pub fn double_poiseuille_expected(
    case: &Case,
    r: &crate::config::DoublePoiseuilleReference,
    means: &[f64],
) -> Vec<f64> {
    let (exact, _) = double_poiseuille_of(case, r);
    let bins = means.len().max(1) as f64;
    let offset = means.iter().sum::<f64>() / bins;
    let width = case.domain.lengths[1] / bins;
    (0..means.len())
        .map(|b| exact(b as f64 * width, (b + 1) as f64 * width) + offset)
        .collect()
}

/// The binned shear stress of a run that asked for `shear_stress_profile` (its per-bin series
/// in `observables`), each bin with the reverse-Poiseuille stress's bin mean when the case is
/// driven by a reverse body force along x, else NaN.
pub fn shear_stress_points(
    case: &Case,
    observables: &BTreeMap<String, Estimate>,
) -> Vec<ProfilePoint> {
    use crate::diagnostics::SHEAR_STRESS_PROFILE_PREFIX;
    let bins: Vec<&Estimate> = observables
        .iter()
        .filter(|(k, _)| k.starts_with(SHEAR_STRESS_PROFILE_PREFIX))
        .map(|(_, e)| e)
        .collect();
    let ly = case.domain.lengths[1];
    let width = ly / bins.len().max(1) as f64;
    let rho = case.particles.density * case.particles.mass;
    let force = case.fluid.model().body_force();
    let g = force.reverse.then(|| force.x());
    bins.iter()
        .enumerate()
        .map(|(b, e)| {
            let (y0, y1) = (b as f64 * width, (b + 1) as f64 * width);
            ProfilePoint {
                y: 0.5 * (y0 + y1),
                mean: e.mean,
                stderr: e.stderr,
                expected: g.map_or(f64::NAN, |g| {
                    crate::analytic::double_poiseuille_stress_mean(y0, y1, ly, rho, g)
                }),
            }
        })
        .collect()
}

/// τ_max = |ρ g L_y/4| of a case driven by a reverse body force along x.
fn double_poiseuille_tau_max(case: &Case) -> f64 {
    (case.particles.density * case.particles.mass * body_force_x(case) * case.domain.lengths[1]
        / 4.0)
        .abs()
}

/// g_x of the fluid's body force (0 without one).
fn body_force_x(case: &Case) -> f64 {
    case.fluid.model().body_force().x()
}

/// The steady reverse-Poiseuille solution of a case with a `double_poiseuille_profile`
/// reference: the mean of u_x over [y0, y1], and u_max = ρ g L_y²/(32η).
pub fn double_poiseuille_of(
    case: &Case,
    r: &crate::config::DoublePoiseuilleReference,
) -> (impl Fn(f64, f64) -> f64, f64) {
    let g = body_force_x(case);
    let eta = r
        .viscosity
        .or(case.fluid.model().target_viscosity())
        .unwrap_or(f64::NAN);
    let rho = case.particles.density * case.particles.mass;
    let ly = case.domain.lengths[1];
    let u_max = (rho * g * ly * ly / (32.0 * eta)).abs();
    (
        move |y0: f64, y1: f64| crate::analytic::double_poiseuille_mean(y0, y1, ly, rho, g, eta),
        u_max,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The profile reference of `cases/dpd_shear_2d.toml` fails on a NaN bin, wherever it is.
    #[test]
    fn a_nan_bin_fails_the_profile_reference() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/dpd_shear_2d.toml");
        let case = crate::config::load(&path).expect("stock case").case;
        let ly = case.domain.lengths[1];
        let bins = 10;
        let exact: Vec<ProfilePoint> = (0..bins)
            .map(|b| {
                let y = (b as f64 + 0.5) * ly / bins as f64;
                let u = case.domain.shear_rate * (y - 0.5 * ly);
                ProfilePoint {
                    y,
                    mean: u,
                    stderr: 0.0,
                    expected: u,
                }
            })
            .collect();
        let profile_check = |profile: &[ProfilePoint]| {
            check_references(&case, &BTreeMap::new(), profile, None)
                .into_iter()
                .find(|v| v.metric.starts_with("max_bin"))
                .expect("the case has a profile reference")
        };
        assert!(profile_check(&exact).pass);
        for at in [0, 4, bins - 1] {
            let mut bad = exact.clone();
            bad[at].mean = f64::NAN;
            let v = profile_check(&bad);
            assert!(!v.pass && v.value.is_nan(), "NaN in bin {at}: {v:?}");
        }
    }
}
