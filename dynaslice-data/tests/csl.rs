//! `.csl` reader: grammar, label → class mapping, manifests, every malformed-input error, and the
//! real upstream files from `../shared/data/csl` when present.

use std::path::Path;

use dynaslice_data::geometry::polygon::signed_area;
use dynaslice_data::{csl, ErrorKind, LabelTable};
use dynaslice_test_support::fixtures::{
    csl_file, shared_data, SQUARE_WITH_HOLE_PLANE, TRIANGLE_PLANE,
};

/// Two planes z = 0 and z = 1 (0x + 0y + 1z + D = 0): a square with a square hole (single-object
/// convention, hole labelled 2), then an empty plane.
fn square_with_hole() -> String {
    csl_file(2, &[SQUARE_WITH_HOLE_PLANE, "2 0 0 0 0 1 -1\n"])
}

fn parse(text: &str) -> dynaslice_data::Result<dynaslice_data::Sequence> {
    csl::parse(text, Path::new("test.csl"), &LabelTable::default())
}

#[test]
fn square_with_hole_single_object_convention() {
    let seq = parse(&square_with_hole()).unwrap();
    assert_eq!(seq.classes().len(), 1, "label 2 on a hole is not a class");
    assert_eq!(seq.classes()[0].label, 1);
    assert_eq!(seq.classes()[0].name, "label 1");
    let planes = &seq.frames()[0].planes;
    assert_eq!(planes.len(), 2);
    let a = planes[0].annotation(0).unwrap();
    assert_eq!(a.polygons.len(), 2);
    assert!(signed_area(&a.polygons[0]) > 0.0 && signed_area(&a.polygons[1]) < 0.0);
    assert!((signed_area(&a.polygons[0]) - 16.0).abs() < 1e-9);
    // The empty plane still annotates the class: it is absent there.
    assert!(planes[1].annotation(0).unwrap().is_absent());
    let n = planes[0].normal();
    assert!((n[2] - 1.0).abs() < 1e-12);
    // Plane coordinates map back to the file's world vertices.
    for p in &a.polygons[0] {
        let w = planes[0].to_world(*p);
        assert!(w[2].abs() < 1e-12 && (0.0..=4.0).contains(&w[0]));
    }
}

#[test]
fn multi_label_holes_carry_their_parents_label() {
    let hole_of_1 = SQUARE_WITH_HOLE_PLANE.replace("4h0 2 4 7 6 5", "4h0 1 4 7 6 5");
    let text = csl_file(2, &[hole_of_1.as_str(), TRIANGLE_PLANE]);
    let names = LabelTable::parse("7 liver\n").unwrap();
    let seq = csl::parse(&text, Path::new("m.csl"), &names).unwrap();
    let labels: Vec<i32> = seq.classes().iter().map(|c| c.label).collect();
    assert_eq!(labels, [1, 7]);
    assert_eq!(seq.classes()[1].name, "liver");
    let p0 = &seq.frames()[0].planes[0];
    assert_eq!(p0.annotation(0).unwrap().polygons.len(), 2);
    assert!(p0.annotation(1).unwrap().is_absent());
    assert_eq!(
        seq.frames()[0].planes[1]
            .annotation(1)
            .unwrap()
            .polygons
            .len(),
        1
    );
}

fn err(text: &str) -> String {
    let e = parse(text).expect_err("malformed input must be rejected");
    let msg = e.to_string();
    assert!(msg.starts_with("test.csl"), "message names the file: {msg}");
    msg
}

#[test]
fn malformed_inputs_name_file_line_plane_and_problem() {
    let m = err("CSLX\n1 1\n");
    assert!(m.contains("line 1") && m.contains("CSLC"), "{m}");
    let m = err(&square_with_hole().replace("4 1 0 1 2 3", "4 1 0 1 2"));
    assert!(
        m.contains("indices of component 0") && m.contains("says 4") && m.contains("plane 0"),
        "{m}"
    );
    let m = err(&square_with_hole().replace("1 8 2 0 0 1 0", "1 9 2 0 0 1 0"));
    assert!(m.contains("vertex 8") && m.contains("vertex count"), "{m}");
    let m = err(&square_with_hole().replace("2 2\n", "3 2\n"));
    assert!(m.contains("planes") && m.contains("says 3"), "{m}");
    let m = err(&format!("{}\n0 0 0\n", square_with_hole()));
    assert!(m.contains("after the last plane"), "{m}");
    let m = err(&square_with_hole().replace("4 4 0\n", "4 NaN 0\n"));
    assert!(m.contains("not finite") && m.contains("line 8"), "{m}");
    let m = err(&square_with_hole().replace("4 4 0\n", "4 4 0.5\n"));
    assert!(m.contains("off its plane") && m.contains("vertex 2"), "{m}");
    let m = err(&square_with_hole().replace("4h0 2", "4h0 5"));
    assert!(m.contains("hole labelled 5"), "{m}");
    let m = err(&square_with_hole().replace("4 1 0 1 2 3", "4 1 0 1 2 9"));
    assert!(m.contains("out of range"), "{m}");
    let m = err(&square_with_hole().replace("4h0 2", "4h1 2"));
    assert!(m.contains("parent"), "{m}");
    let m = err(&square_with_hole().replace("1 8 2 0 0 1 0", "1 8 2 0 0 0 0"));
    assert!(m.contains("normal") && m.contains("zero"), "{m}");
}

#[test]
fn geometry_errors_name_timestep_plane_class_polygon() {
    // Bow-tie: vertices 0 1 3 2 cross.
    let e = parse(&square_with_hole().replace("4 1 0 1 2 3", "4 1 0 1 3 2")).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::SelfIntersection(_)), "{e}");
    let m = e.to_string();
    assert!(
        m.contains("timestep 0")
            && m.contains("plane 0")
            && m.contains("class \"label 1\" (label 1)"),
        "{m}"
    );
    // Two vertices: degenerate.
    let e = parse(&square_with_hole().replace("4 1 0 1 2 3", "2 1 0 1")).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::Degenerate(_)) && e.to_string().contains("polygon 0"),
        "{e}"
    );
    // Hole outside its parent.
    let e = parse(
        &square_with_hole().replace("1 1 0\n3 1 0\n3 3 0\n1 3 0", "5 5 0\n6 5 0\n6 6 0\n5 6 0"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("lies outside it"), "{e}");
    // No contour at all.
    let e = parse(&csl_file(1, &["1 0 0 0 0 1 0\n"])).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::Empty(_)), "{e}");
}

#[test]
fn manifest_sequence_and_its_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("a.csl"), square_with_hole()).unwrap();
    std::fs::write(
        dir.path().join("b.csl"),
        square_with_hole().replace("4 4 0", "4 5 0"),
    )
    .unwrap();
    let manifest = dir.path().join("seq.txt");
    std::fs::write(&manifest, "# two phases\n0.0 a.csl\n\n0.25 b.csl\n").unwrap();
    let seq = csl::read_sequence(&manifest, &LabelTable::default()).unwrap();
    assert_eq!(seq.frames().len(), 2);
    assert_eq!(seq.time_range(), (0.0, 0.25));

    std::fs::write(&manifest, "0.5 a.csl\n0.25 b.csl\n").unwrap();
    let e = csl::read_sequence(&manifest, &LabelTable::default()).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::TimesNotIncreasing { .. }),
        "{e}"
    );
    assert!(e.to_string().contains("timestep 1"), "{e}");

    std::fs::write(
        dir.path().join("bad.csl"),
        square_with_hole().replace("4 1 0 1 2 3", "4 1 0 1 3 2"),
    )
    .unwrap();
    std::fs::write(&manifest, "0 a.csl\n1 bad.csl\n").unwrap();
    let e = csl::read_sequence(&manifest, &LabelTable::default()).unwrap_err();
    assert!(
        e.to_string().contains("bad.csl") && e.to_string().contains("timestep 1"),
        "{e}"
    );

    std::fs::write(&manifest, "0 a.csl\nzero b.csl\n").unwrap();
    let e = csl::read_sequence(&manifest, &LabelTable::default()).unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
    std::fs::write(&manifest, "# nothing\n").unwrap();
    assert!(csl::read_sequence(&manifest, &LabelTable::default()).is_err());
    std::fs::write(&manifest, "0 missing.csl\n").unwrap();
    let e = csl::read_sequence(&manifest, &LabelTable::default()).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::Io(_)) && e.to_string().contains("missing.csl"),
        "{e}"
    );
}

#[test]
fn reads_every_upstream_file() {
    let Some(dir) = shared_data("csl") else {
        return;
    };
    let names = LabelTable::default();
    let expect = [
        ("Heart-simplified.csl", 2, 1),
        ("SideBishop.csl", 10, 1),
        ("balloondog.csl", 15, 1),
        ("eight_15.csl", 15, 1),
        ("hand_ok.csl", 15, 1),
        ("Abdomen.csl", 42, 9),
    ];
    for (file, planes, classes) in expect {
        let seq = csl::read(&dir.join(file), &names).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(seq.frames()[0].planes.len(), planes, "{file}");
        assert_eq!(seq.classes().len(), classes, "{file}");
    }
    // balloondog has the one upstream hole (label 2 under label 1).
    let dog = csl::read(&dir.join("balloondog.csl"), &names).unwrap();
    let holes = dog.frames()[0]
        .planes
        .iter()
        .flat_map(|p| &p.annotations[0].polygons)
        .filter(|p| signed_area(p) < 0.0)
        .count();
    assert_eq!(holes, 1);
}
