//! The 3D Slicer segmentation writer (`.seg.nrrd`, one 3D frame per file). See the
//! [module docs](super) for the fields written.

use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};

use flate2::write::GzEncoder;

use super::{escape, flip_xy};
use crate::atomic::write_atomically;
use crate::error::{DataError, ErrorKind, Result};
use crate::nifti::det3;
use crate::sequence::ClassInfo;

/// What a segmentation file describes besides its voxels.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentationHeader {
    /// Voxels per axis (x, y, z).
    pub dims: [usize; 3],
    /// Voxel index → RAS world, as in [`crate::nifti::LabelVolume::affine`]; written in LPS.
    pub affine: [[f64; 4]; 3],
    /// The segments, in order: each class's label is its voxel value (nonzero, distinct), its
    /// colour the class's or [`palette`] of its position.
    pub classes: Vec<ClassInfo>,
}

/// Tableau 10 (matplotlib's `tab10`): ten qualitative colours chosen to stay distinct from one
/// another and readable on dark and light backgrounds, as 3D Slicer shows segments.
const TABLEAU_10: [[u8; 3]; 10] = [
    [0x1f, 0x77, 0xb4], // blue
    [0xff, 0x7f, 0x0e], // orange
    [0x2c, 0xa0, 0x2c], // green
    [0xd6, 0x27, 0x28], // red
    [0x94, 0x67, 0xbd], // purple
    [0x8c, 0x56, 0x4b], // brown
    [0xe3, 0x77, 0xc2], // pink
    [0x7f, 0x7f, 0x7f], // grey
    [0xbc, 0xbd, 0x22], // olive
    [0x17, 0xbe, 0xcf], // cyan
];

/// The display colour (sRGB) of the segment at position `index` when its class has none: the
/// Tableau 10 palette, repeating after ten.
pub fn palette(index: usize) -> [u8; 3] {
    TABLEAU_10[index % TABLEAU_10.len()]
}

/// The file of frame `frame` of a `frames`-frame series written to `path`: `path` itself for
/// one frame, else `_t` and the zero-padded frame number before `.seg.nrrd` (or `.nrrd`), e.g.
/// `heart.seg.nrrd` → `heart_t07.seg.nrrd` for frame 7 of 20.
pub fn frame_path(path: &Path, frame: usize, frames: usize) -> PathBuf {
    if frames <= 1 {
        return path.to_path_buf();
    }
    let width = (frames - 1).to_string().len();
    let name = path
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    let lower = name.to_ascii_lowercase();
    let stem = [".seg.nrrd", ".nrrd"]
        .iter()
        .find(|ext| lower.ends_with(*ext))
        .map_or(name.len(), |ext| name.len() - ext.len());
    path.with_file_name(format!(
        "{}_t{frame:0width$}{}",
        &name[..stem],
        &name[stem..]
    ))
}

/// Writes one frame's `labels` (x fastest, one per voxel of `header.dims`) as a 3D Slicer
/// segmentation, atomically: on any error nothing is left at `path`. Every nonzero label must
/// be one of `header.classes`.
pub fn write_segmentation(path: &Path, header: &SegmentationHeader, labels: &[i32]) -> Result<()> {
    let at = |what: String| DataError::new(ErrorKind::Nrrd(what)).in_file(path);
    let bytes = encode(header, labels).map_err(at)?;
    write_atomically(path, &bytes).map_err(|e| at(format!("cannot write: {e:#}")))
}

/// The whole file: header text, then the gzip-compressed voxels.
fn encode(h: &SegmentationHeader, labels: &[i32]) -> std::result::Result<Vec<u8>, String> {
    let [nx, ny, nz] = h.dims;
    let voxels = h
        .dims
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .filter(|_| !h.dims.contains(&0))
        .ok_or_else(|| format!("dims {:?} are not a volume", h.dims))?;
    if labels.len() != voxels {
        return Err(format!(
            "{} labels for {nx}×{ny}×{nz} = {voxels} voxels",
            labels.len()
        ));
    }
    let a = h.affine;
    if !a.iter().flatten().all(|v| v.is_finite()) || det3(&a) == 0.0 {
        return Err(format!(
            "voxel-to-world transform is singular or not finite: {a:?}"
        ));
    }
    let mut known = HashSet::new();
    for c in &h.classes {
        if c.label == 0 {
            return Err(format!("class {:?} has label 0, the background", c.name));
        }
        if !known.insert(c.label) {
            return Err(format!("label {} is given to two classes", c.label));
        }
        if c.name
            .chars()
            .any(|ch| ch.is_control() && ch != '\t' && ch != '\n')
        {
            return Err(format!("class name {:?} has a control character", c.name));
        }
    }
    if let Some(n) = labels.iter().position(|&v| v != 0 && !known.contains(&v)) {
        return Err(format!(
            "voxel ({}, {}, {}) has label {}, which no class has",
            n % nx,
            n / nx % ny,
            n / (nx * ny),
            labels[n]
        ));
    }
    let (lo, hi) = h
        .classes
        .iter()
        .fold((0, 0), |(lo, hi), c| (c.label.min(lo), c.label.max(hi)));
    let (type_name, width) = if lo >= 0 && hi <= i32::from(u8::MAX) {
        ("unsigned char", 1)
    } else if lo >= i32::from(i16::MIN) && hi <= i32::from(i16::MAX) {
        ("short", 2)
    } else {
        ("int", 4)
    };
    let num = |x: f64| format!("{}", x + 0.0); // + 0.0: no "-0"
    let vector = |v: [f64; 3]| format!("({},{},{})", num(v[0]), num(v[1]), num(v[2]));
    let lps = flip_xy(&a);
    let column = |c: usize| vector([lps[0][c], lps[1][c], lps[2][c]]);
    let mut text = String::from(
        "NRRD0004\n# Complete NRRD file format specification at:\n\
         # http://teem.sourceforge.net/nrrd/format.html\n",
    );
    let mut line = |s: String| {
        text.push_str(&s);
        text.push('\n');
    };
    line(format!("type: {type_name}"));
    line("dimension: 3".into());
    line("space: left-posterior-superior".into());
    line(format!("sizes: {nx} {ny} {nz}"));
    line(format!(
        "space directions: {} {} {}",
        column(0),
        column(1),
        column(2)
    ));
    line("kinds: domain domain domain".into());
    if width > 1 {
        line("endian: little".into());
    }
    line("encoding: gzip".into());
    line(format!(
        "space origin: {}",
        vector([lps[0][3], lps[1][3], lps[2][3]])
    ));
    for (n, c) in h.classes.iter().enumerate() {
        let color = c.color.unwrap_or_else(|| palette(n));
        let key = |field: &str, value: String| format!("Segment{n}_{field}:={value}");
        line(key(
            "Color",
            color.map(|v| num(f64::from(v) / 255.0)).join(" "),
        ));
        line(key(
            "ColorAutoGenerated",
            u8::from(c.color.is_none()).to_string(),
        ));
        line(key(
            "Extent",
            format!("0 {} 0 {} 0 {}", nx - 1, ny - 1, nz - 1),
        ));
        line(key("ID", format!("Segment_{}", c.label)));
        line(key("LabelValue", c.label.to_string()));
        line(key("Layer", "0".into()));
        line(key("Name", escape(&c.name)));
        line(key("NameAutoGenerated", "0".into()));
        line(key("Tags", "|".into()));
    }
    line("Segmentation_ContainedRepresentationNames:=Binary labelmap|".into());
    line("Segmentation_MasterRepresentation:=Binary labelmap".into());
    line("Segmentation_ReferenceImageExtentOffset:=0 0 0".into());
    line(String::new());
    let mut gz = GzEncoder::new(text.into_bytes(), flate2::Compression::default());
    let mut buffer = Vec::with_capacity(1 << 16);
    for chunk in labels.chunks(1 << 14) {
        buffer.clear();
        // Every value is 0 or a class label, all within the type's range (checked above).
        match width {
            1 => buffer.extend(chunk.iter().map(|&v| v as u8)),
            2 => chunk
                .iter()
                .for_each(|&v| buffer.extend((v as i16).to_le_bytes())),
            _ => chunk.iter().for_each(|&v| buffer.extend(v.to_le_bytes())),
        }
        gz.write_all(&buffer)
            .map_err(|e| format!("cannot compress: {e}"))?;
    }
    gz.finish().map_err(|e| format!("cannot compress: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_paths_keep_the_extension() {
        let p = Path::new("/out/heart.seg.nrrd");
        assert_eq!(frame_path(p, 0, 1), p);
        assert_eq!(frame_path(p, 7, 20), Path::new("/out/heart_t07.seg.nrrd"));
        assert_eq!(
            frame_path(Path::new("a.NRRD"), 3, 5),
            Path::new("a_t3.NRRD")
        );
        assert_eq!(frame_path(Path::new("x.bin"), 0, 2), Path::new("x.bin_t0"));
    }

    #[test]
    fn palette_is_ten_distinct_colours_then_repeats() {
        let first: HashSet<[u8; 3]> = (0..10).map(palette).collect();
        assert_eq!(first.len(), 10);
        assert_eq!(palette(10), palette(0));
    }
}
