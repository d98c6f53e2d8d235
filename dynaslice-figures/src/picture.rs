//! Pictures of a model on an input plane: the Eq. 11 labels it predicts, coloured per class,
//! with the plane's input contours drawn over them, side by side for several times (e.g. an
//! annotated frame and a time between annotated frames).
//!
//! Each panel has mm tick labels (world x, y or z where the plane's axis is one of them, else
//! mm along the plane's own axis), a scale bar, and the anatomical directions (R/L, A/P, S/I of
//! our RAS world), all outside the picture of the data: the u directions at the ends of the
//! axis caption, the v directions beside the panel's top and bottom right corners, the scale
//! bar below the caption. The heading names the plane by orientation and position
//! ([`plane_name`]). Only the model's classes are drawn (fills, contours of the input classes
//! matched to them by [`match_classes`], legend); the legend wraps into as many columns and
//! rows as it needs.

use crate::color::{class_color, lighten};
use crate::display::Display;
use crate::legend::{self, Item};
use anyhow::{anyhow, Result};
use dynaslice_core::{Model, Scratch, UNDEFINED_LABEL};
use dynaslice_sequence::{ClassInfo, Frame, Plane};
use plotters::prelude::*;
use std::path::Path;

/// Pixels along the longer side of each panel.
const PANEL: u32 = 480;
/// Most panels in one picture (bounds the image and the model evaluations).
pub const MAX_PANELS: usize = 16;
/// A plane axis within this of a world axis (cosine) counts as that axis (about 2.6°).
const ALIGNED: f64 = 0.999;

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

impl<'a> Panel<'a> {
    /// The panel of an annotated frame: its time, and the contours of its plane `index`.
    pub fn annotated(frame: &'a Frame, index: usize) -> Panel<'a> {
        Panel {
            time: frame.time,
            title: format!("t = {:.4} (annotated), plane {index}", frame.time),
            contours: Some(&frame.planes[index]),
        }
    }

    /// The panel of a time without contours.
    pub fn unannotated(time: f64) -> Panel<'a> {
        Panel {
            time,
            title: format!("t = {time:.4} (not annotated)"),
            contours: None,
        }
    }
}

/// The plane of `frame` with the most contour length, a picture's default (`None`: the frame
/// has no plane).
pub fn longest_plane(frame: &Frame) -> Option<usize> {
    let length = |plane: &Plane| -> f64 {
        let polygons = plane.annotations.iter().flat_map(|a| &a.polygons);
        polygons
            .map(|p| {
                (0..p.len())
                    .map(|j| {
                        let (a, b) = (p[j], p[(j + 1) % p.len()]);
                        (a[0] - b[0]).hypot(a[1] - b[1])
                    })
                    .sum::<f64>()
            })
            .sum()
    };
    (0..frame.planes.len())
        .max_by(|&i, &j| length(&frame.planes[i]).total_cmp(&length(&frame.planes[j])))
}

/// The names of the `input` classes that [`match_classes`] left undrawn (`drawn_as` `None`).
pub fn undrawn<'a>(input: &'a [ClassInfo], drawn_as: &[Option<usize>]) -> Vec<&'a str> {
    input
        .iter()
        .zip(drawn_as)
        .filter(|(_, k)| k.is_none())
        .map(|(c, _)| c.name.as_str())
        .collect()
}

/// The plane by orientation and position, coordinates in `unit` (the input's): `axial z = 12.0 mm`, `coronal y = …`,
/// `sagittal x = …` when its normal is within about 2.6° of a world axis, else
/// `oblique through (x, y, z) mm` at the centre of its region of interest.
pub fn plane_name(plane: &Plane, unit: &str) -> String {
    let n = plane.normal();
    let centre = plane.to_world([
        0.5 * (plane.roi.min[0] + plane.roi.max[0]),
        0.5 * (plane.roi.min[1] + plane.roi.max[1]),
    ]);
    for (k, (name, axis)) in [("sagittal", "x"), ("coronal", "y"), ("axial", "z")]
        .into_iter()
        .enumerate()
    {
        if n[k].abs() > ALIGNED {
            // The plane's position along its normal axis, at the region's centre.
            return format!("{name} {axis} = {:.1} {unit}", centre[k]);
        }
    }
    format!(
        "oblique through ({:.1}, {:.1}, {:.1}) {unit}",
        centre[0], centre[1], centre[2]
    )
}

/// The anatomical direction of world vector `d` in our RAS frame: the letter of its largest
/// component, followed by that of the second if it is at least sin 22.5° of the whole (e.g.
/// `R`, `AS`).
pub fn direction_letters(d: [f64; 3]) -> String {
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if len.is_nan() || len <= 0.0 {
        return String::new();
    }
    let letters = [('R', 'L'), ('A', 'P'), ('S', 'I')];
    let mut axes = [0, 1, 2];
    axes.sort_by(|&a, &b| d[b].abs().total_cmp(&d[a].abs()));
    let letter = |k: usize| {
        if d[k] >= 0.0 {
            letters[k].0
        } else {
            letters[k].1
        }
    };
    let mut s = String::from(letter(axes[0]));
    if d[axes[1]].abs() / len >= 0.382 {
        s.push(letter(axes[1]));
    }
    s
}

/// A "nice" step (1, 2 or 5 × 10^k) giving about `target` steps over `span`.
fn nice_step(span: f64, target: f64) -> f64 {
    let raw = (span / target).max(1e-12);
    let p = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * p)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * p)
}

/// How tick values along one picture axis relate to plane coordinate `p` on that axis:
/// value = offset + scale · p, and the axis caption.
struct AxisScale {
    offset: f64,
    scale: f64,
    caption: String,
}

/// The displayed coordinate along plane direction `dir` (u or v): a world coordinate where
/// `dir` is a world axis, else mm along the plane's own axis.
fn axis_scale(
    plane: &Plane,
    dir: [f64; 3],
    other: [f64; 3],
    other_mid: f64,
    name: &str,
    unit: &str,
) -> AxisScale {
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        if dir[k].abs() > ALIGNED {
            return AxisScale {
                offset: plane.origin[k] + other_mid * other[k],
                scale: dir[k].signum(),
                caption: format!("{axis} ({unit})"),
            };
        }
    }
    AxisScale {
        offset: 0.0,
        scale: 1.0,
        caption: format!("{unit} along plane {name} ({})", direction_letters(dir)),
    }
}

/// Tick positions (plane coordinates) and labels over plane coordinates `lo..=hi`.
fn ticks(axis: &AxisScale, lo: f64, hi: f64, target: f64) -> Vec<(f64, String)> {
    let (a, b) = (axis.offset + axis.scale * lo, axis.offset + axis.scale * hi);
    let (min, max) = (a.min(b), a.max(b));
    let step = nice_step(max - min, target);
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    let first = (min / step).ceil() as i64;
    let last = (max / step).floor() as i64;
    (first..=last)
        .take(100)
        .map(|i| {
            let value = i as f64 * step;
            let p = (value - axis.offset) / axis.scale;
            // "-0" reads oddly.
            let value = if value == 0.0 { 0.0 } else { value };
            (p, format!("{value:.decimals$}"))
        })
        .collect()
}

/// For each input class, the model channel it is drawn as: the model class of the same name
/// (ignoring case and surrounding blanks), else `None` (not drawn: the model was trained
/// without it, e.g. on `--labels 1,2,3` of a 41-label map).
pub fn match_classes(model: &[ClassInfo], input: &[ClassInfo]) -> Vec<Option<usize>> {
    let key = |c: &ClassInfo| c.name.trim().to_lowercase();
    input
        .iter()
        .map(|i| model.iter().position(|m| key(m) == key(i)))
        .collect()
}

/// Renders `panels` of `model`'s labels over `plane`'s region of interest into a PNG, written
/// atomically. `classes` are the model's (one per channel, with the colours to draw them in);
/// `drawn_as[c]` is the channel input class `c`'s contours are drawn as ([`match_classes`];
/// `None`: not drawn). Axial and coronal planes are drawn in the `display` convention, which
/// the picture's note names.
#[allow(clippy::too_many_arguments)]
pub fn plane_labels(
    model: &Model,
    classes: &[ClassInfo],
    drawn_as: &[Option<usize>],
    plane: &Plane,
    panels: &[Panel],
    unit: &str,
    display: Display,
    path: &Path,
) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| anyhow!("cannot draw {}: {e}", path.display());
    // Axial and coronal planes in the display convention (the note says which); the panels'
    // contours are the plane's own, turned the same way.
    let turned = display.orient(plane);
    let convention = turned.as_ref().map(|_| display.describe());
    let plane = turned.as_ref().unwrap_or(plane);
    let contours: Vec<Option<Plane>> = panels
        .iter()
        .map(|p| {
            p.contours
                .map(|c| display.orient(c).unwrap_or_else(|| c.clone()))
        })
        .collect();
    crate::plot::register_font();
    let (lo, hi) = (plane.roi.min, plane.roi.max);
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    if !(w > 0.0 && h > 0.0 && w.is_finite() && h.is_finite()) {
        return Err(anyhow!(
            "{}: the plane's region of interest is empty",
            path.display()
        ));
    }
    if panels.is_empty() || panels.len() > MAX_PANELS {
        return Err(anyhow!(
            "cannot draw {}: {} panels (1 to {MAX_PANELS})",
            path.display(),
            panels.len()
        ));
    }
    let (pw, ph) = if w >= h {
        (PANEL, ((PANEL as f64 * h / w) as u32).clamp(1, PANEL))
    } else {
        (((PANEL as f64 * w / h) as u32).clamp(1, PANEL), PANEL)
    };

    // Layout: heading; per panel a left gutter for the v ticks, its title, the picture, a
    // right gutter for the v directions, and a bottom gutter for the u ticks, the caption with
    // the u directions at its ends, and the scale bar; the legend below, wrapped to the width.
    let (margin, heading_h, title_h, left, right, bottom) =
        (10u32, 34u32, 26u32, 64u32, 30u32, 78u32);
    let column = left + pw + right;
    let width = margin + column * panels.len() as u32;
    let mut items: Vec<Item> = classes
        .iter()
        .enumerate()
        .map(|(k, class)| {
            let c = class_color(k, class.color);
            Item {
                label: format!("{} ({})", class.name, class.label),
                fill: Some(lighten(c)),
                line: Some(c),
            }
        })
        .collect();
    let note = match convention {
        Some(convention) => {
            format!("fill: predicted labels (Eq. 11); lines: input contours; {convention}")
        }
        None => "fill: predicted labels (Eq. 11); lines: input contours".to_string(),
    };
    let layout = legend::across(&items, width - 2 * margin);
    let width = width.max(layout.width() + 2 * margin);
    let legend_top = heading_h + title_h + ph + bottom;
    let height = legend_top + layout.height() + legend::ROW + margin;
    let mut buffer = crate::canvas(path, width, height)?;

    // Labels, straight into the buffer; lines and text are drawn over them below.
    let mut scratch = Scratch::boxed();
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
    let x_of = |i: usize| margin + i as u32 * column + left;
    for (i, panel) in panels.iter().enumerate() {
        let times = vec![panel.time as f32; points.len()];
        model
            .label_batch(&mut scratch, &points, &times, &mut labels)
            .map_err(|e| err(&e))?;
        for (j, &label) in labels.iter().enumerate() {
            let colour = match label {
                0 => continue,
                UNDEFINED_LABEL => BLACK,
                k => {
                    let k = k as usize - 1;
                    lighten(class_color(k, classes.get(k).and_then(|c| c.color)))
                }
            };
            let (x, y) = (x_of(i) + j as u32 % pw, heading_h + title_h + j as u32 / pw);
            let at = (y as usize * width as usize + x as usize) * 3;
            buffer[at..at + 3].copy_from_slice(&[colour.0, colour.1, colour.2]);
        }
    }

    {
        let root = BitMapBackend::with_buffer(&mut buffer, (width, height)).into_drawing_area();
        let d = |r: Result<(), DrawingAreaErrorKind<_>>| r.map_err(|e| err(&e));
        d(root.draw(&Text::new(
            plane_name(plane, unit),
            (margin as i32, 8),
            ("sans-serif", 22),
        )))?;
        let (u_axis, v_axis) = (
            axis_scale(plane, plane.u, plane.v, 0.5 * (lo[1] + hi[1]), "u", unit),
            axis_scale(plane, plane.v, plane.u, 0.5 * (lo[0] + hi[0]), "v", unit),
        );
        let top = (heading_h + title_h) as i32;
        let small = ("sans-serif", 14).into_font();
        let centred = |dx: u32| dx as i32 / 2;
        for (i, panel) in panels.iter().enumerate() {
            let x0 = x_of(i) as i32;
            let to_px = |p: [f64; 2]| -> (i32, i32) {
                (
                    x0 + ((p[0] - lo[0]) / w * pw as f64).round() as i32,
                    top + ((hi[1] - p[1]) / h * ph as f64).round() as i32,
                )
            };
            d(root.draw(&Text::new(
                panel.title.clone(),
                (x0, heading_h as i32),
                ("sans-serif", 18),
            )))?;
            if let Some(p) = &contours[i] {
                for a in &p.annotations {
                    let Some(k) = drawn_as.get(a.class).copied().flatten() else {
                        continue;
                    };
                    let colour = class_color(k, classes.get(k).and_then(|c| c.color));
                    for poly in &a.polygons {
                        let mut line: Vec<(i32, i32)> = poly.iter().map(|&q| to_px(q)).collect();
                        line.extend(line.first().copied());
                        d(root.draw(&PathElement::new(line, colour.stroke_width(2))))?;
                    }
                }
            }
            let (x1, y1) = (x0 + pw as i32, top + ph as i32);
            d(root.draw(&Rectangle::new(
                [(x0, top), (x1, y1)],
                BLACK.stroke_width(1),
            )))?;

            // Ticks: u along the bottom, v along the left, in mm.
            for (p, text) in ticks(&u_axis, lo[0], hi[0], pw as f64 / 90.0) {
                let x = to_px([p, lo[1]]).0;
                d(root.draw(&PathElement::new(vec![(x, y1), (x, y1 + 5)], BLACK)))?;
                let tw = legend::text_width(&text, 14);
                d(root.draw(&Text::new(text, (x - centred(tw), y1 + 7), small.clone())))?;
            }
            let caption_w = legend::text_width(&u_axis.caption, 14);
            d(root.draw(&Text::new(
                u_axis.caption.clone(),
                (x0 + pw as i32 / 2 - centred(caption_w), y1 + 27),
                small.clone(),
            )))?;
            for (p, text) in ticks(&v_axis, lo[1], hi[1], ph as f64 / 70.0) {
                let y = to_px([lo[0], p]).1;
                d(root.draw(&PathElement::new(vec![(x0 - 5, y), (x0, y)], BLACK)))?;
                let tw = legend::text_width(&text, 14) as i32;
                d(root.draw(&Text::new(text, (x0 - 8 - tw, y - 7), small.clone())))?;
            }
            // The v caption, written upwards beside the tick labels.
            let caption_w = legend::text_width(&v_axis.caption, 14) as i32;
            d(root.draw(&Text::new(
                v_axis.caption.clone(),
                (x0 - left as i32 + 2, top + ph as i32 / 2 + caption_w / 2),
                small.clone().transform(FontTransform::Rotate270),
            )))?;

            // Anatomical directions, off the data: −u and +u at the ends of the u caption's
            // row, +v and −v in the right gutter beside the top and bottom corners.
            let neg = |a: [f64; 3]| a.map(|c| -c);
            let letters_font = ("sans-serif", 16);
            let (u_plus, u_minus) = (direction_letters(plane.u), direction_letters(neg(plane.u)));
            let (v_plus, v_minus) = (direction_letters(plane.v), direction_letters(neg(plane.v)));
            let caption_y = y1 + 26;
            let uw = legend::text_width(&u_plus, 16) as i32;
            for (letters, at) in [
                (u_minus, (x0, caption_y)),
                (u_plus, (x1 - uw, caption_y)),
                (v_plus, (x1 + 6, top)),
                (v_minus, (x1 + 6, y1 - 16)),
            ] {
                d(root.draw(&Text::new(letters, at, letters_font)))?;
            }

            // Scale bar, below the caption at the right: a nice length of about a fifth of the
            // panel, its length written to its left.
            let mm_per_px = w / pw as f64;
            let length = nice_step(0.2 * w, 1.0);
            let bar_px = (length / mm_per_px).round() as i32;
            let (bx1, by) = (x1, y1 + 54);
            let bx0 = bx1 - bar_px;
            let label = format!("{length} {unit}");
            let tw = legend::text_width(&label, 14) as i32;
            d(root.draw(&Rectangle::new([(bx0, by), (bx1, by + 4)], BLACK.filled())))?;
            d(root.draw(&Text::new(label, (bx0 - tw - 6, by - 5), small.clone())))?;
        }
        // Legend: filled = predicted label, line = input contour.
        d(legend::draw(
            &root,
            (margin as i32, legend_top as i32),
            &items,
            layout,
        ))?;
        items.clear();
        d(root.draw(&Text::new(
            note,
            (margin as i32, (legend_top + layout.height()) as i32 + 3),
            ("sans-serif", 14),
        )))?;
        root.present().map_err(|e| err(&e))?;
    }
    crate::save_png(path, &buffer, width, height)
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_sequence::Rect;

    /// The default plane is the one with the most contour length; a frame without planes has
    /// none.
    #[test]
    fn longest_plane_has_the_most_contour() {
        let square = |side: f64| vec![[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]];
        let with = |polygons: Vec<Vec<[f64; 2]>>| Plane {
            annotations: vec![dynaslice_sequence::Annotation { class: 0, polygons }],
            ..plane([0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        };
        let frame = Frame {
            time: 0.0,
            // Perimeters 8, 12 (two squares) and 10.
            planes: vec![
                with(vec![square(2.0)]),
                with(vec![square(1.0), square(2.0)]),
                with(vec![square(2.5)]),
            ],
        };
        assert_eq!(longest_plane(&frame), Some(1));
        let panel = Panel::annotated(&frame, 1);
        assert_eq!(panel.title, "t = 0.0000 (annotated), plane 1");
        assert!(longest_plane(&Frame {
            time: 0.0,
            planes: vec![]
        })
        .is_none());
    }

    fn plane(origin: [f64; 3], u: [f64; 3], v: [f64; 3]) -> Plane {
        Plane {
            origin,
            u,
            v,
            roi: Rect {
                min: [-10.0, -20.0],
                max: [30.0, 20.0],
            },
            annotations: vec![],
        }
    }

    #[test]
    fn planes_are_named_by_orientation_and_position() {
        let axial = plane([0.0, 0.0, 12.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert_eq!(plane_name(&axial, "mm"), "axial z = 12.0 mm");
        let coronal = plane([5.0, -7.25, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!(plane_name(&coronal, "mm"), "coronal y = -7.2 mm");
        let sagittal = plane([3.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!(plane_name(&sagittal, "mm"), "sagittal x = 3.0 mm");
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let oblique = plane([0.0, 0.0, 0.0], [s, s, 0.0], [0.0, 0.0, 1.0]);
        // ROI centre (10, 0) in plane coordinates.
        assert_eq!(
            plane_name(&oblique, "mm"),
            "oblique through (7.1, 7.1, 0.0) mm"
        );
    }

    #[test]
    fn directions_read_in_ras() {
        assert_eq!(direction_letters([1.0, 0.0, 0.0]), "R");
        assert_eq!(direction_letters([-1.0, 0.0, 0.0]), "L");
        assert_eq!(direction_letters([0.0, -1.0, 0.0]), "P");
        assert_eq!(direction_letters([0.0, 0.3, -1.0]), "I");
        assert_eq!(direction_letters([0.0, 0.6, -1.0]), "IA");
        assert_eq!(direction_letters([0.0; 3]), "");
    }

    #[test]
    fn ticks_are_nice_mm_values_at_their_plane_positions() {
        assert_eq!(nice_step(40.0, 5.0), 10.0);
        assert_eq!(nice_step(3.0, 5.0), 1.0);
        assert_eq!(nice_step(0.7, 5.0), 0.2);
        // A plane whose u is world −x, origin x = 100: plane u = 10 is world x = 90.
        let p = plane([100.0, 0.0, 5.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let axis = axis_scale(&p, p.u, p.v, 0.0, "u", "mm");
        assert_eq!(axis.caption, "x (mm)");
        let t = ticks(&axis, -10.0, 30.0, 4.0);
        assert!(
            t.contains(&(10.0, "90".to_string())),
            "{:?}",
            t.iter().collect::<Vec<_>>()
        );
        assert!(t.iter().all(|(p, _)| (-10.0..=30.0).contains(p)));
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let o = plane([0.0; 3], [s, s, 0.0], [0.0, 0.0, 1.0]);
        assert_eq!(
            axis_scale(&o, o.u, o.v, 0.0, "u", "mm").caption,
            "mm along plane u (RA)"
        );
    }
}
