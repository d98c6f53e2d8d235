//! Slice pictures and 3D renderings through a real model file (growing spheres in closed form,
//! `dynaslice_test_support::spheres`): class colours where the model puts each class, legends
//! that hold every class of a 41-class input, and the written PNGs' sizes.

use dynaslice_core::Model;
use dynaslice_figures::class_color;
use dynaslice_figures::display::Display;
use dynaslice_figures::picture::{match_classes, plane_labels, Panel};
use dynaslice_figures::render3d::{render_surfaces, RenderOptions, SurfacePanel};
use dynaslice_mesh::{extract, Options};
use dynaslice_sequence::{Annotation, ClassInfo, Frame, Plane, Rect, Sequence};
use dynaslice_test_support::spheres::{self, Sphere};
use plotters::style::RGBColor;

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
    let drawn_as = match_classes(&classes(), sequence.classes());
    assert_eq!(drawn_as, (0..CLASSES).map(Some).collect::<Vec<_>>());
    plane_labels(
        &model,
        &classes(),
        &drawn_as,
        &plane,
        &panels,
        "mm",
        Display::Radiological,
        &path,
    )
    .unwrap();
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

/// A model of one class pictured on a plane of a 41-class input: only its class is drawn (fill,
/// contour, a one-entry legend), and the direction letters and scale bar sit outside the data.
#[test]
fn slice_picture_draws_only_the_models_classes_and_annotates_off_the_data() {
    let ball = spheres::model(
        &[Sphere::new([0.0; 3], 0.5, 0.1)],
        &[("structure number 0", 1)],
    );
    let model = Model::from_bytes(&ball).unwrap();
    let model_classes = vec![ClassInfo {
        name: "Structure Number 0 ".into(),
        label: 1,
        color: Some([200, 40, 40]),
    }];
    let square = |x: f64| vec![[x, -5.0], [x + 4.0, -5.0], [x + 4.0, -1.0], [x, -1.0]];
    // Class 0 matches the model's class (by name, ignoring case and blanks); 1 to 40 do not.
    let plane = Plane {
        origin: [0.0, 0.0, 2.0],
        u: [1.0, 0.0, 0.0],
        v: [0.0, 1.0, 0.0],
        roi: Rect {
            min: [-10.0, -25.0],
            max: [30.0, 15.0],
        },
        annotations: (0..CLASSES)
            .map(|k| Annotation {
                class: k,
                polygons: vec![square(-9.0 + k as f64 * 0.9)],
            })
            .collect(),
    };
    let input = classes();
    let drawn_as = match_classes(&model_classes, &input);
    assert_eq!(drawn_as[0], Some(0));
    assert!(drawn_as[1..].iter().all(Option::is_none));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.png");
    let panels = [Panel {
        time: 0.0,
        title: "t = 0".into(),
        contours: Some(&plane),
    }];
    plane_labels(
        &model,
        &model_classes,
        &drawn_as,
        &plane,
        &panels,
        "mm",
        Display::Radiological,
        &path,
    )
    .unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    let count = |c: RGBColor| img.pixels().filter(|p| p.0 == [c.0, c.1, c.2]).count();
    // No other class's contour or swatch anywhere.
    for k in [1, 2, 20, CLASSES - 1] {
        assert_eq!(count(class_color(k, None)), 0, "class {k}'s contour drawn");
    }
    // One legend row: the picture is the panel, its gutters and one row, not 41 entries.
    assert!(
        img.height() < 480 + 34 + 26 + 78 + 2 * 22 + 30,
        "{}",
        img.height()
    );
    // Inside the data (the panel less its frame) nothing is drawn in black or grey: no
    // letters, no scale bar.
    let (x0, top) = (10 + 64, 34 + 26);
    let dark = (x0 + 2..x0 + 478)
        .flat_map(|x| (top + 2..top + 478).map(move |y| (x, y)))
        .filter(|&(x, y)| {
            let p = img.get_pixel(x, y).0;
            p.iter().all(|&c| c < 160) && p[0].abs_diff(p[1]) < 30 && p[1].abs_diff(p[2]) < 30
        })
        .count();
    assert_eq!(dark, 0, "text or a scale bar on the data");
    // Beside the data: the letters R, L, A, P and the scale bar are drawn (dark pixels).
    let dark_right = (x0 + 482..x0 + 480 + 28)
        .flat_map(|x| (top..top + 480).map(move |y| (x, y)))
        .filter(|&(x, y)| img.get_pixel(x, y).0.iter().all(|&c| c < 100))
        .count();
    assert!(
        dark_right > 20,
        "{dark_right}: no A/P letters beside the panel"
    );
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

/// An axial plane whose region holds the ball (centre x = 10 mm, the patient's right in RAS)
/// a third of the way from its −x end. Neurological pictures keep +x to the right, so the ball
/// is drawn a third of the way across; radiological ones put the patient's right on the left of
/// the screen (+x to the left), so it is drawn two thirds of the way across.
#[test]
fn axial_pictures_follow_the_display_convention() {
    let bytes = model_bytes();
    let model = Model::from_bytes(&bytes).unwrap();
    let plane = Plane {
        origin: [0.0, 0.0, 2.0],
        u: [1.0, 0.0, 0.0],
        v: [0.0, 1.0, 0.0],
        roi: Rect {
            min: [-10.0, -25.0],
            max: [50.0, 15.0],
        },
        annotations: vec![],
    };
    let panels = [Panel {
        time: 0.0,
        title: "t = 0".into(),
        contours: None,
    }];
    let dir = tempfile::tempdir().unwrap();
    let fill = lighten([200, 40, 40]);
    let mean_x = |display: Display| {
        let path = dir.path().join(format!("{display:?}.png"));
        plane_labels(
            &model,
            &classes(),
            &[],
            &plane,
            &panels,
            "mm",
            display,
            &path,
        )
        .unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        // The panel: 480 × 320 pixels below the heading and title (34 + 26 pixels), right of
        // the margin and tick gutter (10 + 64 pixels); the legend's swatch lies below it.
        let xs: Vec<f64> = img
            .enumerate_pixels()
            .filter(|(x, y, p)| p.0 == fill && *y >= 60 && *y < 60 + 320 && *x >= 74)
            .map(|(x, _, _)| (x - 74) as f64 / 480.0)
            .collect();
        assert!(xs.len() > 10_000, "{display:?}: {} pixels", xs.len());
        xs.iter().sum::<f64>() / xs.len() as f64
    };
    // The ball's centre is at a third of the region from its −x end: 20 of 60 mm.
    let radiological = mean_x(Display::Radiological);
    let neurological = mean_x(Display::Neurological);
    assert!((radiological - 2.0 / 3.0).abs() < 0.02, "{radiological}");
    assert!((neurological - 1.0 / 3.0).abs() < 0.02, "{neurological}");
}
