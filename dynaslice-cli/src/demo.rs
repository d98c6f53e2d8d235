//! `dynaslice demo`: the main job on the built-in default data, as a script of ordinary
//! subcommands (each printed before it runs, so the demo also shows how to use the tool).

use super::console::errln;
use super::options::{
    count, positive_f64_to, MAX_CHAMFER_SAMPLES, MAX_MESH_RESOLUTION, MAX_MINUTES, MAX_STEPS,
};
use super::widths::check_widths;
use super::{parse_line, run_line};
use anyhow::Result;
use dynaslice_core::format::MAX_WIDTH;
use dynaslice_mesh::lattice::MIN_RESOLUTION;
use dynaslice_output::prepare_owned_folder;
use std::path::PathBuf;
use std::time::Instant;

/// The file marking a folder the demo made (dynaslice_output::folder).
const DEMO_MARK: &str = ".dynaslice-demo";

/// Arguments of `dynaslice demo`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Output directory. The demo creates and marks it (a `.dynaslice-demo` file); a second
    /// run into a folder it marked replaces the first one's outputs there. An existing folder
    /// holding other files is refused unless --force.
    #[arg(short, long, default_value = "dynaslice-demo")]
    output: PathBuf,
    /// Write into an existing folder the demo did not make, replacing any of its files named
    /// like the demo's outputs (model.dsm, labels.nii.gz, data/, meshes/, …).
    #[arg(long)]
    force: bool,
    /// Training steps (the learning-rate schedule spans them).
    #[arg(long, default_value_t = 1000, value_parser = count(1, MAX_STEPS))]
    steps: u64,
    /// Cap on training time, minutes: training stops there even short of --steps (default: no
    /// cap, every step runs).
    #[arg(long, value_parser = positive_f64_to(MAX_MINUTES), allow_negative_numbers = true)]
    minutes: Option<f64>,
    /// Widths of the sine layers.
    #[arg(long, value_delimiter = ',', default_value = "256,256,256,256",
          value_parser = count(1, MAX_WIDTH as u32))]
    widths: Vec<u32>,
    /// Mesh resolution (cells along the longest axis), also of the 3D picture's meshes and the
    /// cells per axis of the 3D IoU grid; the exact shapes are meshed at twice this for the Chamfer distance.
    #[arg(long, default_value_t = 96, value_parser = count(MIN_RESOLUTION, MAX_MESH_RESOLUTION / 2))]
    resolution: u32,
    /// Area-uniform samples per surface for the Chamfer distance.
    #[arg(long, default_value_t = dynaslice_metrics::chamfer::DEFAULT_SAMPLES,
          value_parser = count(1, MAX_CHAMFER_SAMPLES))]
    samples: usize,
}

/// Runs `dynaslice demo`: synth, train, mesh, labels, eval volume, eval synthetic, picture and
/// picture --3d on the chambers shape, each printed then run as an ordinary subcommand, all outputs under
/// `--output`.
pub fn run(a: Args) -> Result<()> {
    let start = Instant::now();
    check_widths(&a.widths)?;
    let widths: Vec<String> = a.widths.iter().map(u32::to_string).collect();
    let out = |p: &str| a.output.join(p).to_string_lossy().into_owned();
    let slices = out("data/chambers/slices.json");
    let truth = out("data/chambers/truth.nii.gz");
    let model = out("model.dsm");
    let lines: Vec<Vec<String>> = vec![
        vec![
            "synth".into(),
            "-o".into(),
            out("data"),
            "--shape".into(),
            "chambers".into(),
        ],
        [
            vec![
                "train".into(),
                slices.clone(),
                "-o".into(),
                model.clone(),
                "--steps".into(),
                a.steps.to_string(),
            ],
            a.minutes
                .map(|m| vec!["--minutes".into(), m.to_string()])
                .unwrap_or_default(),
            vec!["--widths".into(), widths.join(",")],
        ]
        .concat(),
        vec![
            "mesh".into(),
            model.clone(),
            "--times".into(),
            "0:1:37".into(),
            "--resolution".into(),
            a.resolution.to_string(),
            "--format".into(),
            "vtp".into(),
            "-o".into(),
            out("meshes"),
        ],
        vec![
            "labels".into(),
            model.clone(),
            "--like".into(),
            truth,
            "-o".into(),
            out("labels.nii.gz"),
        ],
        vec![
            "eval".into(),
            "volume".into(),
            model.clone(),
            "--times".into(),
            "0:1:37".into(),
            "--resolution".into(),
            a.resolution.to_string(),
            "-o".into(),
            out("volumes.csv"),
        ],
        vec![
            "eval".into(),
            "synthetic".into(),
            model.clone(),
            "--shape".into(),
            "chambers".into(),
            "--resolution".into(),
            a.resolution.to_string(),
            "--mesh-resolution".into(),
            a.resolution.to_string(),
            "--truth-resolution".into(),
            (2 * a.resolution).to_string(),
            "--samples".into(),
            a.samples.to_string(),
            "--csv".into(),
            out("metrics.csv"),
        ],
        vec![
            "picture".into(),
            model.clone(),
            slices,
            "--frame".into(),
            "1".into(),
            "-o".into(),
            out("figure.png"),
        ],
        vec![
            "picture".into(),
            "--3d".into(),
            model.clone(),
            "--resolution".into(),
            a.resolution.to_string(),
            "-o".into(),
            out("surfaces.png"),
        ],
    ];
    // Every line's options are checked before the first one runs: a bad value fails at once,
    // not after synthesis and training (and before the folder is made).
    for line in &lines {
        parse_line(line)?;
    }
    // The subcommands write into existing folders only; the demo's own folder it makes and
    // marks. Its outputs are replaced (--force to each subcommand) only in a folder an
    // earlier demo made, or where the user forced it; never in a user's folder otherwise.
    let folder = prepare_owned_folder(&a.output, DEMO_MARK, "dynaslice demo", a.force)?;
    let force: Vec<String> = if folder.replaces() {
        vec!["--force".into()]
    } else {
        Vec::new()
    };
    let lines: Vec<Vec<String>> = lines
        .into_iter()
        .map(|line| [line, force.clone()].concat())
        .collect();
    errln!(
        "demo: {} commands; training runs {} steps of a {} network, {}",
        lines.len(),
        a.steps,
        widths.join(","),
        match a.minutes {
            Some(m) => format!("stopping early if {m} minutes pass first (--minutes)"),
            None => "all of them (no time cap; --minutes sets one)".to_string(),
        }
    );
    for line in &lines {
        run_line(line)?;
    }
    errln!(
        "\ndemo finished in {:.0} s; outputs in {}: model.dsm (+ .loss.png), meshes/series.pvd (open in ParaView), \
         labels.nii.gz (on the ground truth's grid, 37 frames), volumes.csv (+ .png), \
         metrics.csv, figure.png, surfaces.png (the chambers in 3D at 4 times)",
        start.elapsed().as_secs_f64(),
        a.output.display()
    );
    Ok(())
}
