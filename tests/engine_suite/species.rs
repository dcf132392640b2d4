//! Particle species: a DPD fluid between two walls of boundary particles (frozen below, moving
//! at a prescribed velocity above — a Couette cell) runs bitwise identically on 1–3 ranks ×
//! 1–2 threads and across a restart; frozen particles never move, prescribed ones move at
//! their velocity; the walls are not counted as fluid in the temperature; and the channel may
//! be cut into slabs along its length (x) as well as across it.

use crate::common;
use common::case_from_str;
use mesorheo::comm::Comm;
use mesorheo::driver::{RunOptions, in_process, restart_case};
use mesorheo::facade::Engine;
use mesorheo::sim::Simulation;
use mesorheo::species::{Motion, Species};
use std::path::Path;

/// 2D DPD, periodic in x, walls in y at 0 and 8; the particles within 1.2 of a wall become
/// wall particles.
fn case_text(steps: u64) -> String {
    format!(
        r#"
dimension = 2
seed = 3
[box]
lengths = [8.0, 8.0]
boundaries = ["periodic", "wall"]
[particles]
lattice = "random"
density = 4.0
temperature = 1.0
[fluid]
kind = "dpd"
a = 25.0
gamma = 4.5
kt = 1.0
[integrator]
kind = "groot_warren"
dt = 0.02
[run]
steps = {steps}
equilibration = 40
sample_every = 1
progress_seconds = 0
[diagnostics]
observables = ["temperature"]
blocks = 8
[output]
checkpoint_every = 60
"#
    )
}

const WALL_SPEED: f64 = 0.5;

fn table() -> Vec<Species> {
    vec![
        Species::fluid(1.0),
        Species {
            name: "bottom wall".into(),
            mass: 1.0,
            motion: Motion::Frozen,
        },
        Species {
            name: "top wall".into(),
            mass: 1.0,
            motion: Motion::Prescribed([WALL_SPEED, 0.0, 0.0]),
        },
    ]
}

fn assign(_: u64, x: &[f64; 2]) -> u8 {
    if x[1] < 1.2 {
        1
    } else if x[1] > 6.8 {
        2
    } else {
        0
    }
}

/// A fresh run with the walls, through the one step loop; returns the digest and the mean
/// temperature.
fn run(
    comm: &dyn Comm,
    text: &str,
    threads: usize,
    out: Option<&Path>,
) -> Result<(String, f64), mesorheo::error::Error> {
    let loaded = case_from_str(text, "walls");
    let mut sim = Simulation::<2>::new(&loaded.case, comm, threads)?;
    sim.set_species(table(), &assign)?;
    let options = RunOptions {
        threads,
        out: out.map(Path::to_path_buf),
        ..RunOptions::default()
    };
    let s = sim.drive(Path::new("walls"), None, comm, &options, threads)?;
    Ok((s.state_digest, s.observables["temperature"].mean))
}

#[test]
fn walls_of_boundary_particles_are_bitwise_identical_on_1_to_3_ranks_and_1_to_2_threads() {
    let text = case_text(120);
    let mut seen = Vec::new();
    for ranks in 1..=3 {
        for threads in 1..=2 {
            let t = text.clone();
            let (digest, temperature) = in_process(ranks, move |c| run(c, &t, threads, None))
                .unwrap_or_else(|e| panic!("{ranks} × {threads}: {e}"));
            seen.push((ranks, threads, format!("{digest} {temperature:e}")));
        }
    }
    // A channel may also be cut across its length: slabs along x (no shear), walls and all.
    let along_x = common::with_overrides(&text, &["decomposition.axis=\"x\""]);
    for ranks in [2, 3] {
        let t = along_x.clone();
        let (digest, temperature) = in_process(ranks, move |c| run(c, &t, 1, None))
            .unwrap_or_else(|e| panic!("{ranks} slabs along x: {e}"));
        seen.push((ranks, 0, format!("{digest} {temperature:e}")));
    }
    for (r, t, d) in &seen {
        assert_eq!(
            d, &seen[0].2,
            "{r} ranks × {t} threads (0: slabs along x) differs from 1 × 1"
        );
    }
}

#[test]
fn frozen_particles_stay_and_prescribed_ones_move_at_their_velocity() {
    let text = case_text(100);
    in_process(2, move |comm| {
        let loaded = case_from_str(&text, "walls");
        let mut sim = Simulation::<2>::new(&loaded.case, comm, 1).map_err(|e| e.to_string())?;
        sim.set_species(table(), &assign)
            .map_err(|e| e.to_string())?;
        let start: std::collections::HashMap<u64, [f64; 2]> = (0..sim.particles.n_owned)
            .map(|i| (sim.particles.gid[i], sim.particles.pos[i]))
            .collect();
        sim.run_steps(100).map_err(|e| e.to_string())?;
        let p = &sim.particles;
        let (mut frozen, mut moving, mut fluid_moved) = (0.0, 0.0, 0.0);
        // k_BT of the fluid alone, computed here: Σ m |v − ū|² / (D (N_f − 1)), ū the fluid's
        // mean velocity (no shear: one bin).
        let mut sums = [0.0; 4]; // N_f, Σv_x, Σv_y, Σ|v|²
        for i in 0..p.n_owned {
            let x0 = start.get(&p.gid[i]).copied();
            match p.species_of(i) {
                1 => {
                    // Never moved, so never migrated: still here, to the last bit.
                    assert_eq!(Some(p.pos[i]), x0, "frozen particle {}", p.gid[i]);
                    assert_eq!(p.vel[i], [0.0; 2]);
                    frozen += 1.0;
                }
                2 => {
                    // 100 steps of Δt V = 1.0 along x (periodic: modulo 8), none along y.
                    let x0 = x0.ok_or("a top-wall particle changed rank")?;
                    let dx = (p.pos[i][0] - x0[0]).rem_euclid(8.0);
                    assert!((dx - 100.0 * 0.02 * WALL_SPEED).abs() < 1e-12, "dx {dx}");
                    assert_eq!(p.pos[i][1], x0[1]);
                    assert_eq!(p.vel[i], [WALL_SPEED, 0.0]);
                    moving += 1.0;
                }
                _ => {
                    fluid_moved += f64::from(u8::from(x0 != Some(p.pos[i])));
                    let v = p.vel[i];
                    sums[0] += 1.0;
                    sums[1] += v[0];
                    sums[2] += v[1];
                    sums[3] += v[0] * v[0] + v[1] * v[1];
                }
            }
        }
        // Ghosts carry their original's species (checked where the original is on this rank:
        // the periodic images along x).
        let owned: std::collections::HashMap<u64, u8> = (0..p.n_owned)
            .map(|i| (p.gid[i], p.species_of(i)))
            .collect();
        let mut ghosts_checked = 0;
        for g in p.n_owned..p.len() {
            if let Some(&s) = owned.get(&p.gid[g]) {
                assert_eq!(p.species_of(g), s, "ghost of {}", p.gid[g]);
                ghosts_checked += usize::from(s != 0);
            }
        }
        if ghosts_checked == 0 {
            return Err("no wall ghost checked".into());
        }
        let mut counts = [frozen, moving, fluid_moved];
        comm.allreduce_sum(&mut counts);
        comm.allreduce_sum(&mut sums);
        if counts.contains(&0.0) {
            return Err(format!("frozen, moving, fluid moved: {counts:?}"));
        }
        let n = sums[0];
        let kt = (sums[3] - (sums[1] * sums[1] + sums[2] * sums[2]) / n) / (2.0 * (n - 1.0));
        let measured = sim.measure().scalars[0].1;
        // The engine sums exactly, this loop in f64: 1e-12 relative is ample. Counting the
        // walls (≈ 30 % of the particles) would move k_BT by tens of per cent.
        if (measured - kt).abs() > 1e-12 * kt {
            return Err(format!("k_BT measured {measured}, fluid alone {kt}"));
        }
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn a_scene_with_walls_restarts_bitwise_with_its_species() {
    let text = case_text(120);
    let t = text.clone();
    let (whole, _) = in_process(1, move |c| run(c, &t, 1, None)).expect("uninterrupted");
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_path_buf();
    let short = common::with_overrides(&text, &["run.steps=60"]);
    let o = out.clone();
    in_process(2, move |c| run(c, &short, 1, Some(&o))).expect("first part");
    let ck = out.join("checkpoints").join("checkpoint_000000000060.h5");
    assert!(ck.exists());
    let o = out.clone();
    let rest = in_process(3, move |c| {
        let options = RunOptions {
            threads: 1,
            steps: Some(120),
            out: Some(o.clone()),
            ..RunOptions::default()
        };
        restart_case(&ck, c, &options)
    })
    .expect("restart");
    assert_eq!(rest.state_digest, whole);
}
