//! The default case's free-mode study through the command a user runs, at its defaults
//! (cases/blade.toml without `[forced]` and `[rotation]`; issue 24's checks on the whole
//! branch):
//! - every main-branch point in contact has a converged orbit (N doubled until w and the contact
//!   shares stop moving) or is named in report.md's table of the points without one;
//! - every q from q_start to q_max has w(q) on the output (the harmonic balance's main branch or
//!   the exact pieces of the massless contact boundary), except the holes report.md explains:
//!   each such hole lies between exact pieces, and the pieces next to it were followed through
//!   their tongues until they became another mode's family (the traced mode's fundamental under
//!   2 % of the energy, checked on the followed orbits themselves) or met the other side.
//!
//! About 35 s on 2 cores (mesh, reduction of the 93k-DOF blade, backbone and its stages).

mod common;

use std::path::PathBuf;

use serde_json::Value;

/// cases/blade.toml without `[forced]` and `[rotation]`, its results in `dir`.
fn free_case(dir: &std::path::Path) -> PathBuf {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("cases/blade.toml")).expect("cases/blade.toml");
    let text = text
        .split("\n[rotation]")
        .next()
        .expect("text before [rotation]");
    let forced = "[forced]";
    let (before, after) = text.split_once(forced).expect("a [forced] table");
    let after = after.replacen("enabled = true", "enabled = false", 1);
    let text = format!("{before}{forced}{after}")
        .replace(
            "results_dir = \"results\"",
            &format!("results_dir = \"{}\"", dir.join("results").display()),
        )
        .replace(
            "geo = \"meshes/blade.geo\"",
            &format!("geo = \"{}\"", root.join("meshes/blade.geo").display()),
        );
    let case = dir.join("blade.toml");
    std::fs::write(&case, text).expect("write the case");
    case
}

fn json(path: PathBuf) -> Value {
    serde_json::from_slice(&std::fs::read(&path).unwrap_or_else(|e| panic!("{path:?}: {e}")))
        .expect("json")
}

/// The merged q ranges of the exact pieces (m), ascending.
fn exact_ranges(exact: &Value) -> Vec<(f64, f64)> {
    let mut spans: Vec<(f64, f64)> = exact["pieces"]
        .as_array()
        .expect("pieces")
        .iter()
        .map(|p| {
            let q = p["points"].as_array().expect("points").iter();
            let q: Vec<f64> = q.map(|x| x["q"].as_f64().unwrap().abs()).collect();
            let lo = q.iter().copied().fold(f64::INFINITY, f64::min);
            (lo, q.iter().copied().fold(0.0, f64::max))
        })
        .collect();
    spans.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut merged: Vec<(f64, f64)> = Vec::new();
    for (lo, hi) in spans {
        match merged.last_mut() {
            Some(last) if lo <= last.1 => last.1 = last.1.max(hi),
            _ => merged.push((lo, hi)),
        }
    }
    merged
}

#[test]
fn default_case_converges_in_n_or_names_the_points_and_explains_every_hole() {
    let dir = std::env::temp_dir().join(format!("nlmodes-default-case-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let case = free_case(&dir);
    common::nlmodes_ok(&["run", case.to_str().unwrap()]);
    let res = dir.join("results/blade");
    let report = std::fs::read_to_string(res.join("report.md")).expect("report.md");
    let b = json(res.join("backbone/backbone.json"));
    let exact = json(res.join("backbone/backbone_boundary.json"));
    let g = b["gap_reference"].as_f64().unwrap();
    let main_branch = |p: &Value| {
        let branch = p["branch"].as_u64().unwrap() as usize;
        b["branches"][branch]["kind"]["kind"] == "main"
    };
    // Converged in N, or named with why.
    let mut named = 0;
    for p in b["points"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| main_branch(p))
    {
        let in_contact = p["contact_force"]
            .as_array()
            .unwrap()
            .iter()
            .flat_map(|f| f.as_array().unwrap())
            .any(|f| f.as_f64().unwrap() > 0.0);
        let converged = p.get("converged").is_some_and(|c| c["stop"] == "converged");
        if in_contact && !converged {
            let row = format!(
                "| {:.3} | {:.6} |",
                p["q"].as_f64().unwrap() / g,
                p["omega_ratio"].as_f64().unwrap()
            );
            assert!(report.contains(&row), "unconverged point not named: {row}");
            named += 1;
        }
    }
    assert!(
        report.contains("The points without a converged orbit, and why:") || named == 0,
        "report.md has no table of the points without a converged orbit"
    );
    // No hole the report does not explain: what neither the harmonic balance's main branch
    // (all of [q_start, q_max] but the intervals its passages left unjoined) nor the exact
    // pieces cover.
    let ranges = exact_ranges(&exact);
    let follows = exact["hole_follows"].as_array().expect("hole_follows");
    for r in b["internal_resonances"].as_array().unwrap() {
        let Some(unjoined) = r["unjoined"].as_array() else {
            continue;
        };
        let (a, c) = (unjoined[0].as_f64().unwrap(), unjoined[1].as_f64().unwrap());
        let mut from = a;
        for &(lo, hi) in ranges.iter().chain([(c, c)].iter()) {
            let to = lo.min(c);
            if to > from {
                check_hole(from, to, g, follows, &report);
            }
            from = from.max(hi);
            if from >= c {
                break;
            }
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The part [from, to] (m) of q no output covers lies inside a hole between exact pieces that
/// the report explains and whose sides were followed to another mode's family or across.
fn check_hole(from: f64, to: f64, g: f64, follows: &[Value], report: &str) {
    let mid = 0.5 * (from + to);
    let hole = |f: &Value| {
        [
            f["hole"][0].as_f64().unwrap(),
            f["hole"][1].as_f64().unwrap(),
        ]
    };
    let here: Vec<&Value> = follows
        .iter()
        .filter(|f| hole(f)[0] <= mid && mid <= hole(f)[1])
        .collect();
    assert!(
        !here.is_empty(),
        "q/g0 {:.3}-{:.3} has no w(q) and no followed piece",
        from / g,
        to / g
    );
    let [lo, hi] = hole(here[0]);
    assert!(
        report.contains(&format!("The hole q/g0 {:.3}-{:.3}", lo / g, hi / g)),
        "report.md does not explain the hole q/g0 {:.3}-{:.3}",
        lo / g,
        hi / g
    );
    for f in here {
        let pts = f["points"].as_array().expect("followed orbits");
        let last = pts.last().expect("a followed orbit");
        match f["end"].as_str() {
            Some("OtherMode") => {
                let primary = last["primary_share"].as_f64().unwrap();
                let q = last["q"].as_f64().unwrap().abs();
                assert!(
                    primary < 0.02 || q < 0.1 * lo,
                    "ends as another mode's family, yet holds {primary} in the traced mode at q/g0 \
                     {:.3}",
                    q / g
                );
            }
            Some("MetOtherSide") => {}
            _ => panic!("the hole's side was not followed to an end that explains it: {f}"),
        }
    }
}
