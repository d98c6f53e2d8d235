//! `.csl` reader: grammar, label → class mapping, manifests, every malformed-input error, and the
//! real upstream files from `../shared/data/csl` when present.

use std::path::Path;

use dynaslice_data::input::{self, InputOptions};
use dynaslice_data::{csl, ErrorKind, LabelTable};
use dynaslice_geometry::polygon::signed_area;
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
    // A triangle traced twice: its even-odd region is empty, so there is nothing to repair it
    // into (a bow-tie, once refused here, is now repaired: see `self_crossing_ring_*`).
    let twice = csl_file(
        2,
        &[
            SQUARE_WITH_HOLE_PLANE,
            &TRIANGLE_PLANE.replace("3 7 0 1 2", "6 7 0 1 2 0 1 2"),
        ],
    );
    let e = parse(&twice).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::SelfIntersection(_)), "{e}");
    let m = e.to_string();
    assert!(
        m.contains("timestep 0")
            && m.contains("plane 1")
            && m.contains("class \"label 7\" (label 7)"),
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
    let manifest = dir.path().join("seq.cslseq");
    let read = |text: &str| {
        std::fs::write(&manifest, text).unwrap();
        input::read(std::slice::from_ref(&manifest), &InputOptions::default())
    };
    let seq = read("# two phases\n0.0 a.csl\n\n0.25 b.csl\n").unwrap();
    assert_eq!(seq.frames().len(), 2);
    assert_eq!(seq.time_range(), (0.0, 0.25));

    let e = read("0.5 a.csl\n0.25 b.csl\n").unwrap_err();
    assert!(
        e.to_string().contains("earlier than the previous entry"),
        "{e}"
    );

    std::fs::write(
        dir.path().join("bad.csl"),
        square_with_hole().replace("4 1 0 1 2 3", "2 1 0 1"),
    )
    .unwrap();
    let e = read("0 a.csl\n1 bad.csl\n").unwrap_err();
    assert!(e.to_string().contains("bad.csl"), "{e}");

    let e = read("0 a.csl\nzero b.csl\n").unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
    assert!(read("# nothing\n").is_err());
    // An entry that cannot be opened is the manifest line's mistake: both are named.
    let e = read("0 missing.csl\n").unwrap_err().to_string();
    assert!(
        e.contains("seq.cslseq, line 1") && e.contains("missing.csl") && e.contains("i/o error"),
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

// ---- Repairs: real files disagree on conventions and hand-drawn contours touch themselves. ----

/// Warnings logged by the current thread (`log` has one global logger; tests run in threads).
mod warnings {
    use std::sync::{Mutex, Once};
    use std::thread::ThreadId;

    static RECORDS: Mutex<Vec<(ThreadId, String)>> = Mutex::new(Vec::new());
    static INSTALL: Once = Once::new();

    struct Capture;

    impl log::Log for Capture {
        fn enabled(&self, m: &log::Metadata) -> bool {
            m.level() <= log::Level::Warn
        }
        fn log(&self, r: &log::Record) {
            if self.enabled(r.metadata()) {
                let id = std::thread::current().id();
                RECORDS.lock().unwrap().push((id, r.args().to_string()));
            }
        }
        fn flush(&self) {}
    }

    /// Runs `f` and returns what it warned.
    pub fn during<T>(f: impl FnOnce() -> T) -> (T, Vec<String>) {
        INSTALL.call_once(|| {
            log::set_logger(&Capture).unwrap();
            log::set_max_level(log::LevelFilter::Warn);
        });
        let id = std::thread::current().id();
        RECORDS.lock().unwrap().retain(|(t, _)| *t != id);
        let out = f();
        let mine = RECORDS
            .lock()
            .unwrap()
            .iter()
            .filter(|(t, _)| *t == id)
            .map(|(_, m)| m.clone())
            .collect();
        (out, mine)
    }
}

/// One plane z = 0 (stated `0 0 1 0`) with the given `x y` vertices and component lines.
fn flat_plane(vertices: &[[f64; 2]], components: &[&str]) -> String {
    let v: String = vertices
        .iter()
        .map(|p| format!("{} {} 0\n", p[0], p[1]))
        .collect();
    let c: String = components.iter().map(|c| format!("{c}\n")).collect();
    format!("1 {} {} 0 0 1 0\n{v}{c}", vertices.len(), components.len())
}

/// The even-odd area of class 0 on plane 0 (Sequence::new has oriented the rings by nesting).
fn area_of(seq: &dynaslice_data::Sequence) -> (usize, f64) {
    let polys = &seq.frames()[0].planes[0].annotation(0).unwrap().polygons;
    (polys.len(), polys.iter().map(|p| signed_area(p)).sum())
}

#[test]
fn figure_eight_through_one_vertex_is_split_into_its_two_lobes() {
    // Vertex 1 at (1, 1) is used twice and the ring crosses itself there: an "8".
    let v = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.0, 2.0], [2.0, 0.0]];
    let text = csl_file(1, &[flat_plane(&v, &["6 1 0 1 2 3 1 4"])]);
    let (seq, warned) = warnings::during(|| parse(&text));
    let seq = seq.unwrap();
    let (count, area) = area_of(&seq);
    assert_eq!(count, 2, "two triangular lobes");
    // Each lobe has area 1; the validator then cuts the shared corner by a hair.
    assert!((area - 2.0).abs() < 1e-2, "{area}");
    assert_eq!(warned.len(), 1, "{warned:?}");
    let w = &warned[0];
    assert!(
        w.contains("test.csl, plane 0, label 1: component 0 crosses or touches itself")
            && w.contains("even-odd")
            && w.contains("2 simple rings (from 1)"),
        "{w}"
    );
}

#[test]
fn ring_touching_itself_without_crossing_still_reads_as_a_pinch() {
    // Two squares drawn as one ring through their common corner (1, 1) without crossing: the
    // validator separates the pinch itself, no even-odd repair (and no warning) is needed.
    let v = [
        [0.0, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
        [2.0, 1.0],
        [2.0, 2.0],
        [1.0, 2.0],
        [0.0, 1.0],
    ];
    let text = csl_file(1, &[flat_plane(&v, &["8 1 0 1 2 3 4 5 2 6"])]);
    let (seq, warned) = warnings::during(|| parse(&text));
    let (count, area) = area_of(&seq.unwrap());
    assert_eq!(count, 1);
    assert!((area - 2.0).abs() < 1e-2, "{area}");
    assert!(warned.is_empty(), "{warned:?}");
}

#[test]
fn self_crossing_ring_becomes_simple_rings_by_the_even_odd_rule() {
    // A bow-tie: edges 0 and 2 cross at (1, 1), a point that is no vertex.
    let v = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]];
    let text = csl_file(1, &[flat_plane(&v, &["4 1 0 1 2 3"])]);
    let (seq, warned) = warnings::during(|| parse(&text));
    let (count, area) = area_of(&seq.unwrap());
    assert_eq!(count, 2);
    assert!((area - 2.0).abs() < 1e-2, "{area}");
    assert!(
        warned.len() == 1 && warned[0].contains("component 0 crosses"),
        "{warned:?}"
    );

    // A ring that loops twice around the centre (a pentagram): even-odd leaves the five points
    // and makes the pentagon in the middle a hole.
    let star: Vec<[f64; 2]> = (0..5)
        .map(|k| {
            let a = std::f64::consts::FRAC_PI_2 + k as f64 * 4.0 * std::f64::consts::PI / 5.0;
            [a.cos(), a.sin()]
        })
        .collect();
    let text = csl_file(1, &[flat_plane(&star, &["5 1 0 1 2 3 4"])]);
    let (seq, _) = warnings::during(|| parse(&text));
    let (count, area) = area_of(&seq.unwrap());
    // Five triangles around a pentagon: the star's outline (a decagon with radii 1 and r)
    // minus its core (a pentagon of radius r), r = cos 72° / cos 36°.
    let (d36, d72) = (36f64.to_radians(), 72f64.to_radians());
    let r = d72.cos() / d36.cos();
    let points = 5.0 * r * d36.sin() - 2.5 * r * r * d72.sin();
    assert_eq!(count, 5);
    assert!((area - points).abs() < 1e-2, "{area} vs {points}");
}

#[test]
fn crossing_components_of_one_class_read_even_odd() {
    // Two overlapping 2×2 squares of label 1: the overlap (1×1) is inside both, so outside.
    let v = [
        [0.0, 0.0],
        [2.0, 0.0],
        [2.0, 2.0],
        [0.0, 2.0],
        [1.0, 1.0],
        [3.0, 1.0],
        [3.0, 3.0],
        [1.0, 3.0],
    ];
    let text = csl_file(1, &[flat_plane(&v, &["4 1 0 1 2 3", "4 1 4 5 6 7"])]);
    let (seq, warned) = warnings::during(|| parse(&text));
    let (_, area) = area_of(&seq.unwrap());
    assert!((area - 6.0).abs() < 1e-2, "{area}");
    assert!(
        warned.len() == 1 && warned[0].contains("components 0, 1 cross or touch each other"),
        "{warned:?}"
    );
    // Components of different classes may overlap: nothing to repair.
    let text = csl_file(2, &[flat_plane(&v, &["4 1 0 1 2 3", "4 3 4 5 6 7"])]);
    let (seq, warned) = warnings::during(|| parse(&text));
    assert!((area_of(&seq.unwrap()).1 - 4.0).abs() < 1e-12);
    assert!(warned.is_empty(), "{warned:?}");
}

#[test]
fn mirrored_plane_equation_is_read_with_the_other_sign_convention() {
    // Vertices at z = 2, plane written `0 0 1 2`: Ax+By+Cz+D = 0 says z = -2, Ax+By+Cz = D
    // says z = 2 (upstream rose.csl is written this way).
    // Every line ending in ` 0` is a vertex of plane 0 (z → 2) or its header (D → 2).
    let text = square_with_hole().replace(" 0\n", " 2\n");
    assert!(text.contains("1 8 2 0 0 1 2\n"), "{text}");
    let (seq, warned) = warnings::during(|| parse(&text));
    let seq = seq.unwrap();
    let p = &seq.frames()[0].planes[0];
    assert!((p.origin[2] - 2.0).abs() < 1e-12 && (p.normal()[2] - 1.0).abs() < 1e-12);
    let a = &p.annotation(0).unwrap().polygons;
    assert!((a.iter().map(|q| signed_area(q)).sum::<f64>() - 12.0).abs() < 1e-9);
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].starts_with("test.csl, plane 0: ") && warned[0].contains("Ax + By + Cz = D"),
        "{}",
        warned[0]
    );
}

#[test]
fn plane_slightly_off_its_coplanar_vertices_is_fitted_to_them() {
    // Vertices on z = 0.001 + 0.0002 x (coplanar, up to 1.8e-3 off the stated z = 0, which is
    // far more than the 1e-6 × diagonal tolerance).
    let z = |x: f64| 0.001 + 0.0002 * x;
    let v: String = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]]
        .iter()
        .map(|p: &[f64; 2]| format!("{} {} {}\n", p[0], p[1], z(p[0])))
        .collect();
    let text = csl_file(1, &[format!("1 4 1 0 0 1 0\n{v}4 1 0 1 2 3\n")]);
    let (seq, warned) = warnings::during(|| parse(&text));
    let seq = seq.unwrap();
    let p = &seq.frames()[0].planes[0];
    for q in &p.annotation(0).unwrap().polygons[0] {
        let w = p.to_world(*q);
        assert!(
            (w[2] - z(w[0])).abs() < 1e-12,
            "{w:?} is off the vertices' plane"
        );
    }
    assert!(p.normal()[2] > 0.99, "oriented like the stated normal");
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].starts_with("test.csl, plane 0: ")
            && warned[0].contains("up to 1.800e-3 off the stated plane")
            && warned[0].contains("fitted the plane"),
        "{}",
        warned[0]
    );
    // One vertex 1.06e-3 off a plane its seven companions lie on exactly (upstream Horsers.csl
    // has such a vertex): within 1e-3 × the extent of the best-fit plane, so fitted.
    let text = square_with_hole().replace("4 4 0\n", "4 4 0.00106\n");
    let (seq, warned) = warnings::during(|| parse(&text));
    assert!(seq.is_ok() && warned.len() == 1, "{warned:?}");
    assert!(warned[0].contains("up to 1.060e-3 off"), "{}", warned[0]);
}

#[test]
fn non_coplanar_vertices_are_refused_naming_file_and_plane() {
    // One corner of the square 0.05 above the others: no plane is within 1e-3 × the plane's
    // 5.66 extent of all eight vertices.
    let text = square_with_hole().replace("4 4 0\n", "4 4 0.05\n");
    let e = parse(&text).unwrap_err();
    assert!(
        matches!(e.kind, ErrorKind::OffPlane { vertex: 2, .. }),
        "{e}"
    );
    let m = e.to_string();
    assert!(m.starts_with("test.csl") && m.contains("plane 0"), "{m}");
    // Collinear vertices leave the plane undetermined: refused too.
    let text = csl_file(1, &["1 3 1 0 0 1 0\n0 0 1\n1 0 1\n2 0 1\n3 1 0 1 2\n"]);
    let e = parse(&text).unwrap_err();
    assert!(matches!(e.kind, ErrorKind::OffPlane { .. }), "{e}");
}
