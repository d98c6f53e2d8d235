//! PNG line charts (loss curves, volume curves), drawn with plotters and the bundled DejaVu Sans
//! font so they render identically on machines without any system font.
//!
//! The legend sits in a panel right of the plot, sized to fit every entry (in several columns
//! when there are many), so it never hides a curve or gets cut off. On a log scale, a value
//! ≤ 0 cannot be drawn: the curve stops there and resumes at the next positive value, and a ▼
//! on the x axis in the curve's colour marks each such step, so a gap is never mistaken for
//! missing data or a minimum; values are never clamped into a fake level. When every x is an
//! integer (steps), x ticks are integers.

use crate::color::class_color;
use crate::legend::{self, Item};
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// Chart size, without the legend panel.
const SIZE: (u32, u32) = (1000, 600);

/// One named line.
pub struct Series<'a> {
    /// Legend label.
    pub name: &'a str,
    /// (x, y) points in order of x.
    pub points: Vec<(f64, f64)>,
}

/// Registers the bundled font as `sans-serif` (once per process).
pub fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bundled font is valid TTF; registration can only fail on malformed bytes.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// Colours of loss-type charts, whose series are not classes.
const LINES: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 0),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
];

/// Writes a PNG chart of `series` (1000×600 plus a legend panel sized to fit), atomically.
/// With `log_y` the y axis is logarithmic and values ≤ 0 are shown as gaps marked ▼ on the x
/// axis (see the module documentation).
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_y: bool,
) -> Result<()> {
    let colors: Vec<RGBColor> = (0..series.len()).map(|i| LINES[i % LINES.len()]).collect();
    chart(path, title, x_label, y_label, series, &colors, log_y)
}

/// The training loss curve of a run: one series per term (`names`, in the order of each row's
/// values), against the step, on a log scale; written atomically.
pub fn loss_curve(path: &Path, names: &[&str], rows: &[(u64, &[f64])]) -> Result<()> {
    let all: Vec<Series> = names
        .iter()
        .enumerate()
        .map(|(i, &name)| Series {
            name,
            points: rows
                .iter()
                .filter_map(|(step, v)| Some((*step as f64, *v.get(i)?)))
                .collect(),
        })
        .collect();
    dynaslice_output::write_via(path, |tmp| {
        line_chart(
            tmp,
            "DynaSlice training loss",
            "step",
            "loss (unweighted terms)",
            &all,
            true,
        )
    })
}

/// The runs of consecutive drawable points of `points` (finite, and positive on a log scale):
/// each run is one polyline, so a gap separates runs.
fn runs(points: &[(f64, f64)], log_y: bool) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for &(x, y) in points {
        let drawable = x.is_finite() && y.is_finite() && (!log_y || y > 0.0);
        match out.last_mut() {
            Some(run) if drawable => run.push((x, y)),
            Some(run) if !run.is_empty() => out.push(Vec::new()),
            _ => {}
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

/// Tick label of `v` on an axis whose data are all integers: the integer, or nothing for a
/// tick between integers.
fn integer_tick(v: f64) -> String {
    if (v - v.round()).abs() < 1e-9 {
        format!("{}", v.round() as i64)
    } else {
        String::new()
    }
}

/// A tick label on a linear axis from `lo` to `hi`: [`tidy`], with a tick that is zero up to
/// rounding (the axis's key points are sums of floats: `-6e-17` where 0 was meant) shown as 0.
fn linear_tick(v: f64, lo: f64, hi: f64) -> String {
    if v.abs() <= 1e-9 * (hi - lo).abs() {
        "0".into()
    } else {
        tidy(v)
    }
}

/// A tick label without float noise: up to 4 decimals with trailing zeros dropped
/// (`0.3`, `250`, `0.0125`), or `1e-5`-style for very small or large magnitudes.
fn tidy(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:.0e}");
    }
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

fn chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    colors: &[RGBColor],
    log_y: bool,
) -> Result<()> {
    register_font();
    let err = |e: &dyn std::fmt::Display| anyhow!("cannot draw {}: {e}", path.display());
    let all_runs: Vec<Vec<Vec<(f64, f64)>>> =
        series.iter().map(|s| runs(&s.points, log_y)).collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in all_runs.iter().flatten().flatten() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 {
        return Err(anyhow!(
            "cannot draw {}: no finite{} data",
            path.display(),
            if log_y { ", positive" } else { "" }
        ));
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if y1 <= y0 {
        (y0, y1) = if log_y {
            (y0 / 2.0, y1 * 2.0)
        } else {
            (y0 - 1.0, y1 + 1.0)
        };
    }
    let integer_x = series
        .iter()
        .flat_map(|s| &s.points)
        .all(|p| !p.0.is_finite() || p.0.fract() == 0.0);
    // Points off the log scale, per series, marked on the x axis.
    let off_scale: Vec<Vec<f64>> = series
        .iter()
        .map(|s| {
            s.points
                .iter()
                .filter(|p| log_y && p.0.is_finite() && p.1.is_finite() && p.1 <= 0.0)
                .map(|p| p.0)
                .collect()
        })
        .collect();

    let mut items: Vec<Item> = series
        .iter()
        .zip(colors)
        .map(|(s, &c)| Item {
            label: s.name.to_string(),
            fill: None,
            line: Some(c),
        })
        .collect();
    if off_scale.iter().any(|v| !v.is_empty()) {
        items.push(Item {
            label: "▼ on the x axis: value ≤ 0, off the log scale".into(),
            fill: None,
            line: None,
        });
    }
    let layout = legend::down(&items, SIZE.1 - 80);
    let (width, height) = (SIZE.0 + layout.width() + 10, SIZE.1);
    let mut buffer = crate::canvas(path, width, height)?;
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (width, height)).into_drawing_area();
        let (plot_area, legend_area) = root.split_horizontally(SIZE.0);
        let mut builder = ChartBuilder::on(&plot_area);
        builder
            .caption(title, ("sans-serif", 26))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(80);
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart;
                let x_format = |v: &f64| {
                    if integer_x {
                        integer_tick(*v)
                    } else {
                        linear_tick(*v, x0, x1)
                    }
                };
                let y_format = |v: &f64| {
                    if log_y {
                        tidy(*v)
                    } else {
                        linear_tick(*v, y0, y1)
                    }
                };
                chart
                    .configure_mesh()
                    .x_desc(x_label)
                    .y_desc(y_label)
                    .label_style(("sans-serif", 16))
                    .x_label_formatter(&x_format)
                    .y_label_formatter(&y_format)
                    .axis_desc_style(("sans-serif", 18))
                    .draw()
                    .map_err(|e| err(&e))?;
                for ((runs, &color), marks) in all_runs.iter().zip(colors).zip(&off_scale) {
                    for run in runs {
                        chart
                            .draw_series(LineSeries::new(
                                run.iter().copied(),
                                color.stroke_width(2),
                            ))
                            .map_err(|e| err(&e))?;
                    }
                    chart
                        .draw_series(marks.iter().map(|&x| {
                            EmptyElement::at((x, y0))
                                + Polygon::new(vec![(-5, -9), (5, -9), (0, 0)], color.filled())
                        }))
                        .map_err(|e| err(&e))?;
                }
            }};
        }
        if log_y {
            draw!(builder
                .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
                .map_err(|e| err(&e))?);
        } else {
            draw!(builder
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| err(&e))?);
        }
        legend::draw(&legend_area, (0, 60), &items, layout).map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    crate::save_png(path, &buffer, width, height)
}

/// A PNG chart of each class's volume over time: `volumes[time][class]` at `times` in `unit`
/// (`mL`, `units³`), one line per name in `classes`, in the class's colour ([`class_color`] of
/// its index and of its entry in `colors`, which may be shorter than `classes` or empty).
pub fn volume_chart(
    path: &Path,
    title: &str,
    unit: &str,
    classes: &[String],
    colors: &[Option<[u8; 3]>],
    times: &[f64],
    volumes: &[Vec<f64>],
) -> Result<()> {
    let y = format!("volume ({unit})");
    let axes = ("time", y.as_str());
    class_chart(path, title, axes, classes, colors, times, volumes)
}

/// A PNG chart of one value per class over time, `values[time][class]` at `times` (a class's
/// line skips the times where its value is not finite), with the axis titles `(x, y)` (units
/// included), each class in its colour as in [`volume_chart`].
pub fn class_chart(
    path: &Path,
    title: &str,
    (x_label, y_label): (&str, &str),
    classes: &[String],
    colors: &[Option<[u8; 3]>],
    times: &[f64],
    values: &[Vec<f64>],
) -> Result<()> {
    let series: Vec<Series> = classes
        .iter()
        .enumerate()
        .map(|(c, name)| Series {
            name,
            points: times
                .iter()
                .zip(values)
                .filter_map(|(&t, v)| v.get(c).map(|&y| (t, y)))
                .collect(),
        })
        .collect();
    let colors: Vec<RGBColor> = (0..classes.len())
        .map(|c| class_color(c, colors.get(c).copied().flatten()))
        .collect();
    chart(path, title, x_label, y_label, &series, &colors, false)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pixel(img: &image::RgbImage, x: u32, y: u32) -> [u8; 3] {
        img.get_pixel(x, y).0
    }

    #[test]
    fn draws_a_png_and_rejects_empty_data() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.png");
        let a = Series {
            name: "total",
            points: (1..200).map(|i| (i as f64, 1.0 / i as f64)).collect(),
        };
        let b = Series {
            name: "eikonal",
            points: (1..200)
                .map(|i| (i as f64, 0.5 / (i as f64).sqrt()))
                .collect(),
        };
        line_chart(&path, "loss", "step", "loss", &[a, b], true).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        assert!(
            bytes.len() > 5000,
            "a chart with text and two lines: {} bytes",
            bytes.len()
        );
        let empty = Series {
            name: "x",
            points: vec![(1.0, -1.0)],
        };
        let e = line_chart(&path, "t", "x", "y", &[empty], true).unwrap_err();
        assert!(e.to_string().contains("no finite, positive data"), "{e}");
    }

    #[test]
    fn zeros_on_a_log_scale_split_the_curve_and_are_marked() {
        let points: Vec<(f64, f64)> = (0..10)
            .map(|i| {
                (
                    i as f64,
                    if (3..6).contains(&i) {
                        0.0
                    } else {
                        1.0 + i as f64
                    },
                )
            })
            .collect();
        let r = runs(&points, true);
        assert_eq!(r.len(), 2);
        assert_eq!((r[0].len(), r[1].len()), (3, 4));
        assert_eq!(runs(&points, false).len(), 1);
        assert_eq!(
            runs(&[(0.0, f64::NAN), (1.0, 1.0)], false),
            vec![vec![(1.0, 1.0)]]
        );

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("z.png");
        let s = Series {
            name: "spurious",
            points,
        };
        line_chart(&path, "loss", "step", "loss", &[s], true).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        // The legend panel widens the picture past the 1000-pixel chart, and holds the note.
        assert!(img.width() > 1000);
        let blue = LINES[0];
        let marker = (0..img.height())
            .flat_map(|y| (0..1000).map(move |x| (x, y)))
            .filter(|&(x, y)| pixel(&img, x, y) == [blue.0, blue.1, blue.2])
            .count();
        assert!(marker > 50, "curve and markers drawn: {marker} pixels");
    }

    #[test]
    fn a_tick_at_zero_up_to_rounding_reads_0() {
        assert_eq!(linear_tick(-6e-17, 0.0, 1.0), "0");
        assert_eq!(linear_tick(0.25, 0.0, 1.0), "0.25");
        // On an axis of tiny values a tiny tick is a value, not noise.
        assert_eq!(linear_tick(2e-6, 0.0, 1e-5), "2e-6");
    }

    #[test]
    fn integer_data_gets_integer_ticks() {
        assert_eq!(integer_tick(100.0), "100");
        assert_eq!(integer_tick(-3.0), "-3");
        assert_eq!(integer_tick(2.5), "");
        assert_eq!(tidy(0.30000000000000004), "0.3");
        assert_eq!(tidy(400.0), "400");
        assert_eq!(tidy(0.0125), "0.0125");
        assert_eq!(tidy(2e-5), "2e-5");
        assert_eq!(tidy(-0.00001), "-1e-5");
        assert_eq!(tidy(0.0), "0");
    }

    #[test]
    fn volume_chart_uses_the_class_colours_and_fits_its_legend() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.png");
        let classes: Vec<String> = (0..41).map(|i| format!("structure {i}")).collect();
        let volumes: Vec<Vec<f64>> = (0..3)
            .map(|t| (0..41).map(|c| (c * 10 + t) as f64).collect())
            .collect();
        let colors = [Some([250, 0, 250])];
        volume_chart(
            &path,
            "volumes",
            "mL",
            &classes,
            &colors,
            &[0.0, 0.5, 1.0],
            &volumes,
        )
        .unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        let count = |c: [u8; 3]| img.pixels().filter(|p| p.0 == c).count();
        // Class 0 in its given colour, class 1 in the palette's second colour.
        assert!(count([250, 0, 250]) > 100);
        let c1 = class_color(1, None);
        assert!(count([c1.0, c1.1, c1.2]) > 100);
        // 41 entries do not fit one column of 600 px: the legend has several columns.
        assert!(img.width() > 1000 + 2 * 100, "{}", img.width());
        // A short row of volumes is not an index out of bounds.
        volume_chart(&path, "v", "mL", &classes, &[], &[0.0], &[vec![1.0]]).unwrap();
    }
}
