//! Sequence validation: one test per kind of malformed input, the pinch repair, canonical form.

use dynaslice_data::{Annotation, ClassInfo, DataError, ErrorKind, Frame, Plane, Rect, Sequence};
use dynaslice_geometry::polygon::signed_area;

fn square(x: f64, y: f64, s: f64) -> Vec<[f64; 2]> {
    vec![[x, y], [x + s, y], [x + s, y + s], [x, y + s]]
}

fn class(name: &str, label: i32) -> ClassInfo {
    ClassInfo {
        name: name.into(),
        label,
        color: None,
    }
}

fn plane(polys: Vec<Vec<[f64; 2]>>) -> Plane {
    Plane {
        origin: [0.0; 3],
        u: [1.0, 0.0, 0.0],
        v: [0.0, 1.0, 0.0],
        roi: Rect {
            min: [-10.0, -10.0],
            max: [10.0, 10.0],
        },
        annotations: vec![Annotation {
            class: 0,
            polygons: polys,
        }],
    }
}

fn one(p: Plane) -> Result<Sequence, DataError> {
    Sequence::new(
        vec![class("a", 1)],
        vec![Frame {
            time: 0.0,
            planes: vec![p],
        }],
    )
}

fn kind_of(r: Result<Sequence, DataError>) -> (ErrorKind, String) {
    let e = r.expect_err("must be rejected");
    let m = e.to_string();
    (e.kind, m)
}

#[test]
fn canonical_form_and_idempotence() {
    let mut outer = square(0.0, 0.0, 4.0);
    outer.reverse();
    let mut closed = square(1.0, 1.0, 1.0);
    closed.push(closed[0]);
    let seq = one(plane(vec![outer, closed])).unwrap();
    let polys = &seq.frames()[0].planes[0].annotations[0].polygons;
    assert!(signed_area(&polys[0]) > 0.0 && signed_area(&polys[1]) < 0.0);
    assert_eq!(polys[1].len(), 4, "explicit closing vertex dropped");
    let (c, f) = seq.clone().into_parts();
    assert_eq!(Sequence::new(c, f).unwrap(), seq);
}

#[test]
fn geometry_errors() {
    let (k, m) = kind_of(one(plane(vec![vec![
        [0.0, 0.0],
        [1.0, f64::NAN],
        [1.0, 1.0],
    ]])));
    assert!(
        matches!(k, ErrorKind::NotFinite { .. })
            && m.contains("polygon 0")
            && m.contains("class \"a\""),
        "{m}"
    );
    let (k, _) = kind_of(one(plane(vec![vec![[0.0, 0.0], [1.0, 0.0]]])));
    assert!(matches!(k, ErrorKind::Degenerate(_)));
    let (k, m) = kind_of(one(plane(vec![vec![
        [0.0, 0.0],
        [1.0, 0.0],
        [1.0, 0.0],
        [1.0, 1.0],
    ]])));
    assert!(
        matches!(k, ErrorKind::Degenerate(_)) && m.contains("coincide"),
        "{m}"
    );
    let (k, _) = kind_of(one(plane(vec![vec![
        [0.0, 0.0],
        [1.0, 1.0],
        [1.0, 0.0],
        [0.0, 1.0],
    ]])));
    assert!(matches!(k, ErrorKind::SelfIntersection(_)));
    let (k, m) = kind_of(one(plane(vec![
        square(0.0, 0.0, 2.0),
        square(1.0, 1.0, 2.0),
    ])));
    assert!(
        matches!(k, ErrorKind::SelfIntersection(_)) && m.contains("polygon"),
        "{m}"
    );
    let (k, _) = kind_of(one(plane(vec![square(9.0, 9.0, 2.0)])));
    assert!(matches!(k, ErrorKind::OutsideRoi { .. }));
    let (k, _) = kind_of(one(plane(vec![vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]])));
    assert!(matches!(
        k,
        ErrorKind::SelfIntersection(_) | ErrorKind::Degenerate(_)
    ));
}

#[test]
fn pinched_contours_are_separated_not_rejected() {
    // Two squares sharing a corner, and a hole touching its outer boundary at a vertex.
    let seq = one(plane(vec![
        square(0.0, 0.0, 1.0),
        square(1.0, 1.0, 1.0),
        vec![[-4.0, -4.0], [-1.0, -4.0], [-1.0, -1.0], [-4.0, -1.0]],
        vec![[-4.0, -4.0], [-3.0, -2.0], [-2.0, -3.0]],
    ]))
    .unwrap();
    let polys = &seq.frames()[0].planes[0].annotations[0].polygons;
    assert_eq!(polys.iter().map(Vec::len).collect::<Vec<_>>(), [5, 5, 5, 4]);
    assert!(
        signed_area(&polys[3]) < 0.0,
        "the pinched hole is still a hole"
    );
    assert!((signed_area(&polys[0]) - 1.0).abs() < 1e-5);
}

#[test]
fn plane_errors() {
    let mut p = plane(vec![square(0.0, 0.0, 1.0)]);
    p.u = [1.0, 0.1, 0.0];
    let (k, m) = kind_of(one(p));
    assert!(
        matches!(k, ErrorKind::AxesNotOrthonormal { .. })
            && m.contains("timestep 0")
            && m.contains("plane 0"),
        "{m}"
    );
    let mut p = plane(vec![square(0.0, 0.0, 1.0)]);
    p.v = [1.0, 0.0, 0.0];
    assert!(matches!(
        kind_of(one(p)).0,
        ErrorKind::AxesNotOrthonormal { .. }
    ));
    let mut p = plane(vec![square(0.0, 0.0, 1.0)]);
    p.origin[2] = f64::INFINITY;
    assert!(matches!(kind_of(one(p)).0, ErrorKind::NotFinite { .. }));
    let mut p = plane(vec![square(0.0, 0.0, 1.0)]);
    p.roi.max[0] = -20.0;
    assert!(matches!(kind_of(one(p)).0, ErrorKind::EmptyRoi { .. }));
    let mut p = plane(vec![square(0.0, 0.0, 1.0)]);
    p.annotations[0].class = 3;
    assert!(matches!(kind_of(one(p)).0, ErrorKind::BadClass(_)));
    let mut p = plane(vec![square(0.0, 0.0, 1.0)]);
    p.annotations.push(p.annotations[0].clone());
    assert!(matches!(kind_of(one(p)).0, ErrorKind::BadClass(_)));
    let mut p = plane(vec![]);
    p.annotations.clear();
    assert!(matches!(kind_of(one(p)).0, ErrorKind::Empty(_)));
}

#[test]
fn sequence_errors() {
    let good = || Frame {
        time: 0.0,
        planes: vec![plane(vec![square(0.0, 0.0, 1.0)])],
    };
    assert!(matches!(
        kind_of(Sequence::new(vec![], vec![good()])).0,
        ErrorKind::Empty(_)
    ));
    assert!(matches!(
        kind_of(Sequence::new(vec![class("a", 1)], vec![])).0,
        ErrorKind::Empty(_)
    ));
    let (k, m) = kind_of(Sequence::new(vec![class("a", 1)], vec![good(), good()]));
    assert!(
        matches!(k, ErrorKind::TimesNotIncreasing { .. }) && m.contains("timestep 1"),
        "{m}"
    );
    let mut f = good();
    f.time = f64::NAN;
    assert!(matches!(
        kind_of(Sequence::new(vec![class("a", 1)], vec![f])).0,
        ErrorKind::NotFinite { .. }
    ));
    let (k, _) = kind_of(Sequence::new(
        vec![class("a", 1), class("a", 2)],
        vec![good()],
    ));
    assert!(matches!(k, ErrorKind::BadClass(_)));
    let (k, _) = kind_of(Sequence::new(
        vec![class("a", 1), class("b", 1)],
        vec![good()],
    ));
    assert!(matches!(k, ErrorKind::BadClass(_)));
    let (k, m) = kind_of(Sequence::new(
        vec![class("a", 1), class("never", 2)],
        vec![good()],
    ));
    assert!(
        matches!(k, ErrorKind::ClassNeverContoured(_)) && m.contains("never"),
        "{m}"
    );
    let (k, _) = kind_of(Sequence::new(
        vec![class("a", 1)],
        vec![Frame {
            time: 0.0,
            planes: vec![],
        }],
    ));
    assert!(matches!(k, ErrorKind::Empty(_)));
}
