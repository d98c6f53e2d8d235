//! `dynaslice mesh MODEL.dsm --time T -o OUT.ply` (or `--times A:B:N -o DIR`): the zero-level
//! sets of a model's classes as closed triangle meshes in world coordinates. Method, file names
//! and attributes: docs/meshing.md.

use super::model::ModelFile;
use anyhow::{bail, Context, Result};
use dynaslice_core::Model;
use dynaslice_data::atomic::write_atomically;
use dynaslice_data::TimeSeries;
use dynaslice_mesh::io::{self, pvd, Format};
use dynaslice_mesh::{self as mesh, Extraction, Options, Sampling, Surfaces, DEFAULT_SAFETY};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `dynaslice mesh`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Model file (.dsm).
    model: PathBuf,
    /// World time of the meshes (the model's time units; any time in its range).
    #[arg(long, allow_negative_numbers = true, required_unless_present = "times")]
    time: Option<f32>,
    /// A series: N times evenly spaced from A to B inclusive; -o is then a directory.
    #[arg(
        long,
        value_name = "A:B:N",
        conflicts_with = "time",
        allow_hyphen_values = true
    )]
    times: Option<TimeSeries>,
    /// Class to mesh, by number (1..K) or name; repeat for several. Default: every class.
    #[arg(long = "class", value_name = "K")]
    classes: Vec<String>,
    /// Lattice cells along the longest axis of the model's bounds.
    #[arg(long, default_value_t = 128)]
    resolution: u32,
    /// Output: a .ply, .obj, .stl or .vtp file with --time, a directory with --times.
    #[arg(short, long, value_name = "OUT")]
    output: PathBuf,
    /// File format of a series (ply, obj, stl, vtp); a single file takes its extension's.
    #[arg(long, default_value = "vtp", value_parser = parse_format)]
    format: Format,
    /// Non-overlapping surfaces: the boundaries of the Eq. 11 label partition, shared by
    /// neighbouring classes.
    #[arg(long)]
    non_overlapping: bool,
    /// Safety factor s of the distance bound: a cell is skipped when |f| at a corner exceeds
    /// s times the distance it must cover (≥ 1; larger is safer for models far from ‖∇f‖ = 1).
    #[arg(long, default_value_t = DEFAULT_SAFETY)]
    safety: f32,
    /// Evaluate the network at every lattice vertex instead (a slow check of the sparse result).
    #[arg(long)]
    dense: bool,
    /// Newton steps per vertex along ∇ₓf (0: linear interpolation on the lattice edges).
    #[arg(long, default_value_t = 1)]
    newton_steps: u32,
    /// Worker threads (default: one per core).
    #[arg(long)]
    threads: Option<usize>,
}

fn parse_format(s: &str) -> Result<Format, String> {
    Format::from_name(s).ok_or_else(|| format!("unknown format {s:?}; use ply, obj, stl or vtp"))
}

/// The 0-based channels of the `--class` values (numbers or names), all classes by default.
fn resolve_classes(model: &Model, path: &Path, wanted: &[String]) -> Result<Vec<usize>> {
    let classes: Vec<_> = model.classes().collect();
    if wanted.is_empty() {
        return Ok((0..classes.len()).collect());
    }
    let mut out = Vec::new();
    for w in wanted {
        let by_number = w
            .parse::<usize>()
            .ok()
            .filter(|k| (1..=classes.len()).contains(k))
            .map(|k| k - 1);
        let by_name = || classes.iter().position(|c| c.name == w.as_str());
        match by_number.or_else(by_name) {
            Some(k) if !out.contains(&k) => out.push(k),
            Some(_) => {}
            None => {
                let list: Vec<String> = classes
                    .iter()
                    .enumerate()
                    .map(|(i, c)| format!("{} {:?}", i + 1, c.name))
                    .collect();
                bail!(
                    "{}: no class {w:?}; its classes are {}",
                    path.display(),
                    list.join(", ")
                );
            }
        }
    }
    Ok(out)
}

/// The class part of file names: `class{k}_{name}` with the name reduced to [A-Za-z0-9-].
fn class_tag(k: usize, name: &str) -> String {
    let slug: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '-'
            }
        })
        .collect();
    let slug = slug.trim_matches('-');
    if slug.is_empty() {
        format!("class{}", k + 1)
    } else {
        format!("class{}_{slug}", k + 1)
    }
}

pub fn run(args: Args) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start worker threads")?;
    pool.install(|| mesh_all(&args))
}

fn mesh_all(args: &Args) -> Result<()> {
    let file = ModelFile::open(&args.model)?;
    let model = file.model();
    let classes = resolve_classes(&model, &args.model, &args.classes)?;
    let names: Vec<String> = model.classes().map(|c| c.name.to_string()).collect();
    let (t0, t1) = model.domain().time_range();
    let times = match (&args.times, args.time) {
        // The network takes f32 times (the f64 series rounded once).
        (Some(series), _) => series.times().into_iter().map(|t| t as f32).collect(),
        (None, Some(t)) => vec![t],
        (None, None) => bail!("give --time T or --times A:B:N"),
    };
    // The network is only fitted on its time range; outside it, it extrapolates freely.
    let slack = 1e-4 * (t1 - t0).abs().max(1e-6);
    if let Some(t) = times.iter().find(|&&t| t < t0 - slack || t > t1 + slack) {
        bail!(
            "{}: time {t} is outside the model's time range [{t0}, {t1}]",
            args.model.display()
        );
    }
    let options = Options {
        resolution: args.resolution,
        sampling: if args.dense {
            Sampling::Dense
        } else {
            Sampling::Sparse {
                safety: args.safety,
            }
        },
        surfaces: if args.non_overlapping {
            Surfaces::Partition
        } else {
            Surfaces::Overlapping
        },
        newton_steps: args.newton_steps,
    };
    // Where each (time, class) mesh goes.
    let series = args.times.is_some();
    let format = if series {
        std::fs::create_dir_all(&args.output)
            .with_context(|| format!("cannot create directory {}", args.output.display()))?;
        args.format
    } else {
        Format::from_path(&args.output)?
    };
    let path_of = |i: usize, k: usize| -> PathBuf {
        let tag = class_tag(k, &names[k]);
        if series {
            args.output
                .join(format!("{tag}_t{i:04}.{}", format.extension()))
        } else if classes.len() == 1 {
            args.output.clone()
        } else {
            let stem = args
                .output
                .file_stem()
                .unwrap_or_default()
                .to_string_lossy();
            args.output
                .with_file_name(format!("{stem}_{tag}.{}", format.extension()))
        }
    };

    let bar = (series && std::io::stderr().is_terminal()).then(|| {
        let bar = ProgressBar::new(times.len() as u64);
        bar.set_style(
            ProgressStyle::with_template(
                "{elapsed_precise} [{bar:30}] {pos}/{len} times ETA {eta}",
            )
            .expect("valid template")
            .progress_chars("=> "),
        );
        bar
    });
    let bounds = model.domain().bounds();
    let mut entries = Vec::new();
    let (mut values, mut jacobians, mut dense) = (0u64, 0u64, 0u64);
    let started = Instant::now();
    for (i, &t) in times.iter().enumerate() {
        let start = Instant::now();
        let Extraction {
            meshes,
            lattice,
            stats,
        } = mesh::extract(&model, bounds, t, &classes, &options)?;
        let seconds = start.elapsed().as_secs_f64();
        values += stats.value_evaluations;
        jacobians += stats.jacobian_evaluations;
        dense += stats.dense_evaluations;
        let report = |line: String| match &bar {
            Some(bar) => bar.println(line),
            None => eprintln!("{line}"),
        };
        report(format!(
            "t = {t}: {}x{}x{} cells of {:.4}, {} value + {} jacobian evaluations \
             (dense grid: {} values, {:.1}x more), {seconds:.2} s",
            lattice.cells[0],
            lattice.cells[1],
            lattice.cells[2],
            lattice.h,
            stats.value_evaluations,
            stats.jacobian_evaluations,
            stats.dense_evaluations,
            stats.dense_evaluations as f64 / stats.value_evaluations.max(1) as f64
        ));
        for (mesh, &k) in meshes.iter().zip(&classes) {
            let path = path_of(i, k);
            let topology = mesh.topology();
            report(format!(
                "  class {} ({}): {} vertices, {} triangles, volume {:.6}, area {:.6}{} -> {}",
                k + 1,
                names[k],
                mesh.positions.len(),
                mesh.triangles.len(),
                mesh.enclosed_volume(),
                mesh.area(),
                if topology.is_closed_manifold() {
                    String::new()
                } else {
                    format!(" (NOT a closed manifold: {topology:?})")
                },
                path.display()
            ));
            io::write(&path, mesh, format, &names[k])?;
            entries.push(pvd::Entry {
                time: t,
                part: k as u32 + 1,
                file: path
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned(),
            });
        }
        if let Some(bar) = &bar {
            bar.inc(1);
        }
    }
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    if series {
        if format == Format::Vtp {
            let path = args.output.join("series.pvd");
            write_atomically(&path, pvd::encode(&entries).as_bytes())?;
            eprintln!("wrote {}", path.display());
        } else {
            eprintln!(
                "no series.pvd: ParaView collections list VTK XML files only (use --format vtp)"
            );
        }
    }
    if times.len() > 1 {
        eprintln!(
            "{} times in {:.1} s: {values} value + {jacobians} jacobian evaluations (dense: {dense} values, {:.1}x more)",
            times.len(),
            started.elapsed().as_secs_f64(),
            dense as f64 / values.max(1) as f64
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn class_tags_are_file_name_safe() {
        assert_eq!(class_tag(0, "LV blood pool"), "class1_LV-blood-pool");
        assert_eq!(class_tag(2, "myo/cardium"), "class3_myo-cardium");
        assert_eq!(class_tag(1, "??"), "class2");
    }
}
