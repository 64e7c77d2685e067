//! The backbone figures on a small synthetic family (linear segment, main branch with an
//! unstable stretch and a passage past a tongue, the tongue): what each figure draws, the
//! stability runs, and that no legend or label lies over the data (`LineLayout::clashes`).

use super::backbone::{backbone_plot, diagnostics_plot, frequency_energy_plot};
use crate::post::results::BackboneFile;
use nlmodes_output::{LineStyle, Series};
use serde_json::{json, Value};

/// A point at (q / g0, w / w1) with g0 = 1 mm, w1 = 100 rad/s, on `branch`, with the verdict
/// `stable` (Hill's method, unit multipliers but one of modulus `mu`).
fn point(q: f64, w: f64, branch: usize, mu: f64, fold: bool) -> Value {
    json!({
        "q": q * 1e-3, "omega": w * 100.0, "omega_ratio": w, "frequency_hz": w * 100.0 / std::f64::consts::TAU,
        "contact_fraction": [], "powell_measure": 0.0, "newton_iterations": 3,
        "fold": fold, "jump": false, "truncation_warning": false, "energy": q * q,
        "branch": branch, "coefficients": [], "contact_force": [],
        "stability": {
            "stable": mu <= 1.0, "max_multiplier_abs": mu, "trivial_pair_error": 1e-9,
            "method": "hill", "multipliers": [[1.0, 0.0], [1.0, 0.0], [mu, 0.0]],
            "trivial": [0, 1]
        }
    })
}

/// Linear segment q = 0..6, main branch 6..20 (unstable at q = 10, 11), a tongue leaving at
/// q = 14 and coming back, the main branch resuming at 16 (a passage), a fold on the tongue.
fn family() -> BackboneFile {
    let mut pts: Vec<Value> = (0..=6)
        .map(|q| point(q as f64, 1.0, 0, 1.0, false))
        .collect();
    let w = |q: f64| 1.0 + 0.03 * (q - 6.0);
    for q in 7..=14 {
        let mu = if q == 10 || q == 11 { 1.3 } else { 1.0 };
        pts.push(point(q as f64, w(q as f64), 1, mu, false));
    }
    for (k, q) in [14.2, 14.3, 14.2, 13.5].iter().enumerate() {
        pts.push(point(*q, w(14.0) + 0.01 * (k + 1) as f64, 2, 1.0, k == 1));
    }
    for q in 16..=20 {
        pts.push(point(q as f64, w(q as f64), 1, 1.0, false));
    }
    serde_json::from_value(json!({
        "points": pts, "termination": "q_max", "omega_linear": 100.0, "gap_reference": 1e-3,
        "grazing_amplitude": 6e-3,
        "branches": [
            {"id": 0, "parent": null, "kind": {"kind": "linear"}, "end": "grazing"},
            {"id": 1, "parent": 0, "kind": {"kind": "main"}, "end": "q_max reached"},
            {"id": 2, "parent": 1, "kind": {"kind": "tongue", "mode": 2, "harmonic": 3}, "end": "back"}
        ]
    }))
    .expect("a backbone file")
}

fn labels(series: &[Series]) -> Vec<&str> {
    series
        .iter()
        .map(|s| s.label.as_str())
        .filter(|l| !l.is_empty())
        .collect()
}

#[test]
fn fig_3a_draws_the_backbone_only() {
    let plot = backbone_plot(&family());
    assert_eq!(
        labels(&plot.series),
        [
            "stable",
            "unstable",
            "passage past an internal-resonance tongue"
        ]
    );
    // No tongue point (w above the main branch at q = 14.2..14.3) is drawn.
    let top_at_14 = plot
        .series
        .iter()
        .flat_map(|s| s.x.iter().zip(&s.y))
        .filter(|(x, _)| (**x - 14.25).abs() < 0.1)
        .count();
    assert_eq!(top_at_14, 0);
    // The fold lies on the tongue: not on Fig. 3a; grazing is marked.
    assert!(plot.series.iter().all(|s| !s.markers));
    assert_eq!(plot.ref_lines.len(), 1);
    assert_eq!(plot.ref_lines[0].value, 6.0);
    let layout = plot.layout().expect("layout");
    assert!(layout.clashes().is_empty(), "{:?}", layout.clashes());
}

#[test]
fn stability_changes_sit_halfway_between_points() {
    let plot = backbone_plot(&family());
    let dashed: Vec<&Series> = plot
        .series
        .iter()
        .filter(|s| s.style == LineStyle::Dashed)
        .collect();
    assert_eq!(dashed.len(), 1);
    // Points q = 10 and 11 are unstable: the dashed run spans q = 9.5 .. 11.5.
    assert_eq!(dashed[0].x, vec![9.5, 10.0, 11.0, 11.5]);
    // The solid runs meet it there: the curve is continuous.
    let ends: Vec<f64> = plot
        .series
        .iter()
        .filter(|s| s.style == LineStyle::Solid)
        .flat_map(|s| [s.x[0], *s.x.last().expect("a point")])
        .collect();
    assert!(ends.contains(&9.5) && ends.contains(&11.5), "{ends:?}");
}

#[test]
fn the_diagnostics_carry_the_tongue_and_the_fold() {
    let plot = diagnostics_plot(&family(), None);
    let l = labels(&plot.series);
    for want in [
        "harmonic balance (dashed unstable, dotted undetermined)",
        "internal-resonance tongues",
        "fold / jump",
    ] {
        assert!(l.contains(&want), "{l:?}");
    }
    let layout = plot.layout().expect("layout");
    assert!(layout.clashes().is_empty(), "{:?}", layout.clashes());
    let (legend, _) = layout.legend.expect("a legend");
    assert!(legend.y > layout.area.bottom(), "below the plot");
}

#[test]
fn the_frequency_energy_plot_has_no_clash() {
    let plot = frequency_energy_plot(&family()).expect("energies > 0");
    assert!(labels(&plot.series).contains(&"internal-resonance tongues"));
    let layout = plot.layout().expect("layout");
    assert!(layout.clashes().is_empty(), "{:?}", layout.clashes());
}

/// The default case's own figures (results/blade from `scripts/run`): no legend or label over
/// their data, the Campbell diagram's (its modes named, its engine-order lines labelled) among
/// them. Ignored: it needs those results (a 30-minute run). Run it with
/// `cargo test --release --bin nlmodes default_case_figures -- --ignored` after `scripts/run`.
#[test]
#[ignore = "needs results/blade from scripts/run"]
fn default_case_figures_have_no_clash() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("results/blade");
    let dir = root.join("backbone");
    let b: BackboneFile =
        crate::post::results::read_json(&dir.join("backbone.json")).expect("backbone.json");
    let exact = crate::post::results::read_boundary_backbone(&dir).expect("backbone_boundary.json");
    let d: crate::campbell::campbell_stage::CampbellData =
        crate::post::results::read_json(&root.join("campbell/campbell.json"))
            .expect("campbell.json");
    let names = super::curve_names(&root.join("parametric"), d.speeds_rpm[0], d.curves.len());
    assert!(names[0].starts_with("1F"), "{names:?}");
    let band = crate::campbell::campbell_stage::band(&b, 0.0, &[]).expect("a band at rest");
    let campbell = super::campbell::campbell_plot(&super::CampbellPicture {
        speeds_rpm: &d.speeds_rpm,
        curves: (names.iter().cloned())
            .zip(d.curves.iter().map(|c| &c.frequency_hz[..]))
            .collect(),
        engine_orders: &d.engine_orders,
        crossings: d
            .crossings
            .iter()
            .map(|c| (c.speed_rpm, c.frequency_hz))
            .collect(),
        bands: vec![(0.0, band.low_hz, band.high_hz)],
        operating_rpm: 8000.0,
    });
    for plot in [
        backbone_plot(&b),
        diagnostics_plot(&b, exact.as_ref()),
        frequency_energy_plot(&b).expect("energies"),
        campbell,
    ] {
        let layout = plot.layout().expect("layout");
        assert!(
            layout.clashes().is_empty(),
            "{}: {:?}",
            plot.title,
            layout.clashes()
        );
    }
}
