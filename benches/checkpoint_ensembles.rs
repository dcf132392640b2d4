//! Checkpoint write/read time with per-particle ensembles (the variable-length state of the
//! CONNFFESSIT models): N particles × N_d dumbbells × 3 numbers, one rank (`cargo bench --features bench --bench
//! checkpoint_ensembles`). Prints a Markdown table; the ensembles are synthetic (a test-only
//! model fills them), the I/O path is the production one.

use mesorheo::comm::SerialComm;
use mesorheo::config;
use mesorheo::facade::Engine;
use mesorheo::models::{FieldKind, FieldSpec, ParticleModel};
use mesorheo::particles::Particles;
use mesorheo::particles::{FieldFlags, VarStorage};
use mesorheo::sim::Simulation;
use std::path::PathBuf;
use std::time::Instant;

struct Ensembles(usize);

impl<const D: usize> ParticleModel<D> for Ensembles {
    fn name(&self) -> &'static str {
        "synthetic ensembles"
    }
    fn fields(&self) -> Vec<FieldSpec> {
        vec![FieldSpec {
            name: "dumbbells",
            kind: FieldKind::Ensemble(VarStorage::Double),
            flags: FieldFlags::STATE,
        }]
    }
    fn attach(
        &mut self,
        p: &mut Particles<D>,
        _restarted: bool,
    ) -> Result<(), mesorheo::error::Error> {
        let k = p.var.len() - 1;
        for i in 0..p.n_owned {
            let g = p.gid[i] as f64;
            let rows = p.var[k].data.double_mut().expect("f64 storage");
            rows[i] = (0..3 * self.0).map(|j| g + j as f64 * 1e-3).collect();
        }
        Ok(())
    }
}

fn main() {
    let case_path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("cases/bench_dpd_32k.toml");
    let dir = tempfile::tempdir().expect("tempdir");
    println!("| particles | N_d | checkpoint MB | write s | write MB/s | read s |");
    println!("|---|---|---|---|---|---|");
    for (side, nd) in [(10.0, 100), (10.0, 1000), (21.5, 100)] {
        let set = vec![format!("box.lengths=[{side}, {side}, {side}]")];
        let loaded = config::load_with_overrides(&case_path, &set).expect("case");
        let comm = SerialComm::new();
        let mut sim = Simulation::<3>::new(&loaded.case, &comm, 1).expect("sim");
        sim.attach(Box::new(Ensembles(nd))).expect("attach");
        let mut times = Vec::new();
        let mut path = PathBuf::new();
        for _ in 0..3 {
            let t = Instant::now();
            path = sim.write_checkpoint(dir.path(), 1).expect("write");
            times.push(t.elapsed().as_secs_f64());
        }
        times.sort_by(f64::total_cmp);
        let bytes = std::fs::metadata(&path).expect("size").len() as f64;
        let t = Instant::now();
        let r = Simulation::<3>::read_checkpoint(&path, &comm).expect("read");
        let read = t.elapsed().as_secs_f64();
        assert_eq!(r.total, sim.total_particles);
        println!(
            "| {} | {nd} | {:.1} | {:.3} | {:.0} | {read:.3} |",
            sim.total_particles,
            bytes / 1e6,
            times[1],
            bytes / 1e6 / times[1]
        );
    }
}
