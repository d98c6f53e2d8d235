//! `dynaslice eval …`: accuracy of a model against ground truth (synthetic benchmark, reference
//! mesh), on held-out slices, and its class volumes over time. Definitions: docs/metrics.md.

mod benchmark;
mod heldout;
mod reference;
mod volume;

use anyhow::Result;
use benchmark::{synthetic, SyntheticArgs};
use heldout::{held_out, split, HeldoutArgs, SplitArgs};
use reference::{reference, ReferenceArgs};
use volume::{volume, VolumeArgs};

/// Arguments of `dynaslice eval`.
#[derive(clap::Args, Debug)]
#[command(after_help = "\
Examples:
  dynaslice eval synthetic model.dsm --shape chambers --csv frames.csv
  dynaslice eval reference model.dsm eight_15_reference.stl
  dynaslice eval split seg.nii.gz --holdout-planes 3::4 -o train.json
  dynaslice train train.json -o model.dsm
  dynaslice eval heldout model.dsm seg.nii.gz --holdout-planes 3::4
  dynaslice eval volume model.dsm --times 0:1:37 -o volumes.csv

Definitions of every score: docs/metrics.md.")]
pub struct Args {
    #[command(subcommand)]
    what: What,
}

#[derive(clap::Subcommand, Debug)]
enum What {
    /// 3D IoU and Chamfer distance against a synthetic benchmark shape at every frame, split
    /// into annotated and unannotated frames.
    Synthetic(SyntheticArgs),
    /// Chamfer distance of one class against a reference mesh (STL) at one time.
    Reference(ReferenceArgs),
    /// 2D IoU on the planes and frames a split withheld (spatial, temporal, spatio-temporal).
    Heldout(HeldoutArgs),
    /// Write the training input of a held-out split (native JSON) for `dynaslice train`.
    Split(SplitArgs),
    /// Each class's volume over time: CSV and a PNG chart beside it.
    Volume(VolumeArgs),
}

/// Runs `dynaslice eval`: one accuracy measure or the volume curve, printed as a table.
pub fn run(a: Args) -> Result<()> {
    match a.what {
        What::Synthetic(a) => synthetic(a),
        What::Reference(a) => reference(a),
        What::Heldout(a) => held_out(a),
        What::Split(a) => split(a),
        What::Volume(a) => volume(a),
    }
}

/// `v` with `digits` decimals, or `n/a`.
fn fmt(v: Option<f64>, digits: usize) -> String {
    v.map_or("n/a".into(), |v| format!("{v:.digits$}"))
}
