//! Fixtures shared by the reader tests.

use dynaslice_data::{Annotation, ClassInfo, Frame, Plane, Rect, Sequence};

/// The plane at height `z`, its axes turned within it, where class 0 has `polys` (and class 1 is
/// absent, if `absent`).
fn plane(z: f64, polys: Vec<Vec<[f64; 2]>>, absent: bool) -> Plane {
    let mut annotations = vec![Annotation {
        class: 0,
        polygons: polys,
    }];
    if absent {
        annotations.push(Annotation {
            class: 1,
            polygons: vec![],
        });
    }
    Plane {
        origin: [0.1, -0.2, z],
        u: [0.6, 0.8, 0.0],
        v: [-0.8, 0.6, 0.0],
        roi: Rect {
            min: [-2.0, -2.0],
            max: [2.0, 2.0],
        },
        annotations,
    }
}

/// Two classes over two timesteps, with a class absent on one plane, awkward floats (thirds, tiny
/// offsets) to exercise the shortest round-trip representation, and a quoted name.
pub fn sample() -> Sequence {
    let tri = vec![[0.0, 0.0], [1.0 / 3.0, 1e-17 + 0.1], [0.2, 0.7]];
    let sq: Vec<[f64; 2]> = vec![[-1.5, -1.5], [-0.5, -1.5], [-0.5, -0.5], [-1.5, -0.5]];
    let classes = vec![
        ClassInfo {
            name: "liver".into(),
            label: 5,
            color: None,
        },
        ClassInfo {
            name: "kidney \"left\"".into(),
            label: -3,
            color: None,
        },
    ];
    let frames = vec![
        Frame {
            time: 0.0,
            planes: vec![plane(0.0, vec![tri.clone()], true)],
        },
        Frame {
            time: 1.0 / 7.0,
            planes: vec![
                plane(0.5, vec![sq], false),
                Plane {
                    annotations: vec![Annotation {
                        class: 1,
                        polygons: vec![tri],
                    }],
                    ..plane(0.25, vec![], false)
                },
            ],
        },
    ];
    Sequence::new(classes, frames).unwrap()
}
