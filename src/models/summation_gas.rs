//! The engine's two-pass test model (`[fluid] kind = "summation_gas"`): an isothermal SPH gas
//! whose pressure force needs the *neighbours'* densities, so the ghosts' densities must be
//! refreshed between its two passes. It exists to exercise the model layer (multi-pass
//! evaluation, ghost-field refresh, gather passes, per-quantity scales) on every rank count;
//! the SPH models proper (kernels, viscosity, walls, equations of state) build on the same
//! interface. Standard SPH (Monaghan 1992; docs/theory/sph_maxwell.md §1):
//!
//! ```text
//! pass 1   ρ_i = m W(0, h) + Σ_j m W(r_ij, h)                          (summation density)
//! pass 2   F_i = − Σ_j m² (p_i/ρ_i² + p_j/ρ_j²) W'(r_ij) e_ij,  p = c² ρ
//!              = − Σ_j m² c² (1/ρ_i + 1/ρ_j) W'(r_ij) r_ij / r_ij
//! Lucy     W(r, h) = α_D (1 + 3q)(1 − q)³,  q = r/h < 1  ([`Lucy`], tested with the SPH kernels)
//! ```
//!
//! The pair force term is antisymmetric to the last bit (1/ρ_i + 1/ρ_j is commutative and
//! r_ij changes sign), so momentum is conserved pair by pair. Scales of the exact sums: a
//! density term is at most m α_D; since ρ ≥ m W(0) = m α_D (the self term) and
//! max|W'| = 16 α_D/(9h) (at q = 1/3), a force term is at most 32 m c²/(9h) — a bound, so only
//! a non-finite term can fall outside it.

use crate::error::Error;
use crate::fixed_sum::Scale;
use crate::models::gather::{FullList, GatherKernel, gather};
use crate::models::interface::{
    FieldKind, FieldSpec, ParticleModel, PassContext, PassOutput, PassSpec,
};
use crate::models::sph::kernels::{Kernel, Lucy};
use crate::particles::{FieldFlags, Particles};
use serde::{Deserialize, Serialize};

/// `[fluid] kind = "summation_gas"`
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SummationGasCfg {
    /// Smoothing length h (the Lucy kernel's support, the interaction cutoff).
    pub smoothing_length: f64,
    /// Isothermal sound speed c (p = c² ρ).
    pub sound_speed: f64,
}

/// The summation-density field's name.
pub const DENSITY: &str = "density";

/// The summation density ρ_i = m Σ_j W(r_ij), the particle itself included: m W(r) from every
/// neighbour and from the particle itself (pass 1 here; the GENERIC polymer particle's
/// transport-velocity density too).
pub(crate) struct DensityKernel {
    pub(crate) lucy: Lucy,
    pub(crate) mass: f64,
    pub(crate) scales: [Scale; 1],
}

impl<const D: usize> GatherKernel<D> for DensityKernel {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }

    fn cutoff(&self) -> f64 {
        self.lucy.support()
    }

    #[inline]
    fn pair(&self, _: &Particles<D>, _: usize, _: usize, _: &[f64; D], r: f64, out: &mut [f64]) {
        out[0] = self.mass * self.lucy.w(r);
    }

    fn self_term(&self, _: &Particles<D>, _: usize, out: &mut [f64]) -> bool {
        out[0] = self.mass * self.lucy.w(0.0);
        true
    }
}

/// Pass 2: the pressure force, reading both particles' densities.
struct PressureKernel<const D: usize> {
    lucy: Lucy,
    /// m² c².
    m2c2: f64,
    density: usize,
    scales: [Scale; D],
}

impl<const D: usize> GatherKernel<D> for PressureKernel<D> {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }

    fn cutoff(&self) -> f64 {
        self.lucy.support()
    }

    #[inline]
    fn pair(&self, p: &Particles<D>, i: usize, j: usize, r_ij: &[f64; D], r: f64, out: &mut [f64]) {
        let rho = &p.extra[self.density].data;
        let s = -(self.m2c2 * (1.0 / rho[i] + 1.0 / rho[j]) * self.lucy.dw_over_r(r));
        for d in 0..D {
            out[d] = s * r_ij[d];
        }
    }
}

/// The model: its parameters, the density field's index and a reusable output buffer.
pub struct SummationGas<const D: usize> {
    lucy: Lucy,
    mass: f64,
    sound_speed: f64,
    density: usize,
    sums: Vec<f64>,
}

impl<const D: usize> SummationGas<D> {
    /// The gas of particles of mass `mass`.
    pub fn new(cfg: &SummationGasCfg, mass: f64) -> Self {
        Self {
            lucy: Lucy::new(cfg.smoothing_length, D),
            mass,
            sound_speed: cfg.sound_speed,
            density: usize::MAX,
            sums: Vec::new(),
        }
    }

    fn density_kernel(&self) -> DensityKernel {
        DensityKernel {
            lucy: self.lucy,
            mass: self.mass,
            scales: [Scale::covering(self.mass * self.lucy.w(0.0))],
        }
    }

    fn pressure_kernel(&self) -> PressureKernel<D> {
        let m2c2 = self.mass * self.mass * self.sound_speed * self.sound_speed;
        let bound =
            32.0 * self.mass * self.sound_speed * self.sound_speed / (9.0 * self.lucy.support());
        PressureKernel {
            lucy: self.lucy,
            m2c2,
            density: self.density,
            scales: [Scale::covering(bound); D],
        }
    }
}

impl<const D: usize> ParticleModel<D> for SummationGas<D> {
    fn name(&self) -> &'static str {
        "summation_gas"
    }

    fn cutoff(&self) -> f64 {
        self.lucy.support()
    }

    fn fields(&self) -> Vec<FieldSpec> {
        vec![FieldSpec {
            name: DENSITY,
            kind: FieldKind::Scalar,
            flags: FieldFlags::DERIVED,
        }]
    }

    fn passes(&self) -> Vec<PassSpec> {
        vec![
            PassSpec {
                name: "summation density",
                ghost_fields: Vec::new(),
            },
            PassSpec {
                name: "pressure force",
                ghost_fields: vec![DENSITY],
            },
        ]
    }

    fn uses_full_list(&self) -> bool {
        true
    }

    fn attach(&mut self, particles: &mut Particles<D>, _restarted: bool) -> Result<(), Error> {
        self.density = particles
            .extra_index(DENSITY)
            .ok_or("the density field is not registered")?;
        Ok(())
    }

    fn pass(&mut self, pass: usize, ctx: PassContext<'_, D>) -> Result<PassOutput, Error> {
        let p = ctx.particles;
        let full: &FullList = ctx.full;
        let mut sums = std::mem::take(&mut self.sums);
        let n = p.n_owned;
        let result = if pass == 0 {
            gather(&self.density_kernel(), p, full, &mut sums).map(|()| {
                p.extra[self.density].data[..n].copy_from_slice(&sums);
            })
        } else {
            gather(&self.pressure_kernel(), p, full, &mut sums).map(|()| {
                for (f, s) in p.force.iter_mut().zip(sums.chunks_exact(D)) {
                    for d in 0..D {
                        f[d] += s[d];
                    }
                }
            })
        };
        self.sums = sums;
        result.map_err(|e| {
            e.at_step(
                crate::error::Quantity::PairForce,
                ctx.step,
                "summation gas pass",
            )
        })?;
        Ok(PassOutput::default())
    }
}

/// What the summation gas owns besides its passes ([`crate::models::FluidModel`]).
mod spec {
    use super::{SummationGas, SummationGasCfg};
    use crate::integrators::IntegratorCfg;
    use crate::models::fluid_model::CaseView;
    use crate::models::fluid_model::{BuildModels, FluidModel, ModelMemory, generic_support};
    use crate::models::interface::ParticleModel;
    use crate::observable::Observable;
    use crate::spans::{CaseError, Segment, SpanIndex};

    impl SummationGasCfg {
        /// The acoustic (CFL) limit 0.25 h/c.
        pub fn acoustic_limit(&self) -> f64 {
            0.25 * self.smoothing_length / self.sound_speed
        }
    }

    impl crate::models::fluid_model::KindTraits for SummationGasCfg {}

    impl FluidModel for SummationGasCfg {
        fn kind(&self) -> &'static str {
            "summation_gas"
        }

        fn cutoff(&self) -> f64 {
            self.smoothing_length
        }

        fn cutoff_key(&self) -> &'static str {
            "smoothing_length"
        }

        fn validate(&self, _case: &dyn CaseView, ix: &SpanIndex) -> Result<(), CaseError> {
            let fl = |key: &str| vec![Segment::Key("fluid".into()), Segment::Key(key.into())];
            if !(self.smoothing_length.is_finite() && self.smoothing_length > 0.0) {
                return Err(ix.error(
                    &fl("smoothing_length"),
                    format!("found {}; must be > 0", self.smoothing_length),
                ));
            }
            if !(self.sound_speed.is_finite() && self.sound_speed > 0.0) {
                return Err(ix.error(
                    &fl("sound_speed"),
                    format!("found {}; must be > 0", self.sound_speed),
                ));
            }
            Ok(())
        }

        fn accepts_integrator(&self, integrator: &IntegratorCfg) -> Result<(), String> {
            crate::models::dpd::spec::groot_warren_only(integrator)
        }

        fn time_step_limits(&self, _case: &dyn CaseView) -> Vec<(String, f64)> {
            vec![("acoustic (CFL) 0.25 h/c".to_string(), self.acoustic_limit())]
        }

        fn time_step_error(&self, _case: &dyn CaseView, dt: f64) -> Option<String> {
            let cfl = self.acoustic_limit();
            (dt > cfl).then(|| {
                format!(
                    "Δt = {dt} is beyond the acoustic (CFL) limit 0.25 h/c = {cfl:.4e}; use a \
                     smaller time step"
                )
            })
        }

        fn default_observables(&self, _case: &dyn CaseView) -> Vec<Observable> {
            vec![Observable::Temperature, Observable::Momentum]
        }

        fn supports(&self, _case: &dyn CaseView, o: Observable) -> Result<(), String> {
            if o.needs_pair_virial() {
                return Err(format!(
                    "\"{}\" needs the pair virial, which the summation gas does not compute \
                     (the default list has \"pressure\"); list only \"temperature\", \
                     \"momentum\" or \"velocity_profile\"",
                    o.name()
                ));
            }
            generic_support(o)
        }

        fn stress_parts(&self) -> Vec<&'static str> {
            crate::models::fluid_model::CENTRAL_STRESS_PARTS.to_vec()
        }

        fn report(&self, case: &dyn CaseView, _density: f64, line: &mut dyn FnMut(String)) {
            let dt = case.dt();
            let cfl = self.acoustic_limit();
            line(format!(
                "summation gas (the engine's two-pass test model): Lucy kernel h = {}, sound \
                 speed c = {}, p = c² ρ",
                self.smoothing_length, self.sound_speed
            ));
            line(format!(
                "time step Δt = {dt}: acoustic limit 0.25 h/c = {cfl:.4e} [{}]",
                if dt < cfl { "ok" } else { "VIOLATED" }
            ));
        }

        fn memory(&self, _case: &dyn CaseView) -> ModelMemory {
            ModelMemory::default()
        }
    }

    impl<const D: usize> BuildModels<D> for SummationGasCfg {
        fn build_fluid(&self, case: &dyn CaseView) -> Box<dyn ParticleModel<D>> {
            Box::new(SummationGas::<D>::new(self, case.mass()))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::gather::{Parity, pair_symmetry};
    use crate::neighbour::NeighbourList;
    use crate::rng::{Purpose, StreamKey};

    /// The pressure term of a pair is exactly antisymmetric and the density term exactly
    /// symmetric, for random positions and densities.
    #[test]
    fn pair_terms_are_bitwise_antisymmetric() {
        let key = StreamKey::new(3, Purpose::Test, 1);
        let mut p = Particles::<3>::default();
        for i in 0..300u32 {
            let x = std::array::from_fn(|d| 4.0 * key.uniform2(0, i, d as u32).0);
            p.push_owned(u64::from(i), x, [0.0; 3]);
        }
        let k = p
            .register_field(DENSITY, 1, FieldFlags::DERIVED)
            .expect("new");
        for i in 0..p.n_owned {
            p.extra[k].data[i] = 1.0 + key.uniform2(1, i as u32, 0).0;
        }
        let cfg = SummationGasCfg {
            smoothing_length: 1.2,
            sound_speed: 3.0,
        };
        let mut gas = SummationGas::<3>::new(&cfg, 0.7);
        gas.attach(&mut p, false).expect("attach");
        let list = NeighbourList::build(&p, 1.2, 1.2);
        let pressure = gas.pressure_kernel();
        let checked = pair_symmetry(&pressure, &p, &list, &[Parity::Odd; 3]).expect("odd");
        assert!(checked > 1000, "{checked} pairs");
        let density = gas.density_kernel();
        pair_symmetry(&density, &p, &list, &[Parity::Even]).expect("even");
    }
}
