//! Running the gmsh command line on a parametric .geo file.

use anyhow::{bail, Context, Result};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Command;

use crate::exit::bad_input;

/// Names of the numbers a .geo file lets `-setnumber` override: those it defines with
/// `DefineNumber` (`name = DefineNumber[...]`) or guards with `If (!Exists(name))`.
pub fn geo_parameters(geo_text: &str) -> Vec<String> {
    let mut names = Vec::new();
    for line in geo_text.lines() {
        let l = line.trim();
        if let Some(pos) = l.find("DefineNumber") {
            let lhs = l[..pos].trim().trim_end_matches('=').trim();
            if !lhs.is_empty() {
                names.push(lhs.to_string());
            }
        }
        if let Some(pos) = l.find("Exists(") {
            let rest = &l[pos + 7..];
            if let Some(end) = rest.find(')') {
                names.push(rest[..end].trim().to_string());
            }
        }
    }
    names.sort();
    names.dedup();
    names
}

/// Mesh `geo` with gmsh into `out` (MSH 4.1), setting each parameter with `-setnumber`.
/// Writes to a temporary name and renames, so an interrupted run leaves no half-written mesh.
pub fn mesh(geo: &Path, params: &BTreeMap<String, f64>, order: u32, out: &Path) -> Result<()> {
    let text = std::fs::read_to_string(geo).map_err(|e| {
        bad_input(format!(
            "cannot read the geometry file {}: {e}",
            geo.display()
        ))
    })?;
    let known = geo_parameters(&text);
    for name in params.keys() {
        if !known.iter().any(|k| k == name) {
            return Err(bad_input(format!(
                "parameter `{name}` is not defined by {} (it defines: {})",
                geo.display(),
                known.join(", ")
            )));
        }
    }
    if !(1..=2).contains(&order) {
        return Err(bad_input(format!(
            "element order {order} is not supported: expected 1 (TET4) or 2 (TET10)"
        )));
    }
    if out.is_dir() {
        return Err(bad_input(format!(
            "output {} is an existing directory; expected a .msh file name",
            out.display()
        )));
    }
    let gmsh = which_gmsh()?;
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create directory {}", dir.display()))?;
    }
    // `.<name>.tmp-<pid>-gmsh`: the pattern `nlmodes_output::remove_stale_temporaries` removes,
    // so even the file of a gmsh killed with nlmodes is cleaned by the next `nlmodes run`.
    let name = out
        .file_name()
        .map_or_else(|| "mesh.msh".into(), |n| n.to_string_lossy().into_owned());
    let tmp = out.with_file_name(format!(".{name}.tmp-{}-gmsh", std::process::id()));
    let mut cmd = Command::new(&gmsh);
    cmd.arg("-3")
        .arg("-order")
        .arg(order.to_string())
        .arg("-format")
        .arg("msh41")
        .arg("-v")
        .arg("2")
        .arg("-setnumber")
        .arg("order")
        .arg(order.to_string());
    for (k, v) in params {
        cmd.arg("-setnumber").arg(k).arg(format!("{v:e}"));
    }
    cmd.arg(geo).arg("-o").arg(&tmp);
    tracing::debug!("running {:?}", cmd);
    crate::child::without_aslr(&mut cmd);
    let output = crate::child::die_with_parent(&mut cmd).output();
    let output = match output {
        Ok(o) => o,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e).with_context(|| format!("cannot run {}", gmsh.display()));
        }
    };
    if !output.status.success() || !tmp.exists() {
        let _ = std::fs::remove_file(&tmp);
        // The geometry or its parameters did not mesh: bad input.
        return Err(bad_input(format!(
            "gmsh failed on {} ({}):\n{}{}",
            geo.display(),
            output.status,
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        )));
    }
    let stderr = String::from_utf8_lossy(&output.stderr);
    for line in stderr.lines().filter(|l| l.contains("Error")) {
        tracing::warn!("gmsh: {line}");
    }
    // A .geo that meshes without tetrahedra (no volume, a wrong physical group) is refused
    // here rather than by the stage that reads it.
    if let Err(e) = nlmodes_fem::read_msh(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(bad_input(format!(
            "gmsh meshed {} but the result is not a usable mesh: {e}",
            geo.display()
        )));
    }
    if let Err(e) = std::fs::rename(&tmp, out) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e)
            .with_context(|| format!("cannot move {} to {}", tmp.display(), out.display()));
    }
    Ok(())
}

fn which_gmsh() -> Result<std::path::PathBuf> {
    let name = std::env::var_os("NLMODES_GMSH").unwrap_or_else(|| "gmsh".into());
    let p = std::path::PathBuf::from(&name);
    if p.components().count() > 1 {
        if p.exists() {
            return Ok(p);
        }
    } else if let Some(paths) = std::env::var_os("PATH") {
        for dir in std::env::split_paths(&paths) {
            let cand = dir.join(&p);
            if cand.is_file() {
                return Ok(cand);
            }
        }
    }
    bail!(
        "gmsh not found (looked for `{}` on PATH; set NLMODES_GMSH to its path). \
         Install it with `scripts/deps` (Debian package gmsh)",
        p.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_found_from_define_number_and_exists_guards() {
        let geo = "span = DefineNumber[0.12, Name \"span\"];\nIf (!Exists(twist)) twist = 30; EndIf\nx = 3;";
        assert_eq!(
            geo_parameters(geo),
            vec!["span".to_string(), "twist".to_string()]
        );
    }
}
