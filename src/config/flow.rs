//! Homogeneous-flow scenes: particles that carry dumbbell ensembles under an imposed velocity
//! gradient κ(t), the same for every particle (no fluid solver, no positions). A case file is
//! such a scene when it has a `[flow]` table; it then has `[polymer]` instead of `[box]`,
//! `[particles]` and `[fluid]`:
//!
//! ```toml
//! dimension = 3
//! [flow]
//! kind = "simple_shear"      # rest | simple_shear | shear_reversal | planar_elongation | uniaxial_elongation
//! rate = 1.0                 # γ̇ or ε̇
//! particles = 600            # particles carrying an ensemble each
//! [polymer]
//! kind = "dumbbells"
//! spring = "hookean"         # or "fene" with b
//! relaxation_time = 1.0      # λ
//! per_particle = 1000        # N_d
//! [integrator]
//! kind = "brownian_dynamics"
//! dt = 0.01
//! [run]
//! steps = 2000
//! ```
//!
//! `kind = "bddfs"` keeps, instead of each particle's connectors, their histogram on a grid of
//! `cells` per axis over [−q_max, q_max]^D (BDDFS, [`crate::models::bddfs`]).

use super::spans::{Segment, SpanIndex};
use super::{CaseError, OutputCfg, ReferenceCfg, RunCfg};
use crate::models::bddfs::QGrid;
pub use crate::models::dumbbell_settings::{
    Precision, SchemeKind, SpringKind, scheme_or_default, spring_law, validate_ensemble,
};
use crate::models::dumbbells::{DumbbellParams, Scheme, Spring};
use crate::models::homogeneous_flow::Flow;
use serde::{Deserialize, Serialize};

/// A homogeneous-flow scene.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FlowCase {
    /// Free-text title.
    #[serde(default)]
    pub title: String,
    /// 2 or 3.
    pub dimension: usize,
    /// Seed of every random number of the run.
    #[serde(default = "super::default_seed")]
    pub seed: u64,
    /// The imposed flow.
    pub flow: FlowCfg,
    /// The ensembles the particles carry.
    pub polymer: PolymerCfg,
    /// Time step.
    pub integrator: BrownianIntegratorCfg,
    /// Run length and sampling.
    pub run: RunCfg,
    /// Error estimates.
    #[serde(default)]
    pub diagnostics: FlowDiagnosticsCfg,
    /// Checkpoints (no snapshots: the particles have no positions).
    #[serde(default)]
    pub output: OutputCfg,
    /// Known answers the run checks itself against.
    #[serde(default)]
    pub reference: Vec<ReferenceCfg>,
}

/// Imposed homogeneous flows (κ_αβ = ∂v_α/∂x_β).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum FlowKind {
    /// κ = 0.
    Rest,
    /// κ_xy = γ̇.
    SimpleShear,
    /// κ_xy = γ̇, then −γ̇ from `reverse_at` on.
    ShearReversal,
    /// κ = diag(ε̇, −ε̇, 0).
    PlanarElongation,
    /// κ = diag(ε̇, −ε̇/2, −ε̇/2) (3D).
    UniaxialElongation,
}

/// `[flow]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FlowCfg {
    /// Which flow.
    pub kind: FlowKind,
    /// γ̇ (shear) or ε̇ (elongation); 0 at rest.
    #[serde(default)]
    pub rate: f64,
    /// Time of the reversal (shear_reversal only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reverse_at: Option<f64>,
    /// Particles, each carrying an ensemble.
    pub particles: u64,
}

/// Model of the ensembles.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PolymerKind {
    /// Brownian dumbbells (CONNFFESSIT).
    Dumbbells,
    /// Brownian dumbbells regenerated every step from a stored histogram (BDDFS).
    Bddfs,
}

/// `[polymer]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PolymerCfg {
    /// Model.
    pub kind: PolymerKind,
    /// Spring law.
    pub spring: SpringKind,
    /// FENE extensibility b = H Q₀²/k_BT.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b: Option<f64>,
    /// Relaxation time λ = ζ/(4H).
    pub relaxation_time: f64,
    /// Modulus G = n k_BT (stresses are reported in its units × G).
    #[serde(default = "super::one")]
    pub modulus: f64,
    /// Dumbbells per particle N_d.
    pub per_particle: usize,
    /// Scheme; default Heun (Hookean) or semi-implicit (FENE).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scheme: Option<SchemeKind>,
    /// Control variates (an equilibrium copy of each ensemble driven by the same noise).
    #[serde(default)]
    pub variance_reduction: bool,
    /// Storage precision of Q.
    #[serde(default)]
    pub precision: Precision,
    /// BDDFS: cells per axis n_c of the histogram grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cells: Option<usize>,
    /// BDDFS: half-edge Q_max of the grid [−Q_max, Q_max]^D (FENE: default √b).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_max: Option<f64>,
}

/// Integrators of a homogeneous-flow scene.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum BrownianKind {
    /// Brownian dynamics of the connectors (scheme in `polymer.scheme`).
    BrownianDynamics,
}

/// `[integrator]` of a homogeneous-flow scene.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BrownianIntegratorCfg {
    /// Kind.
    pub kind: BrownianKind,
    /// Time step Δt.
    pub dt: f64,
}

/// `[diagnostics]` of a homogeneous-flow scene.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FlowDiagnosticsCfg {
    /// Number of blocks for the block-averaged standard errors.
    #[serde(default = "super::default_blocks")]
    pub blocks: usize,
}

impl Default for FlowDiagnosticsCfg {
    fn default() -> Self {
        Self {
            blocks: super::default_blocks(),
        }
    }
}

/// The flow's largest compressive rate c ≥ 0 (minus the most negative eigenvalue of κ): 0 in
/// shear (κ is nilpotent), ε̇ in planar and ε̇/2 in uniaxial elongation.
pub fn compressive_rate(f: &FlowCfg) -> f64 {
    match f.kind {
        FlowKind::Rest | FlowKind::SimpleShear | FlowKind::ShearReversal => 0.0,
        FlowKind::PlanarElongation => f.rate.abs(),
        FlowKind::UniaxialElongation => {
            if f.rate >= 0.0 {
                0.5 * f.rate
            } else {
                -f.rate
            }
        }
    }
}

/// The share of the explicit schemes' linear stability bound that `check` accepts.
pub const EXPLICIT_STABILITY_MARGIN: f64 = 0.95;

/// The largest stable Δt of the explicit schemes (Euler–Maruyama, Heun) for Hookean springs,
/// None for the semi-implicit scheme (stable at any Δt). Along an eigen-direction of κ with
/// eigenvalue μ the mean connector follows Q' = (1 + zΔt) Q (Euler) or
/// (1 + zΔt + (zΔt)²/2) Q (Heun), z = μ − 1/(2λ); both are bounded iff −2 < zΔt < 0 for the
/// decaying directions, i.e. Δt < 2/(1/(2λ) + c) = 4λ/(1 + 2λc), c the largest compressive
/// rate. (A stretching direction with μ > 1/(2λ), elongation at Wi > ½, grows in the model
/// itself, not by the scheme.) The limit returned keeps a margin of 5 %
/// ([`EXPLICIT_STABILITY_MARGIN`]): near the bound the stationary variance of the scheme grows
/// as 1/(1 − |R|²), and in shear the coupling Q_x ← γ̇Δt Q_y amplifies it further, so a
/// Heun run at 0.987 × 4λ already carries connectors 10⁴ times their physical size (measured
/// with `mesorheo stability`, docs/validation.md), which the blow-up detector stops.
pub fn explicit_stability_limit(case: &FlowCase) -> Option<f64> {
    let p = &case.polymer;
    match p.scheme_or_default() {
        Scheme::SemiImplicit => None,
        Scheme::EulerMaruyama | Scheme::Heun => {
            let lambda = p.relaxation_time;
            Some(
                EXPLICIT_STABILITY_MARGIN * 4.0 * lambda
                    / (1.0 + 2.0 * lambda * compressive_rate(&case.flow)),
            )
        }
    }
}

/// What a time step costs in accuracy (warnings printed by `check` and logged by `run`; the
/// error itself is measured by `mesorheo study`): Δt > λ/2 leaves the relaxation unresolved
/// (the weak error is O(Δt/λ) or O((Δt/λ)²) long before), and |κ|Δt > 0.5 deforms a dumbbell by
/// more than half its length per step.
pub fn accuracy_warnings(case: &FlowCase) -> Vec<String> {
    let mut out = Vec::new();
    let dt = case.integrator.dt;
    let lambda = case.polymer.relaxation_time;
    if dt > 0.5 * lambda {
        out.push(format!(
            "Δt = {dt} is more than λ/2 = {}: the relaxation is not resolved (use Δt ≤ λ/10, or \
             measure the bias with mesorheo study)",
            0.5 * lambda
        ));
    }
    let fastest = case.flow.rate.abs();
    if fastest * dt > 0.5 {
        out.push(format!(
            "rate × Δt = {:.3} > 0.5: the flow deforms a dumbbell by more than half its length \
             per step (use Δt ≤ {:.3e})",
            fastest * dt,
            0.1 / fastest
        ));
    }
    out
}

impl PolymerCfg {
    /// The spring law.
    pub fn spring_law(&self) -> Spring {
        spring_law(self.spring, self.b)
    }

    /// The scheme, with its default.
    pub fn scheme_or_default(&self) -> Scheme {
        scheme_or_default(self.scheme, self.spring)
    }

    /// The BDDFS histogram grid (`kind = "bddfs"`; Q_max defaults to √b for FENE), None for
    /// explicit dumbbells.
    pub fn histogram_grid(&self) -> Option<QGrid> {
        (self.kind == PolymerKind::Bddfs).then(|| QGrid {
            cells: self.cells.unwrap_or(0),
            q_max: self.q_max.or(self.b.map(f64::sqrt)).unwrap_or(f64::NAN),
        })
    }

    /// The `check` lines of the ensembles' storage at time step `dt`: for BDDFS its grid, the
    /// grid's artificial diffusion and the memory per particle
    /// ([`crate::models::bddfs::check_lines`]); none for explicit connectors.
    pub fn storage_check_lines(&self, dimension: usize, dt: f64) -> Vec<String> {
        self.histogram_grid().map_or_else(Vec::new, |grid| {
            crate::models::bddfs::check_lines(
                &grid,
                self.per_particle,
                dimension,
                dt,
                self.relaxation_time,
            )
        })
    }

    /// Bytes per particle for the connector vectors (and the control copy); BDDFS: the bound
    /// 8 × min(N_d, n_c^D) of its sparse histogram.
    pub fn bytes_per_particle(&self, dimension: usize) -> f64 {
        if let Some(grid) = self.histogram_grid() {
            return crate::models::bddfs::histogram_bytes_bound(
                &grid,
                self.per_particle,
                dimension,
            );
        }
        let word = match self.precision {
            Precision::Double => 8.0,
            Precision::Single => 4.0,
        };
        let copies = if self.variance_reduction { 2.0 } else { 1.0 };
        self.per_particle as f64 * dimension as f64 * word * copies
    }
}

impl FlowCase {
    /// The flow as the model sees it.
    pub fn flow_model(&self) -> Flow {
        let rate = self.flow.rate;
        match self.flow.kind {
            FlowKind::Rest => Flow::Rest,
            FlowKind::SimpleShear => Flow::SimpleShear { rate },
            FlowKind::ShearReversal => Flow::ShearReversal {
                rate,
                at: self.flow.reverse_at.unwrap_or(f64::INFINITY),
            },
            FlowKind::PlanarElongation => Flow::PlanarElongation { rate },
            FlowKind::UniaxialElongation => Flow::UniaxialElongation { rate },
        }
    }

    /// Model parameters.
    pub fn dumbbell_params(&self) -> DumbbellParams {
        DumbbellParams {
            spring: self.polymer.spring_law(),
            scheme: self.polymer.scheme_or_default(),
            lambda: self.polymer.relaxation_time,
            dt: self.integrator.dt,
        }
    }

    /// Time step.
    pub fn dt(&self) -> f64 {
        self.integrator.dt
    }

    /// Names of the scalar observables this scene records (what `[[reference]]` may name).
    pub fn scalar_names(&self) -> Vec<String> {
        let d = self.dimension;
        let mut names: Vec<String> = super::observables::tensor_components(d)
            .into_iter()
            .map(|(_, _, n)| format!("polymer_stress_{n}"))
            .collect();
        names.push("first_normal_stress_difference".into());
        if d == 3 {
            names.push("second_normal_stress_difference".into());
        }
        match self.flow.kind {
            FlowKind::SimpleShear | FlowKind::ShearReversal => {
                names.push("polymer_viscosity".into());
                names.push("first_normal_stress_coefficient".into());
                if d == 3 {
                    names.push("second_normal_stress_coefficient".into());
                }
            }
            FlowKind::PlanarElongation | FlowKind::UniaxialElongation => {
                names.push("extensional_viscosity".into());
            }
            FlowKind::Rest => {}
        }
        names.push("mean_square_connector_length".into());
        names.push("max_connector_length".into());
        if self.polymer.kind == PolymerKind::Bddfs {
            names.push("occupied_histogram_cells".into());
        }
        names.sort();
        names
    }
}

fn k(s: &str) -> Segment {
    Segment::Key(s.to_owned())
}

/// Value checks of a homogeneous-flow scene; the first failure is reported.
pub fn validate(case: &FlowCase, ix: &SpanIndex) -> Result<(), CaseError> {
    let err = |keys: &[&str], msg: String| -> Result<(), CaseError> {
        Err(ix.error(&keys.iter().map(|s| k(s)).collect::<Vec<_>>(), msg))
    };
    let dim = case.dimension;
    if dim != 2 && dim != 3 {
        return err(
            &["dimension"],
            format!("found {dim}; valid values are 2 and 3"),
        );
    }
    // [flow]
    let f = &case.flow;
    if !f.rate.is_finite() {
        return err(
            &["flow", "rate"],
            format!("found {}; must be a finite number", f.rate),
        );
    }
    match f.kind {
        FlowKind::Rest if f.rate != 0.0 => {
            return err(
                &["flow", "rate"],
                format!(
                    "found {} for kind = \"rest\"; a fluid at rest has rate 0 (leave it out)",
                    f.rate
                ),
            );
        }
        FlowKind::Rest => {}
        _ if f.rate == 0.0 => {
            return err(
                &["flow", "rate"],
                "missing or 0: give the shear rate γ̇ or elongation rate ε̇ (≠ 0), or use \
                 kind = \"rest\""
                    .into(),
            );
        }
        _ => {}
    }
    if f.kind == FlowKind::UniaxialElongation && dim != 3 {
        return err(
            &["flow", "kind"],
            "uniaxial elongation needs a 3-dimensional case; in 2D use \"planar_elongation\""
                .into(),
        );
    }
    match (f.kind, f.reverse_at) {
        (FlowKind::ShearReversal, None) => {
            return err(
                &["flow", "reverse_at"],
                "missing: a shear reversal needs the time of the reversal (> 0)".into(),
            );
        }
        (FlowKind::ShearReversal, Some(t)) if !(t.is_finite() && t > 0.0) => {
            return err(&["flow", "reverse_at"], format!("found {t}; must be > 0"));
        }
        (k, Some(_)) if k != FlowKind::ShearReversal => {
            return err(
                &["flow", "reverse_at"],
                "only kind = \"shear_reversal\" has a reversal time; remove this key".into(),
            );
        }
        _ => {}
    }
    if f.particles < 2 {
        return err(
            &["flow", "particles"],
            format!(
                "found {}; at least 2 particles are needed (the error bar comes from their spread)",
                f.particles
            ),
        );
    }
    if f.particles > super::validate::MAX_PARTICLES {
        return err(
            &["flow", "particles"],
            format!(
                "found {}; at most {} (32-bit ids key the random numbers)",
                f.particles,
                super::validate::MAX_PARTICLES
            ),
        );
    }
    // [polymer]
    let p = &case.polymer;
    let pk = |key: &str| vec![k("polymer"), k(key)];
    if !(p.relaxation_time.is_finite() && p.relaxation_time > 0.0) {
        return Err(ix.error(
            &pk("relaxation_time"),
            format!("found {}; λ must be > 0", p.relaxation_time),
        ));
    }
    if !(p.modulus.is_finite() && p.modulus > 0.0) {
        return Err(ix.error(
            &pk("modulus"),
            format!("found {}; G = n k_BT must be > 0", p.modulus),
        ));
    }
    validate_ensemble(&[k("polymer")], p.per_particle, p.spring, p.b, p.scheme, ix)?;
    validate_histogram_grid(p, dim, ix)?;
    if p.variance_reduction && p.precision == Precision::Single {
        return Err(ix.error(
            &pk("variance_reduction"),
            "control variates need both copies to see identical arithmetic; they are \
             available in double precision only (set precision = \"double\")",
        ));
    }
    // [integrator]
    let dt = case.integrator.dt;
    if !(dt.is_finite() && dt > 0.0) {
        return err(&["integrator", "dt"], format!("found {dt}; must be > 0"));
    }
    // Stability is refused (unless the case asks to run beyond the limits, for a stability
    // study); accuracy is warned about (`accuracy_warnings`) and measured by `mesorheo study`.
    if let Some(limit) = explicit_stability_limit(case)
        && dt >= limit
        && !case.run.beyond_stability_limits
    {
        return err(
            &["integrator", "dt"],
            format!(
                "Δt = {dt} is beyond the stability limit 0.95 × 4λ/(1 + 2λc) = {limit:.4} of \
                 the explicit scheme (c = {:.4}, the flow's largest compressive rate): the \
                 connectors grow without bound; use Δt ≤ λ/10 for accuracy, or scheme = \
                 \"semi_implicit\", which is stable at any Δt",
                compressive_rate(&case.flow)
            ),
        );
    }
    // [run]
    super::validate::validate_run(&case.run, case.diagnostics.blocks, ix)?;
    // [output]
    let o = &case.output;
    if o.checkpoint_keep == 0 {
        return err(
            &["output", "checkpoint_keep"],
            "found 0; keep at least 1 checkpoint (a restart needs one)".to_owned(),
        );
    }
    if o.snapshot_every > 0 || o.snapshot_fields != OutputCfg::default().snapshot_fields {
        return err(
            &["output", "snapshot_every"],
            "a homogeneous-flow scene has no particle positions to snapshot; its stress time \
             series is written to OUT/polymer_stress.csv. Remove snapshot_every and \
             snapshot_fields"
                .to_owned(),
        );
    }
    // [[reference]]
    let scalars = case.scalar_names();
    for (i, rf) in case.reference.iter().enumerate() {
        let at = |key: &str| vec![k("reference"), Segment::Index(i), k(key)];
        match rf {
            ReferenceCfg::Value(v) => {
                super::validate::validate_value_reference(v, i, &scalars, "scene", ix)?;
            }
            ReferenceCfg::LinearShearProfile(_)
            | ReferenceCfg::StartupProfile(_)
            | ReferenceCfg::DoublePoiseuilleProfile(_)
            | ReferenceCfg::DoublePoiseuilleStress(_) => {
                return Err(ix.error(
                    &at("kind"),
                    "a homogeneous-flow scene has no velocity profile; use kind = \"value\"",
                ));
            }
        }
    }
    Ok(())
}

/// The BDDFS keys of `[polymer]`: `cells` and `q_max` only with `kind = "bddfs"`, where `cells`
/// is required, `q_max` is required for Hookean springs (the grid clips their unbounded
/// connectors) and defaults to √b for FENE, and the storage options of explicit connectors
/// (`precision`, `variance_reduction`) do not apply.
fn validate_histogram_grid(p: &PolymerCfg, dim: usize, ix: &SpanIndex) -> Result<(), CaseError> {
    let pk = |key: &str| vec![k("polymer"), k(key)];
    let Some(grid) = p.histogram_grid() else {
        for (key, given) in [("cells", p.cells.is_some()), ("q_max", p.q_max.is_some())] {
            if given {
                return Err(ix.error(
                    &pk(key),
                    format!(
                        "only kind = \"bddfs\" has a histogram grid; remove {key} or use \
                         kind = \"bddfs\""
                    ),
                ));
            }
        }
        return Ok(());
    };
    crate::models::dumbbell_settings::validate_histogram_grid(
        &[k("polymer")],
        &grid,
        (p.cells.is_some(), p.q_max.is_some()),
        p.spring,
        p.spring_law(),
        dim,
        ix,
    )?;
    if p.precision == Precision::Single {
        return Err(ix.error(
            &pk("precision"),
            "BDDFS stores histograms, not connectors: remove precision (it applies to \
             kind = \"dumbbells\")",
        ));
    }
    if p.variance_reduction {
        return Err(ix.error(
            &pk("variance_reduction"),
            "BDDFS regenerates its dumbbells every step, so no equilibrium copy can share their \
             noise: remove variance_reduction (it applies to kind = \"dumbbells\")",
        ));
    }
    Ok(())
}
