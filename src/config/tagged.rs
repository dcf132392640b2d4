//! Tables selected by `kind` (`[fluid]`, `[integrator]`, `[[reference]]`).
//!
//! serde buffers an internally tagged table before it knows the variant, which loses the key
//! path of errors inside it. So each such table is first checked on its own: `kind` must name a
//! known variant, then the rest of the table is deserialised into that variant's struct with
//! path tracking, so a wrong type or an unknown choice names its own key and line.

use super::registry::FLUIDS;
use super::spans::{Segment, SpanIndex, segments};
use super::{
    CaseError, DoublePoiseuilleReference, DoublePoiseuilleStressReference, GrootWarrenCfg,
    KickDriftKickCfg, ProfileReference, StartupProfileReference, TwoStageCfg, ValueReference,
};
use serde::de::DeserializeOwned;

pub(super) type Check = fn(toml::Value) -> Result<(), serde_path_to_error::Error<toml::de::Error>>;

pub(super) fn check<T: DeserializeOwned>(
    v: toml::Value,
) -> Result<(), serde_path_to_error::Error<toml::de::Error>> {
    serde_path_to_error::deserialize::<_, T>(v).map(|_| ())
}

const INTEGRATORS: &[(&str, Check)] = &[
    ("groot_warren", check::<GrootWarrenCfg>),
    ("kick_drift_kick", check::<KickDriftKickCfg>),
    ("heun", check::<TwoStageCfg>),
    ("midpoint", check::<TwoStageCfg>),
    ("thesis_predictor_corrector", check::<TwoStageCfg>),
];
const REFERENCES: &[(&str, Check)] = &[
    ("value", check::<ValueReference>),
    ("linear_shear_profile", check::<ProfileReference>),
    ("startup_profile", check::<StartupProfileReference>),
    (
        "double_poiseuille_profile",
        check::<DoublePoiseuilleReference>,
    ),
    (
        "double_poiseuille_stress",
        check::<DoublePoiseuilleStressReference>,
    ),
];

/// Checks every tagged table present in the document.
pub fn precheck(doc: &toml::Table, ix: &SpanIndex) -> Result<(), CaseError> {
    for (name, variants) in [("fluid", FLUIDS), ("integrator", INTEGRATORS)] {
        if let Some(toml::Value::Table(t)) = doc.get(name) {
            one(t, vec![Segment::Key(name.into())], variants, ix)?;
        }
    }
    precheck_references(doc, ix)
}

/// Checks every `[[reference]]` table (all kinds of scene have them).
pub fn precheck_references(doc: &toml::Table, ix: &SpanIndex) -> Result<(), CaseError> {
    if let Some(toml::Value::Array(refs)) = doc.get("reference") {
        for (i, r) in refs.iter().enumerate() {
            if let toml::Value::Table(t) = r {
                let path = vec![Segment::Key("reference".into()), Segment::Index(i)];
                one(t, path, REFERENCES, ix)?;
            }
        }
    }
    Ok(())
}

fn one(
    table: &toml::Table,
    path: Vec<Segment>,
    variants: &[(&str, Check)],
    ix: &SpanIndex,
) -> Result<(), CaseError> {
    let names: Vec<String> = variants.iter().map(|(n, _)| format!("`{n}`")).collect();
    let mut kind_path = path.clone();
    kind_path.push(Segment::Key("kind".into()));
    let kind = match table.get("kind") {
        None => {
            let mut e = ix.error(
                &path,
                format!(
                    "missing required key `kind`; valid choices are {}",
                    names.join(", ")
                ),
            );
            e.key = super::spans::render(&kind_path);
            return Err(e);
        }
        Some(toml::Value::String(k)) => k.clone(),
        Some(other) => {
            return Err(ix.error(
                &kind_path,
                format!("found {other}; `kind` must be one of {}", names.join(", ")),
            ));
        }
    };
    let Some((_, check)) = variants.iter().find(|(n, _)| *n == kind) else {
        return Err(ix.error(
            &kind_path,
            format!(
                "unknown choice `{kind}`; valid choices are {}",
                names.join(", ")
            ),
        ));
    };
    let mut rest = table.clone();
    rest.remove("kind");
    check(toml::Value::Table(rest)).map_err(|e| {
        let mut full = path.clone();
        full.extend(segments(e.path()));
        ix.structural_error(&full, e.inner().message(), None)
    })
}
