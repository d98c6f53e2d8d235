//! The internal target volume (ITV) of radiotherapy: the union over a cycle's times of a class's
//! Eq. 11 region, as a voxel mask on a grid (the label volumes' evaluation,
//! `dynaslice_volume::label_indices`) and as a closed mesh (the mesher on the field whose
//! negative set is that union: at each point, the minimum over the times of the class's
//! partition field, [`dynaslice_mesh::LevelSets`]). Both are over the same times, so a time
//! missing from the list is missing from both. [`write_itv`] writes them per class as a NIfTI
//! mask with colour tables and a PLY mesh (`dynaslice measure --itv DIR`).

use crate::measurement::Measurement;
use anyhow::{bail, ensure, Result};
use dynaslice_core::Model;
use dynaslice_data::color_table::{stage_tables, table_paths};
use dynaslice_data::nifti_stream::{NiftiStream, VolumeHeader};
use dynaslice_data::ClassInfo;
use dynaslice_mesh::field::LevelScratch;
use dynaslice_mesh::io::{self as mesh_io, class_tag, is_class_tag, Format, MeshInfo, Space};
use dynaslice_mesh::{self as mesh, LevelSets, Mesh, Sampling, Source, Surfaces};
use dynaslice_output::OutputSet;
use dynaslice_volume::{label_indices, VoxelGrid};
use std::path::{Path, PathBuf};

/// Voxels along the longest side of the model's domain of an ITV mask by default.
pub const DEFAULT_ITV_VOXELS: f64 = 128.0;

/// One class's ITV files in a folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ItvFiles {
    /// The NIfTI mask `classK_NAME.itv.nii.gz` (its colour tables beside it).
    pub mask: PathBuf,
    /// The closed surface `classK_NAME.itv.ply`.
    pub mesh: PathBuf,
}

/// The ITV files of each class (channel order) in `dir`.
pub fn itv_files(dir: &Path, classes: &[ClassInfo]) -> Vec<ItvFiles> {
    classes
        .iter()
        .enumerate()
        .map(|(k, c)| {
            let tag = class_tag(k, &c.name);
            ItvFiles {
                mask: dir.join(format!("{tag}.itv.nii.gz")),
                mesh: dir.join(format!("{tag}.itv.ply")),
            }
        })
        .collect()
}

/// Whether `name` is one of [`itv_files`]' names (any class) or their colour tables.
fn is_itv_file(name: &str) -> bool {
    [".itv.nii.gz", ".itv.ply", ".itv.ctbl", ".itv.label.txt"]
        .iter()
        .find_map(|ext| name.strip_suffix(ext))
        .is_some_and(is_class_tag)
}

/// The ITV masks' grid over `model`'s domain at `time`: `spacing` (given with `option`;
/// default [`DEFAULT_ITV_VOXELS`] voxels along the longest side) checked against the domain
/// ([`VoxelGrid::for_mask`]).
pub fn itv_grid(model: &Model, option: &str, spacing: Option<f64>, time: f64) -> Result<VoxelGrid> {
    let (lo, hi) = model.domain().bounds();
    let (lo, hi) = (lo.map(f64::from), hi.map(f64::from));
    let spacing = spacing.unwrap_or_else(|| {
        let longest = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
        longest / DEFAULT_ITV_VOXELS
    });
    VoxelGrid::for_mask(option, lo, hi, spacing, time)
}

/// Bytes the masks of [`write_itv`] hold on `grid` for `classes` classes: a byte per voxel and
/// class, and the written frame's 4 bytes per voxel (an estimate to check against the
/// memory available before any work).
pub fn itv_bytes(grid: &VoxelGrid, classes: usize) -> f64 {
    grid.voxels_per_frame() as f64 * (classes as f64 + 4.0)
}

/// What [`write_itv`] wrote for one class: its ITV's volume by the mask's voxels and enclosed by
/// its mesh (world units cubed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ItvVolumes {
    /// Voxels of the mask times the voxel volume.
    pub by_voxels: f64,
    /// The mesh's enclosed volume.
    pub enclosed: f64,
}

/// Writes each class's ITV over `m`'s times into `files` (from [`itv_files`], in `dir`, made if
/// missing): the mask on `grid` (named `option` in messages) with its colour tables, the mesh
/// of `resolution` cells (PLY, LPS), all files or none ([`OutputSet`]). `done` is called after
/// each time's labels and after the meshing (times + 1 calls: a minute or more on a busy
/// machine). A class in no voxel of its mask is an error and nothing is written.
pub fn write_itv(
    model: &Model,
    m: &Measurement,
    resolution: u32,
    (grid, option): (&VoxelGrid, &str),
    dir: &Path,
    files: &[ItvFiles],
    mut done: impl FnMut(),
) -> Result<Vec<ItvVolumes>> {
    let times = &m.motion.times;
    let mut set = OutputSet::new();
    set.create_dir(dir)?;
    // With --force over an earlier ITV folder of other classes, its files go too.
    set.supersede(dir, is_itv_file);
    let masks = itv_masks(model, grid, times, &mut done)?;
    let options = mesh::Options {
        resolution,
        ..mesh::Options::default()
    };
    let meshes = itv_meshes(model, model.domain().bounds(), times, &options)?;
    done();
    let mut volumes = Vec::with_capacity(m.classes.len());
    for (k, c) in m.classes.iter().enumerate() {
        let ItvFiles { mask, mesh } = &files[k];
        let header = VolumeHeader {
            dims: grid.dims,
            frames: 1,
            affine: grid.affine,
            frame_interval: 1.0,
            time_offset: times[0],
            label_range: (0.min(c.label), 0.max(c.label)),
            description: "dynaslice ITV (union over the measured times)".into(),
        };
        let labels: Vec<i32> = masks[k]
            .iter()
            .map(|&i| if i { c.label } else { 0 })
            .collect();
        let voxels = labels.iter().filter(|&&l| l != 0).count();
        if voxels == 0 {
            bail!(
                "{}: class {:?} is in no voxel of the ITV mask at {option} {}; nothing \
                 written",
                mask.display(),
                c.name,
                grid.affine[0][0]
            );
        }
        let mut stream = NiftiStream::create(mask, &header)?;
        stream.write_frame(&labels)?;
        stream.finish_into(&mut set)?;
        let (ctbl, label) = table_paths(mask);
        stage_tables(
            &mut set,
            &ctbl,
            &label,
            std::slice::from_ref(&ClassInfo {
                color: Some(m.colors[k]),
                ..c.clone()
            }),
        )?;
        let info = MeshInfo::new(&c.name, Space::Lps)
            .with_label(c.label)
            .with_color(m.colors[k]);
        let bytes = mesh_io::encode(&meshes[k], Format::Ply, &info)?;
        set.write(mesh, &bytes)?;
        volumes.push(ItvVolumes {
            by_voxels: voxels as f64 * grid.voxel_volume(),
            enclosed: meshes[k].enclosed_volume(),
        });
    }
    set.commit()?;
    Ok(volumes)
}

/// Per class (model order), whether each voxel of `grid` (x fastest) is labelled that class at
/// any of `times`; `done` is called after each time (a front end's progress).
pub fn itv_masks(
    model: &Model,
    grid: &VoxelGrid,
    times: &[f64],
    mut done: impl FnMut(),
) -> Result<Vec<Vec<bool>>> {
    ensure!(!times.is_empty(), "an ITV needs at least one time");
    let n = grid.voxels_per_frame();
    let mut masks = vec![vec![false; n]; model.num_classes()];
    let mut labels = vec![0u32; n];
    for &t in times {
        label_indices(model, grid, t, &mut labels)?;
        for (i, &l) in labels.iter().enumerate() {
            if l > 0 {
                masks[l as usize - 1][i] = true;
            }
        }
        done();
    }
    Ok(masks)
}

/// The closed surface of each class's ITV over `times` (channel order), meshed over the world
/// box `bounds` (e.g. a model's `domain().bounds()`) with `options` (its `surfaces` is
/// ignored: the union is of partition regions).
pub fn itv_meshes<S: Source>(
    source: &S,
    bounds: ([f32; 3], [f32; 3]),
    times: &[f64],
    options: &mesh::Options,
) -> Result<Vec<Mesh>> {
    ensure!(!times.is_empty(), "an ITV needs at least one time");
    let classes: Vec<usize> = (0..source.num_classes()).collect();
    let union = Union {
        source,
        times: times.iter().map(|&t| t as f32).collect(),
        classes: classes.clone(),
        clip: bounds,
    };
    let mut options = *options;
    options.surfaces = Surfaces::Overlapping;
    // The partition field is 2-Lipschitz where the distance fields are 1-Lipschitz (its
    // LevelSets::lipschitz), and the sparse sampler assumes 1 for an overlapping field.
    if let Sampling::Sparse { safety } = &mut options.sampling {
        *safety *= 2.0;
    }
    Ok(mesh::extract(&union, bounds, 0.0, &classes, &options)?.meshes)
}

/// The field min over `times` of each class's partition field, the same at every time.
struct Union<'a, S: Source> {
    source: &'a S,
    times: Vec<f32>,
    classes: Vec<usize>,
    clip: ([f32; 3], [f32; 3]),
}

impl<S: Source> Union<'_, S> {
    fn at(&self, t: f32) -> LevelSets<'_, S> {
        LevelSets::new(
            self.source,
            t,
            self.classes.clone(),
            Surfaces::Partition,
            self.clip,
        )
    }
}

/// One time's values, gradients and time derivatives.
type Buffers = (Vec<f32>, Vec<[f32; 3]>, Vec<f32>);

impl<S: Source> Source for Union<'_, S> {
    type Scratch = (LevelScratch<S::Scratch>, Buffers);

    fn scratch(&self) -> Self::Scratch {
        (self.at(0.0).scratch(), Default::default())
    }

    fn num_classes(&self) -> usize {
        self.classes.len()
    }

    fn eval(&self, s: &mut Self::Scratch, xyz: &[[f32; 3]], _: f32, f: &mut [f32]) {
        let (scratch, (values, _, _)) = s;
        values.resize(f.len(), 0.0);
        f.fill(f32::INFINITY);
        for &t in &self.times {
            self.at(t).values(scratch, xyz, values);
            for (out, &v) in f.iter_mut().zip(values.iter()) {
                *out = out.min(v);
            }
        }
    }

    fn eval_jacobian(
        &self,
        s: &mut Self::Scratch,
        xyz: &[[f32; 3]],
        _: f32,
        f: &mut [f32],
        grad: &mut [[f32; 3]],
        dfdt: &mut [f32],
    ) {
        let (scratch, (values, grads, unused)) = s;
        values.resize(f.len(), 0.0);
        grads.resize(f.len(), [0.0; 3]);
        unused.resize(f.len(), 0.0);
        f.fill(f32::INFINITY);
        // The union does not move: ∂/∂t is 0, ∇ₓ that of the time attaining the minimum.
        dfdt.fill(0.0);
        for &t in &self.times {
            self.at(t).jacobians(scratch, xyz, values, grads, unused);
            for i in 0..f.len() {
                if values[i] < f[i] {
                    f[i] = values[i];
                    grad[i] = grads[i];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use dynaslice_mesh::PointField;
    use dynaslice_test_support::spheres::{self, Sphere};

    /// Every file an ITV folder holds is recognised as one, and nothing else.
    #[test]
    fn itv_file_names_are_told_from_others() {
        let classes = [ClassInfo {
            name: "GTV left/upper".into(),
            label: 7,
            color: None,
        }];
        for f in itv_files(Path::new("itv"), &classes) {
            let (ctbl, label) = table_paths(&f.mask);
            for p in [&f.mask, &f.mesh, &ctbl, &label] {
                let name = p.file_name().unwrap().to_str().unwrap();
                assert!(is_itv_file(name), "{name}");
            }
        }
        for other in [
            "notes.txt",
            "class1.nii.gz",
            "classx.itv.ply",
            "gtv.itv.ply",
            "class1_a b.itv.ply",
        ] {
            assert!(!is_itv_file(other), "{other}");
        }
    }

    /// A growing sphere's ITV is its largest ball: the mask's voxel count and the mesh's volume
    /// against the closed form, and the mesh closed.
    #[test]
    fn growing_sphere_itv_is_the_largest_ball() {
        let s = Sphere::new([0.1, -0.2, 0.05], 0.3, 0.1);
        let bytes = spheres::model(&[s], &[("tumour", 7)]);
        let model = Model::from_bytes(&bytes).unwrap();
        let times = [0.0, 1.0, 2.0];
        let want = s.world_volume(2.0);
        let (lo, hi) = model.domain().bounds();
        let grid = VoxelGrid::from_bounds(
            lo.map(f64::from),
            hi.map(f64::from),
            [40.0 / 128.0; 3],
            vec![0.0],
        )
        .unwrap();
        let mut calls = 0;
        let masks = itv_masks(&model, &grid, &times, || calls += 1).unwrap();
        assert_eq!(calls, times.len());
        let counted = masks[0].iter().filter(|&&m| m).count() as f64 * grid.voxel_volume();
        assert!((counted - want).abs() < 0.02 * want, "{counted} vs {want}");
        let options = mesh::Options {
            resolution: 96,
            ..mesh::Options::default()
        };
        let meshes = itv_meshes(&model, model.domain().bounds(), &times, &options).unwrap();
        assert!(meshes[0].topology().is_closed_manifold());
        let v = meshes[0].enclosed_volume();
        assert!((v - want).abs() < 0.01 * want, "{v} vs {want}");
    }

    /// A ball moving along x: its ITV is the capsule it sweeps (the union of 41 positions,
    /// whose scallops between neighbours are 2.5e-4 deep), not any one ball.
    #[test]
    fn moving_ball_sweeps_a_capsule() {
        struct Moving;
        impl PointField for Moving {
            fn num_classes(&self) -> usize {
                1
            }
            fn value(&self, _: usize, p: [f32; 3], t: f32) -> f32 {
                self.jet(0, p, t).0
            }
            fn jet(&self, _: usize, p: [f32; 3], t: f32) -> (f32, [f32; 3], f32) {
                let d = [p[0] - (-0.4 + 0.8 * t), p[1], p[2]];
                let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
                (n - 0.2, d.map(|v| v / n), 0.8 * d[0] / n)
            }
        }
        let times: Vec<f64> = (0..41).map(|i| i as f64 / 40.0).collect();
        let options = mesh::Options {
            resolution: 96,
            ..mesh::Options::default()
        };
        let m = &itv_meshes(&Moving, ([-1.0; 3], [1.0; 3]), &times, &options).unwrap()[0];
        assert!(m.topology().is_closed_manifold());
        let r: f64 = 0.2;
        let want =
            4.0 / 3.0 * std::f64::consts::PI * r.powi(3) + std::f64::consts::PI * r * r * 0.8;
        let v = m.enclosed_volume();
        assert!((v - want).abs() < 0.01 * want, "{v} vs {want}");
        let (lo, hi) = m.bounds().unwrap();
        assert!(
            (lo[0] + 0.6).abs() < 0.01 && (hi[0] - 0.6).abs() < 0.01,
            "{lo:?} {hi:?}"
        );
    }
}
