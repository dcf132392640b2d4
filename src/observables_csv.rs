//! `OUT/observables.csv`: the time series of a run's scalar observables, one row per recorded
//! step (every `run.sample_every` steps from the first step on, the start-up included), written
//! by rank 0 as the run goes.
//!
//! The columns are `step`, `time` and the case's scalar observables, each row holding the same
//! instantaneous values the summary averages after `run.equilibration` (written in Rust's
//! shortest round-trip form, so the rows after equilibration average to the summary's mean to
//! round-off). A restart continues the file: the rows beyond the checkpoint's step (written by
//! the interrupted segment after its last checkpoint) are dropped first, so no step appears
//! twice.

use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The file's name in the output directory.
pub const FILE_NAME: &str = "observables.csv";

/// The open time series of one run segment (rank 0).
pub struct ObservablesCsv {
    path: PathBuf,
    /// The header of the rows already in the file (a restart), if any.
    header: Option<String>,
    writer: Option<BufWriter<File>>,
}

impl ObservablesCsv {
    /// Opens `out/observables.csv`: afresh for a new run; for a restart at step `first_step`,
    /// keeping the header and the rows up to `first_step` of the earlier segments.
    pub fn open(out: &Path, restarted: bool, first_step: u64) -> Result<Self, String> {
        let path = out.join(FILE_NAME);
        let mut header = None;
        if restarted && let Ok(text) = std::fs::read_to_string(&path) {
            let mut lines = text.lines();
            if let Some(h) = lines.next() {
                let mut kept = format!("{h}\n");
                for line in lines {
                    let step = line.split(',').next().and_then(|s| s.parse::<u64>().ok());
                    match step {
                        Some(s) if s <= first_step => {
                            kept.push_str(line);
                            kept.push('\n');
                        }
                        // Beyond the checkpoint (or a torn last line): the new segment writes
                        // these steps again.
                        _ => break,
                    }
                }
                let tmp = out.join(format!("{FILE_NAME}.tmp"));
                std::fs::write(&tmp, kept)
                    .and_then(|()| std::fs::rename(&tmp, &path))
                    .map_err(|e| format!("cannot continue {}: {e}", path.display()))?;
                header = Some(h.to_owned());
            }
        }
        Ok(Self {
            path,
            header,
            writer: None,
        })
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends the row of `step` at `time` (the first row of a new file writes the header).
    pub fn write(&mut self, step: u64, time: f64, row: &[(String, f64)]) -> Result<(), String> {
        let err = |e: std::io::Error| format!("cannot write {}: {e}", self.path.display());
        if self.writer.is_none() {
            let header = header_of(row);
            let continues = self.header.as_deref() == Some(header.as_str());
            if self.header.is_some() && !continues {
                // Another set of observables (the case changed between segments): the earlier
                // rows are kept beside the new file, not mixed into it.
                let aside = self.path.with_extension("csv.previous");
                std::fs::rename(&self.path, &aside).map_err(err)?;
                tracing::warn!(
                    "{} had other columns than this segment's observables: moved to {}",
                    self.path.display(),
                    aside.display()
                );
            }
            let file = OpenOptions::new()
                .create(true)
                .write(true)
                .append(continues)
                .truncate(!continues)
                .open(&self.path)
                .map_err(err)?;
            let mut w = BufWriter::new(file);
            if !continues {
                writeln!(w, "{header}").map_err(err)?;
            }
            self.writer = Some(w);
        }
        let mut line = format!("{step},{time:e}");
        for (_, v) in row {
            line.push_str(&format!(",{v:e}"));
        }
        let w = self.writer.as_mut().expect("opened above");
        writeln!(w, "{line}").map_err(err)
    }

    /// Writes the buffered rows to the file (at progress lines, checkpoints and the end).
    pub fn flush(&mut self) -> Result<(), String> {
        match &mut self.writer {
            Some(w) => w
                .flush()
                .map_err(|e| format!("cannot write {}: {e}", self.path.display())),
            None => Ok(()),
        }
    }
}

/// `step,time,name,…`.
fn header_of(row: &[(String, f64)]) -> String {
    let mut h = String::from("step,time");
    for (name, _) in row {
        h.push(',');
        h.push_str(name);
    }
    h
}

/// The compact values of a progress line: `name=value` for the first `max` observables of
/// `row` (four significant digits), the momentum left out.
pub fn thermo(row: &[(String, f64)], max: usize) -> String {
    row.iter()
        // A conserved momentum is round-off: not worth a column of the console.
        .filter(|(name, _)| !name.starts_with("momentum_"))
        .take(max)
        .map(|(name, v)| format!("{}={}", short_name(name), significant(*v, 4)))
        .collect::<Vec<_>>()
        .join("  ")
}

/// `v` to `digits` significant digits: fixed-point between 10⁻³ and 10⁶, else scientific.
fn significant(v: f64, digits: usize) -> String {
    let a = v.abs();
    if !v.is_finite() || a == 0.0 {
        return format!("{v}");
    }
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:.*e}", digits - 1);
    }
    let decimals = (digits as i32 - 1 - a.log10().floor() as i32).max(0) as usize;
    format!("{v:.decimals$}")
}

/// The name a progress line shows for an observable (`_c`: the constitutive stress's).
fn short_name(name: &str) -> String {
    if let Some(base) = name.strip_suffix("_constitutive") {
        return format!("{}_c", short_name(base));
    }
    match name {
        "first_normal_stress_difference" => "N1".into(),
        "second_normal_stress_difference" => "N2".into(),
        "first_normal_stress_coefficient" => "Psi1".into(),
        "second_normal_stress_coefficient" => "Psi2".into(),
        "temperature" => "kT".into(),
        "mean_square_connector_length" => "Q2".into(),
        "max_connector_length" => "Qmax".into(),
        other => other.to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thermo_values_are_compact() {
        let row = vec![
            ("viscosity".to_owned(), 1.001_234),
            ("first_normal_stress_difference".to_owned(), 0.998),
            ("momentum_x".to_owned(), -3.2e-12),
            (
                "first_normal_stress_difference_constitutive".to_owned(),
                1.5,
            ),
        ];
        assert_eq!(thermo(&row, 2), "viscosity=1.001  N1=0.9980");
        assert_eq!(thermo(&row, 5), "viscosity=1.001  N1=0.9980  N1_c=1.500");
        assert_eq!(significant(-3.2e-12, 4), "-3.200e-12");
        assert_eq!(significant(123.456, 4), "123.5");
        assert_eq!(significant(0.0, 4), "0");
    }
}
