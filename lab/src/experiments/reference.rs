//! Static real data: reconstructions of `.csl` cross-sections (OReX's sliced meshes) against the
//! meshes they were sliced from. The reconstruction is the model's class-1 surface at its only
//! time; CD×10⁴ is normalised by the reference's bounding-box diagonal, and the 3D IoU compares
//! the model's labels with the reference's interior on a grid over the reference's box.

use super::{cell, fit, Fitted, Protocol};
use anyhow::{Context, Result};
use dynaslice_data::{csl, LabelTable, Sequence};
use dynaslice_mesh::io::read_stl;
use dynaslice_mesh::Mesh;
use dynaslice_metrics::chamfer;
use dynaslice_metrics::inside::{grid_for, model_iou, padded_bounds};
use dynaslice_train::fit::Quiet;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// How finely to score.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Resolution {
    /// Lattice cells along the longest axis for the model's mesh.
    pub mesh: u32,
    /// Cells along the longest axis of the IoU grid.
    pub iou: usize,
    /// Area-uniform samples per surface.
    pub samples: usize,
}

/// A `.csl` input and its reference mesh.
pub struct Case {
    /// Name in the table.
    pub name: String,
    /// The cross-sections file.
    pub csl: PathBuf,
    seq: Sequence,
    reference: Mesh,
}

/// One scored reconstruction.
pub struct CaseRun {
    /// Name.
    pub name: String,
    /// Planes in the input.
    pub planes: usize,
    /// The trained model.
    pub fitted: Fitted,
    /// CD×10⁴ against the reference (`None`: the model has no surface).
    pub cd: Option<f64>,
    /// 3D IoU against the reference's interior.
    pub iou: Option<f64>,
}

impl Case {
    /// Reads `<dir>/<name>.csl` and `<dir>/<name>_reference.stl`.
    pub fn read(dir: &Path, name: &str) -> Result<Case> {
        let path = dir.join(format!("{name}.csl"));
        let seq = csl::read(&path, &LabelTable::default())?;
        let reference = read_stl(&dir.join(format!("{name}_reference.stl")))?;
        Ok(Case {
            name: name.into(),
            csl: path,
            seq,
            reference,
        })
    }

    /// Steps that take `p.minutes`.
    pub fn calibrate(&self, p: &Protocol) -> Result<u64> {
        p.steps_for(&self.seq)
    }

    /// Trains for `steps` and scores against the reference.
    pub fn run(&self, p: &Protocol, steps: u64, r: Resolution) -> Result<CaseRun> {
        anyhow::ensure!(
            r.iou >= 1 && r.samples >= 1,
            "the IoU grid needs at least 1 cell and the Chamfer distance at least 1 sample"
        );
        let fitted = fit(
            &self.seq,
            &p.spec(steps, true, true),
            &self.csl.display().to_string(),
            &mut Quiet,
        )
        .with_context(|| self.csl.display().to_string())?;
        let model = fitted.model();
        let t = model.domain().time_range().0;
        let cd = chamfer::against_reference(&model, 0, t, &self.reference, r.mesh, r.samples)?
            .map(|c| c.scaled());
        let bounds = padded_bounds(&self.reference, 0.05);
        let iou = model_iou(
            &model,
            0,
            t,
            &self.reference,
            bounds,
            grid_for(bounds, r.iou),
        );
        let planes = self.seq.frames().iter().map(|f| f.planes.len()).sum();
        Ok(CaseRun {
            name: self.name.clone(),
            planes,
            fitted,
            cd,
            iou,
        })
    }
}

/// The markdown of the static reconstructions.
pub fn markdown(runs: &[CaseRun], p: &Protocol, r: Resolution) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "## Static real data: `.csl` cross-sections against reference meshes\n"
    );
    let _ =
        writeln!(
        s,
        "OReX's sliced meshes (`../shared/data/csl/`, one timestep, one class), each trained for \
         {} ({} threads). CD×10⁴ between {} area-uniform samples of the model's class-1 mesh \
         ({} cells along the longest axis) and of the reference mesh, normalised by the \
         reference's bounding-box diagonal; 3D IoU of the labels against the reference's \
         interior (ray parity) on a grid of {} cells along the longest axis of the reference's \
         box grown by 5 % of its diagonal.\n",
        p.budget(), p.options().threads, r.samples, r.mesh, r.iou
    );
    let _ = writeln!(s, "| input | planes | CD×10⁴ | IoU | steps | train time |");
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for run in runs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {:.0} s |",
            run.name,
            run.planes,
            cell(run.cd, 2),
            cell(run.iou, 3),
            run.fitted.steps,
            run.fitted.seconds
        );
    }
    let _ = writeln!(s);
    s
}
