//! A NIfTI-1 label-volume writer that streams: the header first, then each frame's voxels as
//! they are computed, through gzip for `.gz` names. Memory is one frame's encoding buffer,
//! whatever the number of frames. The only NIfTI writer: [`crate::nifti::write_volume`] writes a
//! whole [`crate::label_volume::LabelVolume`] through it.
//!
//! The header is written field by field at the offsets of the NIfTI-1 standard (`nifti1.h`):
//! the `nifti` crate only serialises headers inside its whole-array writer.
//! - sform = the affine (`sform_code` 2, aligned);
//! - qform = the same affine as a rotation, voxel sizes and `qfac` (`qform_code` 2) when the
//!   affine has orthogonal columns; an affine with shear has no qform form, so `qform_code` is
//!   then 0 and readers use the sform;
//! - `pixdim[4]` = the frame interval, `toffset` = the first frame's time, units mm and s;
//! - `intent_code` = `NIFTI_INTENT_LABEL`, `cal_min`/`cal_max` = the label range, `descrip` = the
//!   description;
//! - datatype int16 when every label value fits, else int32.
//!
//! The file is written beside its destination under a temporary name and renamed when the last
//! frame is in, so an interrupted run never leaves a truncated volume under the real name.

use crate::voxel_type::VoxelType;
use anyhow::{bail, ensure, Context, Result};
use dynaslice_output::{create_temporary, persist, OutputSet};
use flate2::write::GzEncoder;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use tempfile::TempPath;

/// Voxel data offset: the header and the 4-byte extension flag (no extensions).
/// Bytes of a NIfTI-1 header (written here, read by [`crate::nifti`]); the voxel data
/// starts at `vox_offset`, at least 4 bytes later (the extender).
pub(crate) const HEADER_SIZE: usize = 348;

const VOX_OFFSET: usize = HEADER_SIZE + 4;
/// `NIFTI_INTENT_LABEL`: voxel values are label indices.
const INTENT_LABEL: i16 = 1002;
/// `NIFTI_XFORM_ALIGNED_ANAT`.
const XFORM_ALIGNED: i16 = 2;
/// Size of `descrip`, including its terminating NUL.
const DESCRIPTION_BYTES: usize = 80;

/// The types the writer offers, narrowest first: int16 when every label fits, else int32.
const OFFERED: [VoxelType; 2] = [VoxelType::Int16, VoxelType::Int32];

/// NIfTI-1's `datatype` code of `t`.
fn nifti_datatype(t: VoxelType) -> i16 {
    match t {
        VoxelType::Uint8 => 2,
        VoxelType::Int16 => 4,
        VoxelType::Int32 => 8,
        VoxelType::Int8 => 256,
        VoxelType::Uint16 => 512,
        VoxelType::Uint32 => 768,
        VoxelType::Int64 => 1024,
        VoxelType::Uint64 => 1280,
    }
}

/// What the header describes.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeHeader {
    /// Voxels per axis (x, y, z).
    pub dims: [usize; 3],
    /// Frames (1 writes a 3D volume).
    pub frames: usize,
    /// Voxel index → world, as in [`crate::label_volume::LabelVolume::affine`].
    pub affine: [[f64; 4]; 3],
    /// Time between frames (`pixdim[4]`).
    pub frame_interval: f64,
    /// Time of the first frame (`toffset`).
    pub time_offset: f64,
    /// Smallest and largest label value that will be written.
    pub label_range: (i32, i32),
    /// What the volume holds (`descrip`, at most 79 bytes).
    pub description: String,
}

enum Sink {
    Plain(BufWriter<File>),
    Gzip(GzEncoder<BufWriter<File>>),
}

impl Sink {
    fn writer(&mut self) -> &mut dyn Write {
        match self {
            Sink::Plain(w) => w,
            Sink::Gzip(w) => w,
        }
    }
}

/// An open label volume being written frame by frame; see the [module docs](self).
pub struct NiftiStream {
    path: PathBuf,
    /// The temporary of [`create_temporary`], deleted when dropped unfinished.
    tmp: TempPath,
    sink: Sink,
    label_type: VoxelType,
    label_range: (i32, i32),
    voxels_per_frame: usize,
    frames: usize,
    written: usize,
    buffer: Vec<u8>,
}

impl NiftiStream {
    /// Creates the temporary file beside `path` and writes the header; gzip-compressed when
    /// `path` ends in `.gz`.
    pub fn create(path: &Path, header: &VolumeHeader) -> Result<NiftiStream> {
        let (lo, hi) = header.label_range;
        ensure!(lo <= hi, "label range {lo}..{hi} is empty");
        ensure!(header.frames >= 1, "a volume needs at least one frame");
        ensure!(
            header.description.len() < DESCRIPTION_BYTES,
            "description {:?} is longer than NIfTI-1's {} bytes",
            header.description,
            DESCRIPTION_BYTES - 1
        );
        for (a, &n) in header.dims.iter().enumerate() {
            ensure!(
                (1..=i16::MAX as usize).contains(&n),
                "{}: {n} voxels on axis {a}; NIfTI-1 allows 1 to {}",
                path.display(),
                i16::MAX
            );
        }
        ensure!(
            header.frames <= i16::MAX as usize,
            "{}: {} frames; NIfTI-1 allows at most {}",
            path.display(),
            header.frames,
            i16::MAX
        );
        let (file, tmp) = create_temporary(path)?;
        let file = BufWriter::new(file);
        let gzip = path.to_string_lossy().to_ascii_lowercase().ends_with(".gz");
        let sink = if gzip {
            Sink::Gzip(GzEncoder::new(file, flate2::Compression::default()))
        } else {
            Sink::Plain(file)
        };
        // Int32 holds every i32.
        let label_type = VoxelType::narrowest(lo, hi, &OFFERED).unwrap_or(VoxelType::Int32);
        let mut stream = NiftiStream {
            path: path.to_path_buf(),
            tmp,
            sink,
            label_type,
            label_range: (lo, hi),
            voxels_per_frame: header.dims.iter().product(),
            frames: header.frames,
            written: 0,
            buffer: Vec::new(),
        };
        let bytes = encode_header(header, label_type);
        stream.write_bytes(&bytes)?;
        Ok(stream)
    }

    /// The voxel type chosen from the label range.
    pub fn label_type(&self) -> VoxelType {
        self.label_type
    }

    /// Appends the next frame: `labels` has one value per voxel, x fastest.
    pub fn write_frame(&mut self, labels: &[i32]) -> Result<()> {
        ensure!(
            self.written < self.frames,
            "{}: frame {} is one more than the {} the header announced",
            self.path.display(),
            self.written,
            self.frames
        );
        ensure!(
            labels.len() == self.voxels_per_frame,
            "{}: frame {} has {} voxels, the volume {}",
            self.path.display(),
            self.written,
            labels.len(),
            self.voxels_per_frame
        );
        let (lo, hi) = self.label_range;
        if let Some(v) = labels.iter().find(|&&v| v < lo || v > hi) {
            bail!(
                "{}: label {v} in frame {} is outside the announced range {lo}..={hi}",
                self.path.display(),
                self.written
            );
        }
        let mut buffer = std::mem::take(&mut self.buffer);
        buffer.clear();
        // In range by the check above, so the narrowing is exact.
        self.label_type.encode_le_into(labels, &mut buffer);
        let result = self.write_bytes(&buffer);
        self.buffer = buffer;
        result?;
        self.written += 1;
        Ok(())
    }

    /// Completes the file after the last frame: flushes, syncs and renames it into place.
    pub fn finish(self) -> Result<()> {
        let (file, tmp, path) = self.complete()?;
        persist(file, tmp, &path)
    }

    /// Completes the file after the last frame and adds it to `set`, which puts it in place
    /// with the set's other files (a mask with its colour tables, all or none).
    pub fn finish_into(self, set: &mut OutputSet) -> Result<()> {
        let (file, tmp, path) = self.complete()?;
        set.stage(file, tmp, &path)
    }

    /// The complete temporary (every frame written, the stream flushed) and its final path.
    fn complete(self) -> Result<(File, TempPath, PathBuf)> {
        ensure!(
            self.written == self.frames,
            "{}: {} of {} frames written",
            self.path.display(),
            self.written,
            self.frames
        );
        let tmp = self.tmp.display().to_string();
        let file = match self.sink {
            Sink::Plain(w) => w.into_inner().map_err(|e| e.into_error()),
            Sink::Gzip(w) => w
                .finish()
                .and_then(|w| w.into_inner().map_err(|e| e.into_error())),
        }
        .with_context(|| format!("cannot write {tmp}"))?;
        Ok((file, self.tmp, self.path))
    }

    fn write_bytes(&mut self, bytes: &[u8]) -> Result<()> {
        self.sink
            .writer()
            .write_all(bytes)
            .with_context(|| format!("cannot write {}", self.tmp.display()))
    }
}

/// The 348-byte header and the empty extension flag.
fn encode_header(h: &VolumeHeader, label_type: VoxelType) -> [u8; VOX_OFFSET] {
    let mut b = [0u8; VOX_OFFSET];
    let mut put =
        |offset: usize, bytes: &[u8]| b[offset..offset + bytes.len()].copy_from_slice(bytes);
    let i16s = |v: &[i16]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    let f32s = |v: &[f64]| {
        v.iter()
            .flat_map(|&x| (x as f32).to_le_bytes())
            .collect::<Vec<u8>>()
    };
    let (datatype, bitpix) = (nifti_datatype(label_type), 8 * label_type.bytes() as i16);
    let [nx, ny, nz] = h.dims.map(|n| n as i16);
    let rank = if h.frames > 1 { 4 } else { 3 };
    let a = h.affine;
    let spacing: [f64; 3] =
        std::array::from_fn(|c| (0..3).map(|r| a[r][c] * a[r][c]).sum::<f64>().sqrt());
    let qform = quaternion(&a, spacing);
    let qfac = qform.map_or(1.0, |q| q.qfac);

    put(0, &(HEADER_SIZE as i32).to_le_bytes());
    put(38, b"r");
    put(40, &i16s(&[rank, nx, ny, nz, h.frames as i16, 1, 1, 1]));
    put(68, &INTENT_LABEL.to_le_bytes());
    put(70, &datatype.to_le_bytes());
    put(72, &bitpix.to_le_bytes());
    put(
        76,
        &f32s(&[
            qfac,
            spacing[0],
            spacing[1],
            spacing[2],
            h.frame_interval,
            1.0,
            1.0,
            1.0,
        ]),
    );
    put(108, &f32s(&[VOX_OFFSET as f64, 1.0, 0.0])); // vox_offset, scl_slope, scl_inter
    put(123, &[2 | 8]); // xyzt_units: NIFTI_UNITS_MM | NIFTI_UNITS_SEC
    let (lo, hi) = h.label_range;
    put(124, &f32s(&[f64::from(hi), f64::from(lo)])); // cal_max, cal_min
    put(136, &f32s(&[h.time_offset])); // toffset
    put(148, h.description.as_bytes());
    let qform_code = if qform.is_some() { XFORM_ALIGNED } else { 0 };
    put(252, &i16s(&[qform_code, XFORM_ALIGNED]));
    if let Some(q) = qform {
        put(256, &f32s(&[q.b, q.c, q.d, a[0][3], a[1][3], a[2][3]]));
    }
    put(280, &f32s(&a[0]));
    put(296, &f32s(&a[1]));
    put(312, &f32s(&a[2]));
    put(344, b"n+1\0");
    b
}

/// The qform parameters of an affine: quaternion (b, c, d) of its rotation and `qfac`.
#[derive(Debug, Clone, Copy)]
struct Quaternion {
    b: f64,
    c: f64,
    d: f64,
    qfac: f64,
}

/// The rotation of `a`'s columns divided by `spacing`, as NIfTI-1's quaternion with `qfac` = −1
/// for a left-handed affine (its third column flipped); `None` when the columns are not
/// orthogonal (shear), which a qform cannot express.
fn quaternion(a: &[[f64; 4]; 3], spacing: [f64; 3]) -> Option<Quaternion> {
    if spacing.iter().any(|&s| s <= 0.0 || !s.is_finite()) {
        return None;
    }
    let mut r: [[f64; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| a[i][j] / spacing[j]));
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let dot: f64 = (0..3).map(|k| r[k][i] * r[k][j]).sum();
        // f32 header values carry ~1e-7 relative error; anything beyond is real shear.
        if dot.abs() > 1e-5 {
            return None;
        }
    }
    let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1])
        - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
        + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    let qfac = if det < 0.0 {
        r.iter_mut().for_each(|row| row[2] = -row[2]);
        -1.0
    } else {
        1.0
    };
    // Shepperd's method as in nifti1_io's nifti_mat44_to_quatern: divide by the largest of
    // the four candidate terms for accuracy.
    let trace = r[0][0] + r[1][1] + r[2][2];
    let (qa, qb, qc, qd);
    if trace + 1.0 > 0.5 {
        qa = 0.5 * (trace + 1.0).sqrt();
        qb = 0.25 * (r[2][1] - r[1][2]) / qa;
        qc = 0.25 * (r[0][2] - r[2][0]) / qa;
        qd = 0.25 * (r[1][0] - r[0][1]) / qa;
    } else {
        let xd = 1.0 + r[0][0] - (r[1][1] + r[2][2]);
        let yd = 1.0 + r[1][1] - (r[0][0] + r[2][2]);
        let zd = 1.0 + r[2][2] - (r[0][0] + r[1][1]);
        if xd > 1.0 {
            qb = 0.5 * xd.sqrt();
            qc = 0.25 * (r[0][1] + r[1][0]) / qb;
            qd = 0.25 * (r[0][2] + r[2][0]) / qb;
            qa = 0.25 * (r[2][1] - r[1][2]) / qb;
        } else if yd > 1.0 {
            qc = 0.5 * yd.sqrt();
            qb = 0.25 * (r[0][1] + r[1][0]) / qc;
            qd = 0.25 * (r[1][2] + r[2][1]) / qc;
            qa = 0.25 * (r[0][2] - r[2][0]) / qc;
        } else {
            qd = 0.5 * zd.sqrt();
            qb = 0.25 * (r[0][2] + r[2][0]) / qd;
            qc = 0.25 * (r[1][2] + r[2][1]) / qd;
            qa = 0.25 * (r[1][0] - r[0][1]) / qd;
        }
    }
    // Readers recover a = √(1 − b² − c² − d²) ≥ 0, so the sign goes with a ≥ 0.
    let s = if qa < 0.0 { -1.0 } else { 1.0 };
    Some(Quaternion {
        b: s * qb,
        c: s * qc,
        d: s * qd,
        qfac,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::label_volume::LabelVolume;
    use crate::nifti::read_volume;

    fn header(affine: [[f64; 4]; 3], frames: usize, range: (i32, i32)) -> VolumeHeader {
        VolumeHeader {
            dims: [5, 4, 3],
            frames,
            affine,
            frame_interval: 0.25,
            time_offset: 0.0,
            label_range: range,
            description: "test".into(),
        }
    }

    fn write(path: &Path, h: &VolumeHeader, frame: impl Fn(usize, usize) -> i32) -> Vec<i32> {
        let mut s = NiftiStream::create(path, h).unwrap();
        let n = h.dims.iter().product::<usize>();
        let mut all = Vec::new();
        for f in 0..h.frames {
            let labels: Vec<i32> = (0..n).map(|v| frame(f, v)).collect();
            s.write_frame(&labels).unwrap();
            all.extend(labels);
        }
        s.finish().unwrap();
        all
    }

    fn close(a: &[[f64; 4]; 3], b: &[[f64; 4]; 3]) -> bool {
        a.iter()
            .flatten()
            .zip(b.iter().flatten())
            .all(|(x, y)| (x - y).abs() < 1e-5)
    }

    /// A rotation about an oblique axis, anisotropic voxels, a flipped (left-handed) axis.
    fn oblique() -> [[f64; 4]; 3] {
        let (s, c) = 0.7f64.sin_cos();
        let rz = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
        let (s2, c2) = 0.4f64.sin_cos();
        let rx = [[1.0, 0.0, 0.0], [0.0, c2, -s2], [0.0, s2, c2]];
        let spacing = [1.5, 0.8, -2.5];
        std::array::from_fn(|i| {
            let mut row = [0.0; 4];
            for j in 0..3 {
                row[j] = (0..3).map(|k| rz[i][k] * rx[k][j]).sum::<f64>() * spacing[j];
            }
            row[3] = [10.0, -20.0, 5.5][i];
            row
        })
    }

    #[test]
    fn round_trip_through_the_reader_gz_and_plain_3d_and_4d() {
        let dir = tempfile::tempdir().unwrap();
        for (name, frames, range) in [
            ("a.nii.gz", 3, (0, 7)),
            ("b.nii", 1, (-40000, 40000)),
            ("c.NII.GZ", 2, (-3, 300)),
        ] {
            let path = dir.path().join(name);
            let h = header(oblique(), frames, range);
            let labels = write(&path, &h, |f, v| [range.0, 0, range.1][(v * 7 + f) % 3]);
            let back = read_volume(&path).unwrap();
            assert_eq!(back.dims, h.dims);
            assert_eq!(back.frames, frames);
            assert_eq!(back.labels, labels);
            assert!(close(&back.affine, &h.affine), "{:?}", back.affine);
            assert_eq!(back.frame_interval, 0.25);
            let gz = std::fs::read(&path).unwrap().starts_with(&[0x1f, 0x8b]);
            assert_eq!(gz, name.to_lowercase().ends_with(".gz"), "{name}");
            let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
            assert!(names.iter().all(|e| !e
                .as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with('.')));
        }
        let kinds =
            [(0, 7), (-40000, 40000)].map(|(lo, hi)| VoxelType::narrowest(lo, hi, &OFFERED));
        assert_eq!(kinds, [Some(VoxelType::Int16), Some(VoxelType::Int32)]);
    }

    /// The qform alone (sform_code patched to 0) gives the same affine through the reader's
    /// quaternion path, for a left-handed oblique affine and a plain diagonal one.
    #[test]
    fn qform_encodes_the_same_affine() {
        let dir = tempfile::tempdir().unwrap();
        let diagonal = [
            [2.0, 0.0, 0.0, -1.0],
            [0.0, 3.0, 0.0, 4.0],
            [0.0, 0.0, 0.5, 0.0],
        ];
        // Rotations by 170° about axes near x, y and z reach every branch of the extraction.
        let turn = |axis: [f64; 3]| -> [[f64; 4]; 3] {
            let n = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
            let [x, y, z] = axis.map(|v| v / n);
            let (s, c) = 170f64.to_radians().sin_cos();
            let k = [[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]];
            // Rodrigues: R = I + sin θ K + (1 − cos θ) K².
            std::array::from_fn(|i| {
                let mut row = [0.0; 4];
                for j in 0..3 {
                    let k2: f64 = (0..3).map(|m| k[i][m] * k[m][j]).sum();
                    row[j] = f64::from(u8::from(i == j)) + s * k[i][j] + (1.0 - c) * k2;
                }
                row
            })
        };
        let turns = [[1.0, 0.3, 0.2], [0.2, 1.0, 0.3], [0.3, 0.2, 1.0]].map(turn);
        for affine in [oblique(), diagonal].into_iter().chain(turns) {
            let path = dir.path().join("q.nii");
            write(&path, &header(affine, 1, (0, 1)), |_, v| (v % 2) as i32);
            let mut bytes = std::fs::read(&path).unwrap();
            assert_eq!(&bytes[148..153], b"test\0", "descrip");
            assert_eq!(
                i16::from_le_bytes([bytes[252], bytes[253]]),
                2,
                "qform_code"
            );
            bytes[254..256].copy_from_slice(&0i16.to_le_bytes());
            std::fs::write(&path, &bytes).unwrap();
            let back: LabelVolume = read_volume(&path).unwrap();
            assert!(
                close(&back.affine, &affine),
                "{affine:?} → {:?}",
                back.affine
            );
        }
        // Shear: no qform, the sform still carries it.
        let shear = [
            [1.0, 0.5, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ];
        let path = dir.path().join("shear.nii");
        write(&path, &header(shear, 1, (0, 1)), |_, _| 1);
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(i16::from_le_bytes([bytes[252], bytes[253]]), 0);
        assert!(close(&read_volume(&path).unwrap().affine, &shear));
    }

    #[test]
    fn misuse_is_reported_with_the_file_and_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.nii.gz");
        let h = header(oblique(), 2, (0, 3));
        let mut s = NiftiStream::create(&path, &h).unwrap();
        let e = s.write_frame(&[0; 3]).unwrap_err().to_string();
        assert!(
            e.contains("bad.nii.gz") && e.contains("has 3 voxels, the volume 60"),
            "{e}"
        );
        let e = s.write_frame(&[4; 60]).unwrap_err().to_string();
        assert!(e.contains("label 4 in frame 0 is outside"), "{e}");
        s.write_frame(&[1; 60]).unwrap();
        let e = s.finish().unwrap_err().to_string();
        assert!(e.contains("1 of 2 frames written"), "{e}");
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            0,
            "no temporary left"
        );
        let e = NiftiStream::create(
            &path,
            &VolumeHeader {
                dims: [0, 1, 1],
                ..h.clone()
            },
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("0 voxels on axis 0"), "{e}");
        let e = NiftiStream::create(
            &path,
            &VolumeHeader {
                description: "x".repeat(80),
                ..h
            },
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("longer than NIfTI-1's 79 bytes"), "{e}");
    }
}
