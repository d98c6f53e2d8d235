//! NIfTI-1 label volumes (`.nii`, `.nii.gz`; 3D or 4D): reading with world coordinates from the
//! sform/qform, and writing a whole volume (the synthetic benchmark's ground truth) through the
//! one NIfTI writer, [`crate::nifti_stream`].
//!
//! Only label data is accepted: an integer voxel type and no intensity scaling. Files are
//! decompressed by content (gzip magic), not by name. Reading into a [`Sequence`] goes through
//! [`super::reslice`]; see `docs/data-format.md` for the protocol.

use std::io::Read;
use std::path::Path;

use nifti::{Endianness, NiftiHeader, NiftiType, Unit};

use super::label_census::{check_classes, Stored};
use super::label_map::LabelMap;
use super::label_table::LabelTable;
use super::label_volume::{det3, Geometry, LabelVolume};
use super::nifti_stream::{NiftiStream, VolumeHeader, HEADER_SIZE};
use super::reslice::{reslice, ResliceOptions};
use super::voxel_type::VoxelType;
use dynaslice_sequence::error::{DataError, ErrorKind, Result};
use dynaslice_sequence::input_file;
use dynaslice_sequence::sequence::Sequence;
use dynaslice_sequence::TimeUnit;

/// Deflate's largest expansion (one 258-byte match per two bits): a `.nii.gz` of n bytes cannot
/// hold more than this × n bytes of NIfTI.
const MAX_DEFLATE_RATIO: usize = 1032;

/// Reads a label volume; see [`read_labelled_volume`] for the label table its header may carry.
pub fn read_volume(path: &Path) -> Result<LabelVolume> {
    read_labelled_volume(path).map(|(volume, _)| volume)
}

/// Relative difference between two voxel spacings beyond which a header disagrees with itself:
/// more than the rounding of a spacing written to 3 significant digits (1.56 for 1.5625).
pub const SPACING_TOLERANCE: f64 = 5e-3;

/// Where a NIfTI file's voxel-to-world transform takes its voxel spacing from. A header holds
/// it up to three times: the sform's columns, the qform (whose spacing is `pixdim[1..3]`), and
/// `pixdim` itself; real exports disagree (an sform of unit spacing beside a `pixdim` of
/// 1.56 × 1.56 × 10 mm), and every distance and volume follows the one used.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum HeaderSpacing {
    /// The NIfTI-1 rule as nibabel applies it (`get_best_affine`): the sform where
    /// `sform_code > 0`, else the qform where `qform_code > 0`, else `pixdim` alone; a warning
    /// names both spacings where the sform's and `pixdim` disagree.
    #[default]
    Auto,
    /// The sform (refused where `sform_code` is 0).
    Sform,
    /// The qform: the quaternion's rotation, `pixdim`'s spacing, the qoffset (refused where
    /// `qform_code` is 0).
    Qform,
    /// The transform [`HeaderSpacing::Auto`] picks, each voxel axis rescaled to `pixdim`'s
    /// spacing: its orientation and origin kept.
    Pixdim,
}

impl std::fmt::Display for HeaderSpacing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            HeaderSpacing::Auto => "auto",
            HeaderSpacing::Sform => "sform",
            HeaderSpacing::Qform => "qform",
            HeaderSpacing::Pixdim => "pixdim",
        })
    }
}

impl std::str::FromStr for HeaderSpacing {
    type Err = String;

    /// `auto`, `sform`, `qform` or `pixdim`.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "auto" => Ok(HeaderSpacing::Auto),
            "sform" => Ok(HeaderSpacing::Sform),
            "qform" => Ok(HeaderSpacing::Qform),
            "pixdim" => Ok(HeaderSpacing::Pixdim),
            _ => Err(format!(
                "expected `auto`, `sform`, `qform` or `pixdim`, found `{s}`"
            )),
        }
    }
}

/// Bytes of header extensions read for a label table; extensions beyond them are skipped unread.
const MAX_EXTENSION_BYTES: usize = 64 << 20;

/// Reads a label volume and the label table (names, colours) of its header extensions: an XML
/// `LabelTable` as Connectome Workbench and TotalSegmentator write it
/// ([`LabelTable::from_xml`]). An extension that is not understood is skipped with a warning.
///
/// Every size in the header is checked, with overflow-checked arithmetic, against what the file
/// can hold before anything is allocated or decompressed for it: voxels are read from
/// `vox_offset` (the extensions before it are skipped unread), as many bytes as the header's
/// dimensions and datatype need, and a gzip stream is read to its end so its checksum is verified.
pub fn read_labelled_volume(path: &Path) -> Result<(LabelVolume, LabelTable)> {
    read_labelled_volume_with(path, HeaderSpacing::Auto).map(|m| (m.volume, m.table))
}

/// [`read_labelled_volume`] with the voxel spacing taken as `spacing` says, and what the header
/// says of the values: the voxel type, and an intent other than a label map's or a description
/// naming an image ([`Stored`]).
pub fn read_labelled_volume_with(path: &Path, spacing: HeaderSpacing) -> Result<LabelMap> {
    let at = |kind: ErrorKind| DataError::new(kind).in_file(path);
    let unreadable =
        |e: &dyn std::fmt::Display| at(ErrorKind::Nifti(format!("unreadable or truncated: {e}")));
    // Streamed, not read through `InMemNiftiObject`: that reserves whatever the header's dims
    // (and each extension's size field) claim before reading, e.g. terabytes for 32767³ voxels
    // in a 400-byte file, and reads the voxels right after the extensions instead of at
    // `vox_offset`.
    let Source {
        mut source,
        gz,
        capacity,
    } = Source::open(path)?;
    let header = NiftiHeader::from_reader(&mut source).map_err(|e| unreadable(&e))?;
    if header.magic == *b"ni1\0" {
        return Err(at(ErrorKind::Nifti(
            "a header-only file (magic \"ni1\"); give the single-file .nii or .nii.gz".into(),
        )));
    }
    let datatype = header.data_type().map_err(|e| {
        at(ErrorKind::Nifti(format!(
            "unknown datatype code {}: {e}",
            header.datatype
        )))
    })?;
    let datatype = voxel_type(datatype).map_err(at)?;
    let (dims, frames) = dimensions(&header).map_err(at)?;
    let affine = affine_as(&header, spacing, path).map_err(at)?;
    check_scaling(&header).map_err(at)?;
    let (start, size) = data_extent(&header, datatype, dims, frames, capacity, gz).map_err(at)?;
    let skip = (start - HEADER_SIZE) as u64;
    let mut extensions = Vec::new();
    (&mut source)
        .take(skip.min(MAX_EXTENSION_BYTES as u64))
        .read_to_end(&mut extensions)
        .map_err(|e| unreadable(&e))?;
    let skipped = extensions.len() as u64
        + std::io::copy(
            &mut (&mut source).take(skip - extensions.len() as u64),
            &mut std::io::sink(),
        )
        .map_err(|e| unreadable(&e))?;
    let table = extension_table(path, &extensions, header.endianness == Endianness::Big);
    // Exact for a plain file (its length was checked); a gzip stream grows with what it holds.
    let mut raw = Vec::with_capacity(if gz { 0 } else { size });
    (&mut source)
        .take(size as u64)
        .read_to_end(&mut raw)
        .map_err(|e| unreadable(&e))?;
    if skipped < skip || raw.len() < size {
        let [nx, ny, nz] = dims;
        return Err(at(ErrorKind::Nifti(format!(
            "truncated: {} of the {size} bytes of voxel data (dim {nx}×{ny}×{nz}×{frames} of \
             {datatype:?}) at vox_offset {start}",
            raw.len()
        ))));
    }
    if gz {
        // Whatever follows the voxels, and the gzip trailer: verifies the CRC, so a corrupted
        // stream is an error rather than silently wrong labels.
        std::io::copy(&mut source, &mut std::io::sink()).map_err(|e| unreadable(&e))?;
    }
    // `raw` holds exactly `size` = voxels × width bytes (checked above), so decoding yields
    // exactly the voxels the header's dimensions count.
    let mut labels = Vec::new();
    datatype
        .decode_into(&raw, header.endianness == Endianness::Big, &mut labels)
        .map_err(|e| at(ErrorKind::Nifti(e)))?;
    let dt = f64::from(header.pixdim[4]);
    if !dt.is_finite() || dt < 0.0 {
        return Err(at(ErrorKind::Nifti(format!(
            "pixdim[4] (time between frames) is {dt}"
        ))));
    }
    let volume = LabelVolume {
        dims,
        frames,
        affine,
        frame_interval: if dt == 0.0 { 1.0 } else { dt },
        labels,
    };
    Ok(LabelMap {
        volume,
        table,
        stored: stored(&header, datatype),
    })
}

/// NIfTI intent codes that say the values are labels: none given, `NIFTI_INTENT_LABEL` and
/// `NIFTI_INTENT_NEURONAME`.
const LABEL_INTENTS: [i16; 3] = [0, 1002, 1003];

/// What `h` says of its values: the voxel type `t`, and an image where its intent is not a
/// label map's (an estimate, a statistic, a vector, …) or its description or intent name names
/// one.
fn stored(h: &NiftiHeader, t: VoxelType) -> Stored {
    let text = |bytes: &[u8]| {
        let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
        String::from_utf8_lossy(&bytes[..end]).into_owned()
    };
    let mut stored = Stored::new(t, "description", &text(&h.descrip));
    if stored.says_image.is_none() {
        stored = Stored::new(t, "intent name", &text(&h.intent_name));
    }
    if stored.says_image.is_none() && !LABEL_INTENTS.contains(&h.intent_code) {
        stored.says_image = Some(format!(
            "its NIfTI intent code {} is not a label map's",
            h.intent_code
        ));
    }
    stored
}

/// The label table of the header extensions in `bytes` (what lies between the 348-byte header
/// and the voxels: the 4-byte extender, then `esize`, `ecode`, `esize - 8` bytes of content per
/// extension). Extensions without one are reported with a warning and skipped.
fn extension_table(path: &Path, bytes: &[u8], big_endian: bool) -> LabelTable {
    let mut table = LabelTable::default();
    if bytes.first().is_none_or(|&b| b == 0) {
        return table;
    }
    let int = |at: usize| -> Option<i64> {
        let b: [u8; 4] = bytes.get(at..at + 4)?.try_into().ok()?;
        Some(i64::from(if big_endian {
            i32::from_be_bytes(b)
        } else {
            i32::from_le_bytes(b)
        }))
    };
    let mut pos = 4;
    while pos + 8 <= bytes.len() {
        let (Some(size), Some(code)) = (int(pos), int(pos + 4)) else {
            break;
        };
        let end = usize::try_from(size)
            .ok()
            .filter(|&s| s >= 8)
            .and_then(|s| pos.checked_add(s))
            .filter(|&e| e <= bytes.len());
        let Some(end) = end else {
            log::warn!(
                "{}: header extension at byte {} declares {size} bytes, more than the header                  holds; it and any after it are ignored",
                path.display(),
                HEADER_SIZE + pos
            );
            break;
        };
        let content = &bytes[pos + 8..end];
        let text = std::str::from_utf8(content)
            .ok()
            .map(|t| t.trim_matches(|c: char| c == '\0' || c.is_whitespace()));
        match text
            .filter(|t| t.starts_with('<'))
            .map(LabelTable::from_xml)
        {
            Some(Some(Ok(found))) => table = table.overlaid(&found),
            Some(Some(Err(e))) => log::warn!(
                "{}: the label table of header extension {code} is ignored: {e}",
                path.display()
            ),
            _ => log::warn!(
                "{}: header extension {code} ({} bytes) is not a label table this reader \
                 understands (an XML LabelTable); ignored",
                path.display(),
                content.len()
            ),
        }
        pos = end;
    }
    table
}

/// Reads the grid of the NIfTI-1 file at `path` from its 348-byte header only (decompressing
/// no more of a `.gz` than that), whatever its voxel type: the geometry of a reference image
/// whose voxels are not needed, known before anything is allocated for its size. The
/// dimensions, transform and frame interval are checked as [`read_volume`] checks them; the
/// voxel data is not.
pub fn read_geometry(path: &Path) -> Result<Geometry> {
    let at = |kind: ErrorKind| DataError::new(kind).in_file(path);
    let Source {
        mut source,
        gz,
        capacity,
    } = Source::open(path)?;
    let header = read_header(&mut source, path)?;
    let (dims, frames) = dimensions(&header).map_err(at)?;
    let affine = affine_as(&header, HeaderSpacing::Auto, path).map_err(at)?;
    // A header promising more voxels than the file can hold is refused here, before a caller
    // sizes anything (a grid, a frame count) by it.
    let bits = usize::try_from(header.bitpix)
        .ok()
        .filter(|&b| b > 0 && b % 8 == 0)
        .ok_or_else(|| {
            at(ErrorKind::Nifti(format!(
                "bitpix {} is not a whole number of bytes",
                header.bitpix
            )))
        })?;
    let voxel = format!("{bits}-bit voxels");
    check_extent(&header, bits / 8, &voxel, dims, frames, capacity, gz).map_err(at)?;
    let dt = f64::from(header.pixdim[4]);
    if !dt.is_finite() || dt < 0.0 {
        return Err(at(ErrorKind::Nifti(format!(
            "pixdim[4] (time between frames) is {dt}"
        ))));
    }
    Ok(Geometry {
        dims,
        frames,
        affine,
        frame_interval: if dt == 0.0 { 1.0 } else { dt },
        time_origin: time_origin(&header).map_err(at)?,
    })
}

/// The time of frame 0: `toffset`, in the units `xyzt_units` gives the times (as `pixdim[4]`).
fn time_origin(h: &NiftiHeader) -> std::result::Result<f64, ErrorKind> {
    let t = f64::from(h.toffset);
    if t.is_finite() {
        Ok(t)
    } else {
        Err(ErrorKind::Nifti(format!(
            "toffset (time of the first frame) is {t}"
        )))
    }
}

/// The unit of the times of the NIfTI file at `path` (`pixdim[4]`, `toffset`), from its
/// header's `xyzt_units`: seconds, milliseconds or microseconds; [`TimeUnit::Plain`] where it
/// states none (or a code that is no time unit, such as Hz).
pub fn read_time_unit(path: &Path) -> Result<TimeUnit> {
    let Source { mut source, .. } = Source::open(path)?;
    let header = read_header(&mut source, path)?;
    Ok(match header.xyzt_to_time() {
        Ok(Unit::Sec) => TimeUnit::Seconds,
        Ok(Unit::Msec) => TimeUnit::Milliseconds,
        Ok(Unit::Usec) => TimeUnit::Microseconds,
        _ => TimeUnit::Plain,
    })
}

/// The header at the start of `source` (the file at `path`, named in the error).
fn read_header(source: &mut impl Read, path: &Path) -> Result<NiftiHeader> {
    NiftiHeader::from_reader(source).map_err(|e| {
        DataError::new(ErrorKind::Nifti(format!(
            "unreadable or truncated header: {e}"
        )))
        .in_file(path)
    })
}

/// The time of frame 0 of the NIfTI file at `path` (`toffset`), from its header.
pub fn read_time_origin(path: &Path) -> Result<f64> {
    read_geometry(path).map(|g| g.time_origin)
}

/// An opened NIfTI file: its bytes (decompressed when gzipped, detected by content) and how
/// many bytes of NIfTI it can hold, the bound for every size its header claims.
struct Source {
    source: Box<dyn Read>,
    gz: bool,
    capacity: usize,
}

impl Source {
    fn open(path: &Path) -> Result<Source> {
        let (file, size) = input_file::open(path)?;
        // Never more than the size the file had when opened, should it grow.
        let mut file = std::io::BufReader::new(file.take(size));
        let gz = std::io::BufRead::fill_buf(&mut file)
            .map_err(|e| DataError::new(e.into()).in_file(path))?
            .starts_with(&[0x1f, 0x8b]);
        let size = usize::try_from(size).unwrap_or(usize::MAX);
        Ok(if gz {
            Source {
                source: Box::new(flate2::read::GzDecoder::new(file)),
                gz,
                capacity: size.saturating_mul(MAX_DEFLATE_RATIO),
            }
        } else {
            Source {
                source: Box::new(file),
                gz,
                capacity: size,
            }
        })
    }
}

/// The label sample type of a NIfTI `datatype`; floating and complex types are refused.
fn voxel_type(t: NiftiType) -> std::result::Result<VoxelType, ErrorKind> {
    Ok(match t {
        NiftiType::Uint8 => VoxelType::Uint8,
        NiftiType::Int8 => VoxelType::Int8,
        NiftiType::Uint16 => VoxelType::Uint16,
        NiftiType::Int16 => VoxelType::Int16,
        NiftiType::Uint32 => VoxelType::Uint32,
        NiftiType::Int32 => VoxelType::Int32,
        NiftiType::Uint64 => VoxelType::Uint64,
        NiftiType::Int64 => VoxelType::Int64,
        other => {
            return Err(ErrorKind::Nifti(format!(
                "voxel type {other:?} is not an integer type; a label volume needs integer \
                 labels (a non-integer type holds intensities: this seems to be an image, not a \
                 segmentation; give its label map)"
            )))
        }
    })
}

/// Where the voxel data lies: (first byte, bytes), checked against the `capacity` of the file
/// with overflow-checked arithmetic.
fn data_extent(
    h: &NiftiHeader,
    t: VoxelType,
    dims: [usize; 3],
    frames: usize,
    capacity: usize,
    gz: bool,
) -> std::result::Result<(usize, usize), ErrorKind> {
    let bytes_per_voxel = t.bytes();
    if i32::from(h.bitpix) != 8 * bytes_per_voxel as i32 {
        return Err(ErrorKind::Nifti(format!(
            "bitpix {} disagrees with datatype {t:?} ({} bits)",
            h.bitpix,
            8 * bytes_per_voxel
        )));
    }
    check_extent(
        h,
        bytes_per_voxel,
        &format!("{t:?}"),
        dims,
        frames,
        capacity,
        gz,
    )
}

/// Where `bytes_per_voxel`-byte voxels (`voxel` in messages) lie: (first byte, bytes), checked
/// against the `capacity` of the file with overflow-checked arithmetic.
fn check_extent(
    h: &NiftiHeader,
    bytes_per_voxel: usize,
    voxel: &str,
    dims: [usize; 3],
    frames: usize,
    capacity: usize,
    gz: bool,
) -> std::result::Result<(usize, usize), ErrorKind> {
    let offset = h.vox_offset;
    if !(offset.is_finite() && offset >= 0.0) {
        return Err(ErrorKind::Nifti(format!(
            "vox_offset {offset} is not a byte offset"
        )));
    }
    // Below the header and extender means right after them (as the nifti crate reads it).
    let start = (offset as usize).max(HEADER_SIZE + 4);
    let size = dims
        .iter()
        .chain([&frames])
        .try_fold(bytes_per_voxel, |n, &d| n.checked_mul(d));
    let end = size.and_then(|n| n.checked_add(start));
    match (size, end) {
        (Some(size), Some(end)) if end <= capacity => Ok((start, size)),
        _ => {
            let [nx, ny, nz] = dims;
            let limit = if gz {
                ", deflate's limit for its size"
            } else {
                ""
            };
            Err(ErrorKind::Nifti(format!(
                "dim {nx}×{ny}×{nz}×{frames} of {voxel} at vox_offset {start} needs more bytes \
                 than the file can hold ({capacity}{limit})"
            )))
        }
    }
}

/// Reads a label volume and reslices it into a sequence (see [`super::reslice`]), `names` over
/// the table of its header extensions; more classes than a model holds are refused before any
/// plane is cut ([`check_classes`]).
pub fn read(path: &Path, options: &ResliceOptions, names: &LabelTable) -> Result<Sequence> {
    let map = read_labelled_volume_with(path, HeaderSpacing::Auto)?;
    let at = |e: DataError| e.in_file(path);
    check_classes(
        &map.volume,
        options.frames,
        options.labels.as_deref(),
        &map.stored,
    )
    .map_err(at)?;
    reslice(&map.volume, options, &map.table.overlaid(names)).map_err(at)
}

fn dimensions(h: &NiftiHeader) -> std::result::Result<([usize; 3], usize), ErrorKind> {
    let n = h.dim[0] as usize;
    if !(1..=7).contains(&n) {
        return Err(ErrorKind::Nifti(format!(
            "dim[0] = {} is not 1..7",
            h.dim[0]
        )));
    }
    let d = |k: usize| if k <= n { h.dim[k] as usize } else { 1 };
    if let Some(k) = (5..=n).find(|&k| h.dim[k] > 1) {
        return Err(ErrorKind::Nifti(format!(
            "dimension {k} has size {}; only x, y, z and t are supported",
            h.dim[k]
        )));
    }
    let dims = [d(1), d(2), d(3)];
    if dims.contains(&0) || d(4) == 0 {
        return Err(ErrorKind::Nifti(format!(
            "empty volume: dim = {:?}",
            &h.dim[..=n]
        )));
    }
    Ok((dims, d(4)))
}

/// The length of voxel axis `i`'s column of `a`: its voxel spacing.
fn column_norm(a: &[[f64; 4]; 3], i: usize) -> f64 {
    (0..3).map(|r| a[r][i] * a[r][i]).sum::<f64>().sqrt()
}

/// `pixdim[1..3]` as spacings, where all three are positive and finite.
fn pixdim_spacing(h: &NiftiHeader) -> Option<[f64; 3]> {
    let s = [1, 2, 3].map(|k| f64::from(h.pixdim[k]).abs());
    s.iter().all(|v| v.is_finite() && *v > 0.0).then_some(s)
}

fn spacing_text(s: [f64; 3]) -> String {
    let short = |v: f64| format!("{}", (v * 1e4).round() / 1e4);
    format!("{} × {} × {}", short(s[0]), short(s[1]), short(s[2]))
}

/// Voxel → world as `spacing` says ([`HeaderSpacing`]), with a warning naming the file where
/// the sform's spacing and `pixdim` disagree by more than [`SPACING_TOLERANCE`].
fn affine_as(
    h: &NiftiHeader,
    spacing: HeaderSpacing,
    path: &Path,
) -> std::result::Result<[[f64; 4]; 3], ErrorKind> {
    let sform = [h.srow_x, h.srow_y, h.srow_z].map(|r| r.map(f64::from));
    let pixdim = pixdim_spacing(h);
    let disagree = |a: &[[f64; 4]; 3]| {
        let own: [f64; 3] = std::array::from_fn(|i| column_norm(a, i));
        pixdim
            .filter(|p| (0..3).any(|i| (own[i] - p[i]).abs() > SPACING_TOLERANCE * p[i]))
            .map(|p| (own, p))
    };
    let a = match spacing {
        HeaderSpacing::Sform if h.sform_code <= 0 => {
            return Err(ErrorKind::Nifti(format!(
                "--header-spacing sform: sform_code is {}, the header has no sform",
                h.sform_code
            )))
        }
        HeaderSpacing::Qform if h.qform_code <= 0 => {
            return Err(ErrorKind::Nifti(format!(
                "--header-spacing qform: qform_code is {}, the header has no qform",
                h.qform_code
            )))
        }
        HeaderSpacing::Sform => sform,
        HeaderSpacing::Qform => qform(h),
        HeaderSpacing::Auto | HeaderSpacing::Pixdim => {
            let a = affine(h)?;
            match (spacing, h.sform_code > 0, disagree(&a)) {
                (HeaderSpacing::Pixdim, _, Some((_, p))) => std::array::from_fn(|r| {
                    let mut row = a[r];
                    for (i, v) in row.iter_mut().take(3).enumerate() {
                        *v *= p[i] / column_norm(&a, i);
                    }
                    row
                }),
                (HeaderSpacing::Auto, true, Some((own, p))) => {
                    log::warn!(
                        "{}: the sform (sform_code {}) gives voxel spacing {} but pixdim says {}                          (the qform's spacing{}); using the sform, as the NIfTI-1 rule and                          nibabel do where sform_code > 0; --header-spacing pixdim keeps the                          sform's orientation and origin with pixdim's spacing{}",
                        path.display(),
                        h.sform_code,
                        spacing_text(own),
                        spacing_text(p),
                        if h.qform_code > 0 {
                            format!(", qform_code {}", h.qform_code)
                        } else {
                            ", though qform_code is 0".into()
                        },
                        if h.qform_code > 0 {
                            ", --header-spacing qform uses the qform"
                        } else {
                            ""
                        }
                    );
                    a
                }
                _ => a,
            }
        }
    };
    let finite = a.iter().flatten().all(|v| v.is_finite());
    if !finite || det3(&a) == 0.0 {
        return Err(ErrorKind::Nifti(format!(
            "voxel-to-world transform is singular or not finite: {a:?}"
        )));
    }
    Ok(a)
}

/// The qform's voxel → world: the quaternion's rotation, `pixdim`'s spacing (qfac from
/// `pixdim[0]`), the qoffset.
fn qform(h: &NiftiHeader) -> [[f64; 4]; 3] {
    let (b, c, d) = (
        f64::from(h.quatern_b),
        f64::from(h.quatern_c),
        f64::from(h.quatern_d),
    );
    let a = (1.0 - (b * b + c * c + d * d)).max(0.0).sqrt();
    let r = [
        [
            a * a + b * b - c * c - d * d,
            2.0 * (b * c - a * d),
            2.0 * (b * d + a * c),
        ],
        [
            2.0 * (b * c + a * d),
            a * a + c * c - b * b - d * d,
            2.0 * (c * d - a * b),
        ],
        [
            2.0 * (b * d - a * c),
            2.0 * (c * d + a * b),
            a * a + d * d - c * c - b * b,
        ],
    ];
    let qfac = if h.pixdim[0] < 0.0 { -1.0 } else { 1.0 };
    let s = [
        f64::from(h.pixdim[1]),
        f64::from(h.pixdim[2]),
        qfac * f64::from(h.pixdim[3]),
    ];
    let o = [h.quatern_x, h.quatern_y, h.quatern_z].map(f64::from);
    std::array::from_fn(|i| [r[i][0] * s[0], r[i][1] * s[1], r[i][2] * s[2], o[i]])
}

/// Voxel → world per the NIfTI-1 rules: sform if `sform_code > 0`, else qform if
/// `qform_code > 0`, else the voxel spacing alone.
fn affine(h: &NiftiHeader) -> std::result::Result<[[f64; 4]; 3], ErrorKind> {
    Ok(if h.sform_code > 0 {
        [h.srow_x, h.srow_y, h.srow_z].map(|r| r.map(f64::from))
    } else if h.qform_code > 0 {
        qform(h)
    } else {
        let s = |k: usize| {
            let v = f64::from(h.pixdim[k]).abs();
            if v > 0.0 {
                v
            } else {
                1.0
            }
        };
        [
            [s(1), 0.0, 0.0, 0.0],
            [0.0, s(2), 0.0, 0.0],
            [0.0, 0.0, s(3), 0.0],
        ]
    })
}

fn check_scaling(h: &NiftiHeader) -> std::result::Result<(), ErrorKind> {
    // nibabel writes NaN for "unset"; NIfTI-1 says a zero slope means no scaling.
    let slope_ok = h.scl_slope.is_nan() || h.scl_slope == 0.0 || h.scl_slope == 1.0;
    let inter_ok = h.scl_inter.is_nan() || h.scl_inter == 0.0;
    if slope_ok && inter_ok {
        Ok(())
    } else {
        Err(ErrorKind::Nifti(format!(
            "intensity scaling (scl_slope {}, scl_inter {}) means these are not label values",
            h.scl_slope, h.scl_inter
        )))
    }
}

/// Writes `volume` as NIfTI-1 (gzip-compressed when `path` ends in `.gz`) through
/// [`NiftiStream`], one frame at a time: the header of [`crate::nifti_stream`] with the labels'
/// range, time offset 0 and no description.
pub fn write_volume(volume: &LabelVolume, path: &Path) -> Result<()> {
    let voxels: usize = volume.dims.iter().product();
    let (lo, hi) = volume
        .labels
        .iter()
        .fold((0, 0), |(lo, hi), &v| (v.min(lo), v.max(hi)));
    let header = VolumeHeader {
        dims: volume.dims,
        frames: volume.frames,
        affine: volume.affine,
        frame_interval: volume.frame_interval,
        time_offset: 0.0,
        label_range: (lo, hi),
        description: String::new(),
    };
    let write = || -> anyhow::Result<()> {
        anyhow::ensure!(
            volume.labels.len() == voxels * volume.frames,
            "{} labels for {} frames of {voxels} voxels",
            volume.labels.len(),
            volume.frames
        );
        let mut stream = NiftiStream::create(path, &header)?;
        for frame in volume.labels.chunks_exact(voxels.max(1)) {
            stream.write_frame(frame)?;
        }
        stream.finish()
    };
    write()
        .map_err(|e| DataError::new(ErrorKind::Nifti(format!("cannot write: {e:#}"))).in_file(path))
}
