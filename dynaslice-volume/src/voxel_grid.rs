//! The sampling grid of a label volume: voxels, their world positions and the frame times.

use anyhow::{bail, ensure, Result};
use dynaslice_core::Model;
use dynaslice_data::label_volume::Geometry;
use dynaslice_data::TimeSeries;
use dynaslice_sequence::input_file::require;
use std::path::Path;

/// Fewest voxels along the longest side of a mask ([`VoxelGrid::for_mask`]): a coarser mask
/// is a few blocks, not a shape.
pub const MIN_MASK_VOXELS: usize = 8;

/// Where a label volume samples the model: `dims` voxels whose centres are at
/// `world = affine · (i, j, k, 1)`, at each of `times` (one frame per time).
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelGrid {
    /// Voxels per axis (x, y, z).
    pub dims: [usize; 3],
    /// Voxel index → world, rows x, y, z of `[a, b, c, offset]` (the NIfTI sform rows).
    pub affine: [[f64; 4]; 3],
    /// World time of each frame, evenly spaced (NIfTI has a single `pixdim[4]`).
    pub times: Vec<f64>,
}

/// Voxels along the longest side of the box where no spacing is given ([`VoxelGrid::over_model`]).
pub const DEFAULT_VOXELS: usize = 128;
/// Frames over a moving model's time range where no times are given ([`VoxelGrid::over_model`]).
pub const DEFAULT_FRAMES: usize = 10;

/// Whether `path` names a NIfTI image (`.nii`, `.nii.gz`, any case): the one kind of file
/// whose header gives a label volume its grid ([`VoxelGrid::like_file`]).
pub fn is_nifti(path: &Path) -> bool {
    let name = path.to_string_lossy().to_ascii_lowercase();
    name.ends_with(".nii") || name.ends_with(".nii.gz")
}

impl VoxelGrid {
    /// The grid of the NIfTI image at `reference` ([`VoxelGrid::like`]), from its header alone
    /// (its voxels are never needed, and its size is known before anything is allocated for
    /// it, so any voxel type will do), with `times` instead of its frames' where given. Errors
    /// name the file as the command line's `--like` (Python's `like`); another kind of file
    /// is refused with what to give instead.
    pub fn like_file(reference: &Path, times: Option<Vec<f64>>) -> Result<VoxelGrid> {
        require("reference", reference).map_err(anyhow::Error::msg)?;
        if !is_nifti(reference) {
            bail!(
                "--like {}: not a NIfTI image (.nii, .nii.gz), so it has no voxel grid to label \
                 on; give --bounds and --spacing (or neither: the model's domain at \
                 {DEFAULT_VOXELS} voxels along its longest side), or a NIfTI image of the same \
                 subject",
                reference.display()
            );
        }
        let mut grid = VoxelGrid::like(&dynaslice_data::nifti::read_geometry(reference)?);
        if let Some(times) = times {
            grid.times = times;
        }
        Ok(grid)
    }

    /// The grid over the box `bounds` (X0, Y0, Z0, X1, Y1, Z1; default: the model's domain)
    /// with voxel size `spacing` (one value, or one per axis; default: cubic,
    /// [`DEFAULT_VOXELS`] along the box's longest side), at `times` (default:
    /// [`DEFAULT_FRAMES`] evenly over the model's time range, a static model's one time). A
    /// voxel wider than the box along every axis is refused: one voxel of nothing is a
    /// mistyped value. Errors name the values by the command line's options.
    pub fn over_model(
        model: &Model,
        is_static: bool,
        bounds: Option<&[f64]>,
        spacing: Option<&[f64]>,
        times: Option<Vec<f64>>,
    ) -> Result<VoxelGrid> {
        let (lo, hi) = match bounds {
            Some(&[x0, y0, z0, x1, y1, z1]) => ([x0, y0, z0], [x1, y1, z1]),
            Some(b) => bail!("--bounds takes 6 values X0,Y0,Z0,X1,Y1,Z1, not {}", b.len()),
            None => {
                let (lo, hi) = model.domain().bounds();
                (lo.map(f64::from), hi.map(f64::from))
            }
        };
        let spacing = match spacing {
            Some(&[s]) => [s; 3],
            Some(&[x, y, z]) => [x, y, z],
            Some(other) => bail!("--spacing takes 1 or 3 values, not {}", other.len()),
            None => {
                let longest = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
                [longest / DEFAULT_VOXELS as f64; 3]
            }
        };
        if (0..3).all(|i| spacing[i] > hi[i] - lo[i]) {
            bail!(
                "--spacing {spacing:?} is wider than the box (sides {:?}, {lo:?} to {hi:?}) along \
                 every axis: the volume would be a single voxel",
                [0, 1, 2].map(|i| hi[i] - lo[i])
            );
        }
        let times = match times {
            Some(times) => times,
            None if is_static => vec![f64::from(model.domain().time_range().0)],
            None => {
                let (t0, t1) = model.domain().time_range();
                TimeSeries::across(t0, t1, DEFAULT_FRAMES)
                    .map_err(anyhow::Error::msg)?
                    .times()
            }
        };
        VoxelGrid::from_bounds(lo, hi, spacing, times)
    }

    /// The grid of a reference volume: same dimensions, affine and frames, frame f at time
    /// time origin + f · frame interval (NIfTI's `toffset` and `pixdim[4]`), the times the
    /// readers give a volume's frames when it trains on it ([`dynaslice_data::input`]), so a
    /// model trained on `reference` is queried at its own frames. From a file's header alone ([`dynaslice_data::nifti::read_geometry`]) or a
    /// volume in memory ([`dynaslice_data::label_volume::LabelVolume::geometry`]).
    pub fn like(reference: &Geometry) -> VoxelGrid {
        VoxelGrid {
            dims: reference.dims,
            affine: reference.affine,
            times: (0..reference.frames)
                .map(|f| reference.time_origin + f as f64 * reference.frame_interval)
                .collect(),
        }
    }

    /// An axis-aligned grid over the box `lo..hi` with voxel size `spacing`: ⌈(hi − lo)/s⌉
    /// voxels per axis, centred at lo + (i + ½)·s (so the box [−1, 1]³ at spacing 2/64 is
    /// exactly the synthetic benchmark's ground-truth grid).
    pub fn from_bounds(
        lo: [f64; 3],
        hi: [f64; 3],
        spacing: [f64; 3],
        times: Vec<f64>,
    ) -> Result<VoxelGrid> {
        let mut dims = [0; 3];
        for a in 0..3 {
            let (extent, s) = (hi[a] - lo[a], spacing[a]);
            ensure!(
                extent.is_finite() && extent > 0.0,
                "bounds: axis {a} runs from {} to {}, an empty range",
                lo[a],
                hi[a]
            );
            ensure!(
                s.is_finite() && s > 0.0,
                "spacing {s} on axis {a} is not a positive number"
            );
            // The 1e-9 keeps a box that is a whole number of voxels (up to rounding) from
            // gaining a sliver voxel.
            let n = (extent / s - 1e-9).ceil().max(1.0);
            ensure!(
                n <= i16::MAX as f64,
                "{n} voxels on axis {a}: NIfTI-1 allows at most {} per axis",
                i16::MAX
            );
            dims[a] = n as usize;
        }
        let mut affine = [[0.0; 4]; 3];
        for a in 0..3 {
            affine[a][a] = spacing[a];
            affine[a][3] = lo[a] + 0.5 * spacing[a];
        }
        let grid = VoxelGrid {
            dims,
            affine,
            times,
        };
        grid.frame_interval()?;
        Ok(grid)
    }

    /// The grid of a mask over the box `lo`..`hi` with cubic voxels of `spacing` (a time
    /// `time`), refused, naming `option`, where the value makes no mask of a shape: fewer than
    /// [`MIN_MASK_VOXELS`] voxels along the box's longest side (a voxel nearly as large as the
    /// box), or more than NIfTI-1's 32767 along any side. Callers check it before any work.
    pub fn for_mask(
        option: &str,
        lo: [f64; 3],
        hi: [f64; 3],
        spacing: f64,
        time: f64,
    ) -> Result<VoxelGrid> {
        let longest = (0..3).map(|i| hi[i] - lo[i]).fold(0.0, f64::max);
        // 1e30 as 1e30, not 31 digits.
        let spacing_text = if (1e-4..1e6).contains(&spacing) {
            spacing.to_string()
        } else {
            format!("{spacing:e}")
        };
        let coarsest = longest / MIN_MASK_VOXELS as f64;
        let finest = longest / i16::MAX as f64;
        ensure!(
            spacing.is_finite() && spacing > 0.0,
            "{option} {spacing_text}: not a positive number"
        );
        ensure!(
            spacing <= coarsest,
            "{option} {spacing_text}: the mask would have fewer than {MIN_MASK_VOXELS} voxels along \
             the longest side of the model's domain ({longest}); allowed: {finest:.3e} to \
             {coarsest:.4}"
        );
        ensure!(
            spacing >= finest,
            "{option} {spacing_text}: the mask would have more than {} voxels along the longest side \
             of the model's domain ({longest}), NIfTI-1's limit; allowed: {finest:.3e} to \
             {coarsest:.4}",
            i16::MAX
        );
        VoxelGrid::from_bounds(lo, hi, [spacing; 3], vec![time])
    }

    /// Voxels in one frame.
    pub fn voxels_per_frame(&self) -> usize {
        self.dims.iter().product()
    }

    /// World position of the centre of voxel (i, j, k).
    #[inline]
    pub fn world(&self, i: usize, j: usize, k: usize) -> [f64; 3] {
        let q = [i as f64, j as f64, k as f64];
        self.affine
            .map(|r| r[0] * q[0] + r[1] * q[1] + r[2] * q[2] + r[3])
    }

    /// World volume of one voxel, |det A|.
    pub fn voxel_volume(&self) -> f64 {
        dynaslice_data::label_volume::det3(&self.affine).abs()
    }

    /// The time between frames (1 for a single frame, the NIfTI convention for "unknown").
    /// An error unless there is at least one time, all finite, increasing and evenly spaced.
    pub fn frame_interval(&self) -> Result<f64> {
        let t = &self.times;
        ensure!(!t.is_empty(), "no frame times");
        ensure!(
            t.iter().all(|v| v.is_finite()),
            "frame times {t:?} are not all finite"
        );
        if t.len() < 2 {
            return Ok(1.0);
        }
        let (t0, t1) = (t[0], t[1]);
        let dt = t1 - t0;
        ensure!(dt > 0.0, "frame times must increase: {t0} then {t1}");
        for (f, w) in t.windows(2).enumerate() {
            // NIfTI stores one interval; unevenly spaced times would be written as wrong times.
            if ((w[1] - w[0]) - dt).abs() > 1e-6 * dt.max(t0.abs()) {
                bail!(
                    "frame times are not evenly spaced: {} to {} after {dt} between frames 0 and 1 \
                     (frame {f})",
                    w[0],
                    w[1]
                );
            }
        }
        Ok(dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_grid_matches_the_benchmark_truth_grid() {
        let g = VoxelGrid::from_bounds([-1.0; 3], [1.0; 3], [2.0 / 64.0; 3], vec![0.0]).unwrap();
        let truth = dynaslice_synth::label_volume(
            dynaslice_synth::Shape::Blob,
            &dynaslice_synth::BenchmarkOptions {
                timesteps: 2,
                volume_resolution: 64,
                ..Default::default()
            },
        );
        assert_eq!(g.dims, truth.dims);
        assert_eq!(g.affine, truth.affine);
        assert_eq!(VoxelGrid::like(&truth.geometry()).times, vec![0.0, 1.0]);
        // The same grid from the header alone, of a compressed and a plain file.
        let dir = tempfile::tempdir().unwrap();
        for name in ["truth.nii.gz", "truth.nii"] {
            let path = dir.path().join(name);
            dynaslice_data::nifti::write_volume(&truth, &path).unwrap();
            let header = dynaslice_data::nifti::read_geometry(&path).unwrap();
            let volume = dynaslice_data::nifti::read_volume(&path).unwrap();
            assert_eq!(
                VoxelGrid::like(&header),
                VoxelGrid::like(&volume.geometry())
            );
            assert_eq!((header.dims, header.frames), (truth.dims, 2));
        }
        assert!((g.voxel_volume() * 64f64.powi(3) - 8.0).abs() < 1e-9);
        assert_eq!(
            g.world(63, 0, 0),
            [1.0 - 1.0 / 64.0, -1.0 + 1.0 / 64.0, -1.0 + 1.0 / 64.0]
        );
    }

    #[test]
    fn bad_grids_are_refused() {
        let g = |lo: f64, s: f64, times: Vec<f64>| {
            VoxelGrid::from_bounds([lo, 0.0, 0.0], [1.0; 3], [s; 3], times)
        };
        assert_eq!(g(0.0, 0.3, vec![0.0]).unwrap().dims, [4, 4, 4]);
        assert!(g(1.0, 0.1, vec![0.0])
            .unwrap_err()
            .to_string()
            .contains("empty range"));
        assert!(g(0.0, 0.0, vec![0.0])
            .unwrap_err()
            .to_string()
            .contains("spacing"));
        let e = g(0.0, 0.1, vec![0.0, 1.0, 3.0]).unwrap_err().to_string();
        assert!(e.contains("not evenly spaced"), "{e}");
        assert!(g(0.0, 0.1, vec![]).is_err());
    }
}
