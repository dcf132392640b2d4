//! Pass 1a: the summation density ρ_i = Σ_j m_j W_ij (with the particle itself).

#[allow(unused_imports)]
use super::*;

/// Pass: summation density, m_j W_ij and the self term m_i W(0).
pub(super) struct DensityKernel<K> {
    pub(super) kernel: K,
    pub(super) mass: f64,
    pub(super) scales: [Scale; 1],
}

impl<const D: usize, K: Kernel> GatherKernel<D> for DensityKernel<K> {
    fn scales(&self) -> &[Scale] {
        &self.scales
    }
    fn cutoff(&self) -> f64 {
        self.kernel.support()
    }
    #[inline(always)]
    fn pair(&self, _: &Particles<D>, _: usize, _: usize, _: &[f64; D], r: f64, out: &mut [f64]) {
        out[0] = self.mass * self.kernel.w(r);
    }
    fn self_term(&self, _: &Particles<D>, _: usize, out: &mut [f64]) -> bool {
        out[0] = self.mass * self.kernel.w(0.0);
        true
    }
}

impl<const D: usize, K: Kernel> SymmetricKernel<D> for DensityKernel<K> {
    fn parities(&self) -> &[Parity] {
        &[Parity::Even]
    }
}
