//! Case files: a TOML *scene* deserialised with serde, then validated.
//!
//! Every error names the file, line and column, the key path, what was found and what would be
//! valid; nothing panics and nothing runs on a bad case. The key reference in
//! `docs/case-reference.md` is generated from [`reference::keys`], and a test checks that the
//! table, the structs and the document agree.

pub use crate::models::dpd::physical as dpd_physical;
pub mod flow;
pub mod observables;
pub mod reference;
pub mod registry;
pub(crate) use crate::spans;
mod tagged;
mod validate;

use crate::geometry::Boundary;
pub use crate::integrators::groot_warren::{GrootWarrenCfg, Thermostat};
pub use crate::integrators::sph_schemes::{KickDriftKickCfg, TwoStageCfg};
pub use crate::models::dpd::DpdCfg;
pub use crate::models::sph::{InclusionsCfg, SphCfg, WallsCfg};
pub use crate::models::summation_gas::SummationGasCfg;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub use crate::geometry::{Axis, Lattice, VelocityProfile};
pub use crate::integrators::IntegratorCfg;
pub use crate::observable::Observable;
pub use flow::FlowCase;
pub use registry::FluidCfg;
pub use spans::{CaseError, Segment, SpanIndex};

/// A whole case file.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Case {
    /// Free-text title.
    #[serde(default)]
    pub title: String,
    /// 2 or 3.
    pub dimension: usize,
    /// Seed of every random number of the run.
    #[serde(default = "default_seed")]
    pub seed: u64,
    /// Box, boundaries and shear.
    #[serde(rename = "box")]
    pub domain: BoxCfg,
    /// Slab decomposition.
    #[serde(default)]
    pub decomposition: DecompositionCfg,
    /// Initial particles.
    pub particles: ParticlesCfg,
    /// The fluid model.
    pub fluid: FluidCfg,
    /// Time integration.
    pub integrator: IntegratorCfg,
    /// Boundary-particle walls (SPH channels).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub walls: Option<WallsCfg>,
    /// Rigid fixed inclusions filled with boundary particles (SPH).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub inclusions: Option<InclusionsCfg>,
    /// Neighbour lists.
    #[serde(default)]
    pub neighbour: NeighbourCfg,
    /// Run length and sampling.
    pub run: RunCfg,
    /// Observables.
    #[serde(default)]
    pub diagnostics: DiagnosticsCfg,
    /// Snapshots and checkpoints.
    #[serde(default)]
    pub output: OutputCfg,
    /// Known answers the run checks itself against.
    #[serde(default)]
    pub reference: Vec<ReferenceCfg>,
}

/// `[output]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct OutputCfg {
    /// Steps between checkpoints (0: none on schedule).
    #[serde(default)]
    pub checkpoint_every: u64,
    /// Checkpoints kept (older ones are deleted).
    #[serde(default = "three")]
    pub checkpoint_keep: usize,
    /// Whether the run writes a checkpoint when it ends (so it can be extended).
    #[serde(default = "yes")]
    pub checkpoint_at_end: bool,
    /// Steps between snapshots (0: none).
    #[serde(default)]
    pub snapshot_every: u64,
    /// Per-particle fields in the snapshots.
    #[serde(default = "default_snapshot_fields")]
    pub snapshot_fields: Vec<SnapshotField>,
}

fn three() -> usize {
    3
}
fn yes() -> bool {
    true
}
fn default_snapshot_fields() -> Vec<SnapshotField> {
    vec![
        SnapshotField::Position,
        SnapshotField::Velocity,
        SnapshotField::Image,
    ]
}

impl Default for OutputCfg {
    fn default() -> Self {
        Self {
            checkpoint_every: 0,
            checkpoint_keep: three(),
            checkpoint_at_end: true,
            snapshot_every: 0,
            snapshot_fields: default_snapshot_fields(),
        }
    }
}

/// Per-particle fields a snapshot can hold: the engine's (every case has them) and the names a
/// fluid model may provide ([`crate::models::fluid_model::FluidModel::snapshot_quantities`]
/// says which it does in a case, and its particle models give the values).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum SnapshotField {
    /// Positions.
    Position,
    /// Velocities.
    Velocity,
    /// Forces.
    Force,
    /// Periodic image counts.
    Image,
    /// Positions with the periodic crossings undone, r + n ∘ L.
    UnwrappedPosition,
    /// The species number of each particle (time-independent).
    Species,
    /// A model's density (SPH, generic_polymer).
    Density,
    /// A model's pressure (SPH: its equation of state at the particle's density).
    Pressure,
    /// A model's polymer stress τ (symmetric tensor).
    PolymerStress,
    /// A model's conformation ⟨QQ⟩ (symmetric tensor).
    Conformation,
}

impl SnapshotField {
    /// Every field, in the order of the enum.
    pub const ALL: [SnapshotField; 10] = [
        SnapshotField::Position,
        SnapshotField::Velocity,
        SnapshotField::Force,
        SnapshotField::Image,
        SnapshotField::UnwrappedPosition,
        SnapshotField::Species,
        SnapshotField::Density,
        SnapshotField::Pressure,
        SnapshotField::PolymerStress,
        SnapshotField::Conformation,
    ];

    /// Name of the H5MD element.
    pub fn name(self) -> &'static str {
        match self {
            SnapshotField::Position => "position",
            SnapshotField::Velocity => "velocity",
            SnapshotField::Force => "force",
            SnapshotField::Image => "image",
            SnapshotField::UnwrappedPosition => "unwrapped_position",
            SnapshotField::Species => "species",
            SnapshotField::Density => "density",
            SnapshotField::Pressure => "pressure",
            SnapshotField::PolymerStress => "polymer_stress",
            SnapshotField::Conformation => "conformation",
        }
    }

    /// Whether the engine writes it for every case (else a fluid model must provide it).
    pub fn is_engine_field(self) -> bool {
        matches!(
            self,
            SnapshotField::Position
                | SnapshotField::Velocity
                | SnapshotField::Force
                | SnapshotField::Image
                | SnapshotField::UnwrappedPosition
                | SnapshotField::Species
        )
    }
}

fn default_seed() -> u64 {
    1
}

/// `[box]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct BoxCfg {
    /// Edge lengths, one per dimension.
    pub lengths: Vec<f64>,
    /// Boundary per axis; default all periodic.
    #[serde(default)]
    pub boundaries: Option<Vec<Boundary>>,
    /// Lees–Edwards shear rate (flow x, gradient y).
    #[serde(default)]
    pub shear_rate: f64,
}

/// `[decomposition]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct DecompositionCfg {
    /// Slab axis.
    #[serde(default)]
    pub axis: Axis,
}

impl Lattice {
    /// Particles per lattice cell.
    pub fn basis(self, dimension: usize) -> usize {
        match (self, dimension) {
            (Lattice::Cubic | Lattice::Random, _) => 1,
            (Lattice::Fcc, 2) => 2,
            (Lattice::Fcc, _) => 4,
        }
    }
}

/// `[particles]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ParticlesCfg {
    /// Arrangement.
    pub lattice: Lattice,
    /// Number density.
    pub density: f64,
    /// Particle mass.
    #[serde(default = "one")]
    pub mass: f64,
    /// Initial temperature k_BT of the Maxwellian.
    pub temperature: f64,
    /// Initial mean velocity field.
    #[serde(default)]
    pub velocity_profile: VelocityProfile,
    /// Amplitude A of the "half_sine" profile.
    #[serde(default = "one")]
    pub velocity_amplitude: f64,
}

fn one() -> f64 {
    1.0
}

impl FluidCfg {
    /// Interaction range of the fluid's pair forces.
    pub fn cutoff(&self) -> f64 {
        self.model().cutoff()
    }
}

impl Case {
    /// Whether a DPD body force drives the flow (the velocity profile is then binned along y).
    pub fn body_forced(&self) -> bool {
        self.fluid.model().body_force().drives()
    }
}

/// `[neighbour]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct NeighbourCfg {
    /// Verlet skin.
    #[serde(default = "default_skin")]
    pub skin: f64,
}

fn default_skin() -> f64 {
    0.3
}

impl Default for NeighbourCfg {
    fn default() -> Self {
        Self {
            skin: default_skin(),
        }
    }
}

/// `[run]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RunCfg {
    /// Time steps.
    pub steps: u64,
    /// Steps discarded before averaging.
    #[serde(default)]
    pub equilibration: u64,
    /// Sampling interval in steps.
    #[serde(default = "ten")]
    pub sample_every: u64,
    /// Seconds between progress lines (0: none).
    #[serde(default = "ten_f")]
    pub progress_seconds: f64,
    /// Run a time step beyond the stability limits instead of refusing it (default false):
    /// for stability studies, which measure what the limits only estimate. `check` still marks
    /// the violated limit, and the run logs a warning.
    #[serde(default)]
    pub beyond_stability_limits: bool,
}

fn ten() -> u64 {
    10
}
fn ten_f() -> f64 {
    10.0
}

/// `[diagnostics]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DiagnosticsCfg {
    /// What to average.
    #[serde(default = "default_observables")]
    pub observables: Vec<Observable>,
    /// Bins along y for the velocity profile and the profile-unbiased temperature.
    #[serde(default = "ten_usize")]
    pub profile_bins: usize,
    /// Number of blocks for the block-averaged standard errors.
    #[serde(default = "default_blocks")]
    pub blocks: usize,
    /// Upper limit τ of the Green–Kubo integral (time units).
    #[serde(default = "default_green_kubo_time")]
    pub green_kubo_time: f64,
    /// Wavenumbers k_j = 2πj/L, j = 1 … this, of the transverse-current viscosity.
    #[serde(default = "default_transverse_current_modes")]
    pub transverse_current_modes: usize,
    /// Steps between two samples of the transverse currents.
    #[serde(default = "default_transverse_current_every")]
    pub transverse_current_every: u64,
    /// Longest lag of the transverse-current autocorrelation (time units).
    #[serde(default = "default_transverse_current_time")]
    pub transverse_current_time: f64,
    /// Bin width Δr of the colloid–solvent RDF.
    #[serde(default = "default_rdf_bin_width")]
    pub rdf_bin_width: f64,
    /// Outer radius of the colloid–solvent RDF (default half the smallest box edge).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rdf_range: Option<f64>,
}

impl DiagnosticsCfg {
    /// The outer radius of the colloid–solvent RDF: as given, or half the smallest of the box
    /// edges `lengths`.
    pub fn rdf_range(&self, lengths: &[f64]) -> f64 {
        self.rdf_range
            .unwrap_or_else(|| 0.5 * lengths.iter().copied().fold(f64::INFINITY, f64::min))
    }

    /// The number of bins of the colloid–solvent RDF in a box of edges `lengths`.
    pub fn rdf_bins(&self, lengths: &[f64]) -> usize {
        crate::rigid_bodies::rdf::bin_count(self.rdf_range(lengths), self.rdf_bin_width)
    }
}

fn default_rdf_bin_width() -> f64 {
    0.02
}

fn default_transverse_current_modes() -> usize {
    4
}
fn default_transverse_current_every() -> u64 {
    5
}
fn default_transverse_current_time() -> f64 {
    5.0
}

fn default_green_kubo_time() -> f64 {
    2.0
}

fn ten_usize() -> usize {
    10
}
fn default_blocks() -> usize {
    10
}
fn default_observables() -> Vec<Observable> {
    Observable::thermal_defaults()
}

impl Default for DiagnosticsCfg {
    fn default() -> Self {
        Self {
            observables: default_observables(),
            profile_bins: ten_usize(),
            blocks: default_blocks(),
            green_kubo_time: default_green_kubo_time(),
            transverse_current_modes: default_transverse_current_modes(),
            transverse_current_every: default_transverse_current_every(),
            transverse_current_time: default_transverse_current_time(),
            rdf_bin_width: default_rdf_bin_width(),
            rdf_range: None,
        }
    }
}

/// How a reference value is compared.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    /// |x − ref| / |ref|
    RelativeError,
    /// |x − ref|
    AbsoluteError,
}

/// `[[reference]]`: a known answer the run must reproduce.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ReferenceCfg {
    /// A published or analytic number for a scalar observable.
    Value(ValueReference),
    /// The linear profile u_x = γ̇ (y − L_y/2) through the Lees–Edwards plane.
    LinearShearProfile(ProfileReference),
    /// An analytic start-up profile u_x(y, t) of a channel, at given times.
    StartupProfile(StartupProfileReference),
    /// The steady reverse-Poiseuille profile of a DPD fluid driven by a `reverse` body force.
    DoublePoiseuilleProfile(DoublePoiseuilleReference),
    /// The shear-stress profile of the same flow, fixed by the momentum balance alone.
    DoublePoiseuilleStress(DoublePoiseuilleStressReference),
}

/// `[[reference]] kind = "double_poiseuille_stress"`: the time-averaged binned shear stress
/// τ_xy(y) (observable `shear_stress_profile`) of the steady reverse Poiseuille flow against the
/// momentum balance ∂τ_xy/∂y = −ρ g_x(y): τ_xy = ρ g (L_y/4 − |s|), s = y − L_y/2, whatever the
/// viscosity (each bin against the solution's mean over the bin); metric
/// max_b |τ_b − τ_b,exact| / τ_max, τ_max = ρ g L_y/4.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DoublePoiseuilleStressReference {
    /// Short name.
    pub name: String,
    /// Largest acceptable max_b |τ_b − τ_b,exact| / τ_max.
    pub tolerance: f64,
    /// Where the solution comes from.
    #[serde(default)]
    pub source: String,
}

/// `[[reference]] kind = "double_poiseuille_profile"`: the time-averaged binned u_x(y) against
/// the steady reverse Poiseuille flow of a periodic box, u_x = ρ g s (L_y/2 − |s|)/(2η),
/// s = y − L_y/2 (each bin against the solution's mean over the bin); metric
/// max_b |u_b − u_b,exact| / u_max, u_max = ρ g L_y²/(32η).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DoublePoiseuilleReference {
    /// Short name.
    pub name: String,
    /// Largest acceptable max_b |u_b − u_b,exact| / u_max.
    pub tolerance: f64,
    /// η of the solution (default: `fluid.physical.viscosity`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub viscosity: Option<f64>,
    /// Where the solution comes from.
    #[serde(default)]
    pub source: String,
}

/// `[[reference]] kind = "startup_profile"`: the binned u_x(y) at each listed time against an
/// analytic series solution ([`crate::analytic`]), with the walls at the faces of the wall
/// axis. One check per time, each max_b |u_b − u(y_b, t)| / scale.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StartupProfileReference {
    /// Short name.
    pub name: String,
    /// Which solution.
    pub solution: crate::analytic::StartupFlow,
    /// Times (each a multiple of the sampling interval Δt · run.sample_every).
    pub times: Vec<f64>,
    /// Largest acceptable max_b |u_b − u(y_b, t)| / scale at every time.
    pub tolerance: f64,
    /// Wall-normal coordinates whose bins alone are compared (default: every bin), e.g. the
    /// centre line.
    #[serde(default)]
    pub positions: Vec<f64>,
    /// Where the solution comes from.
    #[serde(default)]
    pub source: String,
}

/// `[[reference]] kind = "value"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ValueReference {
    /// Short name.
    pub name: String,
    /// Scalar observable (a name from summary.json `observables`).
    pub observable: String,
    /// Expected value.
    pub value: f64,
    /// Comparison.
    pub metric: Metric,
    /// Largest acceptable metric.
    pub tolerance: f64,
    /// Where the value comes from.
    #[serde(default)]
    pub source: String,
}

/// `[[reference]] kind = "linear_shear_profile"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ProfileReference {
    /// Short name.
    pub name: String,
    /// Largest acceptable max_b |u_b − γ̇ (y_b − L_y/2)| / (γ̇ L_y).
    pub tolerance: f64,
}

/// A parsed, validated case and where it came from.
#[derive(Clone, Debug)]
pub struct LoadedCase {
    /// The case.
    pub case: Case,
    /// The file.
    pub path: PathBuf,
    /// The original text.
    pub source: String,
}

/// What a case file describes.
#[derive(Clone, Debug, PartialEq)]
pub enum CaseScene {
    /// Particles in a box with a fluid model (DPD, …): the engine with halo, lists, shear.
    Particles(Box<Case>),
    /// Particles carrying dumbbell ensembles in an imposed homogeneous flow (a `[flow]` table).
    HomogeneousFlow(Box<FlowCase>),
}

impl CaseScene {
    /// Spatial dimension.
    pub fn dimension(&self) -> usize {
        match self {
            CaseScene::Particles(c) => c.dimension,
            CaseScene::HomogeneousFlow(c) => c.dimension,
        }
    }

    /// The time step and the run lengths.
    pub fn dt_and_run(&self) -> (f64, &RunCfg) {
        match self {
            CaseScene::Particles(c) => (c.integrator.dt(), &c.run),
            CaseScene::HomogeneousFlow(c) => (c.integrator.dt, &c.run),
        }
    }

    /// The scene as TOML (the echo stored in checkpoints and summaries).
    pub fn to_toml(&self) -> Result<String, String> {
        match self {
            CaseScene::Particles(c) => toml::to_string(c),
            CaseScene::HomogeneousFlow(c) => toml::to_string(c),
        }
        .map_err(|e| format!("cannot echo the case: {e}"))
    }
}

/// A parsed, validated case file of any kind of scene.
#[derive(Clone, Debug)]
pub struct LoadedScene {
    /// The scene.
    pub scene: CaseScene,
    /// The file.
    pub path: PathBuf,
    /// The (possibly overridden) text.
    pub source: String,
}

/// Reads, parses and validates a particle case file.
pub fn load(path: &Path) -> Result<LoadedCase, CaseError> {
    load_with_overrides(path, &[])
}

/// Reads a case file of any kind of scene, applies `--set` overrides, parses and validates it.
pub fn load_scene(path: &Path, overrides: &[String]) -> Result<LoadedScene, CaseError> {
    let (source, shown) = read_with_overrides(path, overrides)?;
    let scene = parse_scene(&source, &shown).map_err(|e| locate_override(e, path, overrides))?;
    Ok(LoadedScene {
        scene,
        path: path.to_path_buf(),
        source,
    })
}

/// Parses and validates case text of any kind of scene: a `[flow]` table makes it a
/// homogeneous-flow scene, otherwise it is a particle scene.
pub fn parse_scene(source: &str, path: &Path) -> Result<CaseScene, CaseError> {
    let index = spans::SpanIndex::new(source, path)?;
    let table: toml::Table = toml::from_str(source).map_err(|e| index.syntax_error(&e))?;
    if !table.contains_key("flow") {
        return parse(source, path).map(|c| CaseScene::Particles(Box::new(c)));
    }
    tagged::precheck_references(&table, &index)?;
    let de = toml::Deserializer::parse(source).map_err(|e| index.syntax_error(&e))?;
    let case: FlowCase = serde_path_to_error::deserialize(de).map_err(|e| {
        let mut err = index.serde_error(&e);
        if err.message.contains("unknown key") {
            err.message.push_str(
                " (this is a homogeneous-flow scene because it has a [flow] table; [box],                  [particles] and [fluid] belong to particle scenes)",
            );
        }
        err
    })?;
    flow::validate(&case, &index)?;
    Ok(CaseScene::HomogeneousFlow(Box::new(case)))
}

/// Reads a case file, applies `key.path=value` overrides (as `--set` on the command line gives
/// them; values are TOML literals, bare words are taken as strings), then parses and validates
/// the result, so an override is checked like any other key.
pub fn load_with_overrides(path: &Path, overrides: &[String]) -> Result<LoadedCase, CaseError> {
    let (source, shown) = read_with_overrides(path, overrides)?;
    let case = parse(&source, &shown).map_err(|e| locate_override(e, path, overrides))?;
    Ok(LoadedCase {
        case,
        path: path.to_path_buf(),
        source,
    })
}

/// The case text with `--set` overrides applied, and the name to show in messages.
fn read_with_overrides(path: &Path, overrides: &[String]) -> Result<(String, PathBuf), CaseError> {
    let bad = |message: String| CaseError {
        file: path.display().to_string(),
        line: 0,
        column: 0,
        key: String::new(),
        message,
    };
    let mut source = std::fs::read_to_string(path)
        .map_err(|e| bad(format!("cannot read the case file: {e}")))?;
    let mut shown = path.to_path_buf();
    if !overrides.is_empty() {
        source = apply_overrides(&source, overrides).map_err(bad)?;
        shown = PathBuf::from(format!("{} (with --set overrides)", path.display()));
    }
    Ok((source, shown))
}

/// An error found in the case text with `--set` overrides applied, pointed at what the user
/// wrote: at the override when the error's key is one it set (or lies under it), otherwise at
/// the key's line in the file as it is on disk (an override that adds a key shifts the lines
/// of the edited text, so those line numbers would mislead).
fn locate_override(mut err: CaseError, path: &Path, overrides: &[String]) -> CaseError {
    if overrides.is_empty() {
        return err;
    }
    let under = |key: &str| {
        err.key == key
            || (err.key.starts_with(key)
                && matches!(err.key.as_bytes().get(key.len()), Some(b'.') | Some(b'[')))
    };
    if let Some(o) = overrides
        .iter()
        .find(|o| o.split_once('=').is_some_and(|(k, _)| under(k.trim())))
    {
        err.file = format!("{} (--set {o})", path.display());
        err.line = 0;
        err.column = 0;
        return err;
    }
    err.file = path.display().to_string();
    let original = std::fs::read_to_string(path).unwrap_or_default();
    match spans::SpanIndex::new(&original, path) {
        Ok(index) if !err.key.is_empty() => {
            (err.line, err.column) = index.locate(&spans::parse_key_path(&err.key));
        }
        _ => {
            err.line = 0;
            err.column = 0;
        }
    }
    err
}

/// Case text with `key.path=value` overrides applied (what `--set` does; values are TOML
/// literals, bare words strings). A key the case schema does not know is then refused by the
/// parser like any other, so an edit never silently misses.
pub fn apply_overrides(source: &str, overrides: &[String]) -> Result<String, String> {
    let mut doc: toml_edit::DocumentMut = source
        .parse()
        .map_err(|e: toml_edit::TomlError| format!("invalid TOML: {}", e.message()))?;
    for o in overrides {
        apply_override(&mut doc, o).map_err(|m| format!("--set {o}: {m}"))?;
    }
    Ok(doc.to_string())
}

fn apply_override(doc: &mut toml_edit::DocumentMut, o: &str) -> Result<(), String> {
    let (key, value) = o
        .split_once('=')
        .ok_or("expected KEY=VALUE, e.g. integrator.dt=0.02")?;
    let value: toml_edit::Value = value
        .trim()
        .parse()
        .unwrap_or_else(|_| toml_edit::Value::from(value.trim()));
    let parts: Vec<&str> = key.trim().split('.').collect();
    let (last, parents) = parts.split_last().ok_or("empty key")?;
    let mut table = doc.as_table_mut();
    for part in parents {
        table = table
            .entry(part)
            .or_insert_with(|| toml_edit::Item::Table(toml_edit::Table::new()))
            .as_table_mut()
            .ok_or_else(|| format!("`{part}` is not a table"))?;
    }
    table.insert(last, toml_edit::value(value));
    Ok(())
}

/// Parses and validates case text (`path` is used in messages).
pub fn parse(source: &str, path: &Path) -> Result<Case, CaseError> {
    let index = spans::SpanIndex::new(source, path)?;
    let table: toml::Table = toml::from_str(source).map_err(|e| index.syntax_error(&e))?;
    if table.contains_key("flow") {
        return Err(index.error(
            &[spans::Segment::Key("flow".into())],
            "this is a homogeneous-flow scene; it is run by `mesorheo run`, which reads both \
             kinds (this entry point reads particle scenes only)",
        ));
    }
    let physical = table.get("fluid").and_then(|f| f.get("physical")).is_some();
    let mut table = table;
    if physical {
        // A DPD fluid given by its physical properties: mapped to the raw parameters first.
        dpd_physical::resolve(&mut table, &index)?;
    }
    tagged::precheck(&table, &index)?;
    let mut case: Case = if physical {
        serde_path_to_error::deserialize(toml::Value::Table(table.clone()))
            .map_err(|e| index.serde_error(&e))?
    } else {
        let de = toml::Deserializer::parse(source).map_err(|e| index.syntax_error(&e))?;
        serde_path_to_error::deserialize(de).map_err(|e| index.serde_error(&e))?
    };
    let observables_given = table
        .get("diagnostics")
        .and_then(|d| d.get("observables"))
        .is_some();
    if !observables_given {
        case.diagnostics.observables = case.fluid.model().default_observables(&case);
    }
    validate::validate(&case, &index)?;
    Ok(case)
}

impl Case {
    /// φ = (1 − e^{−ω₀Δt})/(ω₀Δt) when the case integrates a fluid with friction (rate ω₀,
    /// [`crate::models::FluidModel::friction_rate`]) by the exponential thermostat.
    pub fn exponential_friction_factor(&self) -> Option<f64> {
        let IntegratorCfg::GrootWarren(gw) = &self.integrator else {
            return None;
        };
        if gw.thermostat != Thermostat::Exponential {
            return None;
        }
        let omega = self.fluid.model().friction_rate(
            self.dimension,
            self.particles.density,
            self.particles.mass,
        )?;
        Some(crate::integrators::exponential_friction_factor(
            omega * gw.dt,
        ))
    }
}

impl Case {
    /// Rows of boundary particles beyond each face of the wall axis: the wall thickness
    /// (default two interaction ranges) in lattice spacings, rounded up.
    pub fn wall_layer_count(&self, axis: usize) -> usize {
        let (cells, _) = self.lattice_counts();
        let spacing = self.domain.lengths[axis] / cells[axis].max(1) as f64;
        let thickness = self
            .walls
            .as_ref()
            .and_then(|w| w.thickness)
            .unwrap_or(2.0 * self.cutoff());
        (thickness / spacing - 1e-9).ceil().max(1.0) as usize
    }
}

impl Case {
    /// Boundaries, all periodic by default.
    pub fn boundaries(&self) -> Vec<Boundary> {
        self.domain
            .boundaries
            .clone()
            .unwrap_or_else(|| vec![Boundary::Periodic; self.dimension])
    }

    /// Interaction cutoff of the fluid model.
    pub fn cutoff(&self) -> f64 {
        self.fluid.cutoff()
    }

    /// Particles per lattice axis and the total, as the initialiser will create them
    /// (saturating at `u64::MAX` for absurd boxes, which validation then refuses).
    pub fn lattice_counts(&self) -> (Vec<usize>, u64) {
        let basis = self.particles.lattice.basis(self.dimension) as f64;
        let lengths = &self.domain.lengths;
        let to_count = |x: f64| {
            if x >= u64::MAX as f64 {
                u64::MAX
            } else {
                x.max(0.0) as u64
            }
        };
        if self.particles.lattice == Lattice::Random {
            let volume: f64 = lengths.iter().product();
            return (vec![], to_count((self.particles.density * volume).round()));
        }
        let spacing = (basis / self.particles.density).powf(1.0 / self.dimension as f64);
        let per_axis: Vec<f64> = lengths
            .iter()
            .map(|l| (l / spacing).round().max(1.0))
            .collect();
        let total = per_axis.iter().product::<f64>() * basis;
        let cells = per_axis
            .iter()
            .map(|&c| c.min(usize::MAX as f64) as usize)
            .collect();
        (cells, to_count(total))
    }

    /// Lattice spacing of the initial arrangement (cubic and fcc lattices; for a random one,
    /// the mean spacing n^(−1/D)).
    pub fn lattice_spacing(&self) -> f64 {
        let basis = self.particles.lattice.basis(self.dimension) as f64;
        (basis / self.particles.density).powf(1.0 / self.dimension as f64)
    }

    /// Whether an observable was asked for.
    pub fn wants(&self, o: Observable) -> bool {
        self.diagnostics.observables.contains(&o)
    }
}

impl crate::models::fluid_model::CaseView for Case {
    fn dimension(&self) -> usize {
        self.dimension
    }
    fn seed(&self) -> u64 {
        self.seed
    }
    fn lengths(&self) -> &[f64] {
        &self.domain.lengths
    }
    fn shear_rate(&self) -> f64 {
        self.domain.shear_rate
    }
    fn boundaries(&self) -> Vec<Boundary> {
        Case::boundaries(self)
    }
    fn decomposition_axis(&self) -> Axis {
        self.decomposition.axis
    }
    fn mass(&self) -> f64 {
        self.particles.mass
    }
    fn number_density(&self) -> f64 {
        self.particles.density
    }
    fn lattice(&self) -> Lattice {
        self.particles.lattice
    }
    fn lattice_spacing(&self) -> f64 {
        Case::lattice_spacing(self)
    }
    fn lattice_counts(&self) -> (Vec<usize>, u64) {
        Case::lattice_counts(self)
    }
    fn velocity_profile(&self) -> (VelocityProfile, f64) {
        (
            self.particles.velocity_profile,
            self.particles.velocity_amplitude,
        )
    }
    fn integrator(&self) -> &IntegratorCfg {
        &self.integrator
    }
    fn exponential_friction_factor(&self) -> Option<f64> {
        Case::exponential_friction_factor(self)
    }
    fn steps(&self) -> u64 {
        self.run.steps
    }
    fn wants(&self, o: Observable) -> bool {
        Case::wants(self, o)
    }
    fn profile_bins(&self) -> usize {
        self.diagnostics.profile_bins
    }
    fn transverse_current_sampling(&self) -> crate::models::fluid_model::TransverseCurrentSampling {
        crate::models::fluid_model::TransverseCurrentSampling {
            every: self.diagnostics.transverse_current_every,
            modes: self.diagnostics.transverse_current_modes,
            time: self.diagnostics.transverse_current_time,
        }
    }
    fn walls(&self) -> Option<&WallsCfg> {
        self.walls.as_ref()
    }
    fn inclusions(&self) -> Option<&InclusionsCfg> {
        self.inclusions.as_ref()
    }
    fn wall_layer_count(&self, axis: usize) -> usize {
        Case::wall_layer_count(self, axis)
    }
}
