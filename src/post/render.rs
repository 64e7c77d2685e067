//! Mode-shape pictures of the report (the paper's Fig. 5): the deformed blade drawn from its
//! boundary triangles (`nlmodes_output::SurfacePicture`), coloured by the displacement
//! magnitude, the contact nodes marked, the undeformed blade in light gray behind.
//!
//! View: the span (the mesh's longest bounding-box axis) vertical; the horizontal axis turned
//! [`VIEW_TURN_DEG`] from the tip's largest horizontal displacement, so that bending is seen
//! nearly in the picture's plane while the blade's face still shows.
//! Warp factor: the largest displacement over the period is drawn as [`WARP_SHARE`] of the
//! blade's bounding-box diagonal, the factor rounded down to 1, 2 or 5 x 10^k and printed on the
//! picture.

use anyhow::Result;
use nlmodes_fem::Mesh;
use nlmodes_output::plot::{Colormap, Marker, SurfacePanel, SurfacePicture, View};
use std::collections::HashMap;
use std::path::Path;

/// Largest displacement as a share of the bounding-box diagonal once magnified.
pub const WARP_SHARE: f64 = 0.08;
/// Angle between the picture's horizontal axis and the dominant horizontal displacement (deg).
pub const VIEW_TURN_DEG: f64 = 55.0;

/// The boundary of a tetrahedral mesh as outward triangles of corner nodes.
pub struct Surface {
    /// Mesh node indices, counter-clockwise seen from outside.
    pub triangles: Vec<[usize; 3]>,
}

impl Surface {
    /// Faces of the tetrahedra (corner nodes; TET10 mid-edge nodes are not drawn) that belong
    /// to one tetrahedron only, oriented away from the tetrahedron's fourth corner.
    pub fn of_mesh(mesh: &Mesh) -> Self {
        const FACES: [([usize; 3], usize); 4] = [
            ([1, 2, 3], 0),
            ([0, 3, 2], 1),
            ([0, 1, 3], 2),
            ([0, 2, 1], 3),
        ];
        let mut seen: HashMap<[usize; 3], Option<[usize; 3]>> = HashMap::new();
        for e in 0..mesh.n_elements() {
            let el = mesh.element(e);
            for (f, opposite) in FACES {
                let mut t = f.map(|i| el[i]);
                if !outward(&mesh.nodes, &t, el[opposite]) {
                    t.swap(1, 2);
                }
                let mut key = t;
                key.sort_unstable();
                seen.entry(key).and_modify(|v| *v = None).or_insert(Some(t));
            }
        }
        let mut triangles: Vec<[usize; 3]> = seen.into_values().flatten().collect();
        triangles.sort_unstable();
        Surface { triangles }
    }
}

/// Whether triangle `t`'s normal (b - a) x (c - a) points away from node `opposite`.
fn outward(p: &[[f64; 3]], t: &[usize; 3], opposite: usize) -> bool {
    let (a, b, c, o) = (p[t[0]], p[t[1]], p[t[2]], p[opposite]);
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    let n = [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ];
    n[0] * (o[0] - a[0]) + n[1] * (o[1] - a[1]) + n[2] * (o[2] - a[2]) < 0.0
}

/// One instant of a nonlinear mode: nodal displacements (3 per node, m) and the contact force
/// (N) of every contact node.
pub struct Snapshot {
    pub label: String,
    pub displacement: Vec<f64>,
    pub contact_force: Vec<f64>,
}

/// Largest nodal displacement magnitude of `u` (3 per node).
pub fn max_norm(u: &[f64]) -> f64 {
    u.chunks_exact(3)
        .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
        .fold(0.0, f64::max)
}

/// The warp factor drawing `max_displacement` as [`WARP_SHARE`] of `size`: rounded down to
/// 1, 2 or 5 x 10^k; 1 when there is no displacement.
pub fn warp_factor(size: f64, max_displacement: f64) -> f64 {
    if !(max_displacement > 0.0 && size > 0.0) {
        return 1.0;
    }
    let raw = WARP_SHARE * size / max_displacement;
    let decade = 10f64.powf(raw.log10().floor());
    let m = raw / decade;
    let nice = if m >= 5.0 {
        5.0
    } else if m >= 2.0 {
        2.0
    } else {
        1.0
    };
    nice * decade
}

/// Bounding-box diagonal (m) and the index of its longest axis.
fn extent(mesh: &Mesh) -> (f64, usize) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.nodes {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i]);
            hi[i] = hi[i].max(p[i]);
        }
    }
    let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let axis = (0..3).max_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(2);
    ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt(), axis)
}

/// The view described in the module documentation, from a displacement field `u`.
fn side_view(span_axis: usize, u: &[f64]) -> View {
    let mut up = [0.0; 3];
    up[span_axis] = 1.0;
    // The largest displacement's component across the span.
    let node = (0..u.len() / 3)
        .max_by(|&a, &b| {
            let n = |i: usize| {
                u[3 * i] * u[3 * i] + u[3 * i + 1] * u[3 * i + 1] + u[3 * i + 2] * u[3 * i + 2]
            };
            n(a).total_cmp(&n(b))
        })
        .unwrap_or(0);
    let mut d = [0.0; 3];
    for i in 0..3 {
        if i != span_axis && 3 * node + i < u.len() {
            d[i] = u[3 * node + i];
        }
    }
    let norm = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if norm == 0.0 {
        d = [0.0; 3];
        d[(span_axis + 1) % 3] = 1.0;
    } else {
        d = d.map(|x| x / norm);
    }
    // e = up x d, horizontal and across d; right = cos(a) d + sin(a) e.
    let e = [
        up[1] * d[2] - up[2] * d[1],
        up[2] * d[0] - up[0] * d[2],
        up[0] * d[1] - up[1] * d[0],
    ];
    let a = VIEW_TURN_DEG.to_radians();
    let right = [0, 1, 2].map(|i| a.cos() * d[i] + a.sin() * e[i]);
    View { right, up }
}

/// Node positions moved by `factor` u.
fn warped(mesh: &Mesh, u: &[f64], factor: f64) -> Vec<[f64; 3]> {
    mesh.nodes
        .iter()
        .enumerate()
        .map(|(i, p)| [0, 1, 2].map(|c| p[c] + factor * u[3 * i + c]))
        .collect()
}

/// Nodal displacement magnitudes of `u` times `scale`.
fn magnitudes(u: &[f64], scale: f64) -> Vec<f64> {
    u.chunks_exact(3)
        .map(|d| scale * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
        .collect()
}

/// Fig. 5 for one amplitude: one panel per snapshot, one warp factor and colour range (from
/// `max_displacement`, the largest |u| over the period, m); contact nodes filled red where the
/// contact force is positive.
pub fn amplitude_figure(
    surface: &Surface,
    mesh: &Mesh,
    contact_nodes: &[usize],
    snapshots: &[Snapshot],
    max_displacement: f64,
    title: &str,
    path: &Path,
) -> Result<()> {
    let (size, span_axis) = extent(mesh);
    let warp = warp_factor(size, max_displacement);
    let view = side_view(span_axis, &snapshots[0].displacement);
    let panels = snapshots
        .iter()
        .map(|s| {
            let positions = warped(mesh, &s.displacement, warp);
            let mut markers: Vec<Marker> = contact_nodes
                .iter()
                .zip(&s.contact_force)
                .map(|(&n, &f)| Marker {
                    position: positions[n],
                    filled: f > 0.0,
                })
                .collect();
            // Nodes in contact drawn last: seen along the tip edge the markers overlap, and an
            // open neighbour must not hide a red one.
            markers.sort_by_key(|m| m.filled);
            SurfacePanel {
                subtitle: s.label.clone(),
                values: magnitudes(&s.displacement, 1e3),
                positions,
                markers,
                ghost: Some(mesh.nodes.clone()),
            }
        })
        .collect();
    let picture = SurfacePicture {
        title: title.to_string(),
        triangles: surface.triangles.clone(),
        panels,
        view,
        colormap: Colormap::Viridis,
        value_label: "displacement |u| [mm]".to_string(),
        value_range: Some((0.0, (max_displacement * 1e3).max(1e-12))),
        notes: vec![
            format!(
                "Displacement magnified x{} (largest |u| over the period {:.3} mm, drawn as {:.0} % \
                 of the blade's {:.0} mm diagonal); gray: undeformed blade.",
                fmt_factor(warp),
                max_displacement * 1e3,
                100.0 * warp * max_displacement / size,
                size * 1e3
            ),
            "Contact nodes: red = in contact (contact force > 0), white = open. Span vertical."
                .to_string(),
        ],
        panel_width: 300.0,
        panel_height: 380.0,
    };
    picture.write_png(path)?;
    Ok(())
}

/// The first linear modes, one panel each, each normalized to its largest |u| and magnified by
/// its own factor (printed in its subtitle); `modes` are (label, nodal shape).
pub fn modes_figure(
    surface: &Surface,
    mesh: &Mesh,
    contact_nodes: &[usize],
    modes: &[(String, Vec<f64>)],
    path: &Path,
) -> Result<()> {
    let (size, span_axis) = extent(mesh);
    anyhow::ensure!(!modes.is_empty(), "no linear mode to draw");
    let view = side_view(span_axis, &modes[0].1);
    let panels = modes
        .iter()
        .map(|(label, u)| {
            let max = max_norm(u);
            let warp = warp_factor(size, max);
            let positions = warped(mesh, u, warp);
            let markers = contact_nodes
                .iter()
                .map(|&n| Marker {
                    position: positions[n],
                    filled: false,
                })
                .collect();
            SurfacePanel {
                subtitle: format!("{label} (x{})", fmt_factor(warp)),
                values: magnitudes(u, 1.0 / max.max(f64::MIN_POSITIVE)),
                positions,
                markers,
                ghost: Some(mesh.nodes.clone()),
            }
        })
        .collect();
    let picture = SurfacePicture {
        title: "First linear modes (Craig-Bampton model, recovered on the mesh)".to_string(),
        triangles: surface.triangles.clone(),
        panels,
        view,
        colormap: Colormap::Viridis,
        value_label: "|u| / max |u|".to_string(),
        value_range: Some((0.0, 1.0)),
        notes: vec![
            format!(
                "Mass-normalized modes, each magnified so that its largest |u| is drawn as {:.0}-{:.0} % \
                 of the blade's diagonal (factor in each title); gray: undeformed blade.",
                40.0 * WARP_SHARE,
                100.0 * WARP_SHARE
            ),
            "Circles: contact nodes of the tip edge. Span vertical.".to_string(),
        ],
        panel_width: 260.0,
        panel_height: 360.0,
    };
    picture.write_png(path)?;
    Ok(())
}

/// A warp factor as printed: `20`, `0.5`, `0.002`.
fn fmt_factor(f: f64) -> String {
    if f < 1e-4 {
        return format!("{f:e}");
    }
    let s = format!("{f:.6}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}
