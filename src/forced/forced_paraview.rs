//! ParaView series of forced orbits (issue 22, item 7): for each level of a forced study, the
//! peak orbit (the largest first-harmonic amplitude of the master, `[forced] keep_peaks`) and
//! the orbits where the curve crosses each frequency of `[forced] keep` (W / w_mode; every
//! crossing, so a fold region gives up to three), written like the free modes' kept amplitudes:
//! one period on the full FE mesh as an XDMF series (`crate::post::write_orbit_series`), in
//! `forced/orbits/level_<level>_<what>.xdmf`. A model without a recovery basis and mesh (an
//! external reduced model) has no mesh to draw on: nothing is written and the log says so.

use anyhow::Result;
use nlmodes_forced::ForcedPoint;
use nlmodes_hb::FullBasis;
use std::f64::consts::PI;
use std::path::Path;

use crate::forced::{ForcedCurve, ForcedStudy};
use crate::post::{write_orbit_series, FullMesh, OrbitSeries, FIELDS_NOTE};

/// The chosen points of one curve: (name, point index).
fn chosen(st: &ForcedStudy, curve: &ForcedCurve) -> Vec<(String, usize)> {
    let pts = &curve.response.points;
    let mut out = Vec::new();
    let q1 = |p: &ForcedPoint| {
        let m = st.master;
        p.coefficients[(m, 1)].hypot(p.coefficients[(m, 2)])
    };
    if st.settings.keep_peaks {
        if let Some(i) = (0..pts.len()).max_by(|&a, &b| q1(&pts[a]).total_cmp(&q1(&pts[b]))) {
            out.push(("peak".to_string(), i));
        }
    }
    for &r in &st.settings.keep {
        let w = r * st.omega_mode;
        let mut k = 0;
        for i in 1..pts.len() {
            let (a, b) = (pts[i - 1].omega - w, pts[i].omega - w);
            if a * b <= 0.0 && !(a == 0.0 && i > 1) {
                let j = if a.abs() <= b.abs() { i - 1 } else { i };
                k += 1;
                out.push((format!("w{r}_{k}"), j));
            }
        }
    }
    out
}

/// The reduced state at phase theta = W t of every coordinate.
fn state_at(p: &ForcedPoint, theta: f64) -> Vec<f64> {
    let terms = p.coefficients.ncols();
    (0..p.coefficients.nrows())
        .map(|i| {
            let c: Vec<f64> = (0..terms).map(|k| p.coefficients[(i, k)]).collect();
            FullBasis::value_at(&c, theta)
        })
        .collect()
}

/// One orbit's series.
fn write_one(
    model: &nlmodes_modal::ReducedModel,
    full: &FullMesh,
    st: &ForcedStudy,
    curve: &ForcedCurve,
    (what, i): &(String, usize),
    dir: &Path,
) -> Result<()> {
    let p = &curve.response.points[*i];
    let frames = st.settings.frames.max(2);
    let rows = st.contacts.max(1);
    let m = p.contact_force.len() / rows;
    let states: Vec<Vec<f64>> = (0..frames)
        .map(|f| state_at(p, 2.0 * PI * f as f64 / frames as f64))
        .collect();
    let forces: Vec<Vec<f64>> = (0..frames)
        .map(|f| {
            let k = ((f * m) as f64 / frames as f64).round() as usize % m.max(1);
            (0..rows).map(|j| p.contact_force[j * m + k]).collect()
        })
        .collect();
    let period = 2.0 * PI / p.omega;
    let name = format!("level_{}_{what}", curve.level);
    let note = format!(
        "nlmodes: forced orbit, level {} ({:.4e} N largest load entry), W = {:.6} rad/s \
         (W/w = {:.6}), one period T = {period:.9e} s in {frames} frames; time values in \
         seconds, frame f at t = f T / {frames}. {FIELDS_NOTE} Heavy data in {name}.h5.",
        curve.level,
        curve.force,
        p.omega,
        p.omega / st.omega_mode
    );
    let series = OrbitSeries {
        states: &states,
        forces: &forces,
        period,
        note: &note,
    };
    write_orbit_series(model, full, &series, &dir.join(format!("{name}.xdmf")))
}

/// Writes the chosen orbits of every level into `out/orbits/`; returns how many.
pub fn write_orbits(st: &ForcedStudy, model_dir: &Path, out: &Path) -> Result<usize> {
    let wanted = chosen_orbits(st);
    if wanted.is_empty() {
        return Ok(0);
    }
    let model = crate::backbone::load_model(model_dir)?;
    write_orbits_of(st, &model, &wanted, out)
}

/// The orbits of every level chosen by `forced.keep_peaks` and `forced.keep` (as
/// [`write_orbits`]), drawn with `model` (its recovery basis and contact nodes) on its mesh.
pub fn write_chosen_orbits(
    st: &ForcedStudy,
    model: &nlmodes_modal::ReducedModel,
    out: &Path,
) -> Result<usize> {
    write_orbits_of(st, model, &chosen_orbits(st), out)
}

/// Each curve's chosen orbits: (curve, [(name, point)]), curves without any left out.
fn chosen_orbits(st: &ForcedStudy) -> Vec<(usize, Vec<(String, usize)>)> {
    st.curves
        .iter()
        .enumerate()
        .map(|(c, curve)| (c, chosen(st, curve)))
        .filter(|(_, v)| !v.is_empty())
        .collect()
}

/// Writes the `wanted` orbits with `model` into `out/orbits/`; returns how many.
fn write_orbits_of(
    st: &ForcedStudy,
    model: &nlmodes_modal::ReducedModel,
    wanted: &[(usize, Vec<(String, usize)>)],
    out: &Path,
) -> Result<usize> {
    if wanted.is_empty() {
        return Ok(0);
    }
    let Some(full) = FullMesh::of(model)? else {
        tracing::info!("forced orbits: the reduced model has no mesh to draw them on");
        return Ok(0);
    };
    let dir = out.join("orbits");
    std::fs::create_dir_all(&dir)?;
    let mut count = 0;
    for (c, points) in wanted {
        for chosen in points {
            write_one(model, &full, st, &st.curves[*c], chosen, &dir)?;
            count += 1;
        }
    }
    Ok(count)
}
