//! `mesorheo check`: validates a case and prints what it will cost and whether Δt is safe.

use crate::config::{Case, FluidCfg};
use crate::stability::{ball_volume, dpd_limits};

/// Bytes per owned particle (core fields) and per neighbour entry / pair.
const BYTES_CORE: f64 = 8.0 + 4.0 * 8.0 * 3.0 + 4.0 * 3.0;

/// Largest rank count whose slabs are at least cutoff + skin wide.
pub fn max_ranks(case: &Case) -> usize {
    let axis = case.decomposition.axis.index();
    let range = case.cutoff() + case.neighbour.skin;
    (case.domain.lengths[axis] / range).floor().max(1.0) as usize
}

/// The report `check` prints.
pub fn report(case: &Case, ranks: usize) -> String {
    let FluidCfg::Dpd(d) = &case.fluid;
    let dim = case.dimension;
    let (cells, n) = case.lattice_counts();
    let volume: f64 = case.domain.lengths.iter().product();
    let density = n as f64 / volume;
    let lim = dpd_limits(case);
    let dt = case.integrator.dt();
    let skin = case.neighbour.skin;
    let range = d.cutoff + skin;
    let list_neighbours = density * ball_volume(dim, range);
    let axis = case.decomposition.axis.index();
    let l_axis = case.domain.lengths[axis];
    let max_ranks = (l_axis / range).floor().max(1.0) as usize;
    let m = case.particles.mass;
    let mut s = String::new();
    let mut line = |t: String| {
        s.push_str(&t);
        s.push('\n');
    };
    line(format!(
        "case: {}",
        if case.title.is_empty() {
            "(untitled)"
        } else {
            &case.title
        }
    ));
    line(format!(
        "particles: {n} ({}; lattice cells {:?}), number density {density:.4} (asked {})",
        format!("{:?}", case.particles.lattice).to_lowercase(),
        cells,
        case.particles.density
    ));
    line(format!(
        "neighbours per particle: {:.1} within r_c, {:.1} within r_c + skin (list)",
        lim.neighbours, list_neighbours
    ));
    let alpha = d.gamma * d.gamma * d.cutoff / (m * d.a.max(f64::MIN_POSITIVE));
    line(format!(
        "DPD: a = {}, γ = {}, k_BT = {}, r_c = {}, s = {}, σ = {:.4}, α = γ² r_c/(m a) = {:.3}",
        d.a,
        d.gamma,
        d.kt,
        d.cutoff,
        d.weight_exponent,
        (2.0 * d.gamma * d.kt).sqrt(),
        alpha
    ));
    if dim == 3 {
        // Kinetic-theory estimate (Groot & Warren 1997, Eq. 33, s = 2) and their EOS for c².
        let rho_m = density * m;
        let eta = 45.0 * d.kt / (4.0 * std::f64::consts::PI * d.gamma * d.cutoff.powi(3))
            + 2.0 * std::f64::consts::PI * d.gamma * density * density * d.cutoff.powi(5) / 1575.0;
        let c2 = d.kt / m + 2.0 * 0.101 * d.a * density * d.cutoff.powi(4) / m;
        line(format!(
            "estimates (Groot–Warren kinetic theory, s = 2): η ≈ {eta:.3}, sound speed c ≈ {:.3}",
            c2.sqrt()
        ));
        let shear = case.domain.shear_rate;
        if shear != 0.0 {
            let ly = case.domain.lengths[1];
            let u = shear.abs() * ly / 2.0;
            line(format!(
                "shear: γ̇ = {shear}, Re = ρ γ̇ L_y²/η ≈ {:.3}, Ma = (γ̇ L_y/2)/c ≈ {:.3}",
                rho_m * shear.abs() * ly * ly / eta,
                u / c2.sqrt()
            ));
        }
    }
    let ok = |limit: f64| if dt < limit { "ok" } else { "VIOLATED" };
    line(format!(
        "time step Δt = {dt}: dissipative limit m/(γ Σw_D) = {:.4} [{}], Verlet limit 2/ω = {:.4} [{}], Groot–Warren accuracy guide Δt ≤ 0.06 at a = 25 [{}]",
        lim.dissipative,
        ok(lim.dissipative),
        lim.conservative,
        ok(lim.conservative),
        if dt <= 0.06 {
            "ok"
        } else {
            "expect k_BT errors > few %"
        }
    ));
    let slab = l_axis / ranks as f64;
    line(format!(
        "decomposition: slabs along {}, {ranks} rank(s) → width {slab:.3} (needs ≥ {range}); at most {max_ranks} ranks [{}]",
        ["x", "y", "z"][axis],
        if ranks <= max_ranks {
            "ok"
        } else {
            "TOO MANY RANKS"
        }
    ));
    let owned = n as f64 / ranks as f64;
    let ghosts = if ranks == 1 {
        // self-images on every periodic face
        n as f64 * (2.0 * range * case.domain.lengths.iter().map(|l| 1.0 / l).sum::<f64>())
    } else {
        owned * 2.0 * range / slab
    };
    let bytes_entry = 8.0;
    let bytes_pair = 8.0 + (dim as f64 + 4.0) * 8.0;
    let mem = owned * BYTES_CORE
        + ghosts * (8.0 + 2.0 * 8.0 * dim as f64)
        + owned * list_neighbours * (bytes_entry + 0.5 * bytes_pair);
    line(format!(
        "memory per rank ≈ {:.1} MiB ({:.0} owned + {:.0} ghost particles)",
        mem / 1048576.0,
        owned,
        ghosts
    ));
    let pair_evals = n as f64 * lim.neighbours / 2.0;
    line(format!(
        "cost: {} steps × {n} particles = {:.3e} particle-steps, {:.3e} pair evaluations per step",
        case.run.steps,
        case.run.steps as f64 * n as f64,
        pair_evals
    ));
    s
}
