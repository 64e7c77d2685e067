//! Tests of the VTU writer: files are parsed back with a small reader written here.

use super::*;
use crate::base64;

/// gmsh TET10 edges (nodes 4..9), from the gmsh documentation.
const GMSH_EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (0, 2), (0, 3), (2, 3), (1, 3)];
/// VTK_QUADRATIC_TETRA edges (nodes 4..9), from the VTK documentation (vtkQuadraticTetra).
const VTK_EDGES: [(usize, usize); 6] = [(0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3)];

/// Two TET10 sharing a face, gmsh order, with each edge node at the midpoint of its gmsh edge.
fn two_tet10() -> (Vec<[f64; 3]>, Vec<usize>) {
    let mut points = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
    ];
    let mut conn = Vec::new();
    let mut edge_nodes: Vec<((usize, usize), usize)> = Vec::new();
    for verts in [[0usize, 1, 2, 3], [1, 2, 3, 4]] {
        let mut cell: Vec<usize> = verts.to_vec();
        for (a, b) in GMSH_EDGES {
            let key = (verts[a].min(verts[b]), verts[a].max(verts[b]));
            let id = match edge_nodes.iter().find(|(k, _)| *k == key) {
                Some(&(_, id)) => id,
                None => {
                    let (p, q) = (points[key.0], points[key.1]);
                    points.push([
                        0.5 * (p[0] + q[0]),
                        0.5 * (p[1] + q[1]),
                        0.5 * (p[2] + q[2]),
                    ]);
                    edge_nodes.push((key, points.len() - 1));
                    points.len() - 1
                }
            };
            cell.push(id);
        }
        conn.extend(cell);
    }
    (points, conn)
}

/// The text of the DataArray named `name` and its `format` attribute.
fn data_array<'a>(doc: &'a str, name: &str) -> (&'a str, &'a str) {
    let key = format!("Name=\"{name}\"");
    let start = doc
        .find(&key)
        .unwrap_or_else(|| panic!("no DataArray {name}"));
    let open_end = start + doc[start..].find('>').expect("end of tag");
    let tag = &doc[..open_end];
    let tag = &tag[tag.rfind('<').expect("tag start")..];
    let fmt_at = tag.find("format=\"").expect("format attribute") + 8;
    let format = &tag[fmt_at..fmt_at + tag[fmt_at..].find('"').expect("quote")];
    let body_end = open_end + doc[open_end..].find("</DataArray>").expect("closing tag");
    (format, doc[open_end + 1..body_end].trim())
}

/// Decodes a binary (base64, UInt64 header) array into little-endian chunks of `size` bytes.
fn decode_binary(body: &str, size: usize) -> Vec<Vec<u8>> {
    let raw = base64::decode(body).expect("valid base64");
    let n = u64::from_le_bytes(raw[..8].try_into().expect("8-byte header")) as usize;
    assert_eq!(raw.len(), 8 + n, "header byte count must match the data");
    assert_eq!(n % size, 0);
    raw[8..].chunks(size).map(|c| c.to_vec()).collect()
}

fn read_i64(doc: &str, name: &str) -> Vec<i64> {
    match data_array(doc, name) {
        ("binary", body) => decode_binary(body, 8)
            .iter()
            .map(|c| i64::from_le_bytes(c[..].try_into().expect("8 bytes")))
            .collect(),
        ("ascii", body) => body
            .split_whitespace()
            .map(|t| t.parse().expect("integer"))
            .collect(),
        (f, _) => panic!("unexpected format {f}"),
    }
}

fn read_f64(doc: &str, name: &str) -> Vec<f64> {
    match data_array(doc, name) {
        ("binary", body) => decode_binary(body, 8)
            .iter()
            .map(|c| f64::from_le_bytes(c[..].try_into().expect("8 bytes")))
            .collect(),
        ("ascii", body) => body
            .split_whitespace()
            .map(|t| t.parse().expect("number"))
            .collect(),
        (f, _) => panic!("unexpected format {f}"),
    }
}

fn read_u8(doc: &str, name: &str) -> Vec<u8> {
    match data_array(doc, name) {
        ("binary", body) => decode_binary(body, 1).iter().map(|c| c[0]).collect(),
        ("ascii", body) => body
            .split_whitespace()
            .map(|t| t.parse().expect("u8"))
            .collect(),
        (f, _) => panic!("unexpected format {f}"),
    }
}

#[test]
fn tet10_written_in_vtk_node_order_both_encodings() {
    let (points, conn) = two_tet10();
    let disp: Vec<f64> = points
        .iter()
        .flat_map(|p| [p[0] * 1e-3, -p[1], std::f64::consts::PI * p[2]])
        .collect();
    let gap: Vec<f64> = points.iter().map(|p| p[0] - 0.1 * p[2]).collect();
    let cell_id = [7.0, -3.25];
    let mesh = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 10,
    };
    let dir = tempfile::tempdir().expect("tempdir");
    for encoding in [VtuEncoding::Base64, VtuEncoding::Ascii] {
        let path = dir.path().join(format!("tet10_{encoding:?}.vtu"));
        write_vtu_with(
            &path,
            &mesh,
            &[
                Field::vector("displacement", &disp),
                Field::scalar("gap", &gap),
            ],
            &[Field::scalar("cell_id", &cell_id)],
            encoding,
        )
        .expect("write vtu");
        let doc = std::fs::read_to_string(&path).expect("read back");
        assert!(doc.contains("NumberOfPoints=\"14\" NumberOfCells=\"2\""));

        let written = read_i64(&doc, "connectivity");
        assert_eq!(written.len(), 20);
        for c in 0..2 {
            let g = &conn[10 * c..10 * c + 10];
            let w: Vec<usize> = written[10 * c..10 * c + 10]
                .iter()
                .map(|&i| i as usize)
                .collect();
            // Same nodes with 8 and 9 exchanged ...
            let mut expected = g.to_vec();
            expected.swap(8, 9);
            assert_eq!(w, expected, "cell {c}");
            // ... which is what VTK's edge table asks for: edge node k sits at the midpoint of
            // VTK edge k (an independent check of the swap against geometry).
            for (k, (a, b)) in VTK_EDGES.iter().enumerate() {
                let (pa, pb, pm) = (points[w[*a]], points[w[*b]], points[w[4 + k]]);
                for d in 0..3 {
                    assert_eq!(pm[d], 0.5 * (pa[d] + pb[d]), "cell {c} edge node {}", 4 + k);
                }
            }
        }
        assert_eq!(read_i64(&doc, "offsets"), vec![10, 20]);
        assert_eq!(read_u8(&doc, "types"), vec![VTK_QUADRATIC_TETRA; 2]);
        let coords = read_f64(&doc, "Points");
        let flat: Vec<f64> = points.iter().flatten().copied().collect();
        // Both encodings are exact (binary copies bits; ASCII uses round-trip formatting).
        assert_eq!(coords, flat);
        assert_eq!(read_f64(&doc, "displacement"), disp);
        assert_eq!(read_f64(&doc, "gap"), gap);
        assert_eq!(read_f64(&doc, "cell_id"), cell_id.to_vec());
        assert!(doc.contains("<PointData Scalars=\"gap\" Vectors=\"displacement\">"));
    }
}

#[test]
fn tet4_has_vtk_tetra_type_and_unchanged_order() {
    let points = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
    ];
    let conn = [0, 1, 2, 3, 1, 2, 3, 4];
    let mesh = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 4,
    };
    let doc =
        vtu_document(Path::new("t.vtu"), &mesh, &[], &[], VtuEncoding::Base64).expect("document");
    assert_eq!(read_i64(&doc, "connectivity"), vec![0, 1, 2, 3, 1, 2, 3, 4]);
    assert_eq!(read_i64(&doc, "offsets"), vec![4, 8]);
    assert_eq!(read_u8(&doc, "types"), vec![VTK_TETRA; 2]);
    assert!(!doc.contains("<PointData"));
}

#[test]
fn bad_input_is_refused_and_nothing_is_written() {
    let (points, conn) = two_tet10();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("bad.vtu");
    let good = vec![0.0; points.len()];
    let mut nan = good.clone();
    nan[5] = f64::NAN;
    let short = vec![0.0; 3];
    let mut bad_conn = conn.clone();
    bad_conn[3] = 99;
    let mut bad_points = points.clone();
    bad_points[2][1] = f64::INFINITY;

    let mesh = |p: &'static str| -> (usize, Vec<usize>) {
        match p {
            "npc" => (8, conn.clone()),
            "len" => (10, conn[..15].to_vec()),
            _ => (10, bad_conn.clone()),
        }
    };
    for case in ["npc", "len", "index"] {
        let (npc, c) = mesh(case);
        let m = VtuMesh {
            points: &points,
            connectivity: &c,
            nodes_per_cell: npc,
        };
        let err = write_vtu(&path, &m, &[]).expect_err(case);
        assert!(err.to_string().contains("bad.vtu"), "{err}");
    }
    let m = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 10,
    };
    let cases: Vec<(Vec<Field>, &str)> = vec![
        (vec![Field::scalar("gap", &nan)], "non-finite"),
        (
            vec![Field::scalar("gap", &short)],
            "expected 1 components x 14 points",
        ),
        (
            vec![Field::vector("u", &good)],
            "expected 3 components x 14 points",
        ),
        (vec![Field::scalar("", &good)], "empty name"),
        (
            vec![Field::scalar("g", &good), Field::scalar("g", &good)],
            "duplicate",
        ),
        (
            vec![Field {
                components: 0,
                ..Field::scalar("z", &[])
            }],
            "0 components",
        ),
    ];
    for (fields, needle) in cases {
        let err = write_vtu(&path, &m, &fields).expect_err(needle);
        let msg = err.to_string();
        assert!(msg.contains(needle) && msg.contains("bad.vtu"), "{msg}");
    }
    let m = VtuMesh {
        points: &bad_points,
        connectivity: &conn,
        nodes_per_cell: 10,
    };
    let err = write_vtu(&path, &m, &[]).expect_err("infinite coordinate");
    assert!(
        matches!(err, OutputError::NonFinite { index: 7, .. }),
        "{err:?}"
    );
    assert!(!path.exists());
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
}

#[test]
fn names_are_xml_escaped() {
    let points = [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let conn = [0, 1, 2, 3];
    let s = [1.0, 2.0, 3.0, 4.0];
    let mesh = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 4,
    };
    let doc = vtu_document(
        Path::new("e.vtu"),
        &mesh,
        &[Field::scalar("a<b & \"c\"", &s)],
        &[],
        VtuEncoding::Ascii,
    )
    .expect("document");
    assert!(doc.contains("Name=\"a&lt;b &amp; &quot;c&quot;\""));
    assert_eq!(read_f64(&doc, "a&lt;b &amp; &quot;c&quot;"), s.to_vec());
}

/// Decodes a zlib-compressed binary array (vtkZLibDataCompressor layout, UInt64 header): the
/// header's base64 stream, then the blocks' base64 stream, each block inflated with flate2.
fn decode_zlib(body: &str) -> Vec<u8> {
    // The header has 3 + blocks UInt64 values; its base64 length is that of 8 (3 + b) bytes.
    let first = base64::decode(&body[..32]).expect("header start");
    let blocks = u64::from_le_bytes(first[..8].try_into().expect("8 bytes")) as usize;
    let header_len = (8 * (3 + blocks)).div_ceil(3) * 4;
    let header = base64::decode(&body[..header_len]).expect("header");
    let word = |i: usize| u64::from_le_bytes(header[8 * i..8 * i + 8].try_into().expect("8"));
    let (block_size, last) = (word(1) as usize, word(2) as usize);
    let data = base64::decode(&body[header_len..]).expect("blocks");
    let mut out = Vec::new();
    let mut at = 0;
    for b in 0..blocks {
        let size = word(3 + b) as usize;
        let mut inflated = Vec::new();
        std::io::Read::read_to_end(
            &mut flate2::read::ZlibDecoder::new(&data[at..at + size]),
            &mut inflated,
        )
        .expect("zlib block");
        let expected = if b + 1 == blocks && last > 0 {
            last
        } else {
            block_size
        };
        assert_eq!(inflated.len(), expected, "block {b}");
        out.extend(inflated);
        at += size;
    }
    assert_eq!(
        at,
        data.len(),
        "compressed sizes in the header must cover the data"
    );
    out
}

#[test]
fn zlib_float32_frames_decode_to_the_values_written() {
    let (points, conn) = two_tet10();
    let disp: Vec<f64> = points
        .iter()
        .flat_map(|p| [p[0] * 1e-3, -p[1], 0.1 + p[2]])
        .collect();
    let mut gap = vec![f64::NAN; points.len()];
    gap[3] = -2.5e-4;
    gap[7] = 1.5e-10;
    let mesh = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 10,
    };
    let target = Path::new("frame.vtu");
    let writer = VtuWriter::new(target, &mesh, VtuEncoding::Zlib, Precision::F32).expect("mesh");
    let doc = writer
        .document(
            target,
            &[
                Field::vector("displacement_m", &disp).f32(),
                Field::scalar("radial_gap_m", &gap).f32().partial(),
            ],
            &[],
        )
        .expect("document");
    assert!(doc.contains("compressor=\"vtkZLibDataCompressor\""));
    let (format, body) = data_array(&doc, "connectivity");
    assert_eq!(format, "binary");
    assert!(doc.contains("type=\"Int32\" Name=\"connectivity\""));
    let c: Vec<i32> = decode_zlib(body)
        .chunks(4)
        .map(|b| i32::from_le_bytes(b.try_into().expect("4")))
        .collect();
    let mut expected: Vec<i32> = conn.iter().map(|&n| n as i32).collect();
    expected.swap(8, 9);
    expected.swap(18, 19);
    assert_eq!(c, expected);
    let f32s = |name: &str| -> Vec<f32> {
        assert!(doc.contains(&format!("type=\"Float32\" Name=\"{name}\"")));
        decode_zlib(data_array(&doc, name).1)
            .chunks(4)
            .map(|b| f32::from_le_bytes(b.try_into().expect("4")))
            .collect()
    };
    let flat: Vec<f32> = points.iter().flatten().map(|&x| x as f32).collect();
    assert_eq!(f32s("Points"), flat);
    let d: Vec<f32> = disp.iter().map(|&x| x as f32).collect();
    assert_eq!(f32s("displacement_m"), d);
    let g = f32s("radial_gap_m");
    for (i, v) in g.iter().enumerate() {
        match i {
            3 => assert_eq!(*v, -2.5e-4f32),
            7 => assert_eq!(*v, 1.5e-10f32),
            _ => assert!(v.is_nan(), "point {i}: {v}"),
        }
    }
    // A field not marked partial refuses NaN; a partial one still refuses infinities.
    let err = writer
        .document(target, &[Field::scalar("g", &gap)], &[])
        .expect_err("NaN in a complete field");
    assert!(err.to_string().contains("`g`"), "{err}");
    let mut inf = gap.clone();
    inf[0] = f64::INFINITY;
    writer
        .document(target, &[Field::scalar("g", &inf).partial()], &[])
        .expect_err("infinity in a partial field");
}

#[test]
fn zlib_blocks_split_large_arrays() {
    // More than one block: 2.5 blocks of Float64 values.
    let n = (5 * ZLIB_BLOCK_SIZE / 2) / 8;
    let values: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
    let mut s = String::new();
    push_zlib(&mut s, &Values::F64(&values).to_le_bytes());
    let back: Vec<f64> = decode_zlib(&s)
        .chunks(8)
        .map(|b| f64::from_le_bytes(b.try_into().expect("8")))
        .collect();
    assert_eq!(back, values);
}
