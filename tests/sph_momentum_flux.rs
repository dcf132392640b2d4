//! The SPH momentum flux (`src/models/sph/momentum_flux.rs`) against lattice sums written here
//! from the kernel's formula, independently of the code under test.
//!
//! On a square lattice of spacing Δ (every particle alike, summation density ρ_L = Σ_j m W_ij
//! with j = i included) in a Lees–Edwards box sheared at γ̇ with the exact linear profile, the
//! pair forces of the momentum equation carry, per unit volume (N/V = 1/Δ², m/ρ_L per particle),
//!
//! ```text
//! pressure:  P_xx = P_yy = −p(ρ_L) (m/(ρ_L Δ²)) M_yy,  M_yy = Σ_j (m/ρ_L) (W'(r)/r) y_j² ≈ −1
//!            P_xy = 0
//! Morris:    P_xy = (1/Δ²) · ½ Σ_j m² (2η/ρ_L²) (W'/r) γ̇ y_j²   (x-momentum across y = const)
//!            P_yx = 0                        (Morris's force is along v_ij: no y-momentum)
//! ```
//!
//! Every pair crossing the periodic and the Lees–Edwards boundaries counts once: an owned–ghost
//! pair adds half on each side, so a wrong weight or a wrong lever shows at the 10⁻¹ level.
//! Mutations that fail it (run 2026-11-26): an owned–ghost pair counted in full instead of half
//! (pressure 5.8156 against 5.2690); the lever and the force swapped in the tensor (F^b ℓ^a):
//! the Morris part moves to P_yx.

mod common;
use common::case_from_str;
use std::f64::consts::PI;

const SPACING: f64 = 0.05;
const SUPPORT: f64 = 0.15;
const MASS: f64 = 0.0025;
const SOUND: f64 = 10.0;
const BACKGROUND: f64 = 5.0;
const ETA: f64 = 0.5;
const SHEAR: f64 = 1.0;

/// Lucy's kernel in 2D, W(r) = 5/(πh²) (1 + 3r/h)(1 − r/h)³, and W'(r)/r = −60/(πh⁴) (1 − r/h)².
fn lucy(r: f64) -> (f64, f64) {
    let h = SUPPORT;
    if r >= h {
        return (0.0, 0.0);
    }
    let q = 1.0 - r / h;
    (
        5.0 / (PI * h * h) * (1.0 + 3.0 * r / h) * q * q * q,
        -60.0 / (PI * h.powi(4)) * q * q,
    )
}

/// ρ_L, M_xx (= M_yy) and Σ_j (W'/r) y_j² of the square lattice.
fn lattice_sums() -> (f64, f64, f64) {
    let n = (SUPPORT / SPACING).ceil() as i64 + 1;
    let (mut rho, mut wyy) = (lucy(0.0).0 * MASS, 0.0);
    for i in -n..=n {
        for j in -n..=n {
            if (i, j) == (0, 0) {
                continue;
            }
            let (x, y) = (i as f64 * SPACING, j as f64 * SPACING);
            let (w, dw) = lucy((x * x + y * y).sqrt());
            rho += MASS * w;
            wyy += dw * y * y;
        }
    }
    (rho, MASS / rho * wyy, wyy)
}

fn case() -> String {
    format!(
        r#"
title = "SPH momentum flux on a sheared lattice"
dimension = 2
[box]
lengths = [1.0, 1.0]
shear_rate = {SHEAR}
[particles]
lattice = "cubic"
density = 400.0
mass = {MASS}
temperature = 0.0
[fluid]
kind = "sph"
kernel = "lucy"
smoothing_length = {SUPPORT}
rest_density = 1.0
sound_speed = {SOUND}
viscosity = {ETA}
viscous_term = "morris"
equation_of_state = "tait"
background_pressure = {BACKGROUND}
[integrator]
kind = "kick_drift_kick"
dt = 1e-9
[neighbour]
skin = 0.01
[run]
steps = 2
sample_every = 1
[diagnostics]
observables = ["stress"]
blocks = 2
"#
    )
}

#[test]
fn pressure_and_morris_flux_match_the_lattice_sums_on_1_to_3_ranks() {
    let (rho, m_yy, wyy) = lattice_sums();
    // Tait: p = (c₀²ρ₀/7)((ρ/ρ₀)⁷ − 1) + p_b.
    let p = SOUND * SOUND / 7.0 * (rho.powi(7) - 1.0) + BACKGROUND;
    let n_per_volume = 1.0 / (SPACING * SPACING);
    // Pressure: (1/Δ²) · ½ Σ_j m²(2p/ρ²)(−W'/r) y² = −p (m/(ρΔ²)) M_yy.
    let pressure = -p * n_per_volume * MASS / rho * m_yy;
    // Morris: ½ Σ_j m² 2η/ρ² (W'/r) γ̇ y² per particle.
    let morris = n_per_volume * MASS * MASS * ETA / (rho * rho) * SHEAR * wyy;
    let loaded = case_from_str(&case(), "flux_lattice.toml");
    for ranks in 1..=3 {
        let s = mesorheo::driver::run_in_process(&loaded, ranks, 1, None)
            .unwrap_or_else(|e| panic!("{ranks} ranks: {e}"));
        let got = |name: &str| {
            s.observables
                .get(name)
                .unwrap_or_else(|| panic!("{name} missing: {:?}", s.observables.keys()))
                .mean
        };
        eprintln!(
            "{ranks} ranks: ρ_L = {rho:.6}, p = {p:.6}; pressure xx {:.9} (expected {pressure:.9}), \
             Morris xy {:.9} (expected {morris:.9}), yx {:.3e}",
            got("stress_pressure_xx"),
            got("stress_viscous_xy"),
            got("stress_viscous_yx")
        );
        // Δt = 10⁻⁹: the lattice moves by γ̇ y Δt ≤ 10⁻⁹ before the sample, a relative change
        // of ~10⁻⁸ in the sums; 10⁻⁶ leaves room and still sees any miscounted pair (10⁻²).
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs().max(1e-3);
        for c in ["xx", "yy"] {
            let v = got(&format!("stress_pressure_{c}"));
            assert!(close(v, pressure), "pressure {c}: {v} vs {pressure}");
        }
        assert!(got("stress_pressure_xy").abs() < 1e-9);
        assert!(
            close(got("stress_viscous_xy"), morris),
            "Morris xy: {} vs {morris}",
            got("stress_viscous_xy")
        );
        assert!(
            got("stress_viscous_yx").abs() < 1e-9,
            "Morris carries no yx"
        );
        assert!(got("stress_polymer_xy").abs() < 1e-15);
    }
}
