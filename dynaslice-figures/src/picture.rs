//! Pictures of a model on an input plane: the Eq. 11 labels it predicts, coloured per class,
//! with the plane's input contours drawn over them, side by side for several times (e.g. an
//! annotated frame and a time between annotated frames).

use anyhow::{anyhow, Result};
use dynaslice_core::{Model, Scratch, UNDEFINED_LABEL};
use dynaslice_data::{Plane, Sequence};
use plotters::prelude::*;
use std::path::Path;

/// Pixels along the longer side of each panel.
const PANEL: u32 = 480;

/// Class colours (background white); class k uses entry (k − 1) mod len.
const PALETTE: [RGBColor; 8] = [
    RGBColor(230, 85, 70),
    RGBColor(70, 130, 220),
    RGBColor(90, 180, 90),
    RGBColor(240, 180, 40),
    RGBColor(160, 90, 200),
    RGBColor(60, 190, 190),
    RGBColor(200, 120, 160),
    RGBColor(140, 110, 70),
];

fn class_colour(label: u32) -> RGBColor {
    match label {
        0 => WHITE,
        UNDEFINED_LABEL => BLACK,
        k => PALETTE[(k as usize - 1) % PALETTE.len()],
    }
}

fn lighten(c: RGBColor) -> RGBColor {
    let m = |v: u8| (v as u16 + (255 - v as u16) / 2) as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

/// One panel: a time, and the input contours to draw on it (those of the frame at that time,
/// if the time is annotated).
pub struct Panel<'a> {
    /// World time.
    pub time: f64,
    /// Caption.
    pub title: String,
    /// Plane whose contours are drawn (`None`: labels only).
    pub contours: Option<&'a Plane>,
}

/// Renders `panels` of `model`'s labels over `plane`'s region of interest into a PNG.
pub fn plane_labels(
    model: &Model,
    sequence: &Sequence,
    plane: &Plane,
    panels: &[Panel],
    path: &Path,
) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| anyhow!("cannot draw {}: {e}", path.display());
    crate::plot::register_font();
    let (lo, hi) = (plane.roi.min, plane.roi.max);
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    if !(w > 0.0 && h > 0.0) {
        return Err(anyhow!(
            "{}: the plane's region of interest is empty",
            path.display()
        ));
    }
    let (pw, ph) = if w >= h {
        (PANEL, ((PANEL as f64 * h / w) as u32).max(1))
    } else {
        (((PANEL as f64 * w / h) as u32).max(1), PANEL)
    };
    let (title_h, legend_h) = (34, 30);
    let width = pw * panels.len() as u32 + 10 * (panels.len() as u32 + 1);
    let root = BitMapBackend::new(path, (width, ph + title_h + legend_h + 10)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut scratch = Scratch::boxed();
    // Pixel centres in plane coordinates, row by row from the top (v decreasing).
    let pixel = |x: u32, y: u32| {
        [
            lo[0] + w * (x as f64 + 0.5) / pw as f64,
            hi[1] - h * (y as f64 + 0.5) / ph as f64,
        ]
    };
    let points: Vec<[f32; 3]> = (0..ph)
        .flat_map(|y| (0..pw).map(move |x| (x, y)))
        .map(|(x, y)| plane.to_world(pixel(x, y)).map(|v| v as f32))
        .collect();
    let mut labels = vec![0u32; points.len()];
    for (i, panel) in panels.iter().enumerate() {
        let x0 = 10 + i as u32 * (pw + 10);
        let times = vec![panel.time as f32; points.len()];
        model
            .label_batch(&mut scratch, &points, &times, &mut labels)
            .map_err(|e| err(&e))?;
        root.draw(&Text::new(
            panel.title.clone(),
            (x0 as i32, 8),
            ("sans-serif", 20),
        ))
        .map_err(|e| err(&e))?;
        for (j, &label) in labels.iter().enumerate() {
            let (x, y) = (j as u32 % pw, j as u32 / pw);
            let colour = if label == 0 {
                WHITE
            } else {
                lighten(class_colour(label))
            };
            root.draw_pixel(((x0 + x) as i32, (title_h + y) as i32), &colour)
                .map_err(|e| err(&e))?;
        }
        let to_px = |p: [f64; 2]| -> (i32, i32) {
            (
                (x0 as f64 + (p[0] - lo[0]) / w * pw as f64) as i32,
                (title_h as f64 + (hi[1] - p[1]) / h * ph as f64) as i32,
            )
        };
        root.draw(&Rectangle::new(
            [
                (x0 as i32, title_h as i32),
                ((x0 + pw) as i32, (title_h + ph) as i32),
            ],
            BLACK.stroke_width(1),
        ))
        .map_err(|e| err(&e))?;
        if let Some(p) = panel.contours {
            for a in &p.annotations {
                let colour = class_colour(a.class as u32 + 1);
                for poly in &a.polygons {
                    let mut line: Vec<(i32, i32)> = poly.iter().map(|&q| to_px(q)).collect();
                    line.extend(line.first().copied());
                    root.draw(&PathElement::new(line, colour.stroke_width(2)))
                        .map_err(|e| err(&e))?;
                }
            }
        }
    }
    // Legend: filled = predicted label, line = input contour.
    let mut x = 10;
    let y = (title_h + ph + 8) as i32;
    for (k, class) in sequence.classes().iter().enumerate() {
        let c = class_colour(k as u32 + 1);
        root.draw(&Rectangle::new(
            [(x, y), (x + 14, y + 14)],
            lighten(c).filled(),
        ))
        .map_err(|e| err(&e))?;
        root.draw(&PathElement::new(
            vec![(x + 18, y + 7), (x + 34, y + 7)],
            c.stroke_width(2),
        ))
        .map_err(|e| err(&e))?;
        let label = format!("{} ({})", class.name, class.label);
        root.draw(&Text::new(label.clone(), (x + 40, y), ("sans-serif", 15)))
            .map_err(|e| err(&e))?;
        x += 50 + 8 * label.chars().count() as i32;
    }
    root.draw(&Text::new(
        "fill: predicted labels (Eq. 11); lines: input contours",
        (x + 10, y),
        ("sans-serif", 15),
    ))
    .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
