//! PNG line charts (loss curves, volume curves), drawn with plotters and the bundled DejaVu Sans
//! font so they render identically on machines without any system font.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

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

/// Writes a 1000×600 PNG chart of `series` (log-scaled y when `log_y`; non-positive values are
/// then left out).
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_y: bool,
) -> Result<()> {
    register_font();
    let err = |e: &dyn std::fmt::Display| anyhow!("cannot draw {}: {e}", path.display());
    let keep = |y: f64| y.is_finite() && (!log_y || y > 0.0);
    let points = series
        .iter()
        .flat_map(|s| s.points.iter().filter(|p| keep(p.1)));
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in points {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 {
        return Err(anyhow!("cannot draw {}: no finite data", path.display()));
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
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut builder = ChartBuilder::on(&root);
    builder
        .caption(title, ("sans-serif", 26))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(80);
    let palette = [
        BLUE,
        RED,
        RGBColor(0, 150, 0),
        MAGENTA,
        CYAN,
        BLACK,
        RGBColor(230, 140, 0),
        RGBColor(120, 80, 40),
    ];
    macro_rules! draw {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(x_label)
                .y_desc(y_label)
                .label_style(("sans-serif", 16))
                .y_label_formatter(&|v| {
                    if log_y {
                        format!("{v:.0e}")
                    } else {
                        format!("{v:.3}")
                    }
                })
                .axis_desc_style(("sans-serif", 18))
                .draw()
                .map_err(|e| err(&e))?;
            for (i, s) in series.iter().enumerate() {
                let color = palette[i % palette.len()];
                let line = s.points.iter().copied().filter(|p| keep(p.1));
                chart
                    .draw_series(LineSeries::new(line, color.stroke_width(2)))
                    .map_err(|e| err(&e))?
                    .label(s.name)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                    });
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 16))
                .draw()
                .map_err(|e| err(&e))?;
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
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// A PNG chart of each class's volume over time: `volumes[time][class]` at `times`, one line
/// per name in `classes`.
pub fn volume_chart(
    path: &Path,
    title: &str,
    classes: &[String],
    times: &[f64],
    volumes: &[Vec<f64>],
) -> Result<()> {
    let series: Vec<Series> = classes
        .iter()
        .enumerate()
        .map(|(c, name)| Series {
            name,
            points: times.iter().zip(volumes).map(|(&t, v)| (t, v[c])).collect(),
        })
        .collect();
    line_chart(path, title, "time", "volume (world units³)", &series, false)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        assert!(line_chart(&path, "t", "x", "y", &[empty], true).is_err());
    }

    #[test]
    fn volume_chart_draws_one_line_per_class() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.png");
        let classes = ["a".to_string(), "b".to_string()];
        let volumes = [vec![1.0, 2.0], vec![1.5, 2.0], vec![2.0, 2.0]];
        volume_chart(&path, "volumes", &classes, &[0.0, 0.5, 1.0], &volumes).unwrap();
        assert!(std::fs::read(&path).unwrap().starts_with(b"\x89PNG"));
    }
}
