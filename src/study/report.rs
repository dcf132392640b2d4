//! The study's report: the CSV, the Markdown table and the plots.

#[allow(unused_imports)]
use super::*;

impl Analysis {
    /// The CSV: knob values, status, per observable mean ± stderr, error, statistical and
    /// systematic parts, the study error, wall time, core-seconds (the CPU seconds of the point's
    /// processes; wall × ranks × threads for records older than that measure), stored bytes per particle,
    /// the memory/error and cost/error Pareto flags, reference and recommendation.
    pub fn csv(&self, sweep: &Sweep) -> String {
        let mut s = String::new();
        let mut head: Vec<String> = sweep.knobs.iter().map(|k| k.key.clone()).collect();
        head.push("status".into());
        for o in &sweep.observables {
            for part in ["mean", "stderr", "error", "statistical", "systematic"] {
                head.push(format!("{}:{part}", o.name));
            }
        }
        head.extend(
            [
                "error",
                "wall_seconds",
                "core_seconds",
                "bytes_per_particle",
                "pareto_memory",
                "pareto",
                "reference",
                "recommended",
            ]
            .map(str::to_string),
        );
        let _ = writeln!(s, "{}", head.join(","));
        for (i, p) in self.points.iter().enumerate() {
            let mut row: Vec<String> = p.knob_values.iter().map(|v| csv_field(v)).collect();
            row.push(
                match &p.status {
                    Status::Done { .. } => "done",
                    Status::Refused(_) => "refused",
                    Status::Unstable(_) => "unstable",
                }
                .into(),
            );
            match &self.errors[i] {
                Some(e) => {
                    for q in e {
                        for x in [q.mean, q.stderr, q.error, q.statistical, q.systematic] {
                            row.push(format!("{x:.10e}"));
                        }
                    }
                    let worst = e.iter().map(|q| q.error).fold(0.0, f64::max);
                    row.push(format!("{worst:.10e}"));
                    let wall = match &p.status {
                        Status::Done { wall_seconds, .. } => *wall_seconds,
                        _ => f64::NAN,
                    };
                    row.push(format!("{wall:.3}"));
                    row.push(format!("{:.3}", self.core_seconds[i]));
                    let b = self.bytes_per_particle[i];
                    row.push(if b.is_finite() {
                        format!("{b:.1}")
                    } else {
                        String::new()
                    });
                }
                None => {
                    for _ in 0..sweep.observables.len() * 5 + 4 {
                        row.push(String::new());
                    }
                }
            }
            row.push(u8::from(self.pareto_memory[i]).to_string());
            row.push(u8::from(self.pareto[i]).to_string());
            row.push(u8::from(self.reference_point == Some(i)).to_string());
            row.push(u8::from(self.recommended == Some(i)).to_string());
            let _ = writeln!(s, "{}", row.join(","));
        }
        s
    }
}

fn csv_field(v: &str) -> String {
    let v = v.trim_matches('"');
    if v.contains(',') || v.contains('"') {
        format!("\"{}\"", v.replace('"', "\"\""))
    } else {
        v.to_string()
    }
}

/// The plotting script (matplotlib), run with the CSV and the PNG paths.
const PLOT_SCRIPT: &str = include_str!("plot.py");

pub(super) fn plot(
    python: &Path,
    csv: &Path,
    png: &Path,
    title: &str,
    target: Option<f64>,
) -> Result<(), String> {
    let output = Command::new(python)
        .arg("-c")
        .arg(PLOT_SCRIPT)
        .arg(csv)
        .arg(png)
        .arg(title)
        .arg(target.map_or(String::new(), |t| t.to_string()))
        .output()
        .map_err(|e| format!("cannot start {}: {e}", python.display()))?;
    if output.status.success() {
        Ok(())
    } else {
        Err(format!(
            "{} failed: {}",
            python.display(),
            String::from_utf8_lossy(&output.stderr)
                .lines()
                .last()
                .unwrap_or("")
        ))
    }
}
