//! The MSH 4.1 reader: hand-written files (groups of every dimension, TET4 and TET10,
//! non-contiguous and unordered node tags), a file written by gmsh itself (ASCII and binary),
//! and one error per kind of bad input.

// Index loops mirror the index notation of the formulas.
#![allow(clippy::needless_range_loop)]

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use nlmodes_fem::{assemble, fixed_dofs, read_msh, DofMap, FemError, Isotropic, Mesh, TetKind};

fn write_temp(dir: &tempfile::TempDir, name: &str, content: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    let mut f = std::fs::File::create(&path).expect("temp file");
    f.write_all(content).expect("write");
    path
}

fn read_str(content: &str) -> Result<Mesh, FemError> {
    let dir = tempfile::tempdir().expect("temp dir");
    read_msh(&write_temp(&dir, "mesh.msh", content.as_bytes()))
}

const HEADER: &str = "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";

/// Two TET4 (tags 100 and 105) sharing the face 20-30-40; node tags 10..60 (non-contiguous),
/// node 60 used by no element; groups of dimension 0 (point element), 1 (line element, whose
/// curve node block is empty), 2 (triangle), 3 (the tets).
const TWO_TET4: &str = "$PhysicalNames
4
0 5 \"corner\"
1 6 \"edge\"
2 7 \"bottom\"
3 8 \"solid\"
$EndPhysicalNames
$Entities
2 1 1 1
1 0 0 0 1 5
2 1 0 0 0
1 0 0 0 1 0 0 1 6 2 1 -2
1 0 0 0 1 1 0 1 7 0
1 0 0 0 1 1 1 1 8 0
$EndEntities
$Nodes
4 6 10 60
0 1 0 1
10
0 0 0
0 2 0 1
20
1 0 0
1 1 0 0
3 1 0 4
30
40
50
60
0 1 0
0 0 1
1 1 1
5 5 5
$EndNodes
$Elements
4 5 1 105
0 1 15 1
1 10
1 1 1 1
2 10 20
2 1 2 1
3 10 20 30
3 1 4 2
100 10 20 30 40
105 20 30 40 50
$EndElements
";

fn node_of(mesh: &Mesh, x: [f64; 3]) -> usize {
    mesh.nodes
        .iter()
        .position(|&p| p == x)
        .expect("node present")
}

#[test]
fn hand_written_tet4_file_with_groups_of_all_dimensions() {
    let mesh = read_str(&format!("{HEADER}{TWO_TET4}")).expect("valid file");
    assert_eq!(mesh.kind, TetKind::Tet4);
    assert_eq!(mesh.n_elements(), 2);
    assert_eq!(mesh.element_tags, vec![100, 105]);
    // Node 60 belongs to no tetrahedron: dropped.
    assert_eq!(mesh.n_nodes(), 5);
    assert!(!mesh.nodes.contains(&[5.0, 5.0, 5.0]));
    // Volumes 1/6 and 2/6 (exact in binary up to round-off).
    assert!((mesh.volume() - 0.5).abs() < 1e-15);
    let n = |x| node_of(&mesh, x);
    assert_eq!(
        mesh.element(0),
        &[
            n([0.0; 3]),
            n([1.0, 0.0, 0.0]),
            n([0.0, 1.0, 0.0]),
            n([0.0, 0.0, 1.0])
        ]
    );
    assert_eq!(
        mesh.element(1),
        &[
            n([1.0, 0.0, 0.0]),
            n([0.0, 1.0, 0.0]),
            n([0.0, 0.0, 1.0]),
            n([1.0, 1.0, 1.0])
        ]
    );
    let expect = |name: &str, dim: usize, tag: i32, xs: &[[f64; 3]]| {
        let g = mesh.group(name).expect("group present");
        assert_eq!((g.dim, g.tag), (dim, tag), "{name}");
        let mut want: Vec<usize> = xs.iter().map(|&x| n(x)).collect();
        want.sort_unstable();
        assert_eq!(g.nodes, want, "{name}");
    };
    expect("corner", 0, 5, &[[0.0; 3]]);
    expect("edge", 1, 6, &[[0.0; 3], [1.0, 0.0, 0.0]]);
    expect(
        "bottom",
        2,
        7,
        &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
    );
    expect(
        "solid",
        3,
        8,
        &[
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
        ],
    );
    assert_eq!(mesh.groups.len(), 4);
    // The surface group keeps its triangle; a pressure on it pushes into the solid: the face
    // z = 0 of area 1/2 has the outward normal -e_z, so the total force is +p / 2 e_z.
    let bottom = mesh.group("bottom").expect("present");
    assert_eq!(bottom.triangles.len(), 3);
    assert!(mesh.group("edge").expect("present").triangles.is_empty());
    let f = nlmodes_fem::surface_load::pressure_load(&mesh, "bottom", 4.0).expect("surface");
    let fz: f64 = f.iter().skip(2).step_by(3).sum();
    let fxy: f64 = f
        .iter()
        .enumerate()
        .filter(|(i, _)| i % 3 != 2)
        .map(|(_, v)| v.abs())
        .sum();
    assert!((fz - 2.0).abs() < 1e-15 && fxy < 1e-15, "{f:?}");
    // Constraints on the groups.
    let fixed = fixed_dofs(&mesh, &["bottom:z", "corner"]).expect("valid specs");
    assert_eq!(fixed.len(), 3 + 2);
    let map = DofMap::new(mesh.n_nodes(), &fixed).expect("valid");
    assert_eq!(map.n_free(), 15 - 5);
    let err = fixed_dofs(&mesh, &["root"]).expect_err("unknown group");
    assert!(
        err.to_string().contains("'root'") && err.to_string().contains("'bottom' (dim 2)"),
        "{err}"
    );
}

/// One TET10 whose node tags are contiguous (1..10) but listed out of order, so that mshio
/// drops them; a Tri6 surface group on face 0-1-2 and a point group.
const ONE_TET10_UNORDERED: &str = "$PhysicalNames
3
0 1 \"tip\"
2 2 \"base\"
3 3 \"body\"
$EndPhysicalNames
$Entities
1 0 1 1
4 0 0 1 1 1
1 0 0 0 1 1 0 1 2 0
1 0 0 0 1 1 1 1 3 0
$EndEntities
$Nodes
3 10 1 10
0 4 0 1
4
0 0 1
2 1 0 5
3
1
5
2
6
0 1 0
0 0 0
0.5 0.01 0
1 0 0
0.5 0.5 0
3 1 0 4
10
7
9
8
0.5 0 0.5
0 0.5 0
0 0.5 0.5
0 0 0.5
$EndNodes
$Elements
3 3 1 3
0 4 15 1
1 4
2 1 9 1
2 1 2 3 5 6 7
3 1 11 1
3 1 2 3 4 5 6 7 8 9 10
$EndElements
";

#[test]
fn hand_written_tet10_file_with_unordered_contiguous_node_tags() {
    let mesh = read_str(&format!("{HEADER}{ONE_TET10_UNORDERED}")).expect("valid file");
    assert_eq!(mesh.kind, TetKind::Tet10);
    assert_eq!(mesh.n_elements(), 1);
    assert_eq!(mesh.n_nodes(), 10);
    // The element's nodes in gmsh order must be the reference TET10 (with node 4, the
    // mid-edge node of edge 0-1, moved off its chord by 0.01): tags mapped correctly even
    // though mshio dropped them.
    let expected: [[f64; 3]; 10] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.5, 0.01, 0.0],
        [0.5, 0.5, 0.0],
        [0.0, 0.5, 0.0],
        [0.0, 0.0, 0.5],
        [0.0, 0.5, 0.5],
        [0.5, 0.0, 0.5],
    ];
    for (i, &v) in mesh.element(0).iter().enumerate() {
        assert_eq!(mesh.nodes[v], expected[i], "element node {i}");
    }
    let base = mesh.group("base").expect("present");
    assert_eq!(base.nodes.len(), 6);
    assert!(base.nodes.iter().all(|&v| mesh.nodes[v][2] == 0.0));
    let tip = mesh.group("tip").expect("present");
    assert_eq!(tip.nodes.len(), 1);
    assert_eq!(mesh.nodes[tip.nodes[0]], [0.0, 0.0, 1.0]);
    assert_eq!(mesh.group("body").expect("present").nodes.len(), 10);
    let msg = mesh.group("blade").expect_err("absent").to_string();
    for name in [
        "'blade'",
        "'tip' (dim 0)",
        "'base' (dim 2)",
        "'body' (dim 3)",
    ] {
        assert!(msg.contains(name), "{msg}");
    }
}

fn gmsh_available() -> bool {
    Command::new("gmsh").arg("--version").output().is_ok()
}

/// A unit box with 4 segments per edge, TET10, named groups of dimension 0..3.
const BOX_GEO: &str = r#"
SetFactory("Built-in");
lc = 0.25;
Point(1) = {0, 0, 0, lc}; Point(2) = {1, 0, 0, lc}; Point(3) = {1, 1, 0, lc}; Point(4) = {0, 1, 0, lc};
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
Transfinite Curve{1, 2, 3, 4} = 5;
out[] = Extrude {0, 0, 1} { Surface{1}; };
Physical Volume("solid") = {out[1]};
Physical Surface("bottom") = {1};
Physical Curve("front_edge") = {1};
Physical Point("corner") = {2};
"#;

fn run_gmsh(dir: &Path, extra: &[&str], out: &str) -> PathBuf {
    let geo = dir.join("box.geo");
    std::fs::write(&geo, BOX_GEO).expect("write geo");
    let msh = dir.join(out);
    let status = Command::new("gmsh")
        .args(["-3", "-order", "2", "-format", "msh41"])
        .args(extra)
        .arg(&geo)
        .arg("-o")
        .arg(&msh)
        .output()
        .expect("gmsh runs");
    assert!(
        status.status.success(),
        "gmsh failed: {}",
        String::from_utf8_lossy(&status.stderr)
    );
    msh
}

#[test]
fn file_written_by_gmsh_ascii_and_binary() {
    if !gmsh_available() {
        println!("SKIPPED: gmsh is not on PATH (the project's set-up installs it)");
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let ascii = read_msh(&run_gmsh(dir.path(), &[], "box.msh")).expect("gmsh ASCII file");
    let binary_path = run_gmsh(dir.path(), &["-bin"], "box_bin.msh");
    let binary = read_msh(&binary_path).expect("gmsh binary file");
    // Corrupted or truncated binary files give errors (or a mesh), never a panic.
    let bytes = std::fs::read(&binary_path).expect("readable");
    for pos in (0..bytes.len()).step_by(bytes.len() / 150 + 1) {
        for replacement in [0xFFu8, 0x00, 0x7F] {
            let mut corrupted = bytes.clone();
            corrupted[pos] = replacement;
            let r = std::panic::catch_unwind(|| {
                nlmodes_fem::parse_msh(&corrupted, &binary_path).is_ok()
            });
            assert!(
                r.is_ok(),
                "panic with binary byte {pos} set to {replacement:#x}"
            );
        }
        let r = std::panic::catch_unwind(|| {
            nlmodes_fem::parse_msh(&bytes[..pos], &binary_path).is_ok()
        });
        assert!(r.is_ok(), "panic on binary truncation at byte {pos}");
    }
    // Same mesh; coordinates agree to the 16 significant digits of the ASCII file.
    assert_eq!(ascii.kind, binary.kind);
    assert_eq!(ascii.connectivity, binary.connectivity);
    assert_eq!(ascii.element_tags, binary.element_tags);
    assert_eq!(ascii.groups, binary.groups);
    assert_eq!(ascii.nodes.len(), binary.nodes.len());
    for (a, b) in ascii.nodes.iter().zip(&binary.nodes) {
        for d in 0..3 {
            assert!((a[d] - b[d]).abs() <= 1e-15, "{a:?} vs {b:?}");
        }
    }
    let mesh = ascii;
    assert_eq!(mesh.kind, TetKind::Tet10);
    // Straight-edged box: exact volume 1 (round-off of a few hundred element sums).
    assert!(
        (mesh.volume() - 1.0).abs() < 1e-12,
        "volume {}",
        mesh.volume()
    );
    // Group nodes collected from elements, checked against the coordinates.
    let on = |pred: &dyn Fn([f64; 3]) -> bool| -> Vec<usize> {
        (0..mesh.n_nodes())
            .filter(|&v| pred(mesh.nodes[v]))
            .collect()
    };
    let tol = 1e-12;
    assert_eq!(
        mesh.group("bottom").expect("present").nodes,
        on(&|x| x[2].abs() < tol)
    );
    // 4 segments of TET10 line elements: 5 vertices + 4 mid-edge nodes.
    let edge = &mesh.group("front_edge").expect("present").nodes;
    assert_eq!(edge.len(), 9);
    assert_eq!(*edge, on(&|x| x[1].abs() < tol && x[2].abs() < tol));
    // The TRI6 of the bottom face (unstructured, 42 triangles in gmsh 4.x), oriented by their
    // tetrahedra: a pressure p pushes the unit face z = 0 with a total force +p e_z.
    let bottom = mesh.group("bottom").expect("present");
    assert!(bottom.triangles.len() >= 6 * 32 && bottom.triangles.len().is_multiple_of(6));
    let f = nlmodes_fem::surface_load::pressure_load(&mesh, "bottom", 1e5).expect("surface");
    let sum = |d: usize| f.iter().skip(d).step_by(3).sum::<f64>();
    assert!(
        sum(0).abs() < 1e-10 && sum(1).abs() < 1e-10 && (sum(2) - 1e5).abs() < 1e-10,
        "{} {} {}",
        sum(0),
        sum(1),
        sum(2)
    );
    let corner = &mesh.group("corner").expect("present");
    assert_eq!((corner.dim, corner.nodes.len()), (0, 1));
    assert_eq!(mesh.nodes[corner.nodes[0]], [1.0, 0.0, 0.0]);
    assert_eq!(
        mesh.group("solid").expect("present").nodes.len(),
        mesh.n_nodes()
    );
    // The matrices of a gmsh mesh: rigid-body modes in the null space of K.
    let (k, _) =
        assemble(&mesh, &Isotropic::new(210e9, 0.3, 7800.0).expect("valid")).expect("valid mesh");
    let kmax = common::max_abs(&k);
    for r in common::rigid_body_modes(&mesh.nodes) {
        let kr = common::mul(&k, &r);
        assert!(kr.iter().all(|v| v.abs() < 1e-12 * kmax * 2.0));
    }
}

fn expect_error(content: &[u8]) -> String {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = write_temp(&dir, "bad.msh", content);
    let err = read_msh(&path).expect_err("must be rejected");
    let msg = err.to_string();
    println!("{msg}");
    assert!(
        msg.contains("bad.msh"),
        "message does not name the file: {msg}"
    );
    msg
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    // MSH 2.2
    let msg =
        expect_error(b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1\n1 0 0 0\n$EndNodes\n");
    assert!(msg.contains("2.2") && msg.contains("4.1"), "{msg}");
    // missing file
    let missing = Path::new("/nonexistent/dir/blade.msh");
    let err = read_msh(missing).expect_err("missing");
    assert!(
        matches!(err, FemError::Io { .. })
            && err.to_string().contains("/nonexistent/dir/blade.msh"),
        "{err}"
    );
    // garbage
    let msg = expect_error(b"\x00\x01garbage\xff\nmore garbage");
    assert!(msg.contains("not a gmsh MSH file"), "{msg}");
    // valid header, truncated / malformed body
    let msg = expect_error(format!("{HEADER}$Nodes\n1 2 1 2\n0 1 0 2\n1\n").as_bytes());
    assert!(msg.contains("cannot parse"), "{msg}");
    let truncated = &format!("{HEADER}{TWO_TET4}")[..400];
    expect_error(truncated.as_bytes());
    // binary header with an unsupported size_t
    let msg = expect_error(b"$MeshFormat\n4.1 1 3\n\x01\x00\x00\x00\n$EndMeshFormat\n");
    assert!(msg.contains("data-size"), "{msg}");
    // no tetrahedra: only the triangle and point of the hand-written file
    let no_tets = format!("{HEADER}{TWO_TET4}")
        .replace("4 5 1 105", "3 3 1 3")
        .replace("3 1 4 2\n100 10 20 30 40\n105 20 30 40 50\n", "");
    let msg = expect_error(no_tets.as_bytes());
    assert!(msg.contains("no tetrahedra"), "{msg}");
    // unsupported volume element: a hexahedron (gmsh type 5)
    let hexa = format!("{HEADER}{TWO_TET4}")
        .replace(
            "3 1 4 2\n100 10 20 30 40\n105 20 30 40 50\n",
            "3 1 5 1\n100 10 20 30 40 50 60 10 20\n",
        )
        .replace("4 5 1 105", "4 4 1 100");
    let msg = expect_error(hexa.as_bytes());
    assert!(msg.contains("type 5") && msg.contains("Hex8"), "{msg}");
    // mixed TET4 / TET10
    let mixed = format!("{HEADER}{TWO_TET4}")
        .replace(
            "3 1 4 2\n100 10 20 30 40\n105 20 30 40 50\n",
            "3 1 4 1\n100 10 20 30 40\n3 1 11 1\n105 10 20 30 40 50 60 10 20 30 40\n",
        )
        .replace("4 5 1 105", "5 5 1 105");
    let msg = expect_error(mixed.as_bytes());
    assert!(msg.contains("mixes TET4"), "{msg}");
    // an element referring to a node tag that does not exist
    let dangling = format!("{HEADER}{TWO_TET4}").replace("105 20 30 40 50", "105 20 30 40 77");
    let msg = expect_error(dangling.as_bytes());
    assert!(msg.contains("element 105") && msg.contains("77"), "{msg}");
}

#[test]
fn inverted_element_in_a_file_is_reported_by_its_tag() {
    // Swap two vertices of element 105: the reader accepts it, the assembly names it.
    let swapped = format!("{HEADER}{TWO_TET4}").replace("105 20 30 40 50", "105 30 20 40 50");
    let mesh = read_str(&swapped).expect("readable");
    let err =
        assemble(&mesh, &Isotropic::new(1.0, 0.3, 1.0).expect("valid")).expect_err("inverted");
    assert!(
        matches!(
            err,
            FemError::InvertedElement {
                element_tag: 105,
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("element 105"), "{err}");
}

#[test]
fn truncated_and_corrupted_files_never_panic() {
    // Every truncation of the hand-written files, and single-byte corruptions (every 7th
    // byte replaced by a few different values), must give Ok or Err, never a panic.
    let path = Path::new("fuzz.msh");
    for text in [
        format!("{HEADER}{TWO_TET4}"),
        format!("{HEADER}{ONE_TET10_UNORDERED}"),
    ] {
        let bytes = text.as_bytes();
        for cut in 0..bytes.len() {
            let r =
                std::panic::catch_unwind(|| nlmodes_fem::parse_msh(&bytes[..cut], path).is_ok());
            assert!(r.is_ok(), "panic on truncation at byte {cut}");
        }
        for pos in (0..bytes.len()).step_by(7) {
            for replacement in [b'0', b'9', b'-', b' ', b'\n', b'$', b'x'] {
                let mut corrupted = bytes.to_vec();
                corrupted[pos] = replacement;
                let r =
                    std::panic::catch_unwind(|| nlmodes_fem::parse_msh(&corrupted, path).is_ok());
                assert!(
                    r.is_ok(),
                    "panic with byte {pos} set to {:?}",
                    replacement as char
                );
            }
        }
    }
}

#[test]
fn non_finite_coordinate_is_reported_by_node_tag_and_file() {
    for bad in ["nan", "inf", "-inf"] {
        // node 50 (the 4th of the volume block) gets a non-finite y
        let text =
            format!("{HEADER}{TWO_TET4}").replace("1 1 1\n5 5 5", &format!("1 {bad} 1\n5 5 5"));
        let msg = expect_error(text.as_bytes());
        assert!(
            msg.contains("node 50 ") && msg.contains("non-finite"),
            "{bad}: {msg}"
        );
    }
}

#[test]
fn two_point_elements_of_a_group_on_one_node_are_an_error() {
    // a second point element (tag 2) of the dim-0 group "corner" on node 10
    let text = format!("{HEADER}{TWO_TET4}")
        .replace("4 5 1 105", "4 6 1 105")
        .replace("0 1 15 1\n1 10\n", "0 1 15 2\n1 10\n2 10\n")
        .replace("1 1 1 1\n2 10 20\n", "1 1 1 1\n3 10 20\n")
        .replace("2 1 2 1\n3 10 20 30\n", "2 1 2 1\n4 10 20 30\n");
    let msg = expect_error(text.as_bytes());
    assert!(
        msg.contains("node 10") && msg.contains("'corner'") && msg.contains("2 point elements"),
        "{msg}"
    );
}

#[test]
fn a_surface_group_of_other_than_triangles_is_an_error() {
    // The triangle of "bottom" (surface entity 1) replaced by a line element (gmsh type 1).
    let text = format!("{HEADER}{TWO_TET4}").replace("2 1 2 1\n3 10 20 30\n", "2 1 1 1\n3 10 20\n");
    let msg = expect_error(text.as_bytes());
    assert!(
        msg.contains("surface group 'bottom'")
            && msg.contains("gmsh type 1")
            && msg.contains("type 2"),
        "{msg}"
    );
}
