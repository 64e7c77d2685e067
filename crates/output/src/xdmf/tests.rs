use super::*;

/// Two TET4 cells sharing a face.
fn mesh() -> (Vec<[f64; 3]>, Vec<usize>) {
    let points = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 1.0, 1.0],
    ];
    (points, vec![0, 1, 2, 3, 1, 2, 3, 4])
}

fn read_f32(file: &hdf5_metno::File, path: &str) -> Vec<f32> {
    file.dataset(path).unwrap().read_raw::<f32>().unwrap()
}

#[test]
fn identical_arrays_are_stored_once_and_the_xml_points_to_them() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("series.xdmf");
    let (points, conn) = mesh();
    let m = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 4,
    };
    let u: Vec<Vec<f64>> = (0..3).map(|k| vec![0.1 * (k % 2) as f64; 15]).collect();
    let flag = [1.0, 0.0, 0.0, 0.0, 1.0];
    let gap = [-1e-4, f64::NAN, f64::NAN, f64::NAN, 0.0];
    let frames: Vec<XdmfFrame> = (0..3)
        .map(|k| XdmfFrame {
            time: 0.25 * k as f64,
            fields: vec![
                Field::vector("displacement_m", &u[k]).f32(),
                Field::scalar("gap_m", &gap).f32().partial(),
                Field::scalar("flag", &flag).f32(),
            ],
        })
        .collect();
    let w = write_xdmf_series(&path, &m, Precision::F32, &frames, "times in s").unwrap();
    // Frames 0 and 2 have the same displacement; gap and flag never change: 2 + 1 + 1.
    assert_eq!(w.field_datasets, 4);
    assert_eq!(w.field_arrays, 9);
    let xml = std::fs::read_to_string(&path).unwrap();
    assert!(xml.starts_with("<?xml version=\"1.0\"?>\n<!-- times in s -->\n<Xdmf Version=\"3.0\">"));
    assert_eq!(xml.matches("<Time Value=").count(), 3);
    assert!(xml.contains("<Time Value=\"0.5\"/>"));
    assert_eq!(
        xml.matches("series.h5:/fields/displacement_m/000").count(),
        2,
        "{xml}"
    );
    assert_eq!(
        xml.matches("series.h5:/fields/displacement_m/001").count(),
        1
    );
    assert_eq!(xml.matches("TopologyType=\"Tetrahedron\"").count(), 3);
    let h = hdf5_metno::File::open(dir.path().join("series.h5")).unwrap();
    assert_eq!(read_f32(&h, "/fields/displacement_m/001")[0], 0.1_f32);
    assert!(read_f32(&h, "/fields/gap_m/000")[1].is_nan());
    assert_eq!(
        h.dataset("/fields/displacement_m/000").unwrap().shape(),
        vec![5, 3]
    );
    assert_eq!(h.dataset("/fields/flag/000").unwrap().shape(), vec![5]);
    let c = h.dataset("/mesh/connectivity").unwrap();
    assert_eq!(c.shape(), vec![2, 4]);
    assert_eq!(c.read_raw::<i32>().unwrap(), vec![0, 1, 2, 3, 1, 2, 3, 4]);
    // No temporary file left.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

#[test]
fn tet10_edge_nodes_are_written_in_vtk_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("q.xdmf");
    let points: Vec<[f64; 3]> = (0..10).map(|i| [i as f64, 0.0, 0.0]).collect();
    let conn: Vec<usize> = (0..10).collect();
    let m = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 10,
    };
    let u = vec![0.0; 30];
    let frames = [XdmfFrame {
        time: 0.0,
        fields: vec![Field::vector("u", &u)],
    }];
    write_xdmf_series(&path, &m, Precision::F64, &frames, "").unwrap();
    let h = hdf5_metno::File::open(dir.path().join("q.h5")).unwrap();
    let c = h
        .dataset("/mesh/connectivity")
        .unwrap()
        .read_raw::<i32>()
        .unwrap();
    assert_eq!(c, vec![0, 1, 2, 3, 4, 5, 6, 7, 9, 8]);
    let xml = std::fs::read_to_string(&path).unwrap();
    assert!(xml.contains("TopologyType=\"Tetrahedron_10\""));
    assert!(xml.contains("NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">q.h5:/fields/u/000"));
}

#[test]
fn bad_frames_are_refused_without_writing() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.xdmf");
    let (points, conn) = mesh();
    let m = VtuMesh {
        points: &points,
        connectivity: &conn,
        nodes_per_cell: 4,
    };
    let short = vec![0.0; 4];
    let ok = vec![0.0; 5];
    let nan = vec![f64::NAN; 5];
    for (frames, expected) in [
        (vec![], "no frame"),
        (
            vec![XdmfFrame {
                time: 0.0,
                fields: vec![Field::scalar("a", &short)],
            }],
            "4 values",
        ),
        (
            vec![XdmfFrame {
                time: f64::NAN,
                fields: vec![Field::scalar("a", &ok)],
            }],
            "time of frame 0",
        ),
        (
            vec![XdmfFrame {
                time: 0.0,
                fields: vec![Field::scalar("a", &nan)],
            }],
            "non-finite",
        ),
        (
            vec![
                XdmfFrame {
                    time: 0.0,
                    fields: vec![Field::scalar("a", &ok)],
                },
                XdmfFrame {
                    time: 1.0,
                    fields: vec![Field::scalar("b", &ok)],
                },
            ],
            "every frame needs",
        ),
    ] {
        let e = write_xdmf_series(&path, &m, Precision::F32, &frames, "").unwrap_err();
        assert!(e.to_string().contains(expected), "{e}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}
