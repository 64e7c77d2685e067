//! The forced study's inputs checked against the reduced model before any curve is traced
//! (issues 22 and 37; docs/DESIGN.md §10): the mode indices and the damping ratios against the
//! model's order, `C.mtx` (order, symmetry, positive semi-definite), `F.mtx`, what
//! `level_unit = "grazing"` needs (damping on the swept mode and a load that drives it), the
//! penalty stiffness, the backbone of `--backbone` (same model, same mode) and the mesh the
//! orbits are drawn on. Every refusal is bad input (exit code 2) naming the file, the key or the
//! matrix, the value and what was expected. The keys alone: `ForcedSection::check`.

use std::path::Path;

use anyhow::Result;
use faer::Mat;
use nlmodes_forced::FreeOrbit;
use nlmodes_modal::ReducedModel;
use nlmodes_nnm::System;

use crate::exit::bad_input;
use crate::forced::forced_settings::{ForcedContact, ForcedLoadKind, ForcedSection, LevelUnit};
use crate::post::results::BackboneFile;
use crate::problems::Problems;

/// phi^T C phi of the swept mode at or below this times sum |phi_i| |C_ij| |phi_j| is no damping:
/// the quadratic form's rounding is at most about 2 n eps times that sum (4e-13 at n = 1000), so
/// a damped mode lies far above and a mode without damping (C = 0, or a C that leaves it out)
/// at most at this level ([`nlmodes_forced::SEMIDEFINITE_TOLERANCE`], the same argument).
const UNDAMPED_LEVEL: f64 = 1e-10;

/// |phi . f| at or below this times sum |phi_i| |f_i| is a load that does not drive the swept
/// mode. The computed linear modes are M-orthogonal to rounding: |phi_r . M phi_l| is at most
/// 5.5e-12 of sum |phi_r,i (M phi_l)_i| over all 92 modes of the coarse blade of the bad-input
/// corpus (6e-15 among its first 20; measured once), so a pattern orthogonal to the mode shows a
/// drive at that level and 1e-8 keeps a margin of 1800; a real pattern below it would need 1e8
/// times the force of an aligned one to graze.
const UNDRIVEN_LEVEL: f64 = 1e-8;

/// Relative distance within which the backbone's linear frequency and gap reference are those of
/// the model: the same model gives the same numbers up to rounding (1e-15 measured), while
/// another model differs far more (the coarse blade with 16 instead of 20 fixed-interface modes:
/// 5.8e-6 on w1).
const SAME_MODEL: f64 = 1e-9;

/// The reduced model of the study.
pub struct ForcedModel<'a> {
    /// Its directory (`C.mtx`, `F.mtx`; named in the messages).
    pub dir: &'a Path,
    pub reduced: &'a ReducedModel,
    pub system: &'a System,
}

/// What the study reads beside its settings, checked.
pub struct ForcedInputs {
    /// C of `C.mtx` (`damping_matrix = true`), N s/m.
    pub damping_matrix: Option<Mat<f64>>,
    /// The columns of `F.mtx` (`load = "file"`, `"group"`, `"pressure"`), N.
    pub file_load: Option<Mat<f64>>,
}

/// Every check against the model; `source` names the settings (a file, or `[forced]` of the
/// case) and `backbone` is `--backbone` (its file and content).
pub fn check(
    model: &ForcedModel<'_>,
    s: &ForcedSection,
    source: &str,
    backbone: Option<(&Path, &BackboneFile)>,
) -> Result<ForcedInputs> {
    let system = model.system;
    check_indices(system, s, source)?;
    let inputs = ForcedInputs {
        damping_matrix: crate::forced::forced_settings::damping_matrix(s, model.dir, system)?,
        file_load: crate::forced::forced_settings::file_load(s, model.dir, system.n_dofs())?,
    };
    check_penalty(system, s, source)?;
    check_distortion(system, s, source)?;
    // The grazing unit scales the loaded curves and the level sweeps; a casing distortion alone
    // needs no force.
    if s.level_unit == LevelUnit::Grazing && (s.loaded() || !s.level_sweeps.is_empty()) {
        check_grazing(system, model.dir, s, source, &inputs)?;
    }
    if let Some((path, b)) = backbone {
        check_backbone(system, model.dir, s, source, path, b)?;
    }
    check_orbit_mesh(model, s, source)?;
    Ok(inputs)
}

/// `mode` and `load_mode` below the model's order n, at most n damping ratios, and a swept mode
/// that vibrates (not a rigid-body mode, the model's own tolerance) and moves a contact row.
fn check_indices(system: &System, s: &ForcedSection, source: &str) -> Result<()> {
    let n = system.n_dofs();
    let label = source.to_string();
    let mut p = Problems::new(move |key| format!("{label}: {key}"));
    let expected =
        format!("a linear mode index (0-based) below {n}, the order of the reduced model");
    p.check(s.mode < n, "forced.mode", s.mode, &expected);
    p.check(s.load_mode < n, "forced.load_mode", s.load_mode, &expected);
    if s.damping_ratios.len() > n {
        p.note(
            "forced.damping_ratios",
            &format!(
                "{} ratios: expected at most one per linear mode of the reduced model, n = {n} \
                 (the last applies to the modes above)",
                s.damping_ratios.len()
            ),
        );
    }
    p.finish()?;
    let w = system.linear_frequencies();
    let largest = w.iter().fold(0.0_f64, |a, v| a.max(*v));
    let rigid = nlmodes_modal::model_checks::RIGID_MODE_TOLERANCE;
    if w[s.mode] * w[s.mode] <= rigid * largest * largest {
        return Err(bad_input(format!(
            "{source}: forced.mode = {}: a rigid-body mode of the reduced model (w = {:e} rad/s, \
             w^2 within 1e-12 of the largest): expected a vibration mode (is the model clamped?)",
            s.mode, w[s.mode]
        )));
    }
    if system.grazing_amplitude(s.mode)?.is_none() {
        return Err(bad_input(format!(
            "{source}: forced.mode = {}: no contact row moves in this mode, the forced \
             response never touches",
            s.mode
        )));
    }
    Ok(())
}

/// The penalty stiffness kc = `penalty_factor` x the median static contact stiffness is finite.
fn check_penalty(system: &System, s: &ForcedSection, source: &str) -> Result<()> {
    if s.contact != ForcedContact::Penalty {
        return Ok(());
    }
    let mut ks = system.contact_stiffness().to_vec();
    ks.sort_by(f64::total_cmp);
    let median = ks.get(ks.len() / 2).copied().unwrap_or(0.0);
    let kc = s.penalty_factor * median;
    if !(kc.is_finite() && kc > 0.0) {
        return Err(bad_input(format!(
            "{source}: forced.penalty_factor = {:e}: kc = {:e} x the median static contact \
             stiffness {median:e} N/m = {kc:e} N/m: expected a finite penalty stiffness > 0",
            s.penalty_factor, s.penalty_factor
        )));
    }
    Ok(())
}

/// A casing distortion alone (no level above 0) must reach the blade at rest: with delta at or
/// below every row's gap the orbit is the blade at rest, y = 0, and the study computes nothing
/// (docs/DESIGN.md §10.11).
fn check_distortion(system: &System, s: &ForcedSection, source: &str) -> Result<()> {
    let Some(d) = &s.distortion else {
        return Ok(());
    };
    if s.loaded() {
        return Ok(());
    }
    let g0 = system.gap_reference();
    let delta = d.amplitude_m(g0);
    let smallest = system.gaps().iter().copied().fold(f64::INFINITY, f64::min);
    if delta > smallest {
        return Ok(());
    }
    Err(bad_input(format!(
        "{source}: forced.distortion.amplitude = {} ({delta:e} m) with no load (forced.levels = \
         {:?}): expected more than the smallest gap of the model, {smallest:e} m: a casing that \
         never reaches the blade at rest leaves it at rest, and the response is zero (give a \
         larger amplitude, or levels > 0)",
        d.amplitude, s.levels
    )))
}

/// `level_unit = "grazing"`: the force of a level is level x q_graze 2 zeta w^2 /
/// (|phi_master| |phi . f|) (`crate::forced::force_of`), so the swept mode must be damped and
/// driven beyond rounding; otherwise the force is zero or a quotient of rounding errors.
fn check_grazing(
    system: &System,
    dir: &Path,
    s: &ForcedSection,
    source: &str,
    inputs: &ForcedInputs,
) -> Result<()> {
    let c = s
        .damping(inputs.damping_matrix.clone())
        .matrix(system)
        .map_err(|e| bad_input(format!("{source}: [forced] damping: {e}")))?;
    let phi = system.linear_mode(s.mode)?;
    let n = phi.len();
    let (mut form, mut bound) = (0.0, 0.0);
    for i in 0..n {
        for j in 0..n {
            form += phi[i] * c[(i, j)] * phi[j];
            bound += (phi[i] * c[(i, j)] * phi[j]).abs();
        }
    }
    if form <= UNDAMPED_LEVEL * bound {
        return Err(bad_input(format!(
            "{source}: {}: the swept mode (forced.mode = {}) gets no damping (phi^T C phi = \
             {form:e} 1/s, at most 1e-10 of sum |phi_i C_ij phi_j| = {bound:e}): expected damping \
             on it with forced.level_unit = \"grazing\" (its levels are multiples of the force \
             whose damped linear resonance grazes, zero without damping; or level_unit = \"N\")",
            damping_source(dir, s),
            s.mode
        )));
    }
    let largest = phi.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    if phi[system.master()].abs() <= UNDRIVEN_LEVEL * largest {
        return Err(bad_input(format!(
            "{source}: forced.mode = {}: the swept mode does not move the master coordinate {} \
             (|phi_master| = {:e}, at most 1e-8 of its largest entry): expected a mode that \
             moves it with forced.level_unit = \"grazing\" (the grazing amplitude is the \
             master's; or level_unit = \"N\")",
            s.mode,
            system.master(),
            phi[system.master()].abs()
        )));
    }
    let pattern = crate::forced::pattern(system, s, inputs.file_load.as_ref())?;
    let (drive, scale) = pattern.drive(&phi)?;
    if drive <= UNDRIVEN_LEVEL * scale {
        return Err(bad_input(format!(
            "{source}: {}: the load does not drive the swept mode (forced.mode = {}): |phi . f| \
             = {drive:e}, at most 1e-8 of sum |phi_i f_i| = {scale:e}: expected a load that \
             drives it with forced.level_unit = \"grazing\" (no force makes it graze; or \
             level_unit = \"N\")",
            load_source(dir, s),
            s.mode
        )));
    }
    Ok(())
}

/// Where the damping comes from, for messages.
fn damping_source(dir: &Path, s: &ForcedSection) -> String {
    if s.damping_matrix {
        format!(
            "forced.damping_matrix = true ({})",
            dir.join("C.mtx").display()
        )
    } else if let Some(r) = s.rayleigh {
        format!("forced.rayleigh = {r:?}")
    } else if !s.damping_ratios.is_empty() {
        format!("forced.damping_ratios = {:?}", s.damping_ratios)
    } else {
        format!("forced.damping_ratio = {:?}", s.damping_ratio)
    }
}

/// What the load is, for messages.
fn load_source(dir: &Path, s: &ForcedSection) -> String {
    match s.load {
        ForcedLoadKind::Master => "forced.load = \"master\"".into(),
        ForcedLoadKind::Mode => format!("forced.load = \"mode\", load_mode = {}", s.load_mode),
        _ => format!(
            "forced.load = {:?} ({})",
            format!("{:?}", s.load).to_lowercase(),
            dir.join("F.mtx").display()
        ),
    }
}

/// `--backbone`: every point of the model's order (a backbone of another model has another),
/// finite, and the linear frequency and gap reference of the swept mode of this model.
fn check_backbone(
    system: &System,
    dir: &Path,
    s: &ForcedSection,
    source: &str,
    path: &Path,
    b: &BackboneFile,
) -> Result<()> {
    let n = system.n_dofs();
    let file = format!("--backbone {}", path.display());
    let orbits: Vec<FreeOrbit<'_>> = b
        .points
        .iter()
        .map(|p| FreeOrbit {
            q: p.q,
            omega: p.omega,
            coefficients: &p.coefficients,
        })
        .collect();
    nlmodes_forced::check_orbits(n, &orbits).map_err(|e| {
        bad_input(format!(
            "{file}: {e} ({}: a backbone of another model?)",
            dir.display()
        ))
    })?;
    let w = system.linear_frequencies()[s.mode];
    let g = system.gap_reference();
    let same = |a: f64, b: f64| (a - b).abs() <= SAME_MODEL * b.abs();
    if !same(b.omega_linear, w) {
        return Err(bad_input(format!(
            "{file}: omega_linear = {:e} rad/s (the linear frequency of the mode it follows): \
             expected {w:e} rad/s, that of the swept mode ({source}: forced.mode = {}) of {} \
             (within a relative 1e-9): a backbone of another mode or model",
            b.omega_linear,
            s.mode,
            dir.display()
        )));
    }
    if !same(b.gap_reference, g) {
        return Err(bad_input(format!(
            "{file}: gap_reference = {:e} m: expected {g:e} m, the gap reference of {} (within a \
             relative 1e-9): a backbone of another model",
            b.gap_reference,
            dir.display()
        )));
    }
    Ok(())
}

/// The orbits (`keep_peaks`, `keep`) are drawn on the mesh the model was reduced from: it must
/// be readable and of the model's size before the curves are traced.
fn check_orbit_mesh(model: &ForcedModel<'_>, s: &ForcedSection, source: &str) -> Result<()> {
    if !s.keep_peaks && s.keep.is_empty() {
        return Ok(());
    }
    crate::post::FullMesh::of(model.reduced).map_err(|e| {
        bad_input(format!(
            "{}: the mesh the model was reduced from: {e:#}; expected it readable, for the \
             orbits of {source}: forced.keep_peaks = {} and forced.keep = {:?} (set \
             keep_peaks = false and keep = [] to go without them)",
            model.dir.join("model.json").display(),
            s.keep_peaks,
            s.keep
        ))
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 3-DOF system with a non-diagonal mass matrix of the forced crate's tests: one contact
    /// row 0.2 x0 + x2 with gap 1e-3 m, master x2.
    fn three_dof() -> System {
        let m = [[2.0, 0.3, 0.0], [0.3, 1.0, 0.2], [0.0, 0.2, 1.5]];
        let k = [[3.0, -1.0, 0.0], [-1.0, 2.5, -1.0], [0.0, -1.0, 1.2]];
        let a = [0.2, 0.0, 1.0];
        System::new(
            Mat::from_fn(3, 3, |i, j| m[i][j]),
            Mat::from_fn(3, 3, |i, j| k[i][j]),
            Mat::from_fn(1, 3, |_, j| a[j]),
            vec![1e-3],
            2,
        )
        .unwrap()
    }

    fn grazing(s: &ForcedSection, c: Option<Mat<f64>>) -> String {
        let inputs = ForcedInputs {
            damping_matrix: c,
            file_load: None,
        };
        let dir = Path::new("model");
        match check_grazing(&three_dof(), dir, s, "f.toml", &inputs) {
            Ok(()) => String::new(),
            Err(e) => e.to_string(),
        }
    }

    /// Damping that leaves the swept mode out, at rounding level or exactly, is refused naming
    /// its source; damping on the mode passes.
    #[test]
    fn an_undamped_swept_mode_is_refused_with_grazing_levels() {
        let base = ForcedSection::default();
        assert_eq!(grazing(&base, None), "");
        let ratios = ForcedSection {
            damping_ratios: vec![0.0, 0.05],
            ..base.clone()
        };
        let e = grazing(&ratios, None);
        assert!(e.contains("forced.damping_ratios = [0.0, 0.05]: the swept mode (forced.mode = 0) gets no damping"), "{e}");
        let second = ForcedSection { mode: 1, ..ratios };
        assert_eq!(grazing(&second, None), "");
        let matrix = ForcedSection {
            damping_matrix: true,
            ..base.clone()
        };
        let e = grazing(&matrix, Some(Mat::zeros(3, 3)));
        assert!(
            e.contains("forced.damping_matrix = true (model/C.mtx)"),
            "{e}"
        );
        assert!(e.contains("gets no damping"), "{e}");
        let k = three_dof().stiffness().to_owned();
        assert_eq!(grazing(&matrix, Some(&k * 1e-3)), "");
    }

    /// The pattern M phi_l of another mode does not drive the swept mode: its computed drive lies
    /// far below the 1e-8 level (so the check is not at the edge of rounding), and is refused.
    #[test]
    fn a_load_orthogonal_to_the_swept_mode_is_refused_with_grazing_levels() {
        let system = three_dof();
        let (m, n) = (system.mass(), system.n_dofs());
        let mut worst = 0.0_f64;
        for r in 0..n {
            let phi_r = system.linear_mode(r).unwrap();
            for l in (0..n).filter(|&l| l != r) {
                let phi_l = system.linear_mode(l).unwrap();
                let f: Vec<f64> = (0..n)
                    .map(|i| (0..n).map(|j| m[(i, j)] * phi_l[j]).sum())
                    .collect();
                let dot: f64 = phi_r.iter().zip(&f).map(|(a, b)| a * b).sum();
                let bound: f64 = phi_r.iter().zip(&f).map(|(a, b)| (a * b).abs()).sum();
                worst = worst.max(dot.abs() / bound);
            }
        }
        assert!(worst < 1e-5 * UNDRIVEN_LEVEL, "worst {worst:e}");
        let other = ForcedSection {
            load: ForcedLoadKind::Mode,
            load_mode: 1,
            ..ForcedSection::default()
        };
        let e = grazing(&other, None);
        assert!(
            e.contains("forced.load = \"mode\", load_mode = 1: the load does not drive"),
            "{e}"
        );
        let same = ForcedSection { mode: 1, ..other };
        assert_eq!(grazing(&same, None), "");
    }

    /// A mode whose w^2 lies within 1e-12 of the largest is a rigid-body mode: refused.
    #[test]
    fn a_rigid_body_mode_is_refused() {
        let system = System::new(
            Mat::identity(2, 2),
            Mat::from_fn(2, 2, |i, j| [[1e-14, 0.0], [0.0, 1.0]][i][j]),
            Mat::from_fn(1, 2, |_, j| [0.6, 0.8][j]),
            vec![1e-3],
            1,
        )
        .unwrap();
        let s = ForcedSection::default();
        let e = check_indices(&system, &s, "f.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("f.toml: forced.mode = 0: a rigid-body mode of the reduced model"),
            "{e}"
        );
        let vibrating = ForcedSection { mode: 1, ..s };
        check_indices(&system, &vibrating, "f.toml").unwrap();
    }

    fn backbone(n: usize, omega: f64, gap: f64) -> BackboneFile {
        serde_json::from_value(serde_json::json!({
            "points": [{
                "q": 2e-3, "omega": omega * 1.01, "omega_ratio": 1.01, "frequency_hz": 1.0,
                "contact_fraction": [0.0], "powell_measure": 0.0, "newton_iterations": 1,
                "fold": false, "jump": false, "truncation_warning": false,
                "coefficients": [vec![0.0; n], vec![1e-3; n]], "contact_force": [[0.0]],
            }],
            "termination": "Complete", "omega_linear": omega, "gap_reference": gap,
            "grazing_amplitude": 1e-3,
        }))
        .unwrap()
    }

    /// A backbone of another order, mode or gap is refused naming the file and both values.
    #[test]
    fn a_backbone_of_another_model_or_mode_is_refused() {
        let system = three_dof();
        let s = ForcedSection::default();
        let w = system.linear_frequencies();
        let g = system.gap_reference();
        let check = |b: &BackboneFile| {
            let path = Path::new("b/backbone.json");
            match check_backbone(&system, Path::new("model"), &s, "f.toml", path, b) {
                Ok(()) => String::new(),
                Err(e) => e.to_string(),
            }
        };
        assert_eq!(check(&backbone(3, w[0], g)), "");
        let e = check(&backbone(2, w[0], g));
        assert!(e.contains("--backbone b/backbone.json: backbone point 0, harmonic 0 is 2 coordinates, expected 3"), "{e}");
        assert!(
            e.contains("expected 3 (the order of the model) (model: a backbone of another model?)"),
            "{e}"
        );
        let e = check(&backbone(3, w[1], g));
        assert!(
            e.contains("omega_linear = ") && e.contains("another mode or model"),
            "{e}"
        );
        let e = check(&backbone(3, w[0], 2.0 * g));
        assert!(e.contains("gap_reference = "), "{e}");
    }
}
