//! Times the global rotation terms of a clamped mesh turning about the x axis (Ti-6Al-4V, the
//! default blade's case) and prints a checksum of their bits, so that a faster assembly can be
//! shown to give the same matrices bit for bit.
//!
//! Usage: cargo run --release -p nlmodes-fem --example bench_rotation -- MESH.msh [RUNS]
//! (the clamped group is `root`; the displacement is a smooth field of about 0.1 mm).

use std::path::PathBuf;
use std::time::Instant;

use nlmodes_fem::rotation::{RotatingModel, RotorAxis};
use nlmodes_fem::{fixed_dofs, read_msh, DofMap, Isotropic};

/// FNV-1a over the bits of the values.
fn checksum(values: &[f64]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for v in values {
        h ^= v.to_bits();
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

fn median(mut t: Vec<f64>) -> f64 {
    t.sort_by(f64::total_cmp);
    t[t.len() / 2]
}

/// CPU time of this process (user + system, s) from /proc/self/stat (0 where unavailable).
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name (which ends with ')'): utime and stime are the 12th and
    // 13th, in clock ticks (100 per second on Linux).
    let rest = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = rest
        .split_whitespace()
        .skip(11)
        .take(2)
        .filter_map(|x| x.parse().ok())
        .collect();
    f.iter().sum::<f64>() / 100.0
}

/// Median wall time and median CPU time (s) of `runs` calls of `f`, and the last call's result.
fn timed<T>(runs: usize, mut f: impl FnMut() -> T) -> ((f64, f64), T) {
    let (mut wall, mut cpu) = (Vec::with_capacity(runs), Vec::with_capacity(runs));
    let mut last = None;
    for _ in 0..runs {
        let (t, c) = (Instant::now(), cpu_seconds());
        last = Some(f());
        wall.push(t.elapsed().as_secs_f64());
        cpu.push(cpu_seconds() - c);
    }
    ((median(wall), median(cpu)), last.expect("at least one run"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args_os().skip(1);
    let Some(path) = args.next().map(PathBuf::from) else {
        eprintln!("usage: bench_rotation MESH.msh [RUNS]");
        std::process::exit(2);
    };
    let runs: usize = match args.next() {
        Some(r) => r.to_string_lossy().parse()?,
        None => 5,
    };
    let mesh = read_msh(&path)?;
    let fixed = fixed_dofs(&mesh, &["root".to_string()])?;
    let dofs = DofMap::new(mesh.n_nodes(), &fixed)?;
    let material = Isotropic::new(113.8e9, 0.342, 4430.0)?;
    let axis = RotorAxis::new([0.0; 3], [1.0, 0.0, 0.0])?;
    let omega = 8000.0 * std::f64::consts::PI / 30.0;
    let (t_new, model) = timed(1, || {
        RotatingModel::new(&mesh, material, axis, dofs.clone())
    });
    let model = model?;
    println!(
        "{} nodes, {} elements, {} free DOFs; model built in {:.3} s",
        mesh.n_nodes(),
        mesh.n_elements(),
        dofs.n_free(),
        t_new.0
    );
    let u_free: Vec<f64> = (0..dofs.n_free())
        .map(|i| 1e-4 * ((i as f64) * 0.37).sin())
        .collect();
    let (t, rt) = timed(runs, || model.residual_and_tangent(omega, &u_free));
    let rt = rt?;
    println!(
        "residual_and_tangent: {:.3} s (CPU {:.2} s; medians of {runs}); checksums residual {:016x} load {:016x} tangent {:016x}",
        t.0,
        t.1,
        checksum(&rt.residual),
        checksum(&rt.load),
        checksum(rt.tangent.data())
    );
    let (t, r) = timed(runs, || model.residual(omega, &u_free));
    let (residual, load) = r?;
    println!(
        "residual (no tangent): {:.3} s (CPU {:.2} s); checksums residual {:016x} load {:016x}",
        t.0,
        t.1,
        checksum(&residual),
        checksum(&load)
    );
    let (t, m) = timed(runs, || model.spin_softening_matrix());
    println!(
        "spin_softening_matrix: {:.3} s (CPU {:.2} s); checksum {:016x}",
        t.0,
        t.1,
        checksum(m?.data())
    );
    let (t, g) = timed(runs, || model.coriolis_matrix(omega));
    println!(
        "coriolis_matrix: {:.3} s (CPU {:.2} s); checksum {:016x}",
        t.0,
        t.1,
        checksum(g?.data())
    );
    let state = nlmodes_fem::rotation::StaticSolution {
        omega,
        kinematics: nlmodes_fem::rotation::Kinematics::Linear,
        spin_softening_in_operator: false,
        displacement: dofs.try_expand(&u_free)?,
        displacement_free: u_free.clone(),
        steps: Vec::new(),
    };
    let (t, k) = timed(runs, || model.stiffness_at_speed(&state));
    println!(
        "stiffness_at_speed (linear kinematics): {:.3} s (CPU {:.2} s); checksum {:016x}",
        t.0,
        t.1,
        checksum(k?.data())
    );
    Ok(())
}
