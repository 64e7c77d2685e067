//! The frequency derivative the bordered Newton step uses, d y / d W at fixed contact forces
//! (`ModalDynamics::response_rate`), against a central difference of the response, for the
//! diagonal (Rayleigh) and the dense (non-proportional) damping paths.

mod common;

use faer::Mat;
use nlmodes_forced::{Damping, Load, ModalDynamics};

fn check(damping: Damping) {
    let system = common::three_dof(0.5);
    let c = damping.matrix(&system).unwrap();
    let load = Load::fundamental(vec![0.1, 0.0, 0.3]);
    let nh = 4;
    let dynamics = ModalDynamics::new(&system, &c, &load, nh).unwrap();
    let t = 2 * nh + 1;
    let lambda: Vec<f64> = (0..t).map(|p| 0.05 * (p as f64 + 1.0).sin()).collect();
    let contact = |w: f64| -> Vec<f64> {
        let z = dynamics.response(w, 1.0, &lambda).unwrap();
        let psi = dynamics.contact_modes();
        (0..t)
            .map(|p| (0..3).map(|k| psi[(0, k)] * z[(k, p)]).sum())
            .collect()
    };
    for w in [0.4, 0.9, 1.7] {
        let z = dynamics.response(w, 1.0, &lambda).unwrap();
        let rate = dynamics.response_rate(w, &z).unwrap();
        let h = 1e-6;
        let (up, down) = (contact(w + h), contact(w - h));
        let scale = rate.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        for p in 0..t {
            let fd = (up[p] - down[p]) / (2.0 * h);
            // Central difference: error O(h^2 y''') plus round-off O(eps y / h), about 1e-9 here.
            assert!(
                (fd - rate[p]).abs() <= 1e-7 * scale,
                "W {w}, p {p}: {fd} vs {}",
                rate[p]
            );
        }
    }
}

#[test]
fn frequency_derivative_matches_a_central_difference() {
    check(Damping::Rayleigh {
        alpha: 0.02,
        beta: 0.01,
    });
    check(Damping::Matrix(Mat::from_fn(3, 3, |i, j| {
        if i == 0 && j == 0 {
            0.2
        } else {
            0.0
        }
    })));
}
