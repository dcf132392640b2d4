//! `mesorheo info FILE.h5`: what a snapshot series or checkpoint holds.

use hdf5::types::VarLenUnicode;

/// A readable description of an HDF5 file written by mesorheo (or any HDF5 file).
pub fn describe(path: &std::path::Path) -> Result<String, String> {
    let f = super::h5_options()
        .open(path)
        .map_err(|e| format!("{}: not a readable HDF5 file ({e})", path.display()))?;
    let mut s = format!("{}\n", path.display());
    let root_attrs = f.attr_names().unwrap_or_default();
    let format = f
        .attr("format")
        .and_then(|a| a.read_scalar::<VarLenUnicode>())
        .map(|v| v.to_string())
        .unwrap_or_default();
    let kind = if format == super::checkpoint::FORMAT || format == super::checkpoint::FLOW_FORMAT_V1
    {
        match super::checkpoint::scene_of(path) {
            Ok(super::checkpoint::SceneKind::Particles) => "checkpoint of a particle scene",
            Ok(super::checkpoint::SceneKind::HomogeneousFlow) => {
                "checkpoint of a homogeneous-flow scene (dumbbell ensembles)"
            }
            Err(_) => "checkpoint (of a format version this mesorheo does not read)",
        }
    } else if f.link_exists("h5md") {
        "snapshot series (H5MD)"
    } else {
        "HDF5 file"
    };
    s.push_str(&format!("  kind: {kind}\n"));
    let mut case = None;
    for name in &root_attrs {
        let a = f.attr(name).map_err(|e| e.to_string())?;
        if name == "case" {
            case = a.read_scalar::<VarLenUnicode>().ok().map(|v| v.to_string());
            continue;
        }
        s.push_str(&format!("  {name}: {}\n", attr_text(&a)));
    }
    if case.is_none()
        && let Ok(p) = f.group("parameters")
        && let Ok(a) = p.attr("case")
    {
        case = a.read_scalar::<VarLenUnicode>().ok().map(|v| v.to_string());
    }
    if f.link_exists("particles/fluid/position/step")
        && let Ok(d) = f.dataset("particles/fluid/position/step")
        && let Ok(steps) = d.read_raw::<u64>()
    {
        match (steps.first(), steps.last()) {
            (Some(a), Some(b)) => {
                s.push_str(&format!("  frames: {} (steps {a} … {b})\n", steps.len()))
            }
            _ => s.push_str("  frames: 0\n"),
        }
    }
    if f.link_exists("h5md")
        && let Ok(p) = f.group("particles")
    {
        let mut groups = Vec::new();
        for name in p.member_names().unwrap_or_default() {
            let n = p
                .dataset(&format!("{name}/id"))
                .map_or(0, |d| d.shape().first().copied().unwrap_or(0));
            groups.push(format!("{name} ({n})"));
        }
        // The fluid first, as the run writes them.
        groups.sort_by_key(|g| !g.starts_with("fluid "));
        s.push_str(&format!("  particle groups: {}\n", groups.join(", ")));
    }
    s.push_str("  datasets:\n");
    let mut lines = Vec::new();
    walk(&f, "", &mut lines).map_err(|e| e.to_string())?;
    for l in lines {
        s.push_str(&format!("    {l}\n"));
    }
    if let Some(c) = case {
        s.push_str("  case:\n");
        for l in c.lines() {
            s.push_str(&format!("    {l}\n"));
        }
    }
    Ok(s)
}

fn attr_text(a: &hdf5::Attribute) -> String {
    use hdf5::types::{FloatSize, TypeDescriptor as T};
    let Ok(ty) = a.dtype().and_then(|t| t.to_descriptor()) else {
        return "(unknown type)".into();
    };
    let scalar = a.ndim() == 0;
    let shown = match ty {
        T::VarLenUnicode if scalar => a.read_scalar::<VarLenUnicode>().map(|v| v.to_string()),
        T::VarLenUnicode => a
            .read_raw::<VarLenUnicode>()
            .map(|v| format!("{:?}", v.iter().map(|x| x.as_str()).collect::<Vec<_>>())),
        T::Unsigned(_) if scalar => a.read_scalar::<u64>().map(|v| v.to_string()),
        T::Integer(_) if scalar => a.read_scalar::<i64>().map(|v| v.to_string()),
        T::Unsigned(_) | T::Integer(_) => a.read_raw::<i64>().map(|v| format!("{v:?}")),
        T::Float(FloatSize::U8 | FloatSize::U4) if scalar => {
            a.read_scalar::<f64>().map(|v| format!("{v}"))
        }
        T::Float(_) => a.read_raw::<f64>().map(|v| format!("{v:?}")),
        other => return format!("({other})"),
    };
    shown.unwrap_or_else(|e| format!("(unreadable: {e})"))
}

fn walk(g: &hdf5::Group, prefix: &str, out: &mut Vec<String>) -> hdf5::Result<()> {
    let mut names = g.member_names()?;
    names.sort();
    for name in names {
        let path = format!("{prefix}/{name}");
        if let Ok(sub) = g.group(&name) {
            walk(&sub, &path, out)?;
        } else if let Ok(d) = g.dataset(&name) {
            let ty = d
                .dtype()
                .and_then(|t| t.to_descriptor())
                .map_or("?".into(), |t| format!("{t}"));
            out.push(format!("{path}  {:?}  {ty}", d.shape()));
        }
    }
    Ok(())
}
