//! The volume of each class over time (e.g. a lung through a breathing cycle, a ventricle
//! through a heartbeat), as a CSV table (the chart is drawn by `dynaslice-figures`).
//!
//! Volumes come from meshes: the enclosed volume of each class's closed surface, extracted as
//! the boundary of the Eq. 11 partition (so classes never share volume and the values are those
//! of the label volume `dynaslice labels` writes) over the model's domain. A mesh with its
//! vertices placed on the surface by a Newton step is accurate to O(h²) in the cell size h,
//! where counting label voxels is accurate to O(h) (the surface cuts voxels anywhere), and the
//! sparse extractor costs far fewer evaluations than a dense voxel grid. The test checks the
//! two methods against each other and against closed forms.

use anyhow::{Context, Result};
use dynaslice_core::Model;
use dynaslice_data::TimeSeries;
use dynaslice_mesh::{self as mesh, Surfaces};
use dynaslice_model::{ModelFile, RunRecord};
use dynaslice_sequence::nesting::whole_structures;
use std::fmt::Write as _;
use std::path::Path;

/// Class volumes at a list of times.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeCurve {
    /// Class names, in model order.
    pub classes: Vec<String>,
    /// World times.
    pub times: Vec<f64>,
    /// `volumes[time][class]` in world units cubed.
    pub volumes: Vec<Vec<f64>>,
}

/// One class's solid at one time, from its closed partition mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClassShape {
    /// Enclosed volume, world units cubed.
    pub volume: f64,
    /// Centroid of the enclosed solid (world); `None` where the class is absent.
    pub centroid: Option<[f64; 3]>,
    /// Axis-aligned bounding box `(lo, hi)` of the surface (world); `None` where absent.
    pub bounds: Option<([f64; 3], [f64; 3])>,
}

/// The solid of every class of `model` at world time `t` (model order), from the Eq. 11
/// partition meshes with `resolution` cells along the longest axis of its domain. A class the
/// model records as holding others (`nesting` in its metadata, `dynaslice_data::nesting`) is
/// its whole structure: its own region and those nested in it (an epicardium's wall and
/// cavity), as the user drew it.
pub fn class_shapes(model: &Model, t: f64, resolution: u32) -> Result<Vec<ClassShape>> {
    let pairs = RunRecord::parse_lossy(model.metadata())
        .0
        .nested(model)
        .map_err(|e| anyhow::anyhow!("the model's metadata: {e}"))?;
    let own = partition_shapes(model, t, resolution)?;
    Ok(whole_structures(&pairs, own.len())
        .iter()
        .map(|members| ClassShape::union(members.iter().map(|&k| &own[k])))
        .collect())
}

impl ClassShape {
    /// The solid made of disjoint solids `parts`: volumes add, the centroid is their
    /// volume-weighted mean, the bounds their union.
    pub fn union<'a>(parts: impl Iterator<Item = &'a ClassShape>) -> ClassShape {
        let mut volume = 0.0;
        let mut moment = [0.0; 3];
        let mut bounds: Option<([f64; 3], [f64; 3])> = None;
        let mut present = false;
        for p in parts {
            volume += p.volume;
            if let Some(c) = p.centroid {
                present = true;
                for a in 0..3 {
                    moment[a] += p.volume * c[a];
                }
            }
            if let Some((lo, hi)) = p.bounds {
                bounds = Some(match bounds {
                    None => (lo, hi),
                    Some((l, h)) => (
                        std::array::from_fn(|a| l[a].min(lo[a])),
                        std::array::from_fn(|a| h[a].max(hi[a])),
                    ),
                });
            }
        }
        ClassShape {
            volume,
            centroid: (present && volume > 0.0).then(|| moment.map(|m| m / volume)),
            bounds,
        }
    }
}

/// Each class's own region of the Eq. 11 partition as a solid.
fn partition_shapes(model: &Model, t: f64, resolution: u32) -> Result<Vec<ClassShape>> {
    let classes: Vec<usize> = (0..model.num_classes()).collect();
    let options = mesh::Options {
        resolution,
        surfaces: Surfaces::Partition,
        ..mesh::Options::default()
    };
    let x = mesh::extract(model, model.domain().bounds(), t as f32, &classes, &options)?;
    Ok(x.meshes
        .iter()
        .map(|m| ClassShape {
            volume: m.enclosed_volume(),
            centroid: m.enclosed_centroid(),
            bounds: m.bounds(),
        })
        .collect())
}

/// The volume of every class of `model` at each of `times`, from meshes with `resolution`
/// cells along the longest axis of its domain ([`class_shapes`]).
pub fn volume_curve(model: &Model, times: &[f64], resolution: u32) -> Result<VolumeCurve> {
    volume_curve_with(model, times, resolution, |_| {})
}

/// [`volume_curve`], calling `progress` with the number of times done after each.
pub fn volume_curve_with(
    model: &Model,
    times: &[f64],
    resolution: u32,
    mut progress: impl FnMut(usize),
) -> Result<VolumeCurve> {
    let volumes = times
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let v = class_shapes(model, t, resolution)?
                .iter()
                .map(|s| s.volume)
                .collect();
            progress(i + 1);
            Ok(v)
        })
        .collect::<Result<_>>()?;
    Ok(VolumeCurve {
        classes: model.classes().map(|c| c.name.to_string()).collect(),
        times: times.to_vec(),
        volumes,
    })
}

/// Times a volume curve of a moving model takes by default: its time range in this many
/// evenly spaced steps.
pub const DEFAULT_TIMES: usize = 20;

/// The default times of a volume curve of `file`'s model: [`DEFAULT_TIMES`] evenly over its
/// time range, both ends included; a static model's one time (its field is the same at every
/// time).
pub fn default_times(file: &ModelFile) -> Result<Vec<f32>> {
    let (t0, t1) = file.model().domain().time_range();
    if file.is_static() {
        return Ok(vec![t0]);
    }
    let series = TimeSeries::across(t0, t1, DEFAULT_TIMES).map_err(anyhow::Error::msg)?;
    // The network takes f32 times.
    Ok(series.times().into_iter().map(|t| t as f32).collect())
}

/// The volume curve of `file`'s model ([`volume_curve_with`]) in the unit every output
/// reports volumes in: mL for a model of millimetres, the input's plain units³ otherwise
/// ([`ModelFile::units`]).
pub fn class_volumes(
    file: &ModelFile,
    times: &[f64],
    resolution: u32,
    progress: impl FnMut(usize),
) -> Result<VolumeCurve> {
    let mut curve = volume_curve_with(&file.model(), times, resolution, progress)?;
    let units = file.units();
    for v in curve.volumes.iter_mut().flatten() {
        *v = units.from_world_volume(*v);
    }
    Ok(curve)
}

impl VolumeCurve {
    /// CSV: a `time` column, then one column per class (its name, quoted).
    pub fn to_csv(&self) -> String {
        let mut s = String::from("time");
        for c in &self.classes {
            let _ = write!(s, ",\"{}\"", c.replace('"', "\"\""));
        }
        s.push('\n');
        for (t, v) in self.times.iter().zip(&self.volumes) {
            let _ = write!(s, "{t}");
            for x in v {
                let _ = write!(s, ",{x}");
            }
            s.push('\n');
        }
        s
    }

    /// Each class's smallest and largest volume over the times.
    pub fn ranges(&self) -> Vec<(f64, f64)> {
        (0..self.classes.len())
            .map(|c| {
                self.volumes
                    .iter()
                    .map(|v| v[c])
                    .fold((f64::MAX, f64::MIN), |(l, h), x| (l.min(x), h.max(x)))
            })
            .collect()
    }

    /// Writes the CSV to `path`.
    pub fn write_csv(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_csv())
            .with_context(|| format!("cannot write {}", path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each class's range over the times, whatever order the values come in.
    #[test]
    fn ranges_are_each_classes_extremes() {
        let curve = VolumeCurve {
            classes: vec!["a".into(), "b".into()],
            times: vec![0.0, 0.5, 1.0],
            volumes: vec![vec![2.0, 5.0], vec![1.0, 7.0], vec![3.0, 6.0]],
        };
        assert_eq!(curve.ranges(), [(1.0, 3.0), (5.0, 7.0)]);
    }
    use dynaslice_test_support::spheres::{self, Sphere};
    use dynaslice_volume::{label_indices, VoxelGrid};

    /// Two overlapping spheres, one growing: mesh volumes against the closed forms (ball minus
    /// the half lens the partition gives away) and against counted label voxels.
    #[test]
    fn mesh_volumes_match_closed_forms_and_voxel_counts() {
        let s = [
            Sphere::new([-0.2, 0.0, 0.0], 0.45, 0.1),
            Sphere::new([0.4, 0.1, 0.0], 0.3, 0.0),
        ];
        let bytes = spheres::model(&s, &[("a", 1), ("b", 2)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let times = [0.0, 1.0, 2.0];
        let curve = volume_curve(&model, &times, 96).unwrap();
        let (lo, hi) = model.domain().bounds();
        let grid = VoxelGrid::from_bounds(
            lo.map(f64::from),
            hi.map(f64::from),
            [40.0 / 128.0; 3],
            times.to_vec(),
        )
        .unwrap();
        let mut labels = vec![0u32; grid.voxels_per_frame()];
        for (f, &t) in times.iter().enumerate() {
            label_indices(&model, &grid, t, &mut labels).unwrap();
            for c in 0..2 {
                let voxels = labels.iter().filter(|&&l| l == c as u32 + 1).count() as f64;
                let counted = voxels * grid.voxel_volume();
                let meshed = curve.volumes[f][c];
                assert!(
                    (meshed - counted).abs() < 0.01 * counted,
                    "{t} {c}: {meshed} vs {counted}"
                );
            }
            // The two balls overlap in a lens; the partition splits it along the surface where
            // the fields tie, so the classes' volumes add up to the union exactly.
            let [ra, rb] = [s[0].world_radius(t), s[1].world_radius(t)];
            let ca = s[0].world_centre();
            let cb = s[1].world_centre();
            let d = (0..3).map(|a| (ca[a] - cb[a]).powi(2)).sum::<f64>().sqrt();
            let lens = std::f64::consts::PI
                * (ra + rb - d).powi(2)
                * (d * d + 2.0 * d * (ra + rb) - 3.0 * (ra - rb).powi(2))
                / (12.0 * d);
            let union = s[0].world_volume(t) + s[1].world_volume(t) - lens;
            let total: f64 = curve.volumes[f].iter().sum();
            assert!(
                (total - union).abs() < 2e-3 * union,
                "{t}: {total} vs {union}"
            );
        }
        assert!(
            curve.volumes[2][0] > curve.volumes[0][0] * 1.2,
            "class a grows"
        );
        let csv = curve.to_csv();
        assert!(csv.starts_with("time,\"a\",\"b\"\n0,"), "{csv}");
        assert_eq!(csv.lines().count(), 4);
    }

    /// A model recording `nesting = 2:1` (class b drawn inside class a, here poking out of
    /// it, as the partial nesting the reader accepts): class a's shape is
    /// its own partition region and b's together (volumes add, the centroid is their
    /// volume-weighted mean, the box their union), b's is its own.
    #[test]
    fn a_nested_class_s_outer_is_measured_whole() {
        let s = [
            Sphere::new([-0.2, 0.0, 0.0], 0.45, 0.1),
            Sphere::new([0.1, 0.05, 0.0], 0.2, 0.0),
        ];
        let classes = [("a", 1), ("b", 2)];
        let plain = spheres::model(&s, &classes);
        let mut w = spheres::writer_in(spheres::SPHERES_DOMAIN, &s, &classes);
        w.metadata = "nesting = 2:1\n".into();
        let nested = w.to_bytes();
        // At t = 0 (a grows and swallows b later).
        let t = 0.0;
        let own = class_shapes(&Model::from_bytes(&plain).unwrap(), t, 96).unwrap();
        let whole = class_shapes(&Model::from_bytes(&nested).unwrap(), t, 96).unwrap();
        assert_eq!(whole[1], own[1]);
        let volume = own[0].volume + own[1].volume;
        assert!((whole[0].volume - volume).abs() < 1e-12 * volume);
        let (c0, c1) = (own[0].centroid.unwrap(), own[1].centroid.unwrap());
        let c = whole[0].centroid.unwrap();
        for a in 0..3 {
            let mean = (own[0].volume * c0[a] + own[1].volume * c1[a]) / volume;
            assert!((c[a] - mean).abs() < 1e-9, "{t}: axis {a}");
        }
        // The whole is the union of the two balls: a's and b's minus their lens.
        let [ra, rb] = [s[0].world_radius(t), s[1].world_radius(t)];
        let (ca, cb) = (s[0].world_centre(), s[1].world_centre());
        let d = (0..3).map(|a| (ca[a] - cb[a]).powi(2)).sum::<f64>().sqrt();
        let lens = std::f64::consts::PI
            * (ra + rb - d).powi(2)
            * (d * d + 2.0 * d * (ra + rb) - 3.0 * (ra - rb).powi(2))
            / (12.0 * d);
        let union = s[0].world_volume(t) + s[1].world_volume(t) - lens;
        assert!(
            (whole[0].volume - union).abs() < 2e-3 * union,
            "{t}: {} vs {union}",
            whole[0].volume
        );
        let mut w = spheres::writer_in(spheres::SPHERES_DOMAIN, &s, &classes);
        w.metadata = "nesting = 2:9\n".into();
        let e = class_shapes(&Model::from_bytes(&w.to_bytes()).unwrap(), 0.0, 32).unwrap_err();
        assert!(e.to_string().contains("no class of label 9"), "{e}");
    }
}
