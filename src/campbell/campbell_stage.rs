//! The `campbell` stage of `nlmodes run` (issue 23, items 5-6): the linear modes of the
//! prestressed blade over `[rotation] campbell_range` ([`crate::campbell`]), tracked across
//! speeds by their mass-weighted MAC, each curve's Southwell coefficient, the crossings with the
//! engine-order lines, and the interaction map: the band of frequencies the first nonlinear mode
//! sweeps from grazing to the largest traced amplitude, at rest (cold gap) and at the operating
//! speed (running gap), drawn on the diagram. Writes `results/<case>/campbell/`:
//! `campbell.csv`, `crossings.csv`, `campbell.json`, `campbell.png/svg`, `section.md`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Result;
use faer::Mat;
use nlmodes_fem::Isotropic;
use serde::{Deserialize, Serialize};

use crate::campbell::campbell_march::SpeedFamily;
use crate::campbell::campbell_parametric::{check_speeds, ParametricBuilder, ParametricSummary};
use crate::campbell::BasisModes;
use crate::case::Case;
use crate::layout::Layout;
use crate::mesh::fe_model::FeModel;
use crate::rotation::rotation_settings::{RotationSection, RPM_TO_RAD_S};
use crate::rotation::static_states;
use crate::stage::{Only, Stage};
use crate::stage_hash::fnv1a;
use nlmodes_modal::{ParametricModel, RitzBasis, RitzModes};

/// Tracked modes below this MAC with their predecessor are flagged (veering or a mode
/// entering from above: the curve's identity is uncertain there).
pub const MAC_UNCERTAIN: f64 = 0.8;

/// One tracked curve of the diagram.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Curve {
    /// 1-based: the order of the mode at the first speed.
    pub mode: usize,
    /// Frequency at each speed, Hz.
    pub frequency_hz: Vec<f64>,
    /// MAC with the same curve at the previous speed (1 at the first speed).
    pub mac: Vec<f64>,
    /// Euclidean relative residual ||K x - lambda M x|| / (lambda ||M x||) of the Ritz pair on
    /// the full model at each speed: a pessimistic measure (the stiff, small-scale content of a
    /// Ritz vector dominates K x while the frequency is good to the residual squared); the
    /// accuracy is checked by a direct solve ([`CampbellData::direct_check`]).
    pub residual: Vec<f64>,
    /// Southwell fit f^2 = f0^2 + S (rpm / 60)^2: f0 (Hz), S, largest relative misfit in f.
    pub southwell_f0_hz: f64,
    pub southwell: f64,
    pub southwell_misfit: f64,
}

/// A crossing of a curve with an engine-order line f = EO rpm / 60.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Crossing {
    pub engine_order: i64,
    pub mode: usize,
    pub speed_rpm: f64,
    pub frequency_hz: f64,
}

/// `campbell.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CampbellData {
    pub speeds_rpm: Vec<f64>,
    pub basis_speeds_rpm: Vec<f64>,
    /// The prestress: "nonlinear" or "linear" (`[rotation] kinematics`).
    pub kinematics: String,
    pub engine_orders: Vec<i64>,
    pub curves: Vec<Curve>,
    pub crossings: Vec<Crossing>,
    /// The Coriolis effect at the highest speed of the diagram (where it is largest).
    pub coriolis: Option<CoriolisShift>,
    /// The Ritz frequencies against a direct shift-invert eigen-solve of the full model at the
    /// Campbell speed with the largest residual (not a basis speed).
    pub direct_check: Option<DirectCheck>,
    /// The parametric reduced model built from the same static states (`parametric/`).
    #[serde(default)]
    pub parametric: Option<ParametricSummary>,
}

/// The drawn modes' frequencies at one speed without and with the Coriolis matrix (projected
/// onto them: `crate::campbell::coriolis_frequencies`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CoriolisShift {
    pub speed_rpm: f64,
    pub without_hz: Vec<f64>,
    pub with_hz: Vec<f64>,
    /// Largest |f_with - f_without| / f_without.
    pub max_relative_shift: f64,
}

/// A direct eigen-solve at one speed of the diagram.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DirectCheck {
    pub speed_rpm: f64,
    /// Direct frequencies of the drawn modes, Hz (ascending).
    pub frequency_hz: Vec<f64>,
    /// Largest |f_Ritz - f_direct| / f_direct over the drawn modes (in frequency order).
    pub max_relative_error: f64,
}

/// The stage: inputs' hash and outputs.
pub struct CampbellStage<'a> {
    case: &'a Case,
    rotation: &'a RotationSection,
    material: &'a Isotropic,
    layout: &'a Layout,
    out: PathBuf,
    mesh: PathBuf,
    hash: String,
    /// The key of its static states ([`static_states::states_key`]).
    states_key: String,
}

impl<'a> CampbellStage<'a> {
    pub fn new(
        case: &'a Case,
        rotation: &'a RotationSection,
        material: &'a Isotropic,
        layout: &'a Layout,
        fe_hash: &str,
    ) -> Self {
        // Not the operating speed nor the map amplitudes: they are drawn by [`draw`].
        let (r, m) = (rotation, &case.model);
        let inputs = serde_json::to_vec(&(
            (&r.kinematics, r.campbell_range, r.campbell_speeds),
            (r.campbell_modes, &r.engine_orders, r.parametric_checks),
            (m.rotor_axis_point, m.rotor_axis_direction),
            // The parametric model's basis and contact (as the reduced model at speed's).
            (&m.contact_group, m.gap, m.fixed_interface_modes, &m.master),
        ))
        .unwrap_or_default();
        Self {
            case,
            rotation,
            material,
            layout,
            out: layout.shared.join("campbell"),
            mesh: layout.mesh(),
            hash: fnv1a(&[fe_hash.as_bytes(), &inputs]),
            states_key: static_states::states_key(
                fe_hash,
                (m.rotor_axis_point, m.rotor_axis_direction),
                &r.kinematics,
            ),
        }
    }

    /// The parametric reduced model's directory, `results/<case>/parametric/`.
    fn parametric_dir(&self) -> PathBuf {
        self.layout.shared.join("parametric")
    }

    /// Computes the diagram and the parametric model and writes them.
    fn write(&self) -> Result<()> {
        let json = self.out.join("campbell.json");
        let st = crate::ui::Stage::start("campbell");
        let (data, parametric) = self.compute(self.material)?;
        std::fs::create_dir_all(&self.out)?;
        crate::campbell::campbell_parametric::write(
            &parametric,
            &self.parametric_dir(),
            &self.mesh,
        )?;
        write_tables(&data, &self.out)?;
        nlmodes_output::write_json(&json, &data)?;
        st.done(&format!(
            "{} modes at {} speeds, {} engine-order crossings",
            data.curves.len(),
            data.speeds_rpm.len(),
            data.crossings.len()
        ));
        Ok(())
    }

    fn compute(&self, material: &Isotropic) -> Result<(CampbellData, ParametricModel)> {
        let r = self.rotation;
        let fe = FeModel::build(&self.mesh, material, &self.case.model.clamp)?;
        let m = &self.case.model;
        let axis =
            crate::rotation::prestress::fem_axis(m.rotor_axis_point, m.rotor_axis_direction)?;
        let [a, b] = r.campbell_range;
        let basis_rpm = vec![a, 0.5 * (a + b), b];
        let basis: Vec<f64> = basis_rpm.iter().map(|s| s * RPM_TO_RAD_S).collect();
        let speeds = r.campbell_rpm();
        let campbell: Vec<f64> = speeds.iter().map(|s| s * RPM_TO_RAD_S).collect();
        let mut marched = [campbell.as_slice(), &basis].concat();
        marched.sort_by(f64::total_cmp);
        marched.dedup();
        let side = check_speeds(&marched, r.parametric_checks);
        // A few modes beyond those drawn, so that a mode entering from above is in the basis.
        let mut basis_modes = BasisModes::new(&basis, r.campbell_modes + 4);
        let settings = crate::reduce::reduce_stage::reduce_settings(self.case)?;
        let mut builder = ParametricBuilder::new(&fe, settings, axis, basis[1], r.campbell_modes)?;
        // Over the ranks under mpirun: the Newton steps, the basis modes, the parametric basis.
        let solver = crate::rotation::rotation_mpi::FullSolver::of(&fe, &self.mesh, material);
        let mut family = SpeedFamily::of(
            solver,
            &fe,
            material,
            &axis,
            r.nonlinear(),
            (&marched, &side),
            &mut |mut p| {
                basis_modes.visit(&mut p, &fe.m)?;
                builder.visit(&p)
            },
        )?;
        // The speed stages (run after this one) start from these states.
        static_states::write(
            &static_states::states_dir(&self.layout.shared),
            &self.states_key,
            family.static_states(),
        )?;
        let ritz = basis_modes.ritz_basis(&family.m)?;
        builder.enrich(&basis_modes.modes().collect::<Vec<_>>(), &family.m)?;
        let bar = crate::ui::bar((marched.len() + side.len()) as u64, "campbell");
        let mut modes = Vec::with_capacity(speeds.len());
        for (&omega, is_sample) in marched
            .iter()
            .map(|w| (w, true))
            .chain(side.iter().map(|w| (w, false)))
        {
            let k = family.at(omega)?;
            let at = ritz.solve(&k, r.campbell_modes + 2)?;
            let full_hz = at.eigenvalues.iter().map(|&l| hz(l)).collect();
            if is_sample {
                builder.sample(omega, &k, full_hz)?;
            } else {
                builder.check(omega, &k, full_hz)?;
            }
            if campbell.contains(&omega) {
                modes.push(at);
            }
            bar.inc(1);
        }
        bar.finish_and_clear();
        let parametric = builder.finish(&r.kinematics, &self.mesh)?;
        let direct_check =
            direct_check(&mut family, &speeds, &basis_rpm, &modes, r.campbell_modes)?;
        let coriolis = coriolis_shift(&family, &ritz, &speeds, &modes, r.campbell_modes)?;
        let curves = track(&speeds, &modes, r.campbell_modes);
        let crossings = crossings(&speeds, &curves, &r.engine_orders);
        let data = CampbellData {
            speeds_rpm: speeds,
            basis_speeds_rpm: basis_rpm,
            kinematics: r.kinematics.clone(),
            engine_orders: r.engine_orders.clone(),
            curves,
            crossings,
            direct_check,
            coriolis,
            parametric: Some(ParametricSummary::of(&parametric)),
        };
        Ok((data, parametric))
    }
}

impl Stage for CampbellStage<'_> {
    fn name(&self) -> String {
        "campbell".into()
    }
    fn only(&self) -> Only {
        Only::Campbell
    }
    fn hash(&self) -> &str {
        &self.hash
    }
    fn layout(&self) -> &Layout {
        self.layout
    }
    fn outputs(&self) -> Vec<PathBuf> {
        vec![
            self.out.join("campbell.json"),
            self.parametric_dir()
                .join(nlmodes_modal::parametric::PARAMETRIC_FILE),
        ]
    }
    fn work(&self) -> Result<()> {
        self.write()
    }
}

/// The Coriolis shift at the last (highest) speed.
fn coriolis_shift(
    family: &SpeedFamily<'_>,
    ritz: &RitzBasis,
    speeds: &[f64],
    modes: &[RitzModes],
    n: usize,
) -> Result<Option<CoriolisShift>> {
    let (Some(&rpm), Some(m)) = (speeds.last(), modes.last()) else {
        return Ok(None);
    };
    if rpm <= 0.0 {
        return Ok(None);
    }
    let with_hz = crate::campbell::coriolis_frequencies(family, ritz, m, rpm * RPM_TO_RAD_S, n)?;
    let without_hz: Vec<f64> = m.eigenvalues.iter().take(n).map(|&l| hz(l)).collect();
    let max_relative_shift = with_hz
        .iter()
        .zip(&without_hz)
        .map(|(a, b)| (a - b).abs() / b)
        .fold(0.0, f64::max);
    Ok(Some(CoriolisShift {
        speed_rpm: rpm,
        without_hz,
        with_hz,
        max_relative_shift,
    }))
}

/// The direct check at the non-basis speed whose drawn modes have the largest residual (the
/// factorization of K(Omega) reuses the march's analysis; over the ranks under mpirun).
fn direct_check(
    family: &mut SpeedFamily<'_>,
    speeds: &[f64],
    basis: &[f64],
    modes: &[RitzModes],
    n: usize,
) -> Result<Option<DirectCheck>> {
    let worst = |m: &RitzModes| m.residuals.iter().take(n).copied().fold(0.0, f64::max);
    let Some(s) = (0..speeds.len())
        .filter(|&s| !basis.contains(&speeds[s]))
        .max_by(|&a, &b| worst(&modes[a]).total_cmp(&worst(&modes[b])))
    else {
        return Ok(None);
    };
    let k = family.at(speeds[s] * RPM_TO_RAD_S)?;
    let (m, solver) = family.mass_and_solver();
    let direct = solver.lowest_modes(&k, m, n, "campbell check")?;
    let frequency_hz: Vec<f64> = direct.eigenvalues.iter().map(|&l| hz(l)).collect();
    let max_relative_error = frequency_hz
        .iter()
        .zip(&modes[s].eigenvalues)
        .map(|(f, &l)| (hz(l) - f).abs() / f)
        .fold(0.0, f64::max);
    tracing::info!(
        "Campbell: direct eigen-solve at {:.0} rpm: Ritz frequencies within {max_relative_error:.1e}",
        speeds[s]
    );
    Ok(Some(DirectCheck {
        speed_rpm: speeds[s],
        frequency_hz,
        max_relative_error,
    }))
}

fn hz(lambda: f64) -> f64 {
    lambda.max(0.0).sqrt() / (2.0 * std::f64::consts::PI)
}

/// MAC of two Ritz coordinate vectors (M-orthonormal basis: the M-inner product is the dot
/// product).
fn mac(a: &Mat<f64>, i: usize, b: &Mat<f64>, j: usize) -> f64 {
    let (mut ab, mut aa, mut bb) = (0.0, 0.0, 0.0);
    for r in 0..a.nrows() {
        ab += a[(r, i)] * b[(r, j)];
        aa += a[(r, i)] * a[(r, i)];
        bb += b[(r, j)] * b[(r, j)];
    }
    ab * ab / (aa * bb)
}

/// Follows the `n` lowest modes of the first speed across the speeds: at each speed, curve k
/// takes the unused mode of largest MAC with its mode at the previous speed.
fn track(speeds: &[f64], modes: &[RitzModes], n: usize) -> Vec<Curve> {
    let mut at: Vec<usize> = (0..n).collect();
    let mut curves: Vec<Curve> = (0..n)
        .map(|k| Curve {
            mode: k + 1,
            frequency_hz: vec![hz(modes[0].eigenvalues[k])],
            mac: vec![1.0],
            residual: vec![modes[0].residuals[k]],
            southwell_f0_hz: 0.0,
            southwell: 0.0,
            southwell_misfit: 0.0,
        })
        .collect();
    for s in 1..speeds.len() {
        let (prev, cur) = (&modes[s - 1], &modes[s]);
        let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
        for (k, &i) in at.iter().enumerate() {
            for j in 0..cur.eigenvalues.len() {
                pairs.push((mac(&prev.coordinates, i, &cur.coordinates, j), k, j));
            }
        }
        pairs.sort_by(|x, y| y.0.total_cmp(&x.0));
        let (mut done, mut used) = (vec![false; n], vec![false; cur.eigenvalues.len()]);
        for (value, k, j) in pairs {
            if done[k] || used[j] {
                continue;
            }
            (done[k], used[j]) = (true, true);
            at[k] = j;
            let c = &mut curves[k];
            c.frequency_hz.push(hz(cur.eigenvalues[j]));
            c.mac.push(value);
            c.residual.push(cur.residuals[j]);
        }
    }
    for c in &mut curves {
        southwell_fit(speeds, c);
    }
    curves
}

/// Least squares f^2 = f0^2 + S (rpm / 60)^2 over the speeds.
fn southwell_fit(speeds_rpm: &[f64], c: &mut Curve) {
    let x: Vec<f64> = speeds_rpm.iter().map(|r| (r / 60.0).powi(2)).collect();
    let y: Vec<f64> = c.frequency_hz.iter().map(|f| f * f).collect();
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let f0_sq = my - slope * mx;
    c.southwell = slope;
    c.southwell_f0_hz = f0_sq.max(0.0).sqrt();
    c.southwell_misfit = x
        .iter()
        .zip(&c.frequency_hz)
        .map(|(a, f)| ((f0_sq + slope * a).max(0.0).sqrt() - f).abs() / f)
        .fold(0.0, f64::max);
}

/// Where each curve meets each engine-order line: between two speeds where f - EO rpm/60
/// changes sign, f^2 interpolated linearly in rpm^2 (exact for a Southwell curve) and the
/// intersection with the line solved in closed form.
fn crossings(speeds: &[f64], curves: &[Curve], orders: &[i64]) -> Vec<Crossing> {
    let mut out = Vec::new();
    for &eo in orders {
        let e = eo as f64 / 60.0;
        for c in curves {
            for s in 1..speeds.len() {
                let (r0, r1) = (speeds[s - 1], speeds[s]);
                let (f0, f1) = (c.frequency_hz[s - 1], c.frequency_hz[s]);
                let (d0, d1) = (f0 - e * r0, f1 - e * r1);
                if d0 == 0.0 || d0.signum() == d1.signum() {
                    continue;
                }
                // f^2 = a + b r^2 through both points; (e r)^2 = a + b r^2.
                let b = (f1 * f1 - f0 * f0) / (r1 * r1 - r0 * r0);
                let a = f0 * f0 - b * r0 * r0;
                let denom = e * e - b;
                let rpm = if denom > 0.0 && a >= 0.0 {
                    (a / denom).sqrt()
                } else {
                    r0 + (r1 - r0) * d0 / (d0 - d1)
                };
                out.push(Crossing {
                    engine_order: eo,
                    mode: c.mode,
                    speed_rpm: rpm,
                    frequency_hz: e * rpm,
                });
            }
        }
    }
    out.sort_by(|a, b| a.speed_rpm.total_cmp(&b.speed_rpm));
    out
}

/// `campbell.csv` (one row per speed: rpm, then per curve f (Hz), MAC, residual) and
/// `crossings.csv`.
fn write_tables(d: &CampbellData, out: &Path) -> Result<()> {
    let mut s = String::from("speed_rpm");
    for c in &d.curves {
        let k = c.mode;
        let _ = write!(s, ",mode{k}_hz,mode{k}_mac,mode{k}_residual");
    }
    s.push('\n');
    for (i, rpm) in d.speeds_rpm.iter().enumerate() {
        let _ = write!(s, "{rpm}");
        for c in &d.curves {
            let _ = write!(s, ",{},{},{:e}", c.frequency_hz[i], c.mac[i], c.residual[i]);
        }
        s.push('\n');
    }
    crate::post::output::write_atomic(&out.join("campbell.csv"), s.as_bytes())?;
    let mut t = String::from("engine_order,mode,speed_rpm,frequency_hz\n");
    for c in &d.crossings {
        let _ = writeln!(
            t,
            "{},{},{},{}",
            c.engine_order, c.mode, c.speed_rpm, c.frequency_hz
        );
    }
    crate::post::output::write_atomic(&out.join("crossings.csv"), t.as_bytes())
}

/// The band of the first nonlinear mode at one speed: frequencies (Hz) from grazing to the
/// largest traced amplitude on the main branch, and at the marked amplitudes q/g0.
#[derive(Debug, Clone)]
pub struct Band {
    pub speed_rpm: f64,
    pub low_hz: f64,
    pub high_hz: f64,
    pub q_max_over_g0: f64,
    /// (q/g0, f Hz) at the marked amplitudes reached.
    pub marks: Vec<(f64, f64)>,
    /// The main branch from grazing on, (q/g0, f Hz) in continuation order.
    pub branch: Vec<(f64, f64)>,
}

impl Band {
    /// The smallest amplitude q/g0 at which the main branch reaches the frequency `f` (Hz).
    pub fn amplitude_at(&self, f: f64) -> Option<f64> {
        self.branch.windows(2).find_map(|w| {
            let ((q0, f0), (q1, f1)) = (w[0], w[1]);
            ((f0 - f) * (f1 - f) <= 0.0 && f0 != f1).then(|| q0 + (f - f0) / (f1 - f0) * (q1 - q0))
        })
    }
}

/// The band of a backbone (main branch and linear segment, no tongue), `None` without
/// contact.
pub fn band(b: &crate::post::results::BackboneFile, speed_rpm: f64, marks: &[f64]) -> Option<Band> {
    let g0 = b.gap_reference;
    let graze = b.grazing_amplitude?;
    let main: Vec<&crate::post::results::Orbit> =
        b.points.iter().filter(|p| !b.on_tongue(p)).collect();
    let past: Vec<&&crate::post::results::Orbit> = main.iter().filter(|p| p.q >= graze).collect();
    let f = |p: &crate::post::results::Orbit| p.frequency_hz;
    let low = b.omega_linear / (2.0 * std::f64::consts::PI);
    let high = past.iter().map(|p| f(p)).fold(low, f64::max);
    let q_max = past.iter().map(|p| p.q / g0).fold(graze / g0, f64::max);
    let marks = marks
        .iter()
        .filter_map(|&a| {
            main.windows(2).find_map(|w| {
                let (q0, q1) = (w[0].q / g0, w[1].q / g0);
                ((q0 - a) * (q1 - a) <= 0.0 && q0 != q1).then(|| {
                    let t = (a - q0) / (q1 - q0);
                    (a, f(w[0]) + t * (f(w[1]) - f(w[0])))
                })
            })
        })
        .collect();
    let mut branch = vec![(graze / g0, low)];
    branch.extend(past.iter().map(|p| (p.q / g0, f(p))));
    Some(Band {
        speed_rpm,
        low_hz: low,
        high_hz: high,
        q_max_over_g0: q_max,
        marks,
        branch,
    })
}

/// The figure and the report section of the diagram, with the bands of the backbones at rest
/// and at the operating speed when they exist (cheap: rerun on every `run`).
pub fn draw(case: &Case, rotation: &RotationSection, layout: &Layout) -> Result<()> {
    let dir = layout.shared.join("campbell");
    let d: CampbellData = crate::post::results::read_json(&dir.join("campbell.json"))?;
    let read =
        |p: PathBuf| crate::post::results::read_json::<crate::post::results::BackboneFile>(&p).ok();
    let speed = crate::rotation::speed_stage::speed_layout(layout);
    let mut bands = Vec::new();
    if let Some(b) = read(layout.backbone().join("backbone.json")) {
        bands.extend(band(&b, 0.0, &rotation.map_amplitudes));
    }
    let mut at_speed = vec![(rotation.operating_speed, speed)];
    at_speed.extend(
        rotation
            .extra_map_speeds()
            .into_iter()
            .map(|s| (s, crate::rotation::speed_stage::map_speed_layout(layout, s))),
    );
    at_speed.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (rpm, lay) in at_speed {
        if let Some(b) = read(lay.backbone().join("backbone.json")) {
            bands.extend(band(&b, rpm, &rotation.map_amplitudes));
        }
    }
    let op = rotation.operating_speed;
    // The figure (crate::post::figures::campbell) and the forced verdict of the map (issue 39).
    let names = crate::post::figures::curve_names(
        &layout.shared.join("parametric"),
        d.speeds_rpm[0],
        d.curves.len(),
    );
    crate::post::figures::campbell_figure(&picture(&d, op, &bands, &names), &dir)?;
    let mut text = section(case, &d, op, &bands);
    let refs = d.crossing_refs();
    text +=
        &crate::speed_sweep::forced_speed_report::interaction_verdict(case, layout, &refs, &names)?;
    crate::post::output::write_atomic(&dir.join("section.md"), text.as_bytes())
}

fn picture<'a>(
    d: &'a CampbellData,
    op: f64,
    bands: &[Band],
    names: &[String],
) -> crate::post::figures::CampbellPicture<'a> {
    crate::post::figures::CampbellPicture {
        speeds_rpm: &d.speeds_rpm,
        curves: (names.iter().cloned())
            .zip(d.curves.iter().map(|c| &c.frequency_hz[..]))
            .collect(),
        engine_orders: &d.engine_orders,
        crossings: (d.crossings.iter())
            .map(|c| (c.speed_rpm, c.frequency_hz))
            .collect(),
        bands: (bands.iter())
            .map(|b| (b.speed_rpm, b.low_hz, b.high_hz))
            .collect(),
        operating_rpm: op,
    }
}

impl CampbellData {
    /// The crossings as the speed sweeps' forced verdict reads them.
    pub fn crossing_refs(&self) -> Vec<crate::post::results::speed_sweep::CrossingRef> {
        (self.crossings.iter())
            .map(|c| crate::post::results::speed_sweep::CrossingRef {
                engine_order: c.engine_order,
                mode: c.mode,
                speed_rpm: c.speed_rpm,
            })
            .collect()
    }
}

/// The report's section: curves with their Southwell coefficients, the crossings, the accuracy
/// of the Ritz solution, the interaction map.
fn section(case: &Case, d: &CampbellData, op: f64, bands: &[Band]) -> String {
    let mut s = String::from("## Campbell diagram and interaction map\n\n");
    let check = d.direct_check.as_ref().map_or_else(
        || "no speed outside the basis to check".to_string(),
        |c| {
            format!(
                "checked against a direct eigen-solve of the full model at {:.0} rpm (the speed \
                 whose Ritz residuals are largest): frequencies within {:.1e}",
                c.speed_rpm, c.max_relative_error
            )
        },
    );
    let _ = writeln!(
        s,
        "Linear modes of the prestressed blade (stiffness at speed K(Omega) of the `{}` \
         prestress, spin softening included, no Coriolis) at {} speeds from {} to {} rpm, by \
         Rayleigh-Ritz on the modes at {:?} rpm, {check}. Curves tracked by MAC (a MAC below \
         {MAC_UNCERTAIN} with the previous speed is marked `?`). Data: \
         `campbell/campbell.csv`, `campbell/crossings.csv`.\n",
        d.kinematics,
        d.speeds_rpm.len(),
        d.speeds_rpm[0],
        d.speeds_rpm.last().unwrap_or(&0.0),
        d.basis_speeds_rpm
    );
    let _ = writeln!(s, "![Campbell diagram](campbell/campbell.png)\n");
    if let Some(c) = &d.coriolis {
        let _ = writeln!(
            s,
            "Coriolis (left out of the diagram): at {:.0} rpm, projected onto the {} drawn \
             modes (the quadratic eigenproblem with the gyroscopic matrix, as CalculiX \
             reports it), it moves their frequencies by at most {:.1e} (relative; {}). It \
             grows with the speed and matters where two modes coupled by it come close in \
             frequency.\n",
            c.speed_rpm,
            c.with_hz.len(),
            c.max_relative_shift,
            c.without_hz
                .iter()
                .zip(&c.with_hz)
                .map(|(a, b)| format!("{a:.2} -> {b:.2} Hz"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let _ = writeln!(
        s,
        "| mode | f at {} rpm (Hz) | f at {:.0} rpm (Hz) | Southwell S (f^2 = f0^2 + S (rpm/60)^2) | fit misfit | lowest MAC |\n|---|---|---|---|---|---|",
        d.speeds_rpm[0], op
    );
    let at_op = |c: &Curve| interpolate(&d.speeds_rpm, &c.frequency_hz, op);
    for c in &d.curves {
        let low = c.mac.iter().copied().fold(1.0, f64::min);
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.2} | {:.3} | {:.1e} | {:.3}{} |",
            c.mode,
            c.frequency_hz[0],
            at_op(c),
            c.southwell,
            c.southwell_misfit,
            low,
            if low < MAC_UNCERTAIN { " ?" } else { "" }
        );
    }
    let _ = writeln!(s, "\nEngine-order crossings:\n\n| EO | mode | speed (rpm) | frequency (Hz) | from the operating speed |\n|---|---|---|---|---|");
    for c in &d.crossings {
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {:.2} | {:+.1} % |",
            c.engine_order,
            c.mode,
            c.speed_rpm,
            c.frequency_hz,
            100.0 * (c.speed_rpm / op - 1.0)
        );
    }
    interaction(&mut s, case, d, bands);
    s
}

fn interpolate(x: &[f64], y: &[f64], at: f64) -> f64 {
    for i in 1..x.len() {
        if at <= x[i] || i + 1 == x.len() {
            let t = (at - x[i - 1]) / (x[i] - x[i - 1]);
            return y[i - 1] + t * (y[i] - y[i - 1]);
        }
    }
    y.first().copied().unwrap_or(f64::NAN)
}

/// Which engine orders enter the band of the first nonlinear mode at the speeds where it is
/// known.
fn interaction(s: &mut String, case: &Case, d: &CampbellData, bands: &[Band]) {
    let _ = writeln!(
        s,
        "\n### Interaction map\n\nThe thick red segments: the frequencies the first nonlinear \
         mode sweeps from grazing to q/g0 = q_max (gap: the cold gap {:.3e} m at rest, the \
         running gap at each speed: `speed/` for the operating speed, `speeds/<rpm>rpm/` for \
         the map speeds). An engine-order line that enters a band is an \
         excitation that can drive the blade into the casing at that speed.\n",
        case.model.gap
    );
    let _ = writeln!(s, "| speed (rpm) | band (Hz) | q/g0 up to | marked amplitudes (q/g0: Hz) | engine orders inside |\n|---|---|---|---|---|");
    for b in bands {
        let marks: Vec<String> = b
            .marks
            .iter()
            .map(|(q, f)| format!("{q}: {f:.1}"))
            .collect();
        let inside: Vec<String> = d
            .engine_orders
            .iter()
            .filter(|&&eo| {
                let f = eo as f64 * b.speed_rpm / 60.0;
                f >= b.low_hz && f <= b.high_hz
            })
            .map(|eo| {
                let f = *eo as f64 * b.speed_rpm / 60.0;
                match b.amplitude_at(f) {
                    Some(q) => format!("EO {eo} ({f:.1} Hz, reached at q/g0 = {q:.1})"),
                    None => format!("EO {eo} ({f:.1} Hz)"),
                }
            })
            .collect();
        let _ = writeln!(
            s,
            "| {:.0} | {:.1} .. {:.1} | {:.1} | {} | {} |",
            b.speed_rpm,
            b.low_hz,
            b.high_hz,
            b.q_max_over_g0,
            marks.join(", "),
            if inside.is_empty() {
                "none".to_string()
            } else {
                inside.join(", ")
            }
        );
    }
    s.push('\n');
}
