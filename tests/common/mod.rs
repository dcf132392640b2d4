//! Shared helpers of the integration tests.
#![allow(dead_code)]

use mesorheo::config::{self, LoadedCase};
use std::path::{Path, PathBuf};

/// Parses case text (panics with the case error on bad input: tests own their cases).
pub fn case_from_str(text: &str, name: &str) -> LoadedCase {
    let path = PathBuf::from(name);
    let case = config::parse(text, &path).unwrap_or_else(|e| panic!("{e}"));
    LoadedCase {
        case,
        path,
        source: text.to_owned(),
    }
}

/// Loads a stock case from `cases/`.
pub fn stock_case(name: &str) -> LoadedCase {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("cases")
        .join(name);
    config::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A small DPD case: `dimension`, cubic box of side `side`, optional shear.
pub fn small_dpd(dimension: usize, side: f64, shear: f64, steps: u64, extra: &str) -> String {
    let lengths = vec![format!("{side}"); dimension].join(", ");
    format!(
        r#"
dimension = {dimension}
seed = 11
[box]
lengths = [{lengths}]
shear_rate = {shear}
[particles]
lattice = "random"
density = 3.0
temperature = 1.0
[fluid]
kind = "dpd"
a = 25.0
gamma = 4.5
kt = 1.0
[integrator]
kind = "groot_warren"
dt = 0.04
lambda = 0.65
[neighbour]
skin = 0.3
[run]
steps = {steps}
sample_every = 1
progress_seconds = 0
{extra}
"#
    )
}

#[cfg(feature = "hdf5")]
/// Every dataset of an HDF5 file with its values (as bit patterns), in path order.
pub fn h5_content(path: &Path) -> Vec<(String, Vec<usize>, Vec<u64>)> {
    fn walk(g: &hdf5::Group, prefix: &str, out: &mut Vec<(String, Vec<usize>, Vec<u64>)>) {
        let mut names = g.member_names().expect("members");
        names.sort();
        for name in names {
            let p = format!("{prefix}/{name}");
            if let Ok(sub) = g.group(&name) {
                walk(&sub, &p, out);
            } else {
                let d = g.dataset(&name).expect("dataset");
                let bits: Vec<u64> = if let Ok(v) = d.read_raw::<f64>() {
                    v.iter().map(|x| x.to_bits()).collect()
                } else if let Ok(v) = d.read_raw::<u64>() {
                    v
                } else {
                    d.read_raw::<i32>()
                        .expect("f64, u64 or i32")
                        .iter()
                        .map(|&x| x as u32 as u64)
                        .collect()
                };
                out.push((p, d.shape(), bits));
            }
        }
    }
    let f = mesorheo::output::h5_options().open(path).expect("open");
    let mut out = Vec::new();
    walk(&f, "", &mut out);
    out
}
