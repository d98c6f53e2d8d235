//! A model's report assembled from its file and its measurement ([`assemble`]): the input it
//! was trained on, the training (run record, loss curve), the classes, the figures of
//! `dynaslice measure` as charts and tables (per class over the cycle and per time, digit for
//! digit those of its CSV), and the surfaces in an interactive 3D view and as pictures. One
//! call, so the command line, Python and the lab make the same page.

use crate::{viewer, Block, Cell, Document, Section, Table};
use anyhow::{Context, Result};
use dynaslice_core::Model;
use dynaslice_figures::display::Display;
use dynaslice_figures::picture::{longest_plane, match_classes, plane_labels, Panel};
use dynaslice_figures::plot::{class_chart, line_chart, Series};
use dynaslice_figures::render3d::{self, RenderOptions, SurfacePanel};
use dynaslice_mesh::Mesh;
use dynaslice_metrics::measurement::Measurement;
use dynaslice_metrics::motion::{round, Units, RIGID_WITHIN};
use dynaslice_model::ModelFile;
use dynaslice_sequence::{Frame, Plane, Sequence};
use std::path::Path;

/// Draws a figure (a PNG, by the closure given the path to write) and returns its bytes.
type Figure<'a> = dyn Fn(&str, &dyn Fn(&Path) -> Result<()>) -> Result<Vec<u8>> + 'a;

/// Panels of the 3D picture: enough to see the motion, few enough to stay readable.
const PICTURE_TIMES: usize = 4;

/// The report of `file`'s model measured as `m` ([`Measurement::of_file`] at its times and
/// resolution), with the loss curve of `loss_log` (the `MODEL.dsm.loss.csv` a training run
/// writes beside the model; a note says so where it is `None` or absent). An error where the
/// loss log is there but not a loss log, or a figure cannot be drawn.
pub fn assemble(file: &ModelFile, m: &Measurement, loss_log: Option<&Path>) -> Result<Document> {
    assemble_with_input(file, m, loss_log, None)
}

/// The input a report's plane view is drawn on: the cross-sections the model was trained on,
/// read as it was trained.
pub struct Input<'a> {
    /// The cross-sections.
    pub sequence: &'a Sequence,
    /// The input as the page names it (e.g. its files).
    pub name: String,
}

/// [`assemble`] with the plane view of the 3D view drawn on `input` (`None`: no plane view, and
/// the page says how to get one): one input plane, the first frame's with the most contour, with
/// the model's labels at each measured time and the contours where that time is annotated.
pub fn assemble_with_input(
    file: &ModelFile,
    m: &Measurement,
    loss_log: Option<&Path>,
    input: Option<&Input>,
) -> Result<Document> {
    // Figures are drawn by dynaslice-figures into files; they are read back and inlined.
    let dir = tempfile::tempdir().context("cannot create a temporary folder for the figures")?;
    let figure = |name: &str, draw: &dyn Fn(&Path) -> Result<()>| -> Result<Vec<u8>> {
        let path = dir.path().join(name);
        draw(&path)?;
        std::fs::read(&path).with_context(|| format!("cannot read {}", path.display()))
    };
    let path = file.path();
    let name = path.display().to_string();
    let times = &m.motion.times;
    let sections = vec![
        input_section(file, m),
        training_section(file, loss_log, &figure)?,
        classes_section(m),
        if file.is_static() {
            static_section(m)
        } else {
            figures_section(m, &figure)?
        },
        surfaces_section(file, m, input, &figure)?,
    ];
    Ok(Document {
        title: format!("DynaSlice report: {}", file_name(path)),
        subtitle: if file.is_static() {
            format!(
                "model {name}; a static model (trained on one timestep: the same at every \
                 time), measured once on meshes of {} cells along the longest axis",
                m.resolution
            )
        } else {
            format!(
                "model {name}; {} times from {} to {}; measured on meshes of {} cells along \
                 the longest axis",
                times.len(),
                times[0],
                times[times.len() - 1],
                m.resolution
            )
        },
        sections,
    })
}

fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into(),
    )
}

fn input_section(file: &ModelFile, m: &Measurement) -> Section {
    let model = file.model();
    let record = file.record();
    let get = |value: &Option<String>| value.clone().unwrap_or_else(|| "not recorded".into());
    let (lo, hi) = model.domain().bounds();
    let (t0, t1) = model.domain().time_range();
    let l = m.units.length();
    let [x, y, z] = m.positive();
    Section {
        heading: "Input".into(),
        blocks: vec![Block::Facts(vec![
            ("trained on".into(), get(&record.input)),
            ("frames".into(), get(&record.frames)),
            (
                "units".into(),
                match m.units {
                    Units::Millimetres => "millimetres (volumes in mL)".into(),
                    Units::Plain => "the input's plain units (it names none)".into(),
                },
            ),
            (
                "patient frame".into(),
                format!("{} (+x {x}, +y {y}, +z {z})", m.space_name()),
            ),
            (
                "model box (RAS world)".into(),
                format!(
                    "[{:.2}, {:.2}, {:.2}] to [{:.2}, {:.2}, {:.2}] {l}",
                    lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
                ),
            ),
            ("time range".into(), format!("{t0} to {t1}")),
            ("classes".into(), model.num_classes().to_string()),
        ])],
    }
}

fn training_section(file: &ModelFile, loss_log: Option<&Path>, figure: &Figure) -> Result<Section> {
    let facts: Vec<(String, String)> = file
        .record()
        .entries()
        .into_iter()
        .filter(|(k, _)| !["input", "frames", "class_colors"].contains(&k.as_str()))
        .collect();
    let mut blocks = vec![if facts.is_empty() {
        Block::Paragraph("The model file records no training metadata.".into())
    } else {
        Block::Facts(facts)
    }];
    let text = loss_log.map(|p| (p, std::fs::read_to_string(p)));
    match text {
        Some((loss_csv, Ok(text))) => {
            let (names, rows) = parse_loss(&text)
                .with_context(|| format!("{}: not a loss log", loss_csv.display()))?;
            let series: Vec<Series> = names
                .iter()
                .enumerate()
                .map(|(c, name)| Series {
                    name,
                    points: rows.iter().map(|r| (r[0], r[c + 1])).collect(),
                })
                .collect();
            let png = figure("loss.png", &|p| {
                line_chart(p, "training loss", "step", "loss", &series, true)
            })?;
            blocks.push(Block::Image {
                png,
                caption: format!(
                    "Loss per step ({} steps, log scale), from {}",
                    rows.len(),
                    loss_csv.display()
                ),
            });
        }
        Some((loss_csv, Err(_))) => blocks.push(Block::Paragraph(format!(
            "No loss log beside the model ({} is absent): no loss curve.",
            loss_csv.display()
        ))),
        None => blocks.push(Block::Paragraph(
            "No loss log was given: no loss curve.".into(),
        )),
    }
    Ok(Section {
        heading: "Training".into(),
        blocks,
    })
}

/// A loss log's column names (after `step`) and rows (step first); an error for anything
/// but a header and rows of numbers.
fn parse_loss(text: &str) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header: Vec<String> = lines
        .next()
        .context("empty")?
        .split(',')
        .map(|s| s.trim().to_string())
        .collect();
    anyhow::ensure!(
        header.len() >= 2 && header[0] == "step",
        "the header does not start with step"
    );
    let rows = lines
        .enumerate()
        .map(|(i, l)| {
            let row: Vec<f64> = l
                .split(',')
                .map(|v| v.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .with_context(|| format!("line {}: not numbers", i + 2))?;
            anyhow::ensure!(
                row.len() == header.len(),
                "line {}: {} values for {} columns",
                i + 2,
                row.len(),
                header.len()
            );
            Ok(row)
        })
        .collect::<Result<Vec<_>>>()?;
    anyhow::ensure!(!rows.is_empty(), "no rows");
    Ok((header[1..].to_vec(), rows))
}

fn classes_section(m: &Measurement) -> Section {
    let rows = m
        .classes
        .iter()
        .enumerate()
        .map(|(k, c)| {
            vec![
                (k + 1).to_string().into(),
                c.name.clone().into(),
                c.label.to_string().into(),
                Cell::Swatch(m.colors[k]),
                if c.color.is_some() {
                    "the input's"
                } else {
                    "palette"
                }
                .into(),
            ]
        })
        .collect();
    Section {
        heading: "Classes".into(),
        blocks: vec![Block::Table(Table {
            header: ["channel", "name", "label", "colour", "colour from"]
                .map(String::from)
                .to_vec(),
            rows,
        })],
    }
}

fn figures_section(m: &Measurement, figure: &Figure) -> Result<Section> {
    let motion = &m.motion;
    let names = &motion.classes;
    let colors: Vec<Option<[u8; 3]>> = m.colors.iter().map(|&c| Some(c)).collect();
    let (v, l) = (m.units.volume(), m.units.length());
    let x_axis = m.time_axis();
    let volumes: Vec<Vec<f64>> = motion
        .shapes
        .iter()
        .map(|s| s.iter().map(|c| m.volume(c.volume)).collect())
        .collect();
    let volume_png = figure("volume.png", &|p| {
        class_chart(
            p,
            "volume over time",
            (x_axis, &format!("volume ({v})")),
            names,
            &colors,
            &motion.times,
            &volumes,
        )
    })?;
    let mut blocks = vec![Block::Image {
        png: volume_png,
        caption: format!("Each class's volume in {v} over {x_axis}."),
    }];
    let axes = if m.is_anatomical() {
        ["left–right", "anterior–posterior", "superior–inferior"]
    } else {
        ["x", "y", "z"]
    };
    let positive = m.positive();
    for a in 0..3 {
        // Each centroid relative to its mean over the times: the motion, on one scale for all.
        let coordinate =
            |f: usize, k: usize| motion.shapes[f][k].centroid.map(|c| m.from_world(c)[a]);
        let means: Vec<f64> = (0..names.len())
            .map(|k| {
                let present: Vec<f64> = (0..motion.times.len())
                    .filter_map(|f| coordinate(f, k))
                    .collect();
                present.iter().sum::<f64>() / present.len().max(1) as f64
            })
            .collect();
        let values: Vec<Vec<f64>> = (0..motion.times.len())
            .map(|f| {
                (0..names.len())
                    .map(|k| coordinate(f, k).map_or(f64::NAN, |c| c - means[k]))
                    .collect()
            })
            .collect();
        let y = format!("displacement towards {} ({l})", positive[a]);
        let png = figure(&format!("trajectory{a}.png"), &|p| {
            class_chart(
                p,
                &format!("centroid trajectory, {}", axes[a]),
                (x_axis, &y),
                names,
                &colors,
                &motion.times,
                &values,
            )
        })?;
        blocks.push(Block::Image {
            png,
            caption: format!(
                "Centroid {} displacement in {l} (positive towards {}, {} frame), relative to \
                 its mean over the times.",
                axes[a],
                positive[a],
                m.space_name()
            ),
        });
    }
    let mut header: Vec<String> = [
        "class".to_string(),
        format!("min volume ({v})"),
        "at time".into(),
        format!("max volume ({v})"),
        "at time".into(),
        format!("volume change ({v})"),
        "(max − min) / max".into(),
        "volume".into(),
    ]
    .to_vec();
    header.extend(
        m.axis_names()
            .iter()
            .map(|a| format!("{a} peak-to-peak ({l})")),
    );
    let rows = names
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let c = m.cycle(k);
            let mut row: Vec<Cell> = vec![
                name.clone().into(),
                m.volume(c.min.volume).to_string().into(),
                c.min.time.to_string().into(),
                m.volume(c.max.volume).to_string().into(),
                c.max.time.to_string().into(),
                m.volume(c.volume_change).to_string().into(),
                c.relative_change
                    .map_or("-".into(), |e| round(e).to_string())
                    .into(),
                if c.is_rigid() { "rigid" } else { "changes" }.into(),
            ];
            row.extend((0..3).map(|a| {
                c.amplitude
                    .map_or("-".into(), |amp| round(amp[a]).to_string())
                    .into()
            }));
            row
        })
        .collect();
    blocks.push(Block::Paragraph(format!(
        "Over the {} times: the smallest and largest volume (end-systolic and end-diastolic for a \
         ventricle), the volume change max − min and its share of the largest, (max − min) / max \
         (the stroke volume and the ejection fraction for a ventricle), and the centroid's \
         peak-to-peak range along each axis. A class whose volume changes by less than {:.0} % \
         is rigid: its volume is constant within what the measuring resolves, and its change \
         is no stroke volume.",
        motion.times.len(),
        100.0 * RIGID_WITHIN
    )));
    blocks.push(Block::Table(Table { header, rows }));
    // The per-time table is the CSV of `dynaslice measure`, cell for cell.
    let csv = m.to_csv();
    let mut lines = csv.lines();
    let header = lines
        .next()
        .unwrap_or_default()
        .split(',')
        .map(String::from)
        .collect();
    let rows = lines
        .map(|l| split_csv(l).into_iter().map(Cell::Text).collect())
        .collect();
    blocks.push(Block::Paragraph(format!(
        "Per time and class (the table `dynaslice measure -o table.csv` writes): volume in {v}, \
         centroid and bounding box in {l}, {} frame.",
        m.space_name()
    )));
    blocks.push(Block::Table(Table { header, rows }));
    Ok(Section {
        heading: "Motion and function".into(),
        blocks,
    })
}

/// A static model's figures: no time axis, so no charts over time, no cycle (volume change,
/// motion): each class's volume, centroid and bounding box, once.
fn static_section(m: &Measurement) -> Section {
    let (v, l) = (m.units.volume(), m.units.length());
    let header = [
        "class".to_string(),
        format!("volume ({v})"),
        format!("centroid ({l})"),
        format!("bounding box ({l})"),
    ]
    .to_vec();
    let xyz = |p: [f64; 3]| {
        let p = m.from_world(p).map(round);
        format!("({}, {}, {})", p[0], p[1], p[2])
    };
    let rows = m
        .motion
        .classes
        .iter()
        .enumerate()
        .map(|(k, name)| {
            let shape = &m.motion.shapes[0][k];
            vec![
                name.clone().into(),
                round(m.volume(shape.volume)).to_string().into(),
                shape.centroid.map_or("-".into(), xyz).into(),
                shape
                    .bounds
                    .map_or("-".into(), |(lo, hi)| format!("{} to {}", xyz(lo), xyz(hi)))
                    .into(),
            ]
        })
        .collect();
    Section {
        heading: "Structures".into(),
        blocks: vec![
            Block::Paragraph(format!(
                "A static model (trained on one timestep) is the same at every time: each \
                 class's volume in {v}, centroid and bounding box in {l} ({} frame), measured \
                 once. It has no motion and no volume change.",
                m.space_name()
            )),
            Block::Table(Table { header, rows }),
        ],
    }
}

/// The fields of one CSV line (quoted fields unquoted, `""` inside them a quote).
fn split_csv(line: &str) -> Vec<String> {
    let mut fields = vec![String::new()];
    let (mut quoted, mut chars) = (false, line.chars().peekable());
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                fields.last_mut().expect("one field").push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => fields.push(String::new()),
            (c, _) => fields.last_mut().expect("one field").push(c),
        }
    }
    fields
}

fn surfaces_section(
    file: &ModelFile,
    m: &Measurement,
    input: Option<&Input>,
    figure: &Figure,
) -> Result<Section> {
    let resolution = m.resolution;
    let model = file.model();
    let all = &m.motion.times;
    // Times spread over the measured ones (all of them when there are few).
    let n = PICTURE_TIMES.min(all.len());
    let times: Vec<f32> = (0..n)
        .map(|i| {
            all[if n == 1 {
                0
            } else {
                i * (all.len() - 1) / (n - 1)
            }] as f32
        })
        .collect();
    let channels: Vec<usize> = (0..model.num_classes()).collect();
    let options = dynaslice_mesh::Options {
        resolution,
        ..dynaslice_mesh::Options::default()
    };
    let meshes = times
        .iter()
        .map(|&t| surfaces(&model, t, &channels, &options))
        .collect::<Result<Vec<_>>>()?;
    let panels = SurfacePanel::per_time(&times, &meshes);
    let png = figure("surfaces.png", &|p| {
        render3d::render_surfaces(p, &panels, &file.classes(), &RenderOptions::default())
    })?;
    Ok(Section {
        heading: "Surfaces".into(),
        blocks: vec![
            interactive_view(file, m, &channels, input, figure)?,
            Block::Image {
                png,
                caption: format!(
                    "The classes' surfaces at {} times, seen from the front, a little to the \
                 patient's right and above (superior up; `dynaslice picture --3d`).",
                    times.len()
                ),
            },
        ],
    })
}

/// The surfaces of `channels` at world time `t` over the model's bounds.
fn surfaces(
    model: &Model,
    t: f32,
    channels: &[usize],
    options: &dynaslice_mesh::Options,
) -> Result<Vec<Mesh>> {
    let bounds = model.domain().bounds();
    Ok(dynaslice_mesh::extract(model, bounds, t, channels, options)?.meshes)
}

/// Lattice cells of the interactive view's meshes at the most: the view decimates them to its
/// byte budget anyway, and every measured time is meshed again for it.
const VIEW_RESOLUTION: u32 = 64;

/// The interactive 3D view (dynaslice_report::viewer): every class's surface and volume at
/// every measured time.
fn interactive_view(
    file: &ModelFile,
    m: &Measurement,
    channels: &[usize],
    input: Option<&Input>,
    figure: &Figure,
) -> Result<Block> {
    let model = &file.model();
    let options = dynaslice_mesh::Options {
        resolution: m.resolution.min(VIEW_RESOLUTION),
        ..dynaslice_mesh::Options::default()
    };
    let motion = &m.motion;
    let snapshots = motion
        .times
        .iter()
        .zip(&motion.shapes)
        .map(|(&t, shapes)| {
            let meshes = surfaces(model, t as f32, channels, &options)?;
            Ok(viewer::Snapshot {
                time: t,
                surfaces: meshes
                    .into_iter()
                    .map(|mesh| viewer::Surface {
                        positions: mesh.positions,
                        triangles: mesh.triangles,
                    })
                    .collect(),
                volumes: shapes.iter().map(|c| Some(m.volume(c.volume))).collect(),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let scene = viewer::Scene {
        classes: m
            .classes
            .iter()
            .zip(&m.colors)
            .map(|(c, &color)| viewer::Class {
                name: c.name.clone(),
                color,
            })
            .collect(),
        snapshots,
        time_label: format!("{}:", m.time_axis()),
        volume_unit: m.units.volume().to_string(),
        plane: match input {
            Some(input) => plane_view(file, m, input, figure)?,
            None => None,
        },
    };
    let mut html = viewer::render(&scene);
    if input.is_none() {
        html.push_str(
            "<p>No plane view: the report was made without the model's input. Give it \
             (<code>dynaslice report MODEL INPUT… -o REPORT.html</code>, read as the model was \
             trained) to see an input plane with its contours and the predicted labels follow \
             the slider.</p>\n",
        );
    }
    Ok(Block::Html(html))
}

/// The plane view: the first frame's plane with the most contour ([`longest_plane`]), with the
/// model's labels (Eq. 11) at every measured time, and the contours of that plane where a
/// frame of the input is at that time (`None`: the input has no plane).
fn plane_view(
    file: &ModelFile,
    m: &Measurement,
    input: &Input,
    figure: &Figure,
) -> Result<Option<viewer::PlaneView>> {
    let frames = input.sequence.frames();
    let Some((first, index)) = frames
        .first()
        .and_then(|f| longest_plane(f).map(|i| (f, i)))
    else {
        return Ok(None);
    };
    let plane = &first.planes[index];
    let model = file.model();
    let classes = file.classes();
    let drawn_as = match_classes(&classes, input.sequence.classes());
    let unit = file.units().length();
    let span = frames.last().map_or(0.0, |l| l.time - first.time).abs();
    let pngs = m
        .motion
        .times
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let panel = annotated_at(frames, plane, t, span).unwrap_or(Panel::unannotated(t));
            let panel = Panel { time: t, ..panel };
            figure(&format!("plane-{i}.png"), &|path| {
                plane_labels(
                    &model,
                    &classes,
                    &drawn_as,
                    plane,
                    std::slice::from_ref(&panel),
                    unit,
                    Display::default(),
                    path,
                )
            })
        })
        .collect::<Result<Vec<_>>>()
        .with_context(|| format!("the plane view on {}", input.name))?;
    Ok(Some(viewer::PlaneView {
        caption: format!(
            "Plane {index} of the first frame of {} (its plane with the most contour): the \
             model's labels (fill) at the time shown, with the input's contours (lines) where \
             that time is annotated.",
            input.name
        ),
        pngs,
    }))
}

/// The panel of the frame at time `t` (within a small part of the input's time `span`) on the
/// plane where `plane` lies, if one is.
fn annotated_at<'a>(frames: &'a [Frame], plane: &Plane, t: f64, span: f64) -> Option<Panel<'a>> {
    let frame = frames
        .iter()
        .find(|f| (f.time - t).abs() <= 1e-6 * (1.0 + span.max(t.abs())))?;
    let scale =
        1.0 + (plane.roi.max[0] - plane.roi.min[0]).hypot(plane.roi.max[1] - plane.roi.min[1]);
    let near = |a: [f64; 3], b: [f64; 3], tol: f64| (0..3).all(|k| (a[k] - b[k]).abs() <= tol);
    let index = frame.planes.iter().position(|p| {
        near(p.u, plane.u, 1e-6)
            && near(p.v, plane.v, 1e-6)
            && near(p.origin, plane.origin, 1e-6 * scale)
    })?;
    Some(Panel::annotated(frame, index))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_fields_and_loss_logs_parse() {
        assert_eq!(split_csv("0,\"a, \"\"b\"\"\",3"), ["0", "a, \"b\"", "3"]);
        let (names, rows) = parse_loss("step,total,surface\n0,1.5,1\n1,0.5,0.25\n").unwrap();
        assert_eq!(names, ["total", "surface"]);
        assert_eq!(rows[1], [1.0, 0.5, 0.25]);
        assert!(parse_loss("time,x\n0,1\n").is_err());
        assert!(parse_loss("step,x\n0,a\n").is_err());
        assert!(parse_loss("step,x\n0\n").is_err());
    }
}
