//! Checks of a whole case, of the study settings and of output locations before any stage runs
//! (issue 14). Every problem is one line naming the file, the `table.key`, the value and what was
//! expected; all problems are reported together, as bad input (exit code 2, [`crate::exit`]).

use anyhow::Result;
use nlmodes_nnm::{ContinuationSettings, SolverSettings};
use std::path::Path;

use crate::case::{Case, MasterChoice};
use crate::exit::bad_input;
pub use crate::problems::Problems;

fn positive(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Every key of a case and the cross-key rules; `path` names the file in messages.
pub fn check_case(case: &Case, path: &Path) -> Result<()> {
    let mut p = Problems::of_file(path);
    if let Some(name) = &case.name {
        let plain = !name.is_empty()
            && name != "."
            && name != ".."
            && !name.contains(['/', '\\'])
            && !name.contains('\0');
        p.check(
            plain,
            "name",
            name,
            "a plain directory name (no '/', not empty)",
        );
    }
    check_mesh(case, &mut p);
    let m = &case.material;
    p.check(
        positive(m.young),
        "material.young",
        m.young,
        "a finite value > 0 (Pa)",
    );
    p.check(
        m.poisson > -1.0 && m.poisson < 0.5,
        "material.poisson",
        m.poisson,
        "-1 < poisson < 0.5",
    );
    p.check(
        positive(m.density),
        "material.density",
        m.density,
        "a finite value > 0 (kg/m^3)",
    );
    check_model(case, &mut p);
    check_nnm(case.nnm.harmonics, case.nnm.samples, &mut p);
    check_settings(&case.algorithm, &case.continuation, &mut p);
    check_traced_modes(case, &mut p);
    let tol = case.nnm.truncation_tolerance;
    p.check(
        tol.is_finite() && tol > 0.0 && tol < 1.0,
        "nnm.truncation_tolerance",
        tol,
        "a relative change in (0, 1)",
    );
    check_convergence(&case.nnm.convergence(), case.nnm.harmonics, &mut p);
    if let Err(e) = case.stability.hill.validate() {
        p.note("stability.hill", &e.to_string());
    }
    let (lo, hi) = (case.continuation.q_start, case.continuation.q_max);
    for (i, &k) in case.nnm.keep.iter().enumerate() {
        p.check(
            k.is_finite() && k >= lo && k <= hi,
            &format!("nnm.keep[{i}]"),
            k,
            &format!(
                "an amplitude q/g0 within [continuation.q_start, continuation.q_max] = [{lo}, {hi}]"
            ),
        );
    }
    p.check(
        case.nnm.frames >= 2,
        "nnm.frames",
        case.nnm.frames,
        "at least 2 frames per period",
    );
    if case.forced.enabled {
        check_forced(case, &mut p);
    }
    if let Some(r) = &case.rotation {
        r.check(&mut p);
        r.check_map_amplitudes(&case.continuation, &mut p);
    }
    check_speed_sweep(case, &mut p);
    p.finish()?;
    check_output_dir(&case.out_dir(), &format!("{}: results_dir", path.display()))
}

/// `[speed_sweep]`: its keys, its speed range within the Campbell range, `[rotation]` present
/// (the Campbell stage builds the parametric model it runs on), `[forced]` checked even when the
/// frequency sweeps are off, and its penalty law.
fn check_speed_sweep(case: &Case, p: &mut Problems) {
    let Some(sweep) = case.speed_sweep.as_ref().filter(|s| s.enabled) else {
        return;
    };
    match &case.rotation {
        Some(r) => sweep.check(p, Some(r.campbell_range), "rotation.campbell_range"),
        None => p.note(
            "speed_sweep",
            "needs a [rotation] table: the sweeps run on the parametric reduced model of the \
             Campbell stage",
        ),
    }
    if !case.forced.enabled {
        check_forced(case, p);
    }
    crate::speed_sweep::speed_sweep_settings::check_forced_for_sweeps(&case.forced, p);
    crate::speed_sweep::forced_speed_distortion::check(&case.forced, sweep, p);
}

fn check_mesh(case: &Case, p: &mut Problems) {
    let mesh = &case.mesh;
    p.check(
        (1..=2).contains(&mesh.order),
        "mesh.order",
        mesh.order,
        "1 (TET4) or 2 (TET10)",
    );
    for (name, v) in &mesh.parameters {
        p.check(
            v.is_finite(),
            &format!("mesh.parameters.{name}"),
            v,
            "a finite number",
        );
    }
    match std::fs::read_to_string(&mesh.geo) {
        Err(e) => p.note(
            "mesh.geo",
            &format!("cannot read {}: {e}", mesh.geo.display()),
        ),
        Ok(text) => {
            let known = crate::mesh::gmsh::geo_parameters(&text);
            for name in mesh.parameters.keys().filter(|n| !known.contains(n)) {
                p.note(
                    &format!("mesh.parameters.{name}"),
                    &format!(
                        "`{name}` is not defined by {} (it defines: {})",
                        mesh.geo.display(),
                        known.join(", ")
                    ),
                );
            }
        }
    }
}

fn check_model(case: &Case, p: &mut Problems) {
    let m = &case.model;
    p.check(
        !m.clamp.is_empty(),
        "model.clamp",
        &m.clamp,
        "at least one clamped group",
    );
    let mut clamped = Vec::new();
    for (i, spec) in m.clamp.iter().enumerate() {
        match nlmodes_fem::parse_fix_spec(spec) {
            Ok((group, _)) => clamped.push(group),
            Err(e) => p.note(&format!("model.clamp[{i}]"), &e.to_string()),
        }
    }
    p.check(
        !m.contact_group.trim().is_empty(),
        "model.contact_group",
        &m.contact_group,
        "a physical group name",
    );
    p.check(
        !clamped.contains(&m.contact_group),
        "model.contact_group",
        &m.contact_group,
        &format!("a group that is not clamped (model.clamp = {:?})", m.clamp),
    );
    p.check(
        m.rotor_axis_point.iter().all(|v| v.is_finite()),
        "model.rotor_axis_point",
        m.rotor_axis_point,
        "three finite coordinates (m)",
    );
    let d = m.rotor_axis_direction;
    p.check(
        d.iter().all(|v| v.is_finite()) && d.iter().any(|&v| v != 0.0),
        "model.rotor_axis_direction",
        d,
        "a finite, non-zero vector",
    );
    p.check(positive(m.gap), "model.gap", m.gap, "a finite gap > 0 (m)");
    p.check(
        m.fixed_interface_modes >= 1,
        "model.fixed_interface_modes",
        m.fixed_interface_modes,
        "at least 1",
    );
    p.check(
        m.linear_modes >= 1,
        "model.linear_modes",
        m.linear_modes,
        "at least 1",
    );
    p.check(
        crate::reduce::FullCheck::parse(&m.full_check).is_some(),
        "model.full_check",
        &m.full_check,
        "\"auto\" (up to 200000 DOFs), \"on\" or \"off\"",
    );
    if let MasterChoice::Auto(s) = &m.master {
        p.check(
            s == "auto",
            "model.master",
            s,
            "\"auto\" or a reduced DOF index",
        );
    }
}

/// `[forced]` of a case: its keys, then what the case knows of the model before any stage runs.
/// The swept and loading modes and the damping ratios count the modes the Craig-Bampton basis is
/// built to represent (below `model.fixed_interface_modes`, as for the traced modes: the reduced
/// model's higher modes are not converged), so a bad index is refused before meshing, reduction
/// and the backbone; `F.mtx` (`load = "file"`) and `C.mtx` (`damping_matrix`) are not written by
/// the reduce stage, so they must be in the model directory already.
fn check_forced(case: &Case, p: &mut Problems) {
    let f = &case.forced;
    f.check(p);
    let limit = case.model.fixed_interface_modes;
    let expected =
        format!("a linear mode index (0-based) below model.fixed_interface_modes = {limit}");
    p.check(f.mode < limit, "forced.mode", f.mode, &expected);
    p.check(
        f.load_mode < limit,
        "forced.load_mode",
        f.load_mode,
        &expected,
    );
    if f.damping_ratios.len() > limit {
        p.note(
            "forced.damping_ratios",
            &format!(
                "{} ratios: expected at most model.fixed_interface_modes = {limit}, one per \
                 linear mode the reduced model is built to represent (the last applies to the \
                 modes above)",
                f.damping_ratios.len()
            ),
        );
    }
    let model = case.out_dir().join("model");
    let f_mtx = model.join("F.mtx");
    if f.load == crate::forced::forced_settings::ForcedLoadKind::File && !f_mtx.is_file() {
        p.check(
            false,
            "forced.load",
            "file",
            &format!(
                "\"master\" or \"mode\" in a case: \"file\" reads F.mtx of a reduced-model \
                 directory ({} does not exist; the reduce stage writes none): bring it with \
                 `nlmodes forced MODEL`",
                f_mtx.display()
            ),
        );
    }
    let c_mtx = model.join("C.mtx");
    if f.damping_matrix && !c_mtx.is_file() {
        p.check(
            false,
            "forced.damping_matrix",
            true,
            &format!(
                "false in a case: true reads C.mtx of a reduced-model directory ({} does not \
                 exist; the reduce stage writes none): give damping_ratio, damping_ratios or \
                 rayleigh, or bring C.mtx with `nlmodes forced MODEL`",
                c_mtx.display()
            ),
        );
    }
}

/// N >= 1 and m >= 2N + 1 (below that, cosines of different orders alias).
pub fn check_nnm(harmonics: usize, samples: usize, p: &mut Problems) {
    p.check(
        harmonics >= 1,
        "nnm.harmonics",
        harmonics,
        "at least 1 (the fundamental)",
    );
    let min = 2 * harmonics + 1;
    p.check(
        samples >= min,
        "nnm.samples",
        samples,
        &format!("at least 2 nnm.harmonics + 1 = {min} time samples per period"),
    );
}

/// The modes a case traces (`continuation.mode`, or each of `continuation.modes`): below
/// `model.fixed_interface_modes`, the modes the Craig-Bampton basis is built to represent (the
/// reduced model's higher modes are not converged), so a bad index is refused before meshing and
/// reduction.
fn check_traced_modes(case: &Case, p: &mut Problems) {
    let limit = case.model.fixed_interface_modes;
    let expected =
        format!("a linear mode index (0-based) below model.fixed_interface_modes = {limit}");
    let cont = &case.continuation;
    if cont.modes.is_empty() {
        p.check(cont.mode < limit, "continuation.mode", cont.mode, &expected);
    }
    for (i, &k) in cont.modes.iter().enumerate() {
        p.check(k < limit, &format!("continuation.modes[{i}]"), k, &expected);
    }
}

/// The `[algorithm]` and `[continuation]` tables: the ranges of the nnm crate, named by table.
pub fn check_settings(alg: &SolverSettings, cont: &ContinuationSettings, p: &mut Problems) {
    if let Err(e) = alg.validate() {
        p.note("algorithm", &e.to_string());
    }
    if let Err(e) = cont.validate() {
        p.note("continuation", &e.to_string());
    }
}

/// `dir` can hold results: it is a directory, or it can be created (its nearest existing
/// ancestor is a writable directory). `what` names the setting in the error. Creates nothing.
pub fn check_output_dir(dir: &Path, what: &str) -> Result<()> {
    let mut probe = dir;
    loop {
        if probe.as_os_str().is_empty() {
            probe = Path::new(".");
        }
        match std::fs::metadata(probe) {
            Ok(meta) if meta.is_dir() => break,
            Ok(_) => {
                return Err(bad_input(format!(
                    "{what}: output directory {}: {} exists and is not a directory",
                    dir.display(),
                    probe.display()
                )))
            }
            Err(_) => match probe.parent() {
                Some(parent) => probe = parent,
                None => break,
            },
        }
    }
    let test = probe.join(format!(".nlmodes-write-test-{}", std::process::id()));
    match std::fs::File::create(&test) {
        Ok(_) => {
            let _ = std::fs::remove_file(&test);
            Ok(())
        }
        Err(e) => Err(bad_input(format!(
            "{what}: output directory {}: cannot write in {}: {e}",
            dir.display(),
            probe.display()
        ))),
    }
}

/// An output file `out` (e.g. `nlmodes mesh -o FILE`): not an existing directory, and its
/// directory can hold it.
pub fn check_output_file(out: &Path, what: &str) -> Result<()> {
    if out.is_dir() {
        return Err(bad_input(format!(
            "{what} {}: is an existing directory; expected a file name",
            out.display()
        )));
    }
    let parent = out.parent().unwrap_or(Path::new("."));
    check_output_dir(parent, what)
}

/// The converged orbits' settings (`nnm.share_tolerance`, `nnm.max_harmonics`; the command line
/// names them through `p`'s labels).
pub fn check_convergence(r: &nlmodes_nnm::ConvergenceSettings, harmonics: usize, p: &mut Problems) {
    let tol = r.share_tolerance;
    p.check(
        tol.is_finite() && (0.0..1.0).contains(&tol),
        "nnm.share_tolerance",
        tol,
        "a fraction of the period in [0, 1)",
    );
    p.check(
        r.max_harmonics >= harmonics && r.max_harmonics <= 1000,
        "nnm.max_harmonics",
        r.max_harmonics,
        &format!("an N from harmonics = {harmonics} up to 1000 (each refinement doubles N)"),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn problems(case: &Case) -> String {
        match check_case(case, Path::new("c.toml")) {
            Ok(()) => String::new(),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn cross_key_rules_are_named() {
        let mut c = Case::default();
        c.nnm.samples = 5;
        c.nnm.keep = vec![f64::NAN, -1.0, 40.0, 5.0];
        c.nnm.frames = 0;
        c.model.linear_modes = 0;
        c.model.full_check = "sometimes".into();
        c.model.contact_group = "root".into();
        let e = problems(&c);
        for part in [
            "c.toml: nnm.samples = 5: expected at least 2 nnm.harmonics + 1 = 21",
            "nnm.keep[0] = NaN",
            "nnm.keep[1] = -1.0",
            "nnm.keep[2] = 40.0",
            "nnm.frames = 0",
            "model.linear_modes = 0",
            "c.toml: model.full_check = \"sometimes\": expected \"auto\"",
            "model.contact_group = \"root\": expected a group that is not clamped",
        ] {
            assert!(e.contains(part), "missing `{part}` in:\n{e}");
        }
        assert!(!e.contains("nnm.keep[3]"), "{e}");
    }

    /// Issue 37: the forced indices count the modes the basis is built for, and the files the
    /// reduce stage does not write are refused, all before the first stage.
    #[test]
    fn forced_keys_are_checked_against_the_case() {
        let mut c = Case::default();
        c.model.fixed_interface_modes = 20;
        c.forced.mode = 500;
        c.forced.load_mode = 20;
        c.forced.damping_ratios = vec![0.01; 21];
        c.forced.damping_matrix = true;
        c.results_dir = std::env::temp_dir().join("nlmodes-validate-test-none");
        let e = problems(&c);
        for part in [
            "c.toml: forced.mode = 500: expected a linear mode index (0-based) below \
             model.fixed_interface_modes = 20",
            "c.toml: forced.load_mode = 20: expected a linear mode index",
            "c.toml: forced.damping_ratios: 21 ratios: expected at most \
             model.fixed_interface_modes = 20",
            "c.toml: forced.damping_matrix = true: expected false in a case",
        ] {
            assert!(e.contains(part), "missing `{part}` in:\n{e}");
        }
        c.forced.enabled = false;
        assert!(!problems(&c).contains("forced."), "{}", problems(&c));
    }

    #[test]
    fn an_output_directory_under_a_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("f");
        std::fs::write(&file, "x").unwrap();
        let e = check_output_dir(&file.join("sub"), "--out")
            .unwrap_err()
            .to_string();
        assert!(e.contains("is not a directory"), "{e}");
        assert!(check_output_dir(&dir.path().join("new/sub"), "--out").is_ok());
        let e = check_output_file(dir.path(), "-o").unwrap_err().to_string();
        assert!(e.contains("existing directory"), "{e}");
    }
}
