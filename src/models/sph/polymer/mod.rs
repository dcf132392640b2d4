//! The polymer stress τ an SPH particle carries (`[fluid.polymer]`), and the registry of its
//! constitutive laws: the rate τ̇_i = f(τ_i, G_i) that the integrator advances with the
//! particle, from the particle's own stress τ_i and its velocity-gradient estimate
//! G_i^{ab} = ∂v^a/∂x^b; or, for `dumbbells`, the Kramers stress of an ensemble the particle
//! carries ([`crate::models::dumbbell_ensemble`]), or for `bddfs` of the dumbbells regenerated
//! every step from the histogram it carries ([`crate::models::bddfs`]).
//!
//! **Adding a constitutive law is one file in this directory plus one line of
//! `polymer_laws!`**: a unit struct implementing [`Law`] (its rate, its keys and their
//! checks, its zero-shear viscosity and steady-shear tension for `check`, whether its start-up
//! is Oldroyd-B's). Each law's file opens with its equations.
//!
//! The stress is stored packed, the upper triangle row by row: (xx, xy, yy) in 2D,
//! (xx, xy, xz, yy, yz, zz) in 3D.

use crate::models::bddfs::QGrid;
use crate::models::dumbbell_settings::{EnsembleNoise, SchemeKind, SpringKind};
use crate::models::dumbbells::{DumbbellParams, Scheme, Spring};
use crate::particles::Precision;
use serde::{Deserialize, Serialize};

/// `[fluid.polymer]`: a polymer stress carried by every fluid particle.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PolymerCfg {
    /// The constitutive model.
    pub model: PolymerModel,
    /// Polymer (zero-shear) viscosity η_p = Gλ.
    pub viscosity: f64,
    /// Relaxation time λ.
    pub relaxation_time: f64,
    /// The rotation terms Ωτ − τΩ of the corotational model (default on; off is the thesis's
    /// linear variant "SPH2"). Only for `corotational_maxwell`.
    #[serde(default = "yes")]
    pub rotation: bool,
    /// `dumbbells`: dumbbells per particle N_d (required).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub per_particle: Option<usize>,
    /// `dumbbells`: spring law (default Hookean).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spring: Option<SpringKind>,
    /// `dumbbells` with `spring = "fene"`: maximum extensibility b = H Q₀²/k_BT.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub b: Option<f64>,
    /// `dumbbells`: the stochastic scheme (default Heun for Hookean, semi-implicit for FENE).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scheme: Option<SchemeKind>,
    /// `dumbbells`: storage precision of the connectors (default double).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub precision: Option<Precision>,
    /// `dumbbells`: whose Wiener increments the ensembles draw (default independent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub noise: Option<EnsembleNoise>,
    /// `bddfs`: cells per axis n_c of the histogram grid (required).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cells: Option<usize>,
    /// `bddfs`: half-edge Q_max of the histogram grid (required for Hookean springs; √b for
    /// FENE by default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_max: Option<f64>,
}

impl PolymerCfg {
    /// Whether the stress comes from dumbbell ensembles (CONNFFESSIT) rather than a
    /// constitutive equation.
    pub fn is_ensemble(&self) -> bool {
        self.model.is_ensemble()
    }

    /// The ensembles' spring law (Hookean unless `spring = "fene"`).
    pub fn spring_law(&self) -> Spring {
        crate::models::dumbbell_settings::spring_law(
            self.spring.unwrap_or(SpringKind::Hookean),
            self.b,
        )
    }

    /// The ensembles' scheme, with its default (Heun for Hookean, semi-implicit for FENE).
    pub fn scheme_or_default(&self) -> Scheme {
        crate::models::dumbbell_settings::scheme_or_default(
            self.scheme,
            self.spring.unwrap_or(SpringKind::Hookean),
        )
    }

    /// The ensembles' parameters at time step `dt`.
    pub fn dumbbell_params(&self, dt: f64) -> DumbbellParams {
        DumbbellParams {
            spring: self.spring_law(),
            scheme: self.scheme_or_default(),
            lambda: self.relaxation_time,
            dt,
        }
    }

    /// The ensembles' modulus G = η_p/λ (= n k_BT: the stress unit of ⟨QF(Q)⟩ − I).
    pub fn modulus(&self) -> f64 {
        self.viscosity / self.relaxation_time
    }

    /// The ensembles' noise (independent per particle unless `noise = "configuration_fields"`).
    pub fn ensemble_noise(&self) -> EnsembleNoise {
        self.noise.unwrap_or_default()
    }

    /// The connectors' storage precision.
    pub fn connector_precision(&self) -> Precision {
        self.precision.unwrap_or_default()
    }

    /// The BDDFS histogram grid (`model = "bddfs"`; Q_max defaults to √b for FENE), None for
    /// explicit dumbbells and constitutive laws.
    pub fn histogram_grid(&self) -> Option<QGrid> {
        (self.model == PolymerModel::Bddfs).then(|| QGrid {
            cells: self.cells.unwrap_or(0),
            q_max: self.q_max.or(self.b.map(f64::sqrt)).unwrap_or(f64::NAN),
        })
    }

    /// Bytes of connector storage per fluid particle (0 for a constitutive model); BDDFS: the
    /// bound 8 × min(N_d, n_c^D) of its sparse histogram.
    pub fn bytes_per_particle(&self, dimension: usize) -> f64 {
        if let Some(grid) = self.histogram_grid() {
            return crate::models::bddfs::histogram_bytes_bound(
                &grid,
                self.per_particle.unwrap_or(0),
                dimension,
            );
        }
        let word = match self.connector_precision() {
            Precision::Double => 8.0,
            Precision::Single => 4.0,
        };
        self.per_particle.unwrap_or(0) as f64 * dimension as f64 * word
    }
}

fn yes() -> bool {
    true
}

/// Components of the packed symmetric stress in D dimensions.
pub const fn packed_width(dimension: usize) -> usize {
    dimension * (dimension + 1) / 2
}

/// Index of component (a, b) in the packed upper triangle.
#[inline(always)]
pub const fn packed_index<const D: usize>(a: usize, b: usize) -> usize {
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    // Rows 0..a hold D + (D − 1) + … + (D − a + 1) components.
    a * D - a * (a.saturating_sub(1)) / 2 + (b - a)
}

/// The full D×D row-major tensor of a packed one.
#[inline(always)]
pub fn unpack<const D: usize>(packed: &[f64]) -> [[f64; D]; D] {
    std::array::from_fn(|a| std::array::from_fn(|b| packed[packed_index::<D>(a, b)]))
}

/// The parameters a constitutive law's rate reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LawParams {
    /// η_p.
    pub viscosity: f64,
    /// λ.
    pub relaxation_time: f64,
    /// Whether the corotational rotation terms are on.
    pub rotation: bool,
    /// The maximum extensibility b of a finitely extensible law (NaN: none).
    pub b: f64,
}

/// What a polymer law declares (module doc). Associated functions only: the registry
/// dispatches by [`PolymerModel`], statically.
pub trait Law {
    /// Whether the stress comes from a dumbbell ensemble the particle carries (no rate).
    const ENSEMBLE: bool = false;
    /// The optional `[fluid.polymer]` keys it reads (besides model, viscosity and
    /// relaxation_time).
    const KEYS: &'static [&'static str] = &[];

    /// dτ/dt (packed) at stress `tau` (packed) and velocity gradient `g`, into `rate`.
    fn rate<const D: usize>(p: &LawParams, tau: &[f64], g: &[[f64; D]; D], rate: &mut [f64]);

    /// Checks of its keys: `Err((key under fluid.polymer, message))`.
    fn validate(_cfg: &PolymerCfg) -> Result<(), (&'static str, String)> {
        Ok(())
    }

    /// Whether its start-up in unidirectional flow is the Oldroyd-B series.
    fn oldroyd_b(_cfg: &PolymerCfg) -> bool {
        false
    }

    /// Its zero-shear polymer viscosity over η_p in `dimension` dimensions, with the formula
    /// (`None`: η_p itself).
    fn zero_shear_factor(_cfg: &PolymerCfg, _dimension: usize) -> Option<(f64, &'static str)> {
        None
    }

    /// Its steady-shear tension τ_xx at shear rate γ̇ in `dimension` dimensions.
    fn steady_shear_tension(cfg: &PolymerCfg, shear_rate: f64, dimension: usize) -> f64;

    /// Its own lines of the `check` report at time step `dt` (none by default).
    fn check_lines(_cfg: &PolymerCfg, _dimension: usize, _dt: f64) -> Vec<String> {
        Vec::new()
    }
}

/// The registry of polymer laws: `Variant in module = "model name"`, the law being the unit
/// struct `module::Variant` in `module.rs` of this directory.
macro_rules! polymer_laws {
    ($( $(#[$doc:meta])* $variant:ident in $module:ident = $name:literal, )*) => {
        $( mod $module; )*

        /// `[fluid.polymer] model`: one variant per registered law.
        #[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
        pub enum PolymerModel {
            $( $(#[$doc])* #[serde(rename = $name)] $variant, )*
        }

        impl PolymerModel {
            /// Every registered law with its `model` name.
            pub const ALL: &'static [(PolymerModel, &'static str)] =
                &[$( (PolymerModel::$variant, $name), )*];

            /// Its `model` name.
            pub fn name(self) -> &'static str {
                match self {
                    $( PolymerModel::$variant => $name, )*
                }
            }

            /// [`Law::ENSEMBLE`].
            pub fn is_ensemble(self) -> bool {
                match self {
                    $( PolymerModel::$variant => <$module::$variant as Law>::ENSEMBLE, )*
                }
            }

            /// [`Law::oldroyd_b`].
            pub fn is_oldroyd_b(self, cfg: &PolymerCfg) -> bool {
                match self {
                    $( PolymerModel::$variant => <$module::$variant as Law>::oldroyd_b(cfg), )*
                }
            }

            /// Whether it reads the optional key `key` ([`Law::KEYS`]).
            pub fn reads(self, key: &str) -> bool {
                match self {
                    $( PolymerModel::$variant => <$module::$variant as Law>::KEYS.contains(&key), )*
                }
            }

            /// [`Law::validate`].
            pub fn validate(self, cfg: &PolymerCfg) -> Result<(), (&'static str, String)> {
                match self {
                    $( PolymerModel::$variant => <$module::$variant as Law>::validate(cfg), )*
                }
            }

            /// [`Law::zero_shear_factor`].
            pub fn zero_shear_factor(
                self,
                cfg: &PolymerCfg,
                dimension: usize,
            ) -> Option<(f64, &'static str)> {
                match self {
                    $( PolymerModel::$variant => <$module::$variant as Law>::zero_shear_factor(cfg, dimension), )*
                }
            }

            /// [`Law::steady_shear_tension`].
            pub fn steady_shear_tension(
                self,
                cfg: &PolymerCfg,
                shear_rate: f64,
                dimension: usize,
            ) -> f64 {
                match self {
                    $( PolymerModel::$variant => {
                        <$module::$variant as Law>::steady_shear_tension(cfg, shear_rate, dimension)
                    } )*
                }
            }

            /// [`Law::check_lines`].
            pub fn check_lines(self, cfg: &PolymerCfg, dimension: usize, dt: f64) -> Vec<String> {
                match self {
                    $( PolymerModel::$variant => <$module::$variant as Law>::check_lines(cfg, dimension, dt), )*
                }
            }

            /// [`Law::rate`].
            #[inline]
            fn rate<const D: usize>(
                self,
                p: &LawParams,
                tau: &[f64],
                g: &[[f64; D]; D],
                rate: &mut [f64],
            ) {
                match self {
                    $( PolymerModel::$variant => <$module::$variant as Law>::rate::<D>(p, tau, g, rate), )*
                }
            }
        }
    };
}

polymer_laws! {
    /// The corotational (Jaumann) Maxwell model of Ellero 2004 ch. 3 (sign corrected).
    CorotationalMaxwell in corotational_maxwell = "corotational_maxwell",
    /// The upper-convected Maxwell model (Oldroyd-B with `fluid.viscosity` > 0).
    UpperConvectedMaxwell in upper_convected_maxwell = "upper_convected_maxwell",
    /// Every fluid particle carries `per_particle` Brownian dumbbells advanced with its own
    /// velocity gradient; their Kramers stress G(⟨QF(Q)⟩ − I), G = η_p/λ, is τ (CONNFFESSIT,
    /// [`crate::models::dumbbell_ensemble`]). Hookean dumbbells are the stochastic
    /// counterpart of `upper_convected_maxwell`.
    Dumbbells in dumbbells = "dumbbells",
    /// The FENE-P closure of FENE dumbbells (`b`), as a conformation law advanced in τ.
    FeneP in fene_p = "fene_p",
    /// The dumbbells of `dumbbells`, stored per particle as a histogram on a Q-grid (`cells`,
    /// `q_max`) and regenerated every step (BDDFS, [`crate::models::bddfs`]).
    Bddfs in bddfs = "bddfs",
}

/// A constitutive polymer law with its parameters, as the gradient pass applies it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstitutiveLaw {
    /// Which law.
    pub model: PolymerModel,
    /// Its parameters.
    pub params: LawParams,
}

impl ConstitutiveLaw {
    /// The constitutive law of a `[fluid.polymer]` table (none for dumbbell ensembles, whose
    /// stress is no function of τ and G).
    pub fn of(c: &PolymerCfg) -> Option<Self> {
        (!c.is_ensemble()).then_some(Self {
            model: c.model,
            params: LawParams {
                viscosity: c.viscosity,
                relaxation_time: c.relaxation_time,
                rotation: c.rotation,
                b: c.b.unwrap_or(f64::NAN),
            },
        })
    }

    /// The rate dτ/dt (packed) at stress `tau` (packed) and velocity gradient `g`
    /// (g[a][b] = ∂v^a/∂x^b), written into `rate`.
    #[inline]
    pub fn rate<const D: usize>(&self, tau: &[f64], g: &[[f64; D]; D], rate: &mut [f64]) {
        self.model.rate::<D>(&self.params, tau, g, rate);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_indices_enumerate_the_upper_triangle() {
        assert_eq!(
            [(0, 0), (0, 1), (1, 1)].map(|(a, b)| packed_index::<2>(a, b)),
            [0, 1, 2]
        );
        let three = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];
        assert_eq!(
            three.map(|(a, b)| packed_index::<3>(a, b)),
            [0, 1, 2, 3, 4, 5]
        );
        assert_eq!(packed_index::<3>(2, 0), 2);
        assert_eq!(packed_width(2), 3);
        assert_eq!(packed_width(3), 6);
    }

    /// Integrates dτ/dt = rate(τ, G) for a particle in the prescribed simple shear
    /// v = γ̇ y x̂ (G_xy = γ̇) with classical RK4, from τ = 0 to `t_end`, in 20 000 steps.
    fn start_up<const D: usize>(m: &ConstitutiveLaw, rate_of_shear: f64, t_end: f64) -> Vec<f64> {
        start_up_in::<D>(m, rate_of_shear, t_end, 20_000)
    }

    /// [`start_up`] in `steps` steps (the laws' own tests use it too).
    pub(super) fn start_up_in<const D: usize>(
        m: &ConstitutiveLaw,
        rate_of_shear: f64,
        t_end: f64,
        steps: usize,
    ) -> Vec<f64> {
        let mut g = [[0.0; D]; D];
        g[0][1] = rate_of_shear;
        let w = packed_width(D);
        let f = |tau: &[f64]| {
            let mut r = vec![0.0; w];
            m.rate::<D>(tau, &g, &mut r);
            r
        };
        let dt = t_end / steps as f64;
        let mut tau = vec![0.0; w];
        let axpy = |x: &[f64], a: f64, y: &[f64]| -> Vec<f64> {
            x.iter().zip(y).map(|(x, y)| x + a * y).collect()
        };
        for _ in 0..steps {
            let k1 = f(&tau);
            let k2 = f(&axpy(&tau, 0.5 * dt, &k1));
            let k3 = f(&axpy(&tau, 0.5 * dt, &k2));
            let k4 = f(&axpy(&tau, dt, &k3));
            for c in 0..w {
                tau[c] += dt / 6.0 * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c]);
            }
        }
        tau
    }

    /// docs/theory/sph_maxwell.md §3 T4 (B2): start-up of simple shear from τ = 0, Wi = λγ̇,
    /// τ_xy(t) = (ηγ̇/(1+Wi²)) [1 − e^{−t/λ}(cos γ̇t − Wi sin γ̇t)],
    /// τ_xx(t) = −τ_yy(t) = (ηγ̇/(1+Wi²)) [Wi − e^{−t/λ}(Wi cos γ̇t + sin γ̇t)],
    /// to 1e-6 relative (RK4 with 20 000 steps is exact to ~1e-12 here). The thesis's printed
    /// rotation sign (σω + ωσ) keeps τ_xx = 0 and fails; so does ½ missing from Ω.
    #[test]
    fn corotational_start_up_follows_the_analytic_solution() {
        let (eta, gamma) = (10.0, 1.0);
        for wi in [0.1, 1.0, 3.2] {
            let m = ConstitutiveLaw {
                model: PolymerModel::CorotationalMaxwell,
                params: LawParams {
                    viscosity: eta,
                    relaxation_time: wi / gamma,
                    rotation: true,
                    b: f64::NAN,
                },
            };
            for t in [0.3, 1.0, 2.5, 7.0] {
                let tau2 = start_up::<2>(&m, gamma, t);
                let tau3 = start_up::<3>(&m, gamma, t);
                let scale = eta * gamma / (1.0 + wi * wi);
                let decay = (-t / m.params.relaxation_time).exp();
                let (c, s) = ((gamma * t).cos(), (gamma * t).sin());
                let xy = scale * (1.0 - decay * (c - wi * s));
                let xx = scale * (wi - decay * (wi * c + s));
                let close = |got: f64, want: f64, what: &str| {
                    assert!(
                        (got - want).abs() <= 1e-6 * scale,
                        "Wi {wi}, t {t}, {what}: {got} vs {want}"
                    );
                };
                close(tau2[1], xy, "2D xy");
                close(tau2[0], xx, "2D xx");
                close(tau2[2], -xx, "2D yy");
                close(tau3[1], xy, "3D xy");
                close(tau3[0], xx, "3D xx");
                close(tau3[3], -xx, "3D yy");
                close(tau3[5], 0.0, "3D zz");
                close(tau3[2], 0.0, "3D xz");
                close(tau3[4], 0.0, "3D yz");
            }
        }
    }

    /// The linear variant (rotation off) in simple shear: τ_xy = ηγ̇(1 − e^{−t/λ}), no normal
    /// stresses.
    #[test]
    fn linear_variant_has_no_normal_stresses() {
        let m = ConstitutiveLaw {
            model: PolymerModel::CorotationalMaxwell,
            params: LawParams {
                viscosity: 2.0,
                relaxation_time: 0.5,
                rotation: false,
                b: f64::NAN,
            },
        };
        let tau = start_up::<2>(&m, 3.0, 1.0);
        let want = 2.0 * 3.0 * (1.0 - (-2.0f64).exp());
        assert!((tau[1] - want).abs() < 1e-9 * want, "{} vs {want}", tau[1]);
        assert_eq!((tau[0], tau[2]), (0.0, 0.0));
    }

    /// Upper-convected Maxwell start-up in simple shear (Bird et al. 1987):
    /// τ_xy = η_pγ̇(1 − e^{−t/λ}), τ_xx = 2η_pλγ̇²[1 − e^{−t/λ}(1 + t/λ)], τ_yy = τ_zz = 0.
    #[test]
    fn upper_convected_start_up_follows_the_analytic_solution() {
        let (eta, lambda, gamma) = (3.0, 0.7, 2.0);
        let m = ConstitutiveLaw {
            model: PolymerModel::UpperConvectedMaxwell,
            params: LawParams {
                viscosity: eta,
                relaxation_time: lambda,
                rotation: true,
                b: f64::NAN,
            },
        };
        for t in [0.2, 1.0, 4.0] {
            let tau = start_up::<3>(&m, gamma, t);
            let e = (-t / lambda).exp();
            let xy = eta * gamma * (1.0 - e);
            let xx = 2.0 * eta * lambda * gamma * gamma * (1.0 - e * (1.0 + t / lambda));
            let scale = 2.0 * eta * lambda * gamma * gamma;
            assert!(
                (tau[1] - xy).abs() < 1e-6 * scale,
                "t {t} xy {} vs {xy}",
                tau[1]
            );
            assert!(
                (tau[0] - xx).abs() < 1e-6 * scale,
                "t {t} xx {} vs {xx}",
                tau[0]
            );
            for c in [2, 3, 4, 5] {
                assert!(
                    tau[c].abs() < 1e-12 * scale,
                    "t {t} component {c}: {}",
                    tau[c]
                );
            }
        }
    }
}
