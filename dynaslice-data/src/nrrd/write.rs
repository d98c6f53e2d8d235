//! The 3D Slicer segmentation writer (`.seg.nrrd`, one 3D frame per file). See the
//! [module docs](super) for the fields written.

use std::collections::HashSet;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use flate2::write::GzEncoder;
use tempfile::TempPath;

use super::{escape, flip_xy};
use crate::label_volume::det3;
use crate::voxel_type::VoxelType;
use dynaslice_output::{create_temporary, persist, write_atomically, OutputSet};
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::palette::palette;
use dynaslice_sequence::sequence::ClassInfo;

/// What a segmentation file describes besides its voxels.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentationHeader {
    /// Voxels per axis (x, y, z).
    pub dims: [usize; 3],
    /// Voxel index → RAS world, as in [`crate::label_volume::LabelVolume::affine`]; written in LPS.
    pub affine: [[f64; 4]; 3],
    /// The segments, in order: each class's label is its voxel value (nonzero, distinct), its
    /// colour the class's or [`palette`] of its position.
    pub classes: Vec<ClassInfo>,
}

/// The file of frame `frame` of a `frames`-frame series written to `path`: `path` itself for
/// one frame, else `_t` and the zero-padded frame number before `.seg.nrrd` (or `.nrrd`), e.g.
/// `heart.seg.nrrd` → `heart_t07.seg.nrrd` for frame 7 of 20.
pub fn frame_path(path: &Path, frame: usize, frames: usize) -> PathBuf {
    if frames <= 1 {
        return path.to_path_buf();
    }
    let width = (frames - 1).to_string().len();
    let (name, stem) = name_and_stem(path);
    path.with_file_name(format!(
        "{}_t{frame:0width$}{}",
        &name[..stem],
        &name[stem..]
    ))
}

/// A test of a file name: whether it is one of the names [`frame_path`] gives a series of any
/// length written to `path` (`heart_t7.seg.nrrd`, `heart_t07.seg.nrrd`, …), so that a series
/// written over a longer one can remove the earlier frames it does not write again.
pub fn frame_name_test(path: &Path) -> impl Fn(&str) -> bool + Send + Sync + 'static {
    let (name, stem) = name_and_stem(path);
    let (prefix, ext) = (format!("{}_t", &name[..stem]), name[stem..].to_string());
    move |candidate: &str| {
        candidate
            .strip_prefix(prefix.as_str())
            .and_then(|rest| rest.strip_suffix(ext.as_str()))
            .is_some_and(|i| !i.is_empty() && i.bytes().all(|b| b.is_ascii_digit()))
    }
}

/// Writes one frame's `labels` (x fastest, one per voxel of `header.dims`) as a 3D Slicer
/// segmentation, atomically: on any error nothing is left at `path`. Every nonzero label must
/// be one of `header.classes`.
pub fn write_segmentation(path: &Path, header: &SegmentationHeader, labels: &[i32]) -> Result<()> {
    let at = |what: String| DataError::new(ErrorKind::Nrrd(what)).in_file(path);
    let bytes = encode(header, labels).map_err(at)?;
    write_atomically(path, &bytes).map_err(|e| at(format!("cannot write: {e:#}")))
}

/// Adds one frame's segmentation at `path` (as [`write_segmentation`] writes it) to `set`,
/// which puts it in place with the set's other files (a series' frames and its sequence, all
/// or none).
pub fn stage_segmentation(
    set: &mut OutputSet,
    path: &Path,
    header: &SegmentationHeader,
    labels: &[i32],
) -> Result<()> {
    let at = |what: String| DataError::new(ErrorKind::Nrrd(what)).in_file(path);
    let bytes = encode(header, labels).map_err(at)?;
    set.write(path, &bytes)
        .map_err(|e| at(format!("cannot write: {e:#}")))
}

/// The file of the 3D Slicer sequence beside a segmentation series written to `path`:
/// `.seg.nrrd` (or a last `.nrrd`, any case) replaced by `.seq.nrrd`, e.g. `heart.seg.nrrd` →
/// `heart.seq.nrrd`; other names get `.seq.nrrd` appended.
pub fn sequence_path(path: &Path) -> PathBuf {
    let (name, stem) = name_and_stem(path);
    path.with_file_name(format!("{}.seq.nrrd", &name[..stem]))
}

/// The file name of `path` and the length of its stem: the name without a last `.seg.nrrd` or
/// `.nrrd` (any case), or the whole name.
fn name_and_stem(path: &Path) -> (String, usize) {
    let name = path
        .file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into_owned());
    let lower = name.to_ascii_lowercase();
    let stem = [".seg.nrrd", ".nrrd"]
        .iter()
        .find(|ext| lower.ends_with(*ext))
        .map_or(name.len(), |ext| name.len() - ext.len());
    (name, stem)
}

/// The types the writer offers, narrowest first (ITK and 3D Slicer read all three).
const OFFERED: [VoxelType; 3] = [VoxelType::Uint8, VoxelType::Int16, VoxelType::Int32];

/// NRRD's name of `t`, as teem and 3D Slicer write it.
fn type_name(t: VoxelType) -> &'static str {
    match t {
        VoxelType::Uint8 => "unsigned char",
        VoxelType::Int8 => "signed char",
        VoxelType::Uint16 => "unsigned short",
        VoxelType::Int16 => "short",
        VoxelType::Uint32 => "unsigned int",
        VoxelType::Int32 => "int",
        VoxelType::Uint64 => "unsigned long long",
        VoxelType::Int64 => "long long",
    }
}

/// Checks `h` and returns the voxels per frame and the voxel type: the narrowest of `unsigned
/// char`, `short` and `int` that holds every class label.
fn check_header(h: &SegmentationHeader) -> std::result::Result<(usize, VoxelType), String> {
    let voxels = h
        .dims
        .iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .filter(|_| !h.dims.contains(&0))
        .ok_or_else(|| format!("dims {:?} are not a volume", h.dims))?;
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
    let (lo, hi) = h
        .classes
        .iter()
        .fold((0, 0), |(lo, hi), c| (c.label.min(lo), c.label.max(hi)));
    // Int32 holds every i32.
    let t = VoxelType::narrowest(lo, hi, &OFFERED).unwrap_or(VoxelType::Int32);
    Ok((voxels, t))
}

/// An error unless `labels` has one value per voxel, each 0 or a class's label.
fn check_labels(h: &SegmentationHeader, labels: &[i32]) -> std::result::Result<(), String> {
    let [nx, ny, nz] = h.dims;
    let voxels = nx * ny * nz;
    if labels.len() != voxels {
        return Err(format!(
            "{} labels for {nx}×{ny}×{nz} = {voxels} voxels",
            labels.len()
        ));
    }
    let known: HashSet<i32> = h.classes.iter().map(|c| c.label).collect();
    if let Some(n) = labels.iter().position(|&v| v != 0 && !known.contains(&v)) {
        return Err(format!(
            "voxel ({}, {}, {}) has label {}, which no class has",
            n % nx,
            n / nx % ny,
            n / (nx * ny),
            labels[n]
        ));
    }
    Ok(())
}

/// A number as NRRD headers write it: the shortest exact decimal, never `-0`.
fn num(x: f64) -> String {
    format!("{}", x + 0.0)
}

/// The header text (through the blank line) of one frame, or of a sequence of frames at
/// `times` (a fourth, `list` axis, slowest).
fn header_text(h: &SegmentationHeader, t: VoxelType, times: Option<&[f64]>) -> String {
    let [nx, ny, nz] = h.dims;
    let vector = |v: [f64; 3]| format!("({},{},{})", num(v[0]), num(v[1]), num(v[2]));
    let lps = flip_xy(&h.affine);
    let column = |c: usize| vector([lps[0][c], lps[1][c], lps[2][c]]);
    let mut text = String::from(
        "NRRD0004\n# Complete NRRD file format specification at:\n\
         # http://teem.sourceforge.net/nrrd/format.html\n",
    );
    let mut line = |s: String| {
        text.push_str(&s);
        text.push('\n');
    };
    line(format!("type: {}", type_name(t)));
    let directions = format!("{} {} {}", column(0), column(1), column(2));
    match times {
        None => {
            line("dimension: 3".into());
            line("space: left-posterior-superior".into());
            line(format!("sizes: {nx} {ny} {nz}"));
            line(format!("space directions: {directions}"));
            line("kinds: domain domain domain".into());
        }
        Some(times) => {
            line("dimension: 4".into());
            line("space: left-posterior-superior".into());
            line(format!("sizes: {nx} {ny} {nz} {}", times.len()));
            line(format!("space directions: {directions} none"));
            line("kinds: domain domain domain list".into());
            line("labels: \"\" \"\" \"\" \"time\"".into());
        }
    }
    if t.bytes() > 1 {
        line("endian: little".into());
    }
    line("encoding: gzip".into());
    line(format!(
        "space origin: {}",
        vector([lps[0][3], lps[1][3], lps[2][3]])
    ));
    if let Some(times) = times {
        // Times at the f32 precision of the NIfTI output's header (1, not 1.0000000074505806).
        let values: Vec<String> = times
            .iter()
            .map(|&t| (t as f32 + 0.0).to_string())
            .collect();
        line("DataNodeClassName:=vtkMRMLLabelMapVolumeNode".into());
        line("axis 3 index type:=numeric".into());
        line(format!("axis 3 index values:={}", values.join(" ")));
    }
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
    if times.is_none() {
        line("Segmentation_ContainedRepresentationNames:=Binary labelmap|".into());
        line("Segmentation_MasterRepresentation:=Binary labelmap".into());
        line("Segmentation_ReferenceImageExtentOffset:=0 0 0".into());
    }
    line(String::new());
    text
}

/// `labels` in the file's voxel type, little-endian, into `out` (cleared first). Every value is
/// 0 or a class label, all within the type's range ([`check_header`], [`check_labels`]).
fn encode_voxels(labels: &[i32], t: VoxelType, out: &mut Vec<u8>) {
    out.clear();
    t.encode_le_into(labels, out);
}

/// The whole file: header text, then the gzip-compressed voxels.
fn encode(h: &SegmentationHeader, labels: &[i32]) -> std::result::Result<Vec<u8>, String> {
    let (_, t) = check_header(h)?;
    check_labels(h, labels)?;
    let text = header_text(h, t, None);
    let mut gz = GzEncoder::new(text.into_bytes(), flate2::Compression::default());
    let mut buffer = Vec::with_capacity(1 << 16);
    for chunk in labels.chunks(1 << 14) {
        encode_voxels(chunk, t, &mut buffer);
        gz.write_all(&buffer)
            .map_err(|e| format!("cannot compress: {e}"))?;
    }
    gz.finish().map_err(|e| format!("cannot compress: {e}"))
}

/// A write error of the sequence.
fn failed(e: String) -> DataError {
    DataError::new(ErrorKind::Nrrd(format!("cannot write: {e}")))
}

/// A 3D Slicer sequence of segmentation frames (`.seq.nrrd`) being written frame by frame:
/// the format of Slicer's Sequences module for a sequence of volumes on one grid, a 4D NRRD
/// whose last axis is a `list` of frames (`kinds: domain domain domain list`, `labels: "" ""
/// "" "time"`), with `DataNodeClassName:=vtkMRMLLabelMapVolumeNode`, `axis 3 index
/// type:=numeric` and `axis 3 index values:=` the frames' times; the voxels are the classes'
/// labels as in [`write_segmentation`], whose `SegmentN_` keys (names, colours, label values) it
/// carries too. Slicer 5.10 and later load it as a label-map sequence indexed by time (earlier
/// versions read `axis 0` keys only and number the frames 0, 1, …).
///
/// Memory is one chunk of encoded voxels: frames are compressed into a temporary file beside
/// `path` as they come, renamed into place by [`SequenceWriter::finish`] and deleted if the
/// writer is dropped before.
pub struct SequenceWriter {
    path: PathBuf,
    /// The temporary of [`create_temporary`], deleted when dropped unfinished.
    tmp: TempPath,
    sink: GzEncoder<BufWriter<File>>,
    header: SegmentationHeader,
    voxel_type: VoxelType,
    frames: usize,
    written: usize,
    buffer: Vec<u8>,
}

impl SequenceWriter {
    /// Checks `header` and `times` (finite, one per frame, at least one), creates the temporary
    /// file beside `path` and writes the header.
    pub fn create(path: &Path, header: &SegmentationHeader, times: &[f64]) -> Result<Self> {
        let at = |what: String| DataError::new(ErrorKind::Nrrd(what)).in_file(path);
        let (_, voxel_type) = check_header(header).map_err(at)?;
        if times.is_empty() {
            return Err(at("a sequence needs at least one frame".into()));
        }
        if let Some(t) = times.iter().find(|t| !t.is_finite()) {
            return Err(at(format!("frame time {t} is not finite")));
        }
        // Dropping `tmp` (on any error below) deletes the temporary file.
        let (file, tmp) = create_temporary(path).map_err(|e| at(format!("{e:#}")))?;
        let mut file = BufWriter::new(file);
        let text = header_text(header, voxel_type, Some(times));
        file.write_all(text.as_bytes())
            .map_err(|e| at(format!("cannot write: {e}")))?;
        Ok(SequenceWriter {
            path: path.to_path_buf(),
            tmp,
            sink: GzEncoder::new(file, flate2::Compression::default()),
            header: header.clone(),
            voxel_type,
            frames: times.len(),
            written: 0,
            buffer: Vec::with_capacity(1 << 16),
        })
    }

    /// Appends the next frame: one label per voxel, x fastest, each 0 or a class's label.
    pub fn write_frame(&mut self, labels: &[i32]) -> Result<()> {
        if self.written == self.frames {
            return Err(self.error(format!(
                "frame {} is one more than the {} announced",
                self.written, self.frames
            )));
        }
        check_labels(&self.header, labels).map_err(|e| self.error(e))?;
        let mut buffer = std::mem::take(&mut self.buffer);
        let sink = &mut self.sink;
        let mut result = Ok(());
        for chunk in labels.chunks(1 << 14) {
            encode_voxels(chunk, self.voxel_type, &mut buffer);
            result = sink.write_all(&buffer);
            if result.is_err() {
                break;
            }
        }
        self.buffer = buffer;
        result.map_err(|e| self.error(format!("cannot write: {e}")))?;
        self.written += 1;
        Ok(())
    }

    /// Completes the file after the last frame: flushes, syncs and renames it into place.
    pub fn finish(self) -> Result<()> {
        let (file, tmp, path) = self.complete()?;
        persist(file, tmp, &path).map_err(|e| failed(format!("{e:#}")).in_file(&path))
    }

    /// Completes the file after the last frame and adds it to `set`, which puts it in place
    /// with the frames' own files (all or none).
    pub fn finish_into(self, set: &mut OutputSet) -> Result<()> {
        let (file, tmp, path) = self.complete()?;
        set.stage(file, tmp, &path)
            .map_err(|e| failed(format!("{e:#}")).in_file(&path))
    }

    /// The complete temporary (every frame written, the stream flushed) and its final path.
    fn complete(self) -> Result<(File, TempPath, PathBuf)> {
        if self.written != self.frames {
            return Err(self.error(format!(
                "{} of {} frames written",
                self.written, self.frames
            )));
        }
        let path = self.path;
        let file = self
            .sink
            .finish()
            .and_then(|w| w.into_inner().map_err(|e| e.into_error()))
            .map_err(|e| failed(e.to_string()).in_file(&path))?;
        Ok((file, self.tmp, path))
    }

    fn error(&self, what: String) -> DataError {
        DataError::new(ErrorKind::Nrrd(what)).in_file(&self.path)
    }
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
    fn frame_names_of_any_series_length_are_recognised() {
        let is_frame = frame_name_test(Path::new("/out/heart.seg.nrrd"));
        for frames in [2, 11, 101] {
            let name = frame_path(Path::new("/out/heart.seg.nrrd"), 1, frames);
            assert!(
                is_frame(name.file_name().unwrap().to_str().unwrap()),
                "{frames}"
            );
        }
        for other in [
            "heart.seg.nrrd",
            "heart.seq.nrrd",
            "heart_t.seg.nrrd",
            "heart_tx.seg.nrrd",
            "lung_t01.seg.nrrd",
            "heart_t01.nrrd",
        ] {
            assert!(!is_frame(other), "{other}");
        }
    }

    #[test]
    fn sequence_paths_replace_the_extension() {
        let p = |s: &str| sequence_path(Path::new(s));
        assert_eq!(p("/out/heart.seg.nrrd"), Path::new("/out/heart.seq.nrrd"));
        assert_eq!(p("a.SEG.NRRD"), Path::new("a.seq.nrrd"));
        assert_eq!(p("a.nrrd"), Path::new("a.seq.nrrd"));
        assert_eq!(p("x.bin"), Path::new("x.bin.seq.nrrd"));
    }

    fn two_classes() -> SegmentationHeader {
        SegmentationHeader {
            dims: [3, 2, 1],
            affine: [
                [2.0, 0.0, 0.0, 10.0],
                [0.0, 1.0, 0.0, -5.0],
                [0.0, 0.0, 3.0, 0.0],
            ],
            classes: vec![
                ClassInfo {
                    name: "a b".into(),
                    label: 1,
                    color: Some([255, 0, 0]),
                },
                ClassInfo {
                    name: "c".into(),
                    label: 300,
                    color: None,
                },
            ],
        }
    }

    /// The header names a 4D list-last volume with the sequence keys, and the gzip stream holds
    /// the frames one after the other as 16-bit little-endian labels.
    #[test]
    fn sequence_streams_frames_after_its_header() {
        use std::io::Read;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.seq.nrrd");
        let h = two_classes();
        let frames = [[0, 1, 300, 1, 0, 0], [300, 300, 0, 0, 1, 0]];
        let mut w = SequenceWriter::create(&path, &h, &[0.0, 0.1 + 0.2]).unwrap();
        for f in &frames {
            w.write_frame(f).unwrap();
        }
        w.finish().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let end = bytes.windows(2).position(|w| w == b"\n\n").unwrap() + 2;
        let text = std::str::from_utf8(&bytes[..end]).unwrap();
        for want in [
            "type: short\n",
            "dimension: 4\n",
            "sizes: 3 2 1 2\n",
            "space directions: (-2,0,0) (0,-1,0) (0,0,3) none\n",
            "kinds: domain domain domain list\n",
            "labels: \"\" \"\" \"\" \"time\"\n",
            "space origin: (-10,5,0)\n",
            "DataNodeClassName:=vtkMRMLLabelMapVolumeNode\n",
            "axis 3 index type:=numeric\n",
            "axis 3 index values:=0 0.3\n",
            "Segment0_Color:=1 0 0\n",
            "Segment1_LabelValue:=300\n",
            "Segment0_Name:=a b\n",
        ] {
            assert!(text.contains(want), "{want:?} missing from\n{text}");
        }
        let mut raw = Vec::new();
        flate2::read::GzDecoder::new(&bytes[end..])
            .read_to_end(&mut raw)
            .unwrap();
        let values: Vec<i32> = raw
            .chunks_exact(2)
            .map(|c| i32::from(i16::from_le_bytes([c[0], c[1]])))
            .collect();
        assert_eq!(values, frames.concat());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn unfinished_or_wrong_sequences_leave_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.seq.nrrd");
        let h = two_classes();
        let mut w = SequenceWriter::create(&path, &h, &[0.0, 1.0]).unwrap();
        let e = w.write_frame(&[0, 2, 0, 0, 0, 0]).unwrap_err().to_string();
        assert!(
            e.contains("label 2, which no class has") && e.contains("s.seq.nrrd"),
            "{e}"
        );
        w.write_frame(&[0; 6]).unwrap();
        let e = w.finish().unwrap_err().to_string();
        assert!(e.contains("1 of 2 frames"), "{e}");
        let w = SequenceWriter::create(&path, &h, &[0.0]).unwrap();
        drop(w);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        for times in [&[][..], &[f64::NAN][..]] {
            assert!(SequenceWriter::create(&path, &h, times).is_err());
        }
    }
}
