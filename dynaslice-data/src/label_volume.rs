//! A label volume on a voxel grid with its voxel-to-world transform: what the NIfTI and NRRD
//! readers give and the writers take, and what reslicing cuts planes from, whatever the file
//! format.

/// A label volume: `frames` frames of `dims` voxels, voxel (i, j, k) of frame f at
/// `labels[i + nx·(j + ny·(k + nz·f))]`.
#[derive(Debug, Clone, PartialEq)]
pub struct LabelVolume {
    /// Voxels per axis (x, y, z).
    pub dims: [usize; 3],
    /// Number of frames (1 for a 3D file).
    pub frames: usize,
    /// Voxel index → world: `world = affine[r][0..3] · (i, j, k) + affine[r][3]` for row r.
    pub affine: [[f64; 4]; 3],
    /// Time between frames (`pixdim[4]`, 0 read as 1).
    pub frame_interval: f64,
    /// Label values, x fastest.
    pub labels: Vec<i32>,
}

impl LabelVolume {
    /// The label at voxel (i, j, k) of frame `f`; 0 (background) outside the volume.
    #[inline]
    pub fn label(&self, i: isize, j: isize, k: isize, f: usize) -> i32 {
        let [nx, ny, nz] = self.dims;
        if i < 0 || j < 0 || k < 0 || i as usize >= nx || j as usize >= ny || k as usize >= nz {
            return 0;
        }
        self.labels[i as usize + nx * (j as usize + ny * (k as usize + nz * f))]
    }

    /// World position of voxel coordinates `q` (continuous, voxel centres at integers).
    pub fn to_world(&self, q: [f64; 3]) -> [f64; 3] {
        self.affine
            .map(|r| r[0] * q[0] + r[1] * q[1] + r[2] * q[2] + r[3])
    }

    /// The volume's grid, as [`crate::nifti::read_geometry`] reads it from a file's header.
    pub fn geometry(&self) -> Geometry {
        Geometry {
            dims: self.dims,
            frames: self.frames,
            affine: self.affine,
            frame_interval: self.frame_interval,
            time_origin: 0.0,
        }
    }
}

/// A label volume's grid without its voxels: what [`crate::nifti::read_geometry`] reads from a
/// NIfTI header alone.
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// Voxels per axis (x, y, z).
    pub dims: [usize; 3],
    /// Number of frames (1 for a 3D file).
    pub frames: usize,
    /// Voxel index → world, as [`LabelVolume::affine`].
    pub affine: [[f64; 4]; 3],
    /// Time between frames (`pixdim[4]`, 0 read as 1).
    pub frame_interval: f64,
    /// Time of the first frame: NIfTI's `toffset` (0 for a volume in memory, whose frame f is
    /// at f × `frame_interval`). Frame f is at `time_origin + f × frame_interval`.
    pub time_origin: f64,
}

/// Determinant of an affine's 3×3 linear part (the voxel volume, up to sign).
pub fn det3(a: &[[f64; 4]; 3]) -> f64 {
    a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
}
