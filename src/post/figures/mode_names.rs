//! Names of a blade's linear modes (1F, 2F, 1E, 1T, ...) from the motion of its tip edge: the
//! contact nodes of the reduced model, whose displacements are reduced coordinates of the
//! Craig-Bampton basis (DESIGN §7). Per mode, the tip edge's displacement is split into the
//! rigid motions of the tip chord in the plane across the span: a translation across the chord
//! (flapwise, F), along it (edgewise, E), and a turn about the span (torsion, T). The family
//! holding at least half of the tip edge's motion (sum of |u|^2 over its nodes) names the mode,
//! numbered by frequency within the family; a mode without one (a plate mode bending the tip
//! chord, or an axial one) keeps "mode k". Used by the Campbell diagram (docs/ROTATION.md).

use anyhow::Result;
use nlmodes_modal::{ContactNode, ReducedModel};

/// Share of the tip edge's motion a family needs to name the mode.
const DOMINANT: f64 = 0.5;

/// The tip edge's motion in one mode: shares (0..1) of sum |u|^2 over the contact nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipMotion {
    pub flap: f64,
    pub edge: f64,
    pub torsion: f64,
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt().max(f64::MIN_POSITIVE);
    a.map(|v| v / n)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// The tip frame: the span (mean radial direction of the nodes), the chord (the principal
/// direction of their positions across the span) and the flapwise direction (span x chord).
fn tip_frame(nodes: &[ContactNode]) -> ([f64; 3], [f64; 3], [f64; 3], [f64; 3]) {
    let n = nodes.len().max(1) as f64;
    let mean = |f: &dyn Fn(&ContactNode) -> [f64; 3]| {
        let s = nodes
            .iter()
            .map(f)
            .fold([0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]]);
        s.map(|v| v / n)
    };
    let span = unit(mean(&|c| c.radial));
    let centre = mean(&|c| c.position);
    let across = |c: &ContactNode| {
        let d: [f64; 3] = std::array::from_fn(|i| c.position[i] - centre[i]);
        let s = dot(d, span);
        std::array::from_fn(|i| d[i] - s * span[i])
    };
    // Power iteration on the 3 x 3 scatter of the positions across the span, from the
    // leading-to-trailing vector.
    let first = nodes.first().map_or([1.0, 0.0, 0.0], &across);
    let last = nodes.last().map_or([0.0; 3], &across);
    let mut chord = unit(std::array::from_fn(|i| last[i] - first[i] + 1e-30));
    for _ in 0..50 {
        let next = nodes.iter().map(&across).fold([0.0; 3], |a, d| {
            let w = dot(d, chord);
            [a[0] + w * d[0], a[1] + w * d[1], a[2] + w * d[2]]
        });
        chord = unit(next);
    }
    (span, chord, unit(cross(span, chord)), centre)
}

/// The tip edge's motion in the mode of reduced shape `shape`.
pub fn tip_motion(nodes: &[ContactNode], shape: &[f64]) -> TipMotion {
    let (_, chord, flap, centre) = tip_frame(nodes);
    let u = |c: &ContactNode| -> [f64; 3] { c.dofs.map(|d| shape[d]) };
    let s: Vec<f64> = (nodes.iter())
        .map(|c| dot(std::array::from_fn(|i| c.position[i] - centre[i]), chord))
        .collect();
    let n = nodes.len().max(1) as f64;
    let total: f64 = nodes.iter().map(|c| dot(u(c), u(c))).sum();
    let mean_f = nodes.iter().map(|c| dot(u(c), flap)).sum::<f64>() / n;
    let mean_e = nodes.iter().map(|c| dot(u(c), chord)).sum::<f64>() / n;
    let ss: f64 = s.iter().map(|v| v * v).sum();
    let turn = if ss > 0.0 {
        (nodes.iter().zip(&s))
            .map(|(c, sj)| dot(u(c), flap) * sj)
            .sum::<f64>()
            / ss
    } else {
        0.0
    };
    let share = |e: f64| if total > 0.0 { e / total } else { 0.0 };
    TipMotion {
        flap: share(n * mean_f * mean_f),
        edge: share(n * mean_e * mean_e),
        torsion: share(turn * turn * ss),
    }
}

/// Names in frequency order: "1F (mode 1)", "1T (mode 2)", ..., or "mode k".
pub fn names(motions: &[TipMotion]) -> Vec<String> {
    let mut counts = [0usize; 3];
    (motions.iter().enumerate())
        .map(|(k, m)| {
            let shares = [m.flap, m.edge, m.torsion];
            let (i, &best) = (shares.iter().enumerate())
                .max_by(|a, b| a.1.total_cmp(b.1))
                .expect("three shares");
            if best < DOMINANT {
                return format!("mode {}", k + 1);
            }
            counts[i] += 1;
            format!("{}{} (mode {})", counts[i], ["F", "E", "T"][i], k + 1)
        })
        .collect()
}

/// The names of the lowest `count` modes of `model` (K_r, M_r at one speed).
pub fn mode_names(model: &ReducedModel, count: usize) -> Result<Vec<String>> {
    let (_, vectors) = nlmodes_modal::dense_generalized_eigen(model.k.as_ref(), model.m.as_ref())?;
    let motions: Vec<TipMotion> = (0..count.min(vectors.ncols()))
        .map(|j| {
            let shape: Vec<f64> = vectors.col(j).iter().copied().collect();
            tip_motion(&model.contact_nodes, &shape)
        })
        .collect();
    let mut out = names(&motions);
    out.extend((out.len()..count).map(|k| format!("mode {}", k + 1)));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eleven nodes along a chord in y at radius 0.37 m (span along z), each with its own
    /// three reduced coordinates.
    fn chord() -> Vec<ContactNode> {
        (0..11)
            .map(|j| ContactNode {
                mesh_node: None,
                dofs: [3 * j, 3 * j + 1, 3 * j + 2],
                position: [0.002 * j as f64, -0.025 + 0.005 * j as f64, 0.37],
                radial: [0.0, 0.0, 1.0],
                gap: 2e-4,
            })
            .collect()
    }

    /// A shape of the nodes from the displacement u(s) of the node at chord coordinate s.
    fn shape(nodes: &[ContactNode], u: impl Fn(f64) -> [f64; 3]) -> Vec<f64> {
        let centre_y = nodes.iter().map(|c| c.position[1]).sum::<f64>() / nodes.len() as f64;
        let mut out = vec![0.0; 3 * nodes.len()];
        for c in nodes {
            let v = u(c.position[1] - centre_y);
            for i in 0..3 {
                out[c.dofs[i]] = v[i];
            }
        }
        out
    }

    /// The chord runs along (0.37, 0.93, 0) roughly (x grows with y); across it, in the
    /// plane normal to the span, lies the flapwise direction. A translation across the chord
    /// is flapwise, one along it edgewise, a turn about the span torsion, a chordwise bending
    /// of the tip (u ~ s^2) none of them; numbering counts within each family.
    #[test]
    fn rigid_tip_motions_name_their_family() {
        let nodes = chord();
        let (span, chord_dir, flap, _) = tip_frame(&nodes);
        assert!((span[2] - 1.0).abs() < 1e-12);
        assert!(
            (chord_dir[0] / chord_dir[1] - 0.4).abs() < 1e-9,
            "{chord_dir:?}"
        );
        let along = |a: f64| chord_dir.map(|v| a * v);
        let across = |a: f64| flap.map(|v| a * v);
        let m = |u: Vec<f64>| tip_motion(&nodes, &u);
        let f = m(shape(&nodes, |_| across(1.0)));
        assert!(f.flap > 0.999 && f.torsion < 1e-9, "{f:?}");
        let e = m(shape(&nodes, |_| along(1.0)));
        assert!(e.edge > 0.999, "{e:?}");
        let t = m(shape(&nodes, |s| across(40.0 * s / chord_dir[1])));
        assert!(t.torsion > 0.999 && t.flap < 1e-9, "{t:?}");
        let plate = m(shape(&nodes, |s| across(1600.0 * s * s - 0.4)));
        let motions = [f, t, plate, f, e];
        assert_eq!(
            names(&motions),
            [
                "1F (mode 1)",
                "1T (mode 2)",
                "mode 3",
                "2F (mode 4)",
                "1E (mode 5)"
            ]
        );
    }
}
