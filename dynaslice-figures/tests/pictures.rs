//! Slice pictures and 3D renderings through a real model file (growing spheres in closed form,
//! `dynaslice_test_support::spheres`): class colours where the model puts each class, legends
//! that hold every class of a 41-class input, and the written PNGs' sizes.

use dynaslice_core::Model;
use dynaslice_data::{Annotation, ClassInfo, Frame, Plane, Rect, Sequence};
use dynaslice_figures::class_color;
use dynaslice_figures::picture::{plane_labels, Panel};
use dynaslice_figures::render3d::{render_surfaces, RenderOptions, SurfacePanel};
use dynaslice_mesh::{extract, Options};
use dynaslice_test_support::spheres::{self, Sphere};

const CLASSES: usize = 41;

/// Class 1 is a ball of radius 0.5 (10 mm) at the domain centre (10, −5, 2) mm; the others are
/// tiny balls far outside the picture, so the legend has 41 entries.
fn model_bytes() -> Vec<u8> {
    let mut balls = vec![Sphere::new([0.0; 3], 0.5, 0.1)];
    balls.extend((1..CLASSES).map(|i| Sphere::new([0.9, 0.9, -0.9 + 0.01 * i as f64], 0.001, 0.0)));
    let names: Vec<String> = (0..CLASSES)
        .map(|i| format!("structure number {i}"))
        .collect();
    let classes: Vec<(&str, i32)> = names
        .iter()
        .enumerate()
        .map(|(i, n)| (n.as_str(), i as i32 + 1))
        .collect();
    spheres::model(&balls, &classes)
}

fn classes() -> Vec<ClassInfo> {
    (0..CLASSES)
        .map(|i| ClassInfo {
            name: format!("structure number {i}"),
            label: i as i32 + 1,
            color: (i == 0).then_some([200, 40, 40]),
        })
        .collect()
}

fn lighten(c: [u8; 3]) -> [u8; 3] {
    c.map(|v| (u16::from(v) + (255 - u16::from(v)) / 2) as u8)
}

#[test]
fn slice_picture_colours_classes_and_fits_a_41_class_legend() {
    let bytes = model_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    // Axial plane through the ball's centre: plane (u, v) = world (x, y), z = 2.
    let circle: Vec<[f64; 2]> = (0..64)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 64.0;
            [10.0 + 10.0 * a.cos(), -5.0 + 10.0 * a.sin()]
        })
        .collect();
    let plane = Plane {
        origin: [0.0, 0.0, 2.0],
        u: [1.0, 0.0, 0.0],
        v: [0.0, 1.0, 0.0],
        roi: Rect {
            min: [-10.0, -25.0],
            max: [30.0, 15.0],
        },
        annotations: vec![Annotation {
            class: 0,
            polygons: vec![circle],
        }],
    };
    // Every class needs a contour somewhere: small squares on a plane below the picture's.
    let others = Plane {
        origin: [0.0, 0.0, -16.0],
        roi: Rect {
            min: [-20.0, -20.0],
            max: [60.0, 20.0],
        },
        annotations: (1..CLASSES)
            .map(|k| {
                let x = k as f64 * 1.5 - 15.0;
                Annotation {
                    class: k,
                    polygons: vec![vec![[x, 0.0], [x + 1.0, 0.0], [x + 1.0, 1.0], [x, 1.0]]],
                }
            })
            .collect(),
        ..plane.clone()
    };
    let sequence = Sequence::new(
        classes(),
        vec![Frame {
            time: 0.0,
            planes: vec![plane.clone(), others],
        }],
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.png");
    let panels = [
        Panel {
            time: 0.0,
            title: "t = 0 (annotated)".into(),
            contours: Some(&plane),
        },
        Panel {
            time: 1.0,
            title: "t = 1".into(),
            contours: None,
        },
    ];
    plane_labels(&model, &sequence, &plane, &panels, &path).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    // Two 480-pixel panels side by side; the legend's 41 entries in several columns below.
    assert!(
        img.width() >= 2 * 480 && img.width() < 1400,
        "{}",
        img.width()
    );
    assert!(img.height() > 480 + 100, "{}", img.height());
    let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
    // The ball's fill in its given colour, lightened: most of a 10 mm disc in a 40 mm panel.
    let fill = count(lighten([200, 40, 40]));
    assert!(fill > 2 * 25_000, "{fill}");
    // Every legend swatch is drawn (the last class's too: nothing cut off).
    for k in [1, 20, CLASSES - 1] {
        let c = class_color(k, None);
        let swatch = count(lighten([c.0, c.1, c.2]));
        assert!(swatch >= 14 * 14, "class {k}: {swatch}");
    }
    // The bottom rows hold the legend note, not a cut-off entry: the last row of pixels is
    // white margin.
    let last = img.height() - 1;
    assert!((0..img.width()).all(|x| img.get_pixel(x, last).0 == [255, 255, 255]));
}

#[test]
fn rendered_surfaces_of_a_model_at_two_times() {
    let bytes = model_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    let options = Options {
        resolution: 48,
        ..Options::default()
    };
    let bounds = model.domain().bounds();
    let meshes: Vec<_> = [0.0f32, 2.0]
        .iter()
        .map(|&t| extract(&model, bounds, t, &[0], &options).unwrap().meshes)
        .collect();
    let panels: Vec<SurfacePanel> = [0.0, 2.0]
        .iter()
        .zip(&meshes)
        .map(|(&time, m)| SurfacePanel {
            time,
            meshes: vec![(0, &m[0])],
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.png");
    render_surfaces(&path, &panels, &classes(), &RenderOptions::default()).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    // The ball grows: more of its (shaded) colour in the second panel.
    let shaded = |x0: u32| {
        (x0..x0 + 480)
            .flat_map(|x| (30..510).map(move |y| (x, y)))
            .filter(|&(x, y)| {
                let p = img.get_pixel(x, y).0;
                p != [255, 255, 255] && p[0] > p[1] && p[1] == p[2]
            })
            .count()
    };
    let (first, second) = (shaded(10), shaded(500));
    assert!(first > 20_000 && second > first, "{first} {second}");
}
