//! `mesorheo check`: validates a case and prints what it will cost and whether Δt is safe.

use crate::capacity::{
    check_particles_per_rank, check_rank_memory, particles_per_rank, rank_memory,
};
use crate::config::Case;
use crate::geometry::ball_volume;

/// The report `check` prints.
pub fn report(case: &Case, ranks: usize) -> String {
    let dim = case.dimension;
    let (cells, n) = case.lattice_counts();
    let volume: f64 = case.domain.lengths.iter().product();
    let density = n as f64 / volume;
    let skin = case.neighbour.skin;
    let cutoff = case.cutoff();
    let range = cutoff + skin;
    let neighbours = density * ball_volume(dim, cutoff);
    let list_neighbours = density * ball_volume(dim, range);
    let axis = case.decomposition.axis.index();
    let l_axis = case.domain.lengths[axis];
    let max_ranks = (l_axis / range).floor().max(1.0) as usize;
    let mut s = String::new();
    let mut line = |t: String| {
        s.push_str(&t);
        s.push('\n');
    };
    line(title_line(&case.title));
    line(format!(
        "particles: {n} ({}; lattice cells {:?}), number density {density:.4} (asked {})",
        format!("{:?}", case.particles.lattice).to_lowercase(),
        cells,
        case.particles.density
    ));
    // Constituents of suspended bodies come on top of the lattice (the solvent keeps its
    // density): counted apart, and in the cost.
    let constituents = case.fluid.model().constituent_count(case);
    if constituents > 0 {
        line(format!(
            "particles with colloids: {n} solvent + {constituents} colloid constituents = {}",
            n + constituents
        ));
    }
    let n = n + constituents;
    line(format!(
        "neighbours per particle: {:.1} within r_c, {:.1} within r_c + skin (list)",
        neighbours, list_neighbours
    ));
    case.fluid.model().report(case, density, &mut line);
    let slab = l_axis / ranks as f64;
    line(format!(
        "decomposition: slabs along {}, {ranks} rank(s) → width {slab:.3} (needs ≥ {range:.4}); at most {max_ranks} ranks [{}]",
        ["x", "y", "z"][axis],
        if ranks <= max_ranks {
            "ok"
        } else {
            "TOO MANY RANKS"
        }
    ));
    let (owned, ghosts) = particles_per_rank(case, ranks);
    if let Err(e) = check_particles_per_rank(case, ranks) {
        line(format!("PARTICLES PER RANK: {e}"));
    }
    let mem = rank_memory(case, ranks);
    line(format!(
        "memory per rank ≈ {:.1} MiB ({:.0} owned + {:.0} ghost particles) [{}]",
        mem / 1048576.0,
        owned,
        ghosts,
        match check_rank_memory(case, ranks, crate::capacity::available_memory()) {
            Ok(()) => "ok".to_string(),
            Err(e) => format!("DOES NOT FIT: {e}"),
        }
    ));
    let pair_evals = n as f64 * neighbours / 2.0;
    line(format!(
        "cost: {} steps × {n} particles = {:.3e} particle-steps, {:.3e} pair evaluations per step",
        case.run.steps,
        case.run.steps as f64 * n as f64,
        pair_evals
    ));
    case.fluid.model().cost_report(case, n as f64, &mut line);
    s
}

/// The report `check` prints for a homogeneous-flow scene, and whether it fits this machine
/// on `ranks` ranks (memory of the largest rank's ensembles against MemAvailable here).
pub fn flow_report(case: &crate::config::FlowCase, ranks: usize) -> (String, Result<(), String>) {
    use crate::config::flow::{FlowKind, Precision};
    let p = &case.polymer;
    let params = case.dumbbell_params();
    let n = case.flow.particles;
    let n_d = p.per_particle as u64;
    let dim = case.dimension;
    let lambda = p.relaxation_time;
    let gib = 1024.0 * 1024.0 * 1024.0;
    let per_rank = crate::flow_scene::rank_memory(case, ranks, 0);
    let total = n as f64 * p.bytes_per_particle(dim);
    let mut s = String::new();
    let mut line = |t: String| {
        s.push_str(&t);
        s.push('\n');
    };
    line(title_line(&case.title));
    line(format!(
        "homogeneous flow: {:?}, rate {} ({}D); Weissenberg number Wi = rate × λ = {:.4}",
        case.flow.kind,
        case.flow.rate,
        dim,
        case.flow.rate * lambda
    ));
    if case.flow.kind == FlowKind::UniaxialElongation && case.flow.rate * lambda >= 0.5 {
        line(
            "  note: ε̇λ ≥ 1/2 is beyond the coil–stretch transition: Hookean dumbbells stretch \
             without bound (no steady state); FENE ones saturate"
                .into(),
        );
    }
    line(format!(
        "dumbbells: {n} particles × {n_d} = {:.3e}, spring {:?}, scheme {:?}, λ = {lambda}, G = {}",
        (n * n_d) as f64,
        params.spring,
        params.scheme,
        p.modulus
    ));
    line(format!(
        "time step: Δt = {} = {:.4} λ; {} steps = {:.3} λ; equilibration {} steps; sample every {}",
        params.dt,
        params.dt / lambda,
        case.run.steps,
        case.run.steps as f64 * params.dt / lambda,
        case.run.equilibration,
        case.run.sample_every
    ));
    line(match crate::config::flow::explicit_stability_limit(case) {
        Some(limit) => format!(
            "stability: explicit scheme, Δt < 0.95 × 4λ/(1 + 2λc) = {limit:.4} [{}]",
            if params.dt < limit {
                "ok"
            } else {
                "BEYOND (run.beyond_stability_limits)"
            }
        ),
        None => "stability: semi-implicit scheme, stable at any Δt [ok]".to_string(),
    });
    for w in crate::config::flow::accuracy_warnings(case) {
        line(format!("accuracy: {w} [warning]"));
    }
    for l in p.storage_check_lines(dim, params.dt) {
        line(l);
    }
    line(format!(
        "memory: {:.3} MiB on the largest of {ranks} rank(s), {:.3} MiB in all ({}{})",
        per_rank / (1024.0 * 1024.0),
        total / (1024.0 * 1024.0),
        match (p.histogram_grid(), p.precision) {
            (Some(_), _) => "BDDFS histograms, at most",
            (None, Precision::Double) => "double precision",
            (None, Precision::Single) => "single precision",
        },
        if p.variance_reduction {
            ", × 2 for the control copies"
        } else {
            ""
        }
    ));
    let work = (n * n_d) as f64 * case.run.steps as f64;
    line(format!(
        "cost: {work:.3e} dumbbell-steps; at ~5·10⁷ dumbbell-steps/s per core (Hookean, \
         docs/performance.md) about {:.1} core-seconds",
        work / 5e7
    ));
    let free = crate::capacity::available_memory();
    let verdict = match free {
        Some(free) if per_rank > 0.9 * free => Err(format!(
            "one rank's ensembles need {:.2} GiB but this machine has {:.2} GiB available; use \
             more ranks, fewer dumbbells per particle or polymer.precision = \"single\"",
            per_rank / gib,
            free / gib
        )),
        Some(free) if total > 0.9 * free => {
            line(format!(
                "  note: all ranks together need {:.2} GiB, more than this machine's {:.2} GiB \
                 available: spread them over several nodes",
                total / gib,
                free / gib
            ));
            Ok(())
        }
        _ => Ok(()),
    };
    (s, verdict)
}

/// The first line of every `check` report: the case's title.
fn title_line(title: &str) -> String {
    let title = if title.is_empty() {
        "(untitled)"
    } else {
        title
    };
    format!("case: {title}")
}
