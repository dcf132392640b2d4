//! Maxwell-type polymer stress of an SPH particle (`[fluid.polymer]`): the constitutive rate
//! τ̇_i = f(τ_i, G_i) that the integrator advances with the particle, from the particle's own
//! stress τ_i and its velocity-gradient estimate G_i^{ab} = ∂v^a/∂x^b (Ellero 2004 Eq. 3.7,
//! ×2). docs/theory/sph_maxwell.md §1.9, with the thesis's printed sign corrected.
//!
//! ```text
//! Ω = ½ (G − Gᵀ)   (vorticity, Ω^{ab} = ½(∂_b v^a − ∂_a v^b))
//! D = ½ (G + Gᵀ)   (rate of strain),   D̄ = D − (1/d) tr G · I   (its deviatoric part)
//!
//! corotational (Jaumann) Maxwell   dτ/dt = Ωτ − τΩ + (2η_p/λ) D̄ − τ/λ
//! linear ("SPH2")                  dτ/dt =            (2η_p/λ) D̄ − τ/λ
//! upper-convected Maxwell          dτ/dt = Gτ + τGᵀ  + (2η_p/λ) D  − τ/λ
//! ```
//!
//! **Departure from the printed text.** The thesis's Eq. 3.4 and Eq. 3.6 combine the rotation
//! terms into σω + ωσ, an antisymmetric tensor for symmetric σ: with it steady shear gives
//! σ_xx = σ_yy = 0 and σ_xy = ηγ̇, no shear thinning and no normal stresses, which contradicts
//! the thesis's own Figs. 3.5–3.6. The Jaumann form above is what is implemented
//! (docs/theory/sph_maxwell.md §1.9 erratum); in simple shear v_x = γ̇y it gives
//! dτ_xx/dt = γ̇τ_xy − τ_xx/λ, dτ_yy/dt = −γ̇τ_xy − τ_yy/λ,
//! dτ_xy/dt = (γ̇/2)(τ_yy − τ_xx) + η_pγ̇/λ − τ_xy/λ.
//!
//! The corotational and linear models keep tr τ = 0 (tr(Ωτ − τΩ) = tr D̄ = 0); it is monitored,
//! not enforced (`stress_trace` observable). The upper-convected model (Oldroyd-B with a
//! solvent viscosity `fluid.viscosity`) has a non-zero trace: in steady shear
//! τ_xx = 2η_pλγ̇², τ_yy = τ_zz = 0, so η = η_s + η_p, Ψ₁ = 2η_pλ, Ψ₂ = 0; it uses the full
//! rate of strain D (= D̄ for an incompressible flow; the weakly compressible tr G is O(M²)).
//!
//! The stress is stored packed, the upper triangle row by row: (xx, xy, yy) in 2D,
//! (xx, xy, xz, yy, yz, zz) in 3D.

use crate::config::flow::{Precision as ConnectorPrecision, SchemeKind, SpringKind};
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
    pub precision: Option<ConnectorPrecision>,
}

impl PolymerCfg {
    /// Whether the stress comes from dumbbell ensembles (CONNFFESSIT) rather than a
    /// constitutive equation.
    pub fn is_ensemble(&self) -> bool {
        self.model == PolymerModel::Dumbbells
    }

    /// The ensembles' spring law (Hookean unless `spring = "fene"`).
    pub fn spring_law(&self) -> Spring {
        crate::config::flow::spring_law(self.spring.unwrap_or(SpringKind::Hookean), self.b)
    }

    /// The ensembles' scheme, with its default (Heun for Hookean, semi-implicit for FENE).
    pub fn scheme_or_default(&self) -> Scheme {
        crate::config::flow::scheme_or_default(
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

    /// The connectors' storage precision.
    pub fn connector_precision(&self) -> Precision {
        match self.precision.unwrap_or_default() {
            ConnectorPrecision::Double => Precision::Double,
            ConnectorPrecision::Single => Precision::Single,
        }
    }

    /// Bytes of connector storage per fluid particle (0 for a constitutive model).
    pub fn bytes_per_particle(&self, dimension: usize) -> f64 {
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

/// `[fluid.polymer] model`
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PolymerModel {
    /// The corotational (Jaumann) Maxwell model of Ellero 2004 ch. 3 (sign corrected).
    CorotationalMaxwell,
    /// The upper-convected Maxwell model (Oldroyd-B with `fluid.viscosity` > 0).
    UpperConvectedMaxwell,
    /// Every fluid particle carries `per_particle` Brownian dumbbells advanced with its own
    /// velocity gradient; their Kramers stress G(⟨QF(Q)⟩ − I), G = η_p/λ, is τ (CONNFFESSIT,
    /// [`crate::models::dumbbell_ensemble`]). Hookean dumbbells are the stochastic
    /// counterpart of `upper_convected_maxwell`.
    Dumbbells,
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

/// A polymer model with its parameters, as the gradient pass applies it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Maxwell {
    /// Which model.
    pub model: PolymerModel,
    /// η_p.
    pub viscosity: f64,
    /// λ.
    pub relaxation_time: f64,
    /// Whether the corotational rotation terms are on.
    pub rotation: bool,
}

impl Maxwell {
    /// The constitutive model of a `[fluid.polymer]` table (none for dumbbell ensembles, whose
    /// stress is no function of τ and G).
    pub fn constitutive(c: &PolymerCfg) -> Option<Self> {
        (!c.is_ensemble()).then_some(Self {
            model: c.model,
            viscosity: c.viscosity,
            relaxation_time: c.relaxation_time,
            rotation: c.rotation,
        })
    }
}

impl Maxwell {
    /// The rate dτ/dt (packed) at stress `tau` (packed) and velocity gradient `g`
    /// (g[a][b] = ∂v^a/∂x^b), written into `rate`.
    #[inline]
    pub fn rate<const D: usize>(&self, tau: &[f64], g: &[[f64; D]; D], rate: &mut [f64]) {
        let t = unpack::<D>(tau);
        let inv_lambda = 1.0 / self.relaxation_time;
        let modulus = self.viscosity * inv_lambda; // G = η_p/λ
        let trace_over_d = (0..D).map(|a| g[a][a]).sum::<f64>() / D as f64;
        for a in 0..D {
            for b in a..D {
                let strain = 0.5 * (g[a][b] + g[b][a]);
                let mut r = match self.model {
                    PolymerModel::CorotationalMaxwell => {
                        let deviatoric = if a == b {
                            strain - trace_over_d
                        } else {
                            strain
                        };
                        2.0 * modulus * deviatoric
                    }
                    PolymerModel::UpperConvectedMaxwell => 2.0 * modulus * strain,
                    PolymerModel::Dumbbells => unreachable!("`constitutive` builds none"),
                };
                r -= t[a][b] * inv_lambda;
                match self.model {
                    PolymerModel::CorotationalMaxwell if self.rotation => {
                        // (Ωτ − τΩ)^{ab} = Σ_c Ω^{ac} τ^{cb} − τ^{ac} Ω^{cb}.
                        for c in 0..D {
                            let omega_ac = 0.5 * (g[a][c] - g[c][a]);
                            let omega_cb = 0.5 * (g[c][b] - g[b][c]);
                            r += omega_ac * t[c][b] - t[a][c] * omega_cb;
                        }
                    }
                    PolymerModel::CorotationalMaxwell | PolymerModel::Dumbbells => {}
                    PolymerModel::UpperConvectedMaxwell => {
                        // (Gτ + τGᵀ)^{ab} = Σ_c G^{ac} τ^{cb} + τ^{ac} G^{bc}.
                        for c in 0..D {
                            r += g[a][c] * t[c][b] + t[a][c] * g[b][c];
                        }
                    }
                }
                rate[packed_index::<D>(a, b)] = r;
            }
        }
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
    /// v = γ̇ y x̂ (G_xy = γ̇) with classical RK4, from τ = 0 to `t_end`.
    fn start_up<const D: usize>(m: &Maxwell, rate_of_shear: f64, t_end: f64) -> Vec<f64> {
        let mut g = [[0.0; D]; D];
        g[0][1] = rate_of_shear;
        let w = packed_width(D);
        let f = |tau: &[f64]| {
            let mut r = vec![0.0; w];
            m.rate::<D>(tau, &g, &mut r);
            r
        };
        let steps = 20_000;
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
            let m = Maxwell {
                model: PolymerModel::CorotationalMaxwell,
                viscosity: eta,
                relaxation_time: wi / gamma,
                rotation: true,
            };
            for t in [0.3, 1.0, 2.5, 7.0] {
                let tau2 = start_up::<2>(&m, gamma, t);
                let tau3 = start_up::<3>(&m, gamma, t);
                let scale = eta * gamma / (1.0 + wi * wi);
                let decay = (-t / m.relaxation_time).exp();
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
        let m = Maxwell {
            model: PolymerModel::CorotationalMaxwell,
            viscosity: 2.0,
            relaxation_time: 0.5,
            rotation: false,
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
        let m = Maxwell {
            model: PolymerModel::UpperConvectedMaxwell,
            viscosity: eta,
            relaxation_time: lambda,
            rotation: true,
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
