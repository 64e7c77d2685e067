//! The exact response curve on the massless contact boundary (`[forced] exact_curve`,
//! `forced/frf_boundary.csv`) through `nlmodes forced`, against plain time integration of the
//! physical equations.
//!
//! On the 2-DOF chain (`common::chain_model`) under the default penalty law (kc = 1000 x the
//! static contact stiffness 1.5 N/m) every mode is resolved, so the boundary model is the
//! penalty equation itself: M x'' + C x' + K x + kc (x_1 - g)_+ e_1 = F cos(W t) e_0. At 5 %
//! modal damping and 3 x grazing the response from rest settles on one orbit at every W of the
//! range: the test integrates that equation from rest by classical RK4 with a fixed step (no
//! pieces, no eigenvectors, no contact events), 150 periods, and compares the first harmonic
//! of the master over the last period with the CSV's `q1_over_g0` at the same W. Errors: the
//! transient decays like exp(-zeta w t) = exp(-47); the fixed step T / 8000 (contact frequency
//! sqrt(kc) = 38.7 rad/s, so h w_c = 0.03) loses O(h^2) at each kink of the contact force
//! (about 1e-6 relative); the boundary curve's master is sampled at 128 instants (exact for its
//! first harmonic up to aliasing). Tolerance 1e-4 relative; measured 6.6e-6 at W/w1 = 1.197 and
//! at most 1.5e-6 at the other five (main at ba2b8b2).

mod common;

use common::{chain_model, nlmodes};

/// The named columns of a CSV, one `Vec<String>` per row.
fn columns(csv: &str, names: &[&str]) -> Vec<Vec<String>> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let at: Vec<usize> = names
        .iter()
        .map(|n| header.iter().position(|h| h == n).expect(n))
        .collect();
    lines
        .map(|l| {
            let v: Vec<&str> = l.split(',').collect();
            at.iter().map(|&i| v[i].to_string()).collect()
        })
        .collect()
}

fn num(s: &str) -> f64 {
    s.parse().expect("a number")
}

/// The rows of frf_boundary.csv as (omega_ratio, q1_over_g0, stability, force_N).
fn exact_rows(csv: &str) -> Vec<(f64, f64, String, f64)> {
    columns(csv, &["omega_ratio", "q1_over_g0", "stability", "force_N"])
        .into_iter()
        .map(|r| (num(&r[0]), num(&r[1]), r[2].clone(), num(&r[3])))
        .collect()
}

/// The chain's steady response at W from rest: first-harmonic amplitude of x_0 over the last of
/// `periods` periods (module docs).
fn steady_amplitude(omega: f64, force: f64, kc: f64, zeta: f64, periods: usize) -> f64 {
    // C = sum_k 2 zeta w_k phi_k phi_k^T, phi = [1, +-1] / sqrt(2), w = 1, sqrt(3).
    let (c1, c2) = (2.0 * zeta, 2.0 * zeta * 3f64.sqrt());
    let c = [
        [(c1 + c2) / 2.0, (c1 - c2) / 2.0],
        [(c1 - c2) / 2.0, (c1 + c2) / 2.0],
    ];
    let accel = |t: f64, y: &[f64; 4]| -> [f64; 4] {
        let (x, v) = ([y[0], y[1]], [y[2], y[3]]);
        let contact = kc * (x[1] - 1.0).max(0.0);
        let f = [force * (omega * t).cos(), -contact];
        let a = |i: usize| {
            let kx = if i == 0 {
                2.0 * x[0] - x[1]
            } else {
                2.0 * x[1] - x[0]
            };
            f[i] - c[i][0] * v[0] - c[i][1] * v[1] - kx
        };
        [v[0], v[1], a(0), a(1)]
    };
    let steps = 8000;
    let h = 2.0 * std::f64::consts::PI / omega / steps as f64;
    let mut y = [0.0; 4];
    let (mut a, mut b) = (0.0, 0.0);
    for period in 0..periods {
        for s in 0..steps {
            let t = (period * steps + s) as f64 * h;
            if period + 1 == periods {
                a += y[0] * (omega * t).cos();
                b += y[0] * (omega * t).sin();
            }
            let k1 = accel(t, &y);
            let shift = |k: &[f64; 4], f: f64| std::array::from_fn(|i| y[i] + f * h * k[i]);
            let k2 = accel(t + 0.5 * h, &shift(&k1, 0.5));
            let k3 = accel(t + 0.5 * h, &shift(&k2, 0.5));
            let k4 = accel(t + h, &shift(&k3, 1.0));
            for i in 0..4 {
                y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
        }
    }
    2.0 * a.hypot(b) / steps as f64
}

/// `nlmodes forced` on the chain (`common::chain_model`) with the `[forced]` table `forced`:
/// the run's output and its output directory (inside the returned temporary directory).
fn forced_chain(forced: &str) -> (std::process::Output, std::path::PathBuf, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("model");
    chain_model(&model);
    let settings = dir.path().join("forced.toml");
    std::fs::write(&settings, forced).unwrap();
    let out_dir = dir.path().join("out");
    let run = nlmodes(&[
        "forced",
        model.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
        "--settings",
        settings.to_str().unwrap(),
    ]);
    (run, out_dir, dir)
}

#[test]
fn the_exact_curve_of_the_penalty_chain_is_the_time_integrated_response() {
    // The exact curve is written whether or not the harmonic-balance curve covers its range.
    let (run, out_dir, _dir) = forced_chain("[forced]\nlevels = [3.0]\ndamping_ratio = 0.05\n");
    let csv = std::fs::read_to_string(out_dir.join("frf_boundary.csv")).unwrap_or_else(|e| {
        panic!(
            "no frf_boundary.csv ({e}):\n{}{}",
            String::from_utf8_lossy(&run.stdout),
            String::from_utf8_lossy(&run.stderr)
        )
    });
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        stdout.contains("exact on the massless boundary"),
        "{stdout}"
    );
    let rows = exact_rows(&csv);
    let (first, last) = (rows[0].0, rows[rows.len() - 1].0);
    assert!(
        (first - 0.9).abs() < 1e-12 && last >= 1.2,
        "the exact curve spans the range: {first} .. {last}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("frf.json")).unwrap()).unwrap();
    let kc = json["penalty_stiffness_n_per_m"]
        .as_f64()
        .expect("penalty law");
    assert!((kc - 1500.0).abs() < 1e-9, "{kc}");
    let inside: Vec<_> = rows.iter().filter(|r| r.0 >= 0.95 && r.0 <= 1.2).collect();
    assert!(inside.len() >= 6, "{} points in [0.95, 1.2]", inside.len());
    let mut worst = 0.0_f64;
    let checked = 6;
    for k in 0..checked {
        let (ratio, q, verdict, force) = inside[k * (inside.len() - 1) / (checked - 1)];
        let amplitude = steady_amplitude(*ratio, *force, kc, 0.05, 150);
        let error = (amplitude / q - 1.0).abs();
        println!(
            "W/w = {ratio:.5}: exact {q:.8}, RK4 from rest {amplitude:.8} ({verdict}), {error:.1e}"
        );
        // A response reached from rest is an attractor: the exact monodromy must say stable.
        assert_eq!(verdict, "stable", "W/w = {ratio}");
        worst = worst.max(error);
    }
    println!("{checked} points, worst relative difference {worst:.1e}");
    assert!(worst < 1e-4, "{worst}");
}
