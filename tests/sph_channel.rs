//! SPH in channels and periodic boxes: the viscous operators against analytic decay rates.

mod common;
use common::case_from_str;
use mesorheo::comm::SerialComm;
use mesorheo::sim::Simulation;

/// A periodic box of side 1 (Δ = 0.02) with u_x = A sin(2πy) decays as exp(−ν k² t).
fn shear_wave(viscous_term: &str) -> String {
    format!(
        r#"
dimension = 2
[box]
lengths = [1.0, 1.0]
[particles]
lattice = "cubic"
density = 2500.0
mass = 0.0004
temperature = 0.0
[fluid]
kind = "sph"
kernel = "lucy"
smoothing_length = 0.05
sound_speed = 10.0
viscosity = 1.0
viscous_term = "{viscous_term}"
equation_of_state = "tait"
[integrator]
kind = "kick_drift_kick"
dt = 1e-4
[neighbour]
skin = 0.01
[run]
steps = 100
[diagnostics]
observables = ["momentum"]
"#
    )
}

#[test]
fn shear_wave_decays_at_the_viscous_rate() {
    for term in ["morris", "nested_summation"] {
        let loaded = case_from_str(&shear_wave(term), "wave.toml");
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
        let k = 2.0 * std::f64::consts::PI;
        let amp = 0.01;
        let n = sim.particles.n_owned;
        for i in 0..n {
            let y = sim.particles.pos[i][1];
            sim.particles.vel[i] = [amp * (k * y).sin(), 0.0];
        }
        sim.jump_to_step(0).expect("forces");
        let steps = 200;
        sim.run_steps(steps, |_| {}).expect("run");
        let t = steps as f64 * 1e-4;
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..sim.particles.n_owned {
            let y = sim.particles.pos[i][1];
            num += sim.particles.vel[i][0] * (k * y).sin();
            den += (k * y).sin().powi(2);
        }
        let measured = num / den / amp;
        let want = (-k * k * t).exp();
        eprintln!("{term}: amplitude ratio {measured:.6} vs exp(−νk²t) = {want:.6}");
    }
}

fn couette(viscous_term: &str, treatment: &str) -> String {
    shear_wave(viscous_term).replace(
        "lengths = [1.0, 1.0]",
        "lengths = [1.0, 1.0]\nboundaries = [\"periodic\", \"wall\"]",
    ) + &format!("[walls]\nupper_velocity = [1.0, 0.0]\ntreatment = \"{treatment}\"\n")
}

#[test]
fn steady_couette_stays_linear() {
    for term in ["morris"] {
        for treatment in ["morris\"\nmorris_cap = 6.0\n#", "layers"] {
            let loaded = case_from_str(&couette(term, treatment), "couette.toml");
            let comm = SerialComm::new();
            let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
            let n = sim.particles.n_owned;
            for i in 0..n {
                if sim.particles.species_of(i) == 0 {
                    let y = sim.particles.pos[i][1];
                    sim.particles.vel[i] = [y, 0.0];
                }
            }
            sim.jump_to_step(0).expect("forces");
            for _ in 0..5 {
                sim.run_steps(200, |_| {}).expect("run");
                let (mut worst, mut dy, mut at) = (0.0f64, 0.0f64, 0.0);
                for i in 0..sim.particles.n_owned {
                    if sim.particles.species_of(i) == 0 {
                        let y = sim.particles.pos[i][1];
                        if (sim.particles.vel[i][0] - y).abs() > worst { worst = (sim.particles.vel[i][0] - y).abs(); at = y; }
                        let row = (y / 0.02 - 0.5).round() * 0.02 + 0.01;
                        dy = dy.max((y - row).abs());
                    }
                }
                eprintln!("{term}/{treatment} t = {:.3}: max |u − y| = {worst:.5}, max row offset {dy:.5} at y = {at:.3}", sim.time());
            }
        }
    }
}

#[test]
fn startup_couette_momentum() {
    for (term, treatment, integ, u) in [("morris", "morris\"\nmorris_cap = 2.0\n#", "kick_drift_kick", 1.0)] {
        let fine = std::env::var("FINE").is_ok();
        let text = if fine { couette(term, treatment).replace("2500.0", "10000.0").replace("0.0004", "0.0001").replace("0.05\n", "0.025\n").replace("1e-4", "5e-5").replace("skin = 0.01", "skin = 0.005") } else { couette(term, treatment) };
        let text = text.replace("kick_drift_kick", integ).replace("upper_velocity = [1.0, 0.0]", &format!("upper_velocity = [{u}, 0.0]"));
        let loaded = case_from_str(&text, "couette.toml");
        let comm = SerialComm::new();
        let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
        for _ in 0..6 {
            sim.run_steps(if fine { 1000 } else { 500 }, |_| {}).expect("run");
            let t = sim.time();
            let (mut sum, mut count, mut err) = (0.0, 0.0, 0.0f64);
            for i in 0..sim.particles.n_owned {
                if sim.particles.species_of(i) == 0 {
                    sum += sim.particles.vel[i][0];
                    count += 1.0;
                    let y = sim.particles.pos[i][1];
                    err = err.max((sim.particles.vel[i][0]/u - mesorheo::analytic::couette(y, t, 1.0, 1.0, 1.0)).abs());
                }
            }
            let exact: f64 = (0..50).map(|r| mesorheo::analytic::couette(0.01 + 0.02 * r as f64, t, 1.0, 1.0, 1.0)).sum::<f64>() / 50.0;
            eprintln!("{term}/{treatment}/{integ} t = {t:.3}: mean u {:.5} vs {exact:.5}; max particle error {err:.5}", sum / count / u);
        }
    }
}

#[test]
fn linear_profile_accelerations() {
    let loaded = case_from_str(&couette("morris", "morris\"\nmorris_cap = 6.0\n#"), "couette.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    let n = sim.particles.n_owned;
    for i in 0..n {
        if sim.particles.species_of(i) == 0 {
            let y = sim.particles.pos[i][1];
            sim.particles.vel[i] = [y, 0.0];
        }
    }
    sim.jump_to_step(0).expect("forces");
    let mut rows = std::collections::BTreeMap::new();
    for i in 0..n {
        if sim.particles.species_of(i) == 0 {
            let y = sim.particles.pos[i][1];
            let e = rows.entry((y * 1000.0).round() as i64).or_insert((0.0, 0.0, 0.0, 0.0));
            e.0 += sim.particles.force[i][0] / 0.0004;
            e.1 += sim.particles.force[i][1] / 0.0004;
            e.2 += 1.0;
            e.3 += sim.particles.extra[sim.particles.extra_index("density").unwrap()].data[i];
        }
    }
    for (y, (ax, ay, c, rho)) in rows {
        eprintln!("y {y}: a_x {:+.5e} a_y {:+.5e} rho {:.6}", ax / c, ay / c, rho / c);
    }
}

#[test]
fn poiseuille_disorder() {
    let text = couette("morris", &std::env::var("TREAT").unwrap_or("morris\"\nmorris_cap = 2.0\n#".into()))
        .replace("upper_velocity = [1.0, 0.0]\n", "")
        .replace("viscosity = 1.0", &std::env::var("VISC").unwrap_or("viscosity = 0.125\nbody_force = [1.0, 0.0]".into()));
    let loaded = case_from_str(&text, "p.toml");
    let comm = SerialComm::new();
    let mut sim = Simulation::<2>::new(&loaded.case, &comm, 1).expect("set up");
    for _ in 0..8 {
        sim.run_steps(2500, |_| {}).expect("run");
        let t = sim.time();
        let k = sim.particles.extra_index("density").unwrap();
        let (mut lo, mut hi, mut dy, mut err, mut vy) = (f64::MAX, 0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for i in 0..sim.particles.n_owned {
            if sim.particles.species_of(i) == 0 {
                let r = sim.particles.extra[k].data[i];
                lo = lo.min(r); hi = hi.max(r);
                let y = sim.particles.pos[i][1];
                let row = (y / 0.02 - 0.5).round() * 0.02 + 0.01;
                dy = dy.max((y - row).abs());
                err = err.max((sim.particles.vel[i][0] - mesorheo::analytic::poiseuille(y, t, 1.0, 1.0, 0.125)).abs());
                vy = vy.max(sim.particles.vel[i][1].abs());
            }
        }
        eprintln!("t = {t:.2}: density {lo:.5}..{hi:.5}, max row offset {dy:.5}, max |v_y| {vy:.2e}, max particle error {err:.4}");
    }
}
