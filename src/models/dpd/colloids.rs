//! Suspended colloids in a DPD fluid (`[fluid.colloids]`): rigid bodies whose reference sites
//! carry constituents — ordinary particles of the fluid, tied to their sites by springs — run
//! by the engine's rigid-body facility ([`crate::rigid_bodies`]; Nguyen 2021 §2.4, §5.2;
//! docs/theory/colloids.md).
//!
//! This file owns the case syntax: the shape, how many bodies (a count or the particle volume
//! fraction φ = N_C/(N_C + N_S) of the thesis, L815), where they start (a lattice, seeded random
//! placement without overlap, or explicit centres), the site radius and the spring stiffness H;
//! their validation, `check` lines and time-step limit. The solvent keeps the number density
//! `particles.density`: the constituents come on top of it (L618).

use crate::models::fluid_model::CaseView;
use crate::rigid_bodies::{BodyShape, RigidBodySpec};
use crate::rng::{Purpose, StreamKey};
use crate::spans::{CaseError, Segment, SpanIndex};
use serde::{Deserialize, Serialize};

/// The spring tie's time-step limit: √(H/m) Δt ≤ this. Velocity Verlet integrates an
/// oscillator stably for ωΔt < 2; at ωΔt = 0.2 its frequency error is (ωΔt)²/24 ≈ 0.2 % and
/// its energy error 1 %, so the tie neither heats nor lags the constituents (the thesis asks
/// √(H/m)Δt ≲ 0.1 without a reason; docs/theory/colloids.md).
pub const SPRING_LIMIT: f64 = 0.2;

/// The default √(H/m) Δt when `spring_stiffness` is left out.
pub const DEFAULT_SPRING_STEP: f64 = 0.05;

/// Random placement gives up on a body after this many rejected tries.
const PLACEMENT_TRIES: u32 = 10_000;

/// Where the bodies start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Placement {
    /// The first N cells of a k^D lattice, k = ⌈N^{1/D}⌉, at the cell centres.
    #[default]
    Lattice,
    /// Uniformly random centres (seeded), each at least `min_separation` from the others.
    Random,
}

/// `[fluid.colloids]`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ColloidsCfg {
    /// Layout of the sites.
    pub shape: BodyShape,
    /// Number of bodies (exclusive with `volume_fraction` and `centres`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub count: Option<u64>,
    /// Particle volume fraction φ = N_C/(N_C + N_S).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub volume_fraction: Option<f64>,
    /// Explicit centres (one D-array per body).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub centres: Vec<Vec<f64>>,
    /// How centres are chosen when not given.
    #[serde(default)]
    pub placement: Placement,
    /// Smallest centre distance of random placement (default r_c).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_separation: Option<f64>,
    /// Distance of the outermost site from the centre.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub site_radius: Option<f64>,
    /// Spring stiffness H.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring_stiffness: Option<f64>,
    /// Fixed bodies (V = 0, ω = 0).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub fixed: bool,
}

fn path(key: &str) -> Vec<Segment> {
    vec![
        Segment::Key("fluid".into()),
        Segment::Key("colloids".into()),
        Segment::Key(key.into()),
    ]
}

impl ColloidsCfg {
    /// The site radius: as given, or 0.1 n^{−1/3} in 3D (the spec's starting point, from the
    /// thesis's 2D rule) and 0.075 (8/n)^{1/2} in 2D (the thesis's cylinder, L873: r₂ = 2 r₁,
    /// r₁ = 0.1 (1/2 + 1/4)/2 = 0.0375 at n = 8).
    pub fn site_radius(&self, case: &dyn CaseView) -> f64 {
        self.site_radius.unwrap_or_else(|| {
            let n = case.number_density();
            if case.dimension() == 3 {
                0.1 * n.powf(-1.0 / 3.0)
            } else {
                0.075 * (8.0 / n).sqrt()
            }
        })
    }

    /// H: as given, or m (0.05/Δt)².
    pub fn spring_stiffness(&self, case: &dyn CaseView) -> f64 {
        self.spring_stiffness
            .unwrap_or_else(|| case.mass() * (DEFAULT_SPRING_STEP / case.dt()).powi(2))
    }

    /// √(H/m) Δt.
    pub fn spring_step(&self, case: &dyn CaseView) -> f64 {
        (self.spring_stiffness(case) / case.mass()).sqrt() * case.dt()
    }

    /// The solvent's particle count (the fluid lattice).
    fn solvent_count(case: &dyn CaseView) -> u64 {
        case.lattice_counts().1
    }

    /// The number of bodies: the count, the centres given, or from φ:
    /// N_b = round(φ N_S / ((1 − φ) n_cp)).
    pub fn body_count(&self, case: &dyn CaseView) -> u64 {
        if !self.centres.is_empty() {
            return self.centres.len() as u64;
        }
        if let Some(n) = self.count {
            return n;
        }
        let phi = self.volume_fraction.unwrap_or(0.0);
        let ns = Self::solvent_count(case) as f64;
        (phi * ns / ((1.0 - phi) * self.shape.sites() as f64)).round() as u64
    }

    /// The bodies' centres (3 components, z = 0 in 2D).
    pub fn centres(&self, case: &dyn CaseView, cutoff: f64) -> Result<Vec<[f64; 3]>, String> {
        let d = case.dimension();
        let lengths = case.lengths();
        let n = self.body_count(case) as usize;
        if !self.centres.is_empty() {
            return Ok(self
                .centres
                .iter()
                .map(|c| std::array::from_fn(|k| if k < d { c[k] } else { 0.0 }))
                .collect());
        }
        match self.placement {
            Placement::Lattice => {
                let per_axis = (1..).find(|k: &usize| k.pow(d as u32) >= n).unwrap_or(1);
                Ok((0..n)
                    .map(|c| {
                        let mut x = [0.0; 3];
                        let mut rem = c;
                        for k in 0..d {
                            let spacing = lengths[k] / per_axis as f64;
                            x[k] = ((rem % per_axis) as f64 + 0.5) * spacing;
                            rem /= per_axis;
                        }
                        x
                    })
                    .collect())
            }
            Placement::Random => {
                let key = StreamKey::new(case.seed(), Purpose::RigidBodyPlacement, 0);
                let min = self.min_separation.unwrap_or(cutoff);
                let mut placed: Vec<[f64; 3]> = Vec::with_capacity(n);
                for b in 0..n {
                    let mut tries = 0u32;
                    loop {
                        let (u0, u1) = key.uniform2(u64::from(tries), b as u32, 0);
                        let (u2, _) = key.uniform2(u64::from(tries), b as u32, 1);
                        let u = [u0, u1, u2];
                        let x: [f64; 3] =
                            std::array::from_fn(|k| if k < d { u[k] * lengths[k] } else { 0.0 });
                        if placed.iter().all(|y| distance(case, &x, y) >= min) {
                            placed.push(x);
                            break;
                        }
                        tries += 1;
                        if tries >= PLACEMENT_TRIES {
                            return Err(format!(
                                "random placement found room for only {b} of {n} bodies at \
                                 least min_separation = {min} apart ({PLACEMENT_TRIES} tries for \
                                 the next); lower the count or volume_fraction, or \
                                 min_separation, or use placement = \"lattice\""
                            ));
                        }
                    }
                }
                Ok(placed)
            }
        }
    }

    /// What the engine builds: the spec of the bodies.
    pub fn spec(&self, case: &dyn CaseView, cutoff: f64) -> Result<RigidBodySpec, String> {
        Ok(RigidBodySpec {
            shape: self.shape,
            site_radius: self.site_radius(case),
            constituent_mass: case.mass(),
            spring_stiffness: self.spring_stiffness(case),
            first_gid: Self::solvent_count(case),
            centres: self.centres(case, cutoff)?,
            fixed: self.fixed,
        })
    }

    /// The check lines.
    pub fn report(&self, case: &dyn CaseView, kt: f64, line: &mut dyn FnMut(String)) {
        let n = self.body_count(case);
        let ncp = self.shape.sites() as u64;
        let ns = Self::solvent_count(case);
        let phi = (n * ncp) as f64 / ((n * ncp + ns) as f64);
        let h = self.spring_stiffness(case);
        let step = self.spring_step(case);
        line(format!(
            "colloids: {n} {} bodies{} of n_cp = {ncp} constituents (M_c = {} m = {}), particle \
             fraction φ = N_C/(N_C + N_S) = {phi:.5} ({} constituents beside {ns} solvent \
             particles), site radius {:.4}",
            self.shape.name(),
            if self.fixed { " (fixed)" } else { "" },
            ncp,
            ncp as f64 * case.mass(),
            n * ncp,
            self.site_radius(case)
        ));
        line(format!(
            "colloid springs: H = {h:.6}, √(H/m)Δt = {step:.4} [{}] (limit {SPRING_LIMIT}; \
             equipartition k_BT/M_c = {:.5} for var(V_x))",
            if step <= SPRING_LIMIT {
                "ok"
            } else {
                "UNSTABLE"
            },
            kt / (ncp as f64 * case.mass())
        ));
    }

    /// The spring's time-step limit Δt ≤ SPRING_LIMIT / √(H/m).
    pub fn time_step_limit(&self, case: &dyn CaseView) -> f64 {
        SPRING_LIMIT / (self.spring_stiffness(case) / case.mass()).sqrt()
    }

    /// Checks the table against the case.
    pub fn validate(
        &self,
        case: &dyn CaseView,
        cutoff: f64,
        ix: &SpanIndex,
    ) -> Result<(), CaseError> {
        let d = case.dimension();
        if self.shape.dimension() != d {
            let valid: Vec<&str> = BodyShape::ALL
                .iter()
                .filter(|s| s.dimension() == d)
                .map(|s| s.name())
                .collect();
            return Err(ix.error(
                &path("shape"),
                format!(
                    "the {} is a {}D body, the case is {d}D; use one of {}",
                    self.shape.name(),
                    self.shape.dimension(),
                    valid.join(", ")
                ),
            ));
        }
        let given = [
            self.count.is_some(),
            self.volume_fraction.is_some(),
            !self.centres.is_empty(),
        ];
        if given.iter().filter(|&&g| g).count() != 1 {
            return Err(ix.error(
                &[
                    Segment::Key("fluid".into()),
                    Segment::Key("colloids".into()),
                ],
                "give exactly one of count, volume_fraction and centres",
            ));
        }
        if let Some(phi) = self.volume_fraction
            && !(phi.is_finite() && phi > 0.0 && phi < 1.0)
        {
            return Err(ix.error(
                &path("volume_fraction"),
                format!("found {phi}; φ = N_C/(N_C + N_S) must lie in (0, 1)"),
            ));
        }
        if self.count == Some(0) || (self.volume_fraction.is_some() && self.body_count(case) == 0) {
            return Err(ix.error(
                &path(if self.count.is_some() {
                    "count"
                } else {
                    "volume_fraction"
                }),
                "no body: give at least one (or leave [fluid.colloids] out)",
            ));
        }
        for (k, c) in self.centres.iter().enumerate() {
            let inside = c.len() == d
                && c.iter()
                    .zip(case.lengths())
                    .all(|(x, l)| x.is_finite() && *x >= 0.0 && x < l);
            if !inside {
                let mut p = path("centres");
                p.push(Segment::Index(k));
                return Err(ix.error(
                    &p,
                    format!(
                        "found {c:?}; a centre has {d} coordinates inside the box [0, L) = {:?}",
                        case.lengths()
                    ),
                ));
            }
        }
        let radius = self.site_radius(case);
        if !(radius.is_finite() && radius > 0.0) {
            return Err(ix.error(
                &path("site_radius"),
                format!("found {radius}; the site radius must be > 0"),
            ));
        }
        // The bodies must fit in the box without overlapping (each holds at least the cube of
        // its diameter): a count beyond that is an error, not a placement to attempt (an absurd
        // count would otherwise exhaust the memory before the placement could fail).
        let volume: f64 = case.lengths().iter().take(d).product();
        // (1 + 10⁻⁹: a box of exactly k bodies' cubes must not lose one to round-off.)
        let fit = (volume / (2.0 * radius).powi(d as i32) * (1.0 + 1e-9)).floor();
        let n = self.body_count(case);
        if self.centres.is_empty() && n as f64 > fit {
            return Err(ix.error(
                &path(if self.count.is_some() {
                    "count"
                } else {
                    "volume_fraction"
                }),
                format!(
                    "{n} bodies of diameter 2 × site radius = {:.4} do not fit in the box \
                     (volume {volume:.4}): at most {fit:.0} fit without overlapping; lower the \
                     count (or volume_fraction) or enlarge the box",
                    2.0 * radius
                ),
            ));
        }
        // A body and the reach of its constituents' forces must fit in half the box, so that
        // the minimum image of every lever arm and spring is its own body's.
        let extent = 2.0 * radius + cutoff;
        let half = case
            .lengths()
            .iter()
            .fold(f64::INFINITY, |a, &l| a.min(0.5 * l));
        if extent >= half {
            return Err(ix.error(
                &path("site_radius"),
                format!(
                    "a body spans 2 × site radius + r_c = {extent:.4}, not less than half the \
                     smallest box edge ({half:.4}): the minimum image of its lever arms would be \
                     ambiguous; use a smaller site radius or a larger box"
                ),
            ));
        }
        if let Some(h) = self.spring_stiffness
            && !(h.is_finite() && h > 0.0)
        {
            return Err(ix.error(
                &path("spring_stiffness"),
                format!("found {h}; the spring stiffness H must be > 0"),
            ));
        }
        let step = self.spring_step(case);
        if step > SPRING_LIMIT {
            return Err(ix.error(
                &path("spring_stiffness"),
                format!(
                    "H = {} with m = {} and Δt = {} gives √(H/m)Δt = {step:.4}, beyond the spring \
                     limit {SPRING_LIMIT} (velocity Verlet of the tie; docs/theory/colloids.md): \
                     use H ≤ {:.6} or Δt ≤ {:.4e}",
                    self.spring_stiffness(case),
                    case.mass(),
                    case.dt(),
                    case.mass() * (SPRING_LIMIT / case.dt()).powi(2),
                    self.time_step_limit(case)
                ),
            ));
        }
        if let Some(min) = self.min_separation
            && !(min.is_finite() && min >= 0.0)
        {
            return Err(ix.error(&path("min_separation"), format!("found {min}; must be ≥ 0")));
        }
        let centres = self
            .centres(case, cutoff)
            .map_err(|e| ix.error(&path("placement"), e))?;
        // Overlap: two bodies whose site spheres intersect.
        for a in 0..centres.len() {
            for b in a + 1..centres.len() {
                let r = distance(case, &centres[a], &centres[b]);
                if r < 2.0 * radius {
                    let key = if self.centres.is_empty() {
                        path("placement")
                    } else {
                        let mut p = path("centres");
                        p.push(Segment::Index(b));
                        p
                    };
                    return Err(ix.error(
                        &key,
                        format!(
                            "bodies {a} and {b} overlap: their centres are {r:.4} apart, less \
                             than twice the site radius ({:.4}); move them apart or use fewer \
                             bodies",
                            2.0 * radius
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Minimum-image distance of two centres (no shear offset at the start).
fn distance(case: &dyn CaseView, a: &[f64; 3], b: &[f64; 3]) -> f64 {
    let d = case.dimension();
    let lengths = case.lengths();
    let mut s = 0.0;
    for k in 0..d {
        let mut x = a[k] - b[k];
        if case.boundaries()[k] == crate::geometry::Boundary::Periodic {
            x -= (x / lengths[k]).round() * lengths[k];
        }
        s += x * x;
    }
    s.sqrt()
}
