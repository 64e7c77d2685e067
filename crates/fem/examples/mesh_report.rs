//! Reads a gmsh MSH 4.1 file, prints its groups, the curvature of its elements, the stiffness
//! rule each curved element gets, and times the assembly of K and M (steel).
//!
//! Usage: cargo run --release -p nlmodes-fem --example mesh_report -- mesh.msh

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Instant;

use nlmodes_fem::element::{curvature, is_affine, ElementRules};
use nlmodes_fem::{assemble, read_msh, Isotropic, TetKind};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let Some(path) = std::env::args_os().nth(1).map(PathBuf::from) else {
        eprintln!("usage: mesh_report MESH.msh");
        std::process::exit(2);
    };
    let t = Instant::now();
    let mesh = read_msh(&path)?;
    println!(
        "read {} in {:.3} s",
        path.display(),
        t.elapsed().as_secs_f64()
    );
    println!(
        "{} nodes ({} DOFs), {} {:?} elements, volume {:.6e} m^3",
        mesh.n_nodes(),
        3 * mesh.n_nodes(),
        mesh.n_elements(),
        mesh.kind,
        mesh.volume()
    );
    for g in &mesh.groups {
        println!(
            "  group '{}' dim {} tag {}: {} nodes",
            g.name,
            g.dim,
            g.tag,
            g.nodes.len()
        );
    }
    if mesh.kind == TetKind::Tet10 {
        let rules = ElementRules::for_kind(TetKind::Tet10);
        let mut by_rule = BTreeMap::new();
        let mut by_curvature = BTreeMap::new();
        let mut coords = [[0.0; 3]; 10];
        for e in 0..mesh.n_elements() {
            mesh.element_coords_into(e, &mut coords);
            let c = curvature(mesh.kind, &coords);
            let bucket = if c <= 1e-10 {
                -10
            } else {
                c.log10().floor() as i32
            };
            *by_curvature.entry(bucket).or_insert(0usize) += 1;
            let points = if is_affine(mesh.kind, &coords) {
                4
            } else {
                rules.curved_stiffness_rule(&coords).rule.len()
            };
            *by_rule.entry(points).or_insert(0usize) += 1;
        }
        println!("mid-edge offset / h (decade: elements; -10 = affine): {by_curvature:?}");
        println!("stiffness rule (points: elements): {by_rule:?}");
    }
    let mat = Isotropic::new(210e9, 0.3, 7800.0)?;
    for _ in 0..2 {
        let t = Instant::now();
        let (k, m) = assemble(&mesh, &mat)?;
        println!(
            "assembled K, M ({} x {}, {} non-zeros each) in {:.3} s",
            k.rows(),
            k.cols(),
            k.nnz(),
            t.elapsed().as_secs_f64()
        );
        let _ = m;
    }
    Ok(())
}
