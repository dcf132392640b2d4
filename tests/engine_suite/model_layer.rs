//! The model layer: a two-pass model (the summation gas: density by summation, then a pressure
//! force from both particles' densities, so the ghosts' densities must be refreshed between
//! the passes) is bitwise identical on 1–4 in-process ranks × 1–2 threads with Lees–Edwards
//! shear on, reproduces the discrete lattice sum of its kernel, conserves momentum; and the
//! ghost-field refresh delivers every ghost its original's value, with the Lees–Edwards
//! velocity shift on velocity-like fields and on no others.

use crate::common;
use common::{assert_all_equal, case_from_str, digests_on_1_to_4_ranks, small_gas};
use mesorheo::comm::Comm;
use mesorheo::driver::{in_process, run_in_process};
use mesorheo::facade::Engine;
use mesorheo::models::interface::{
    FieldKind, FieldSpec, ParticleModel, PassContext, PassOutput, PassSpec,
};
use mesorheo::models::summation_gas::DENSITY;
use mesorheo::particles::{FieldFlags, Particles};
use mesorheo::sim::Simulation;

/// A summation-gas case (the shared one of the tests).
fn gas_case(dimension: usize, side: f64, shear: f64, lattice: &str, steps: u64) -> String {
    small_gas(dimension, side, shear, lattice, steps, "")
}

fn digests(text: &str, name: &str) -> Vec<(usize, usize, String)> {
    digests_on_1_to_4_ranks(text, name, |_| {})
}

#[test]
fn two_pass_model_under_lees_edwards_is_bitwise_identical_on_1_to_4_ranks_2d() {
    let d = digests(&gas_case(2, 8.0, 0.5, "random", 200), "gas_le_2d");
    assert_all_equal("summation gas, Lees–Edwards 2D", &d);
}

#[test]
fn two_pass_model_under_lees_edwards_is_bitwise_identical_on_1_to_4_ranks_3d() {
    let d = digests(&gas_case(3, 6.0, 0.3, "random", 100), "gas_le_3d");
    assert_all_equal("summation gas, Lees–Edwards 3D", &d);
}

/// Lucy's kernel written out here, independently of the model's code.
fn lucy(r: f64, h: f64, dimension: usize) -> f64 {
    let q = r / h;
    if q >= 1.0 {
        return 0.0;
    }
    let norm = if dimension == 2 {
        5.0 / (std::f64::consts::PI * h * h)
    } else {
        105.0 / (16.0 * std::f64::consts::PI * h.powi(3))
    };
    norm * (1.0 + 3.0 * q) * (1.0 - q).powi(3)
}

/// On a perfect square (cubic) lattice every particle's summation density is the discrete
/// lattice sum m Σ_n W(|n| Δ) over the lattice vectors within h — computed here directly —
/// whatever the rank count (the periodic and slab images are all ghosts), and the pressure
/// forces cancel by symmetry. Tolerances: the exact sums round once, so 1e-13 relative on ρ
/// is ~500 ulp of slack for the different summation order of the reference loop; the force
/// on a particle is a sum of O(10) terms of size m²c²/ρ·|W'| ≈ 1 that cancel, so 1e-12.
#[test]
fn summation_density_on_a_lattice_equals_the_lattice_sum_on_any_rank_count() {
    for (dimension, side) in [(2usize, 8.0), (3, 6.0)] {
        let text = gas_case(dimension, side, 0.0, "cubic", 100);
        let loaded = case_from_str(&text, "lattice");
        // The initialiser puts round(L/Δ₀) cells along each axis, Δ₀ = (1/n)^(1/D).
        let cells = (side / (1.0 / 4.0f64).powf(1.0 / dimension as f64)).round();
        let spacing = side / cells;
        let h = 1.2;
        let reach = (h / spacing).ceil() as i64;
        let mut want = 0.0;
        let range = -reach..=reach;
        for a in range.clone() {
            for b in range.clone() {
                for c in if dimension == 3 { range.clone() } else { 0..=0 } {
                    let r = spacing * ((a * a + b * b + c * c) as f64).sqrt();
                    want += lucy(r, h, dimension);
                }
            }
        }
        for ranks in [1, 2, 3] {
            let case = loaded.case.clone();
            let [deviation, largest_force, count] =
                in_process(ranks, move |comm: &dyn Comm| match case.dimension {
                    2 => probe::<2>(&case, comm, want),
                    _ => probe::<3>(&case, comm, want),
                })
                .expect("run");
            assert_eq!(count, cells.powi(dimension as i32), "particles checked");
            assert!(
                deviation <= 1e-13,
                "{dimension}D on {ranks} ranks: ρ off the lattice sum {want} by {deviation:e}"
            );
            assert!(largest_force < 1e-12, "{dimension}D: |F| = {largest_force}");
        }
    }
}

/// Over every rank: the largest relative deviation of an owned density from `want`, the
/// largest force component after the set-up, and the number of owned particles.
fn probe<const D: usize>(
    case: &mesorheo::config::Case,
    comm: &dyn Comm,
    want: f64,
) -> Result<[f64; 3], mesorheo::error::Error>
where
    for<'c> Simulation<'c, D>: Engine<'c, D>,
{
    let sim = Simulation::<D>::new(case, comm, 1)?;
    let p = &sim.particles;
    let k = p.extra_index(DENSITY).ok_or("no density field")?;
    let rho = &p.extra[k].data[..p.n_owned];
    let deviation = rho
        .iter()
        .fold(0.0f64, |m, r| m.max((r - want).abs() / want));
    let f = p.force.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut max = [deviation, f];
    comm.allreduce_max(&mut max);
    let mut n = [p.n_owned as u64];
    comm.allreduce_u64(&mut n, mesorheo::comm::U64Op::Sum);
    Ok([max[0], max[1], n[0] as f64])
}

/// Pair forces antisymmetric to the last bit: the total momentum stays what it was, up to the
/// single rounding of each particle's force (N × 1e-16 × |F| per step, far below 1e-9 after
/// 200 steps). A ghost density not refreshed between the passes breaks the antisymmetry of
/// the pairs that cross a slab or periodic boundary, and with it this conservation.
#[test]
fn the_two_pass_model_conserves_momentum_under_lees_edwards_along_x_and_y() {
    let text = common::with_overrides(
        &gas_case(2, 8.0, 0.5, "random", 200),
        &["run.sample_every=1", "run.equilibration=0"],
    );
    let loaded = case_from_str(&text, "momentum");
    let s = run_in_process(&loaded, 2, 1, None).expect("run");
    // Peculiar momentum per sample: its spread over the samples must vanish (it is the same
    // value at every step, up to rounding).
    for axis in ["x", "y"] {
        let m = &s.observables[&format!("momentum_{axis}")];
        assert!(m.samples >= 100, "{} samples", m.samples);
        assert!(
            m.stderr < 1e-9,
            "momentum_{axis}: mean {} stderr {} (not conserved)",
            m.mean,
            m.stderr
        );
    }
}

/// A test-only model that checks the ghost-field refresh from inside a run: pass 0 writes every
/// owned particle's velocity into a velocity-like field and its id into a plain one; pass 1,
/// after the engine refreshed both, requires each ghost's copies to equal the ghost's own
/// velocity (which the halo shifted by ±γ̇L_y for a Lees–Edwards image) and id, bit for bit.
struct GhostFieldProbe {
    fields: (usize, usize),
    /// On one rank every ghost's original is local, so the shifted ones can be counted.
    one_rank: bool,
}

impl<const D: usize> ParticleModel<D> for GhostFieldProbe {
    fn name(&self) -> &'static str {
        "ghost field probe"
    }

    fn fields(&self) -> Vec<FieldSpec> {
        vec![
            FieldSpec {
                name: "velocity_copy",
                kind: FieldKind::Vector,
                flags: FieldFlags {
                    velocity_like: true,
                    ..FieldFlags::DERIVED
                },
            },
            FieldSpec {
                name: "id_copy",
                kind: FieldKind::Scalar,
                flags: FieldFlags::DERIVED,
            },
        ]
    }

    fn passes(&self) -> Vec<PassSpec> {
        vec![
            PassSpec {
                name: "write",
                ghost_fields: vec![],
            },
            PassSpec {
                name: "check",
                ghost_fields: vec!["velocity_copy", "id_copy"],
            },
        ]
    }

    fn attach(&mut self, p: &mut Particles<D>, _: bool) -> Result<(), mesorheo::error::Error> {
        let index = |name| p.extra_index(name).ok_or(format!("no {name}"));
        self.fields = (index("velocity_copy")?, index("id_copy")?);
        Ok(())
    }

    fn pass(
        &mut self,
        pass: usize,
        ctx: PassContext<'_, D>,
    ) -> Result<PassOutput, mesorheo::error::Error> {
        let p = ctx.particles;
        let (v, id) = self.fields;
        if pass == 0 {
            for i in 0..p.n_owned {
                let vel = p.vel[i];
                p.extra[v].data[i * D..(i + 1) * D].copy_from_slice(&vel);
                p.extra[id].data[i] = p.gid[i] as f64;
            }
            return Ok(PassOutput::default());
        }
        // Ghosts whose original is on this rank: how many carry a Lees–Edwards shift.
        let owned: std::collections::HashMap<u64, usize> =
            (0..p.n_owned).map(|i| (p.gid[i], i)).collect();
        let mut shifted = 0;
        for g in p.n_owned..p.len() {
            let copy = &p.extra[v].data[g * D..(g + 1) * D];
            let same = (0..D).all(|d| copy[d].to_bits() == p.vel[g][d].to_bits());
            if !same || p.extra[id].data[g] != p.gid[g] as f64 {
                return Err(format!(
                    "ghost {g} (id {}): velocity {:?}, refreshed copy {copy:?}, id copy {}",
                    p.gid[g], p.vel[g], p.extra[id].data[g]
                )
                .into());
            }
            if let Some(&i) = owned.get(&p.gid[g]) {
                // The shift is 0 or ±γ̇L_y = ±4 (up to the rounding of the addition).
                let jump = copy[0] - p.vel[i][0];
                let k = (jump / 4.0).round();
                if (jump - 4.0 * k).abs() > 1e-12 || k.abs() > 1.0 {
                    return Err(format!("ghost {g}: velocity shift {jump}, not 0 or ±4").into());
                }
                shifted += usize::from(k != 0.0);
            }
        }
        if p.n_owned == p.len() || (self.one_rank && shifted == 0) {
            return Err("no ghost carries a Lees–Edwards velocity shift".into());
        }
        Ok(PassOutput::default())
    }
}

#[test]
fn ghost_fields_are_refreshed_with_the_lees_edwards_shift_on_velocity_like_fields_only() {
    // DPD at rest on average, sheared at γ̇ = 0.5 in a box of L_y = 8: an image across the
    // Lees–Edwards plane carries v_x ± 4, so some ghost velocities exceed 0.4 in magnitude.
    let loaded = case_from_str(&common::small_dpd(2, 8.0, 0.5, 30, ""), "probe");
    for ranks in 1..=3 {
        let case = loaded.case.clone();
        in_process(ranks, move |comm: &dyn Comm| {
            let mut sim = Simulation::<2>::new(&case, comm, 2)?;
            sim.attach(Box::new(GhostFieldProbe {
                fields: (0, 0),
                one_rank: comm.size() == 1,
            }))?;
            sim.run_steps(30)?;
            Ok::<_, mesorheo::error::Error>(())
        })
        .unwrap_or_else(|e| panic!("{ranks} ranks: {e}"));
    }
}

/// The two-pass model continues bitwise from a checkpoint, on another rank count: its derived
/// densities are not in the checkpoint, and its fields are registered after the restart's
/// list-build positions have been taken out (their indices must not shift).
#[test]
fn the_two_pass_model_restarts_bitwise_on_another_rank_count() {
    use mesorheo::driver::{RunOptions, restart_case, run_case};
    let text = common::with_overrides(
        &gas_case(2, 8.0, 0.5, "random", 120),
        &["output.checkpoint_every=50"],
    );
    let loaded = case_from_str(&text, "gas_restart");
    let whole = run_in_process(&loaded, 1, 1, None).expect("uninterrupted");
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_path_buf();
    let (l, o) = (loaded.clone(), out.clone());
    in_process(2, move |comm| {
        let options = RunOptions {
            threads: 1,
            until_step: Some(50),
            out: Some(o.clone()),
            ..RunOptions::default()
        };
        run_case(&l, comm, &options).map(|_| ())
    })
    .expect("first part");
    let ck = out.join("checkpoints").join("checkpoint_000000000050.h5");
    let rest = in_process(3, move |comm| {
        let options = RunOptions {
            threads: 2,
            out: Some(out.clone()),
            ..RunOptions::default()
        };
        restart_case(&ck, comm, &options)
    })
    .expect("restart");
    assert_eq!(rest.state_digest, whole.state_digest);
}
