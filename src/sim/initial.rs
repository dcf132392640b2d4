//! The initial state of a fresh run: lattice positions, boundary particles, velocities.

#[allow(unused_imports)]
use super::*;

/// Builds the initial particles of the whole system in global-id order — the same on every
/// rank, so nothing depends on the decomposition — and keeps this rank's. Returns them and the
/// total count.
///
/// A random start's positions are relaxed by the fluid model's soft start
/// ([`crate::models::fluid_model::BuildModels::relax_random_start`]) before the bodies'
/// constituents join.
///
/// Velocities: Maxwellian at k_BT from Philox keyed by id, centre-of-mass motion removed and
/// rescaled to exactly k_BT over D(N − 1) degrees of freedom; then the shear profile if asked.
///
/// With `bodies`, their constituents follow the fluid's particles in id order, each at its site,
/// and are thermalised like them; each free body starts with its constituents' mean velocity.
pub fn initial_particles<const D: usize>(
    case: &Case,
    sim_box: &SimBox<D>,
    slab: &Slab,
    bodies: Option<&mut crate::rigid_bodies::RigidBodies<D>>,
) -> (Particles<D>, u64) {
    let dim = D;
    let (cells, total) = case.lattice_counts();
    let wall_layers = case.walls.as_ref().map(|w| {
        let axis = w.axis.index();
        (axis, case.wall_layer_count(axis))
    });
    let mut positions: Vec<[f64; D]> = Vec::with_capacity(total as usize);
    match case.particles.lattice {
        Lattice::Random => {
            let key = StreamKey::new(case.seed, Purpose::InitialPosition, 0);
            for g in 0..total {
                let mut x = [0.0; D];
                let (a, b) = key.uniform2(0, g as u32, 0);
                let (c, _) = key.uniform2(0, g as u32, 1);
                let u = [a, b, c];
                for d in 0..D {
                    x[d] = u[d] * sim_box.lengths[d];
                }
                positions.push(x);
            }
            // The model's soft start (DPD: overlap removal, `fluid.soft_start_sweeps`), on the
            // whole system in id order: the same on every rank.
            case.fluid
                .builder::<D>()
                .relax_random_start(case, &mut positions);
        }
        lattice => {
            // Lattice sites at (k + 0.25) spacings; with walls, at (k + ½) along the wall axis,
            // so that the boundary rows mirror the fluid rows about each face.
            let mut offset = [0.25; D];
            if let Some((axis, _)) = wall_layers {
                offset[axis] = 0.5;
            }
            let basis: Vec<[f64; 3]> = match (lattice, dim) {
                (Lattice::Fcc, 3) => vec![
                    [0.0, 0.0, 0.0],
                    [0.5, 0.5, 0.0],
                    [0.5, 0.0, 0.5],
                    [0.0, 0.5, 0.5],
                ],
                (Lattice::Fcc, _) => vec![[0.0, 0.0, 0.0], [0.5, 0.5, 0.0]],
                _ => vec![[0.0; 3]],
            };
            let ncell: usize = cells.iter().product();
            for c in 0..ncell {
                let mut idx = [0usize; 3];
                let mut rem = c;
                for d in 0..D {
                    idx[d] = rem % cells[d];
                    rem /= cells[d];
                }
                for b in &basis {
                    let mut x = [0.0; D];
                    for d in 0..D {
                        let spacing = sim_box.lengths[d] / cells[d] as f64;
                        x[d] = (idx[d] as f64 + b[d] + offset[d]) * spacing;
                    }
                    positions.push(x);
                }
            }
            // Boundary particles: the lattice continued beyond both faces of the wall axis,
            // `layers` rows each side, after every fluid particle in id order.
            if let Some((axis, layers)) = wall_layers {
                let spacing = sim_box.lengths[axis] / cells[axis] as f64;
                let across: usize = (0..D).filter(|&d| d != axis).map(|d| cells[d]).product();
                for side in 0..2 {
                    for layer in 0..layers {
                        let depth = (layer as f64 + 0.5) * spacing;
                        for c in 0..across {
                            let mut x = [0.0; D];
                            let mut rem = c;
                            for d in (0..D).filter(|&d| d != axis) {
                                let sp = sim_box.lengths[d] / cells[d] as f64;
                                x[d] = ((rem % cells[d]) as f64 + offset[d]) * sp;
                                rem /= cells[d];
                            }
                            x[axis] = if side == 0 {
                                -depth
                            } else {
                                sim_box.lengths[axis] + depth
                            };
                            positions.push(x);
                        }
                    }
                }
            }
        }
    }
    if let Some(b) = &bodies {
        debug_assert_eq!(b.spec().first_gid, positions.len() as u64);
        // Sites near a face lie outside the box: wrapped in (no Lees–Edwards offset at step 0).
        positions.extend(b.initial_constituents().into_iter().map(|(_, mut x)| {
            sim_box.wrap(&mut x, &mut [], &mut [0; D], 0.0, true);
            x
        }));
    }
    let total = positions.len() as u64;
    let key = StreamKey::new(case.seed, Purpose::InitialVelocity, 0);
    let m = case.particles.mass;
    let kt = case.particles.temperature;
    let scale = (kt / m).sqrt();
    let mut velocities: Vec<[f64; D]> = (0..total)
        .map(|g| {
            let (a, b) = key.gaussian2(0, g as u32, 0);
            let (c, _) = key.gaussian2(0, g as u32, 1);
            let gs = [a, b, c];
            let mut v = [0.0; D];
            for d in 0..D {
                v[d] = scale * gs[d];
            }
            v
        })
        .collect();
    if total > 1 {
        let mut com = [0.0; D];
        for v in &velocities {
            for d in 0..D {
                com[d] += v[d];
            }
        }
        for c in &mut com {
            *c /= total as f64;
        }
        let mut ke2 = 0.0;
        for v in &mut velocities {
            for d in 0..D {
                v[d] -= com[d];
                ke2 += m * v[d] * v[d];
            }
        }
        let t_now = ke2 / (D as f64 * (total as f64 - 1.0));
        if t_now > 0.0 {
            let f = (kt / t_now).sqrt();
            for v in &mut velocities {
                for x in v.iter_mut() {
                    *x *= f;
                }
            }
        }
    }
    let shear_profile = match case.particles.velocity_profile {
        VelocityProfile::Auto => sim_box.sheared(),
        VelocityProfile::Shear => true,
        VelocityProfile::Rest | VelocityProfile::HalfSine => false,
    };
    let half_sine = case.particles.velocity_profile == VelocityProfile::HalfSine;
    let (amplitude, ly) = (case.particles.velocity_amplitude, sim_box.lengths[GRADIENT]);
    let mut particles = Particles::default();
    for (x, v) in positions.iter().zip(velocities.iter_mut()) {
        if shear_profile {
            v[0] += sim_box.streaming_velocity(x[GRADIENT]);
        }
        let y = x[GRADIENT];
        if half_sine && (0.0..=ly).contains(&y) {
            v[0] += amplitude * (std::f64::consts::PI * y / ly).sin();
        }
    }
    if let Some(b) = bodies {
        b.start_with_constituent_velocities(|gid| velocities[gid as usize]);
    }
    for (g, (x, v)) in positions.into_iter().zip(velocities).enumerate() {
        if slab.owner_of(x[slab.axis]) == slab.rank {
            particles.push_owned(g as u64, x, v);
        }
    }
    (particles, total)
}
