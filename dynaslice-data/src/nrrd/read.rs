//! The NRRD reader: header text, axes and world frame, the voxel data, and 3D Slicer's segment
//! keys. See the [module docs](super) for what is accepted.

use std::collections::{BTreeMap, HashMap};
use std::io::Read;
use std::path::{Path, PathBuf};

use super::{flip_xy, unescape, MAX_ELEMENTS, MAX_FILE_BYTES};
use crate::label_census::Stored;
use crate::label_map::LabelMap;
use crate::label_table::LabelTable;
use crate::label_volume::{det3, LabelVolume};
use crate::voxel_type::VoxelType;
use dynaslice_sequence::error::{excerpt, DataError, ErrorKind, Result};
use dynaslice_sequence::input_file;

/// Deflate's largest expansion (one 258-byte match per two bits): n bytes of gzip cannot hold
/// more than this × n bytes of data.
const MAX_DEFLATE_RATIO: usize = 1032;

/// Newest format version read (`NRRD0005`, Teem 1.11+); older ones are subsets.
const NEWEST_VERSION: u8 = b'5';

fn nrrd(message: impl Into<String>) -> DataError {
    DataError::new(ErrorKind::Nrrd(message.into()))
}

/// Reads an NRRD label map or 3D Slicer segmentation: the volume (world in RAS) and the table
/// of its segments' names and colours (empty for a plain label map). See the
/// [module docs](super) for the formats, the LPS → RAS conversion and how the layers of a
/// segmentation become one label map.
///
/// Every size in the header is checked, with overflow-checked arithmetic, against what the
/// file can hold and against [`MAX_ELEMENTS`] before anything is allocated or decompressed.
pub fn read_volume(path: &Path) -> Result<(LabelVolume, LabelTable)> {
    read_label_map(path).map(|m| (m.volume, m.table))
}

/// [`read_volume`], with what the file says of its values: the voxel type, and a `content`
/// field naming an image ([`Stored`]).
pub fn read_label_map(path: &Path) -> Result<LabelMap> {
    let bytes = input_file::read(path, MAX_FILE_BYTES, "an NRRD file")?;
    read_bytes(path, &bytes).map_err(|e| e.in_file(path))
}

fn read_bytes(path: &Path, bytes: &[u8]) -> Result<LabelMap> {
    let header = Header::parse(path, bytes)?;
    let layout = Layout::of(path, &header)?;
    let layers = match layout.extra {
        Some((axis, Extra::Layers)) => layout.sizes[axis],
        _ => 1,
    };
    let segments = segments(&header, layers, layout.layered())?;
    let raw = load(path, &header, &layout, bytes)?;
    let (labels, frames) = arrange(path, &layout, raw, &segments);
    let volume = LabelVolume {
        dims: layout.spatial.map(|a| layout.sizes[a]),
        frames,
        affine: layout.affine,
        frame_interval: layout.frame_interval,
        labels,
    };
    check_extents(path, &volume, &segments);
    let mut table = LabelTable::default();
    for s in &segments {
        table.insert(s.label, s.name.clone());
        if let Some(color) = s.color {
            table.insert_color(s.label, color);
        }
    }
    let content = header
        .fields
        .get("content")
        .map_or("", |f| f.value.as_str());
    Ok(LabelMap {
        volume,
        table,
        stored: Stored::new(layout.voxel, "content field", content),
    })
}

/// A `field: description` line.
struct Field {
    value: String,
    line: usize,
}

impl Field {
    /// An error about this field, naming it and its line.
    fn error(&self, name: &str, what: impl std::fmt::Display) -> DataError {
        nrrd(format!("`{name}: {}`: {what}", excerpt(&self.value))).at_line(self.line)
    }
}

struct Header {
    /// Fields by canonical name.
    fields: HashMap<&'static str, Field>,
    /// `key:=value` pairs (values unescaped) with their lines, in file order.
    pairs: Vec<(String, String, usize)>,
    /// The first byte after the blank line that ends the header; `None` when the file ends first
    /// (a detached header).
    data_start: Option<usize>,
}

/// The canonical name of a field identifier (NRRD allows some without their space), or `None`
/// for an unknown one.
fn canonical(name: &str) -> Option<&'static str> {
    Some(match name.to_ascii_lowercase().as_str() {
        "type" => "type",
        "dimension" => "dimension",
        "sizes" => "sizes",
        "encoding" => "encoding",
        "endian" => "endian",
        "space" => "space",
        "space dimension" => "space dimension",
        "space directions" => "space directions",
        "space origin" => "space origin",
        "kinds" => "kinds",
        "spacings" => "spacings",
        "data file" | "datafile" => "data file",
        "line skip" | "lineskip" => "line skip",
        "byte skip" | "byteskip" => "byte skip",
        // Read past: they do not change which label a voxel has or where it is.
        "content" => "content",
        "min" => "min",
        "max" => "max",
        "old min" | "oldmin" => "old min",
        "old max" | "oldmax" => "old max",
        "block size" | "blocksize" => "block size",
        "number" => "number",
        "sample units" => "sample units",
        "thicknesses" => "thicknesses",
        "axis mins" | "axismins" => "axis mins",
        "axis maxs" | "axismaxs" => "axis maxs",
        "centers" | "centerings" => "centers",
        "labels" => "labels",
        "units" => "units",
        "space units" => "space units",
        "measurement frame" => "measurement frame",
        _ => return None,
    })
}

impl Header {
    fn parse(path: &Path, bytes: &[u8]) -> Result<Header> {
        let mut header = Header {
            fields: HashMap::new(),
            pairs: Vec::new(),
            data_start: None,
        };
        let mut keys: HashMap<String, usize> = HashMap::new();
        let mut pos = 0;
        let mut number = 0;
        while pos < bytes.len() {
            let end = bytes[pos..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(bytes.len(), |n| pos + n);
            let raw = &bytes[pos..end];
            let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
            pos = (end + 1).min(bytes.len());
            number += 1;
            let at = |what: String| nrrd(what).at_line(number);
            if number == 1 {
                check_magic(raw)?;
                continue;
            }
            if raw.is_empty() {
                header.data_start = Some(pos);
                break;
            }
            let text = std::str::from_utf8(raw).map_err(|_| {
                at("not text: the header must end with a blank line before the data".into())
            })?;
            if text.starts_with('#') {
                continue;
            }
            let colon = text.find(':').ok_or_else(|| {
                at(format!(
                    "`{}` is neither `field: description` nor `key:=value`",
                    excerpt(text)
                ))
            })?;
            let (name, rest) = (&text[..colon], &text[colon + 1..]);
            if let Some(value) = rest.strip_prefix('=') {
                if name.is_empty() {
                    return Err(at(format!("`{}` has an empty key", excerpt(text))));
                }
                if let Some(first) = keys.insert(name.to_string(), number) {
                    return Err(at(format!(
                        "key `{}` is given twice (lines {first} and {number})",
                        excerpt(name)
                    )));
                }
                header
                    .pairs
                    .push((name.to_string(), unescape(value), number));
                continue;
            }
            let Some(field) = canonical(name.trim()) else {
                log::warn!(
                    "{}, line {number}: unknown NRRD field `{}` is ignored",
                    path.display(),
                    excerpt(name)
                );
                continue;
            };
            let value = rest.trim().to_string();
            if let Some(first) = header.fields.get(field) {
                return Err(at(format!(
                    "field `{field}` is given twice (lines {} and {number})",
                    first.line
                )));
            }
            header.fields.insert(
                field,
                Field {
                    value,
                    line: number,
                },
            );
        }
        if number == 0 {
            return Err(nrrd(
                "empty file; an NRRD file starts with the magic NRRD000X",
            ));
        }
        Ok(header)
    }

    fn get(&self, name: &str) -> Option<&Field> {
        self.fields.get(name)
    }

    fn required(&self, name: &str) -> Result<&Field> {
        self.get(name).ok_or_else(|| {
            nrrd(format!(
                "field `{name}` is missing (a label map needs type, dimension, sizes and encoding)"
            ))
        })
    }

    /// The value of key `name` (`name:=value`), if given.
    fn pair(&self, name: &str) -> Option<&str> {
        self.pairs
            .iter()
            .find(|(k, _, _)| k == name)
            .map(|(_, v, _)| v.as_str())
    }

    /// Whether any `SegmentN_…` key is present: the file is a 3D Slicer segmentation.
    fn has_segments(&self) -> bool {
        self.pairs.iter().any(|(k, _, _)| segment_key(k).is_some())
    }
}

fn check_magic(line: &[u8]) -> Result<()> {
    let bad = || {
        let shown = String::from_utf8_lossy(&line[..line.len().min(16)]).into_owned();
        nrrd(format!(
            "not an NRRD file: it starts with {shown:?}, not the magic NRRD000X"
        ))
    };
    match line {
        [b'N', b'R', b'R', b'D', b'0', b'0', b'0', v] if (b'1'..=NEWEST_VERSION).contains(v) => {
            Ok(())
        }
        [b'N', b'R', b'R', b'D', b'0', b'0', b'0', v] if v.is_ascii_digit() => Err(nrrd(format!(
            "format version NRRD000{} is newer than NRRD000{} that this reader knows",
            *v as char, NEWEST_VERSION as char
        ))
        .at_line(1)),
        _ => Err(bad().at_line(1)),
    }
}

/// The label sample type of an NRRD `type` field; floating types are refused (labels are
/// integers).
fn voxel_type(f: &Field) -> Result<VoxelType> {
    let name = f
        .value
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .to_ascii_lowercase();
    Ok(match name.as_str() {
        "signed char" | "int8" | "int8_t" => VoxelType::Int8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => VoxelType::Uint8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            VoxelType::Int16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => {
            VoxelType::Uint16
        }
        "int" | "signed int" | "int32" | "int32_t" => VoxelType::Int32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => VoxelType::Uint32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => VoxelType::Int64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            VoxelType::Uint64
        }
        "float" | "double" | "block" => {
            return Err(f.error(
                "type",
                "not an integer type; a label map needs integer labels (a non-integer type \
                 holds intensities: this seems to be an image, not a segmentation; give its \
                 label map)",
            ))
        }
        _ => return Err(f.error("type", "not an NRRD type")),
    })
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Encoding {
    Raw,
    Gzip,
}

/// What the one non-spatial axis of a 4D file holds.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Extra {
    /// Frames (`kinds` entry `time`).
    Time,
    /// The layers of a 3D Slicer segmentation (a `list` axis).
    Layers,
}

/// How the samples are stored and where they are.
struct Layout {
    voxel: VoxelType,
    encoding: Encoding,
    big_endian: bool,
    sizes: Vec<usize>,
    /// File axes of x, y and z (increasing).
    spatial: [usize; 3],
    /// The non-spatial axis, if any, and its role.
    extra: Option<(usize, Extra)>,
    /// Voxel → RAS world.
    affine: [[f64; 4]; 3],
    frame_interval: f64,
}

/// The world frames accepted, by how they map to RAS.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Space {
    Ras,
    Las,
    Lps,
    /// `space dimension: 3` without a name: taken as RAS.
    Unnamed,
}

impl Layout {
    fn layered(&self) -> bool {
        matches!(self.extra, Some((_, Extra::Layers)))
    }

    fn of(path: &Path, h: &Header) -> Result<Layout> {
        let voxel = voxel_type(h.required("type")?)?;
        let f = h.required("encoding")?;
        let encoding = match f.value.to_ascii_lowercase().as_str() {
            "raw" => Encoding::Raw,
            "gzip" | "gz" => Encoding::Gzip,
            _ => return Err(f.error("encoding", "not supported; a label map must be raw or gzip")),
        };
        let big_endian = match h.get("endian") {
            Some(f) => match f.value.to_ascii_lowercase().as_str() {
                "little" => false,
                "big" => true,
                _ => return Err(f.error("endian", "neither little nor big")),
            },
            None if voxel.bytes() > 1 => {
                return Err(nrrd(format!(
                    "field `endian` is missing; {voxel:?} samples need it"
                )))
            }
            None => false,
        };
        let f = h.required("dimension")?;
        let dimension: usize = f
            .value
            .parse()
            .map_err(|_| f.error("dimension", "not a whole number"))?;
        if !(3..=4).contains(&dimension) {
            return Err(f.error(
                "dimension",
                "a label map has 3 axes (x, y, z) or 4 (with time, or a segmentation's layers)",
            ));
        }
        let f = h.required("sizes")?;
        let sizes = f
            .value
            .split_whitespace()
            .map(|s| s.parse::<usize>().ok().filter(|&n| n >= 1))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| f.error("sizes", "each size must be a whole number ≥ 1"))?;
        if sizes.len() != dimension {
            return Err(f.error(
                "sizes",
                format!("{} sizes for dimension {dimension}", sizes.len()),
            ));
        }
        let kinds = per_axis(h, "kinds", dimension)?;
        let spacings = match h.get("spacings") {
            Some(f) => {
                let v = f
                    .value
                    .split_whitespace()
                    .map(|s| s.parse::<f64>().ok())
                    .collect::<Option<Vec<_>>>()
                    .ok_or_else(|| f.error("spacings", "not a list of numbers"))?;
                if v.len() != dimension {
                    return Err(f.error(
                        "spacings",
                        format!("{} spacings for dimension {dimension}", v.len()),
                    ));
                }
                Some(v)
            }
            None => None,
        };
        let space = space(path, h)?;
        let directions = match h.get("space directions") {
            Some(f) => {
                if space.is_none() {
                    return Err(f.error(
                        "space directions",
                        "given without `space` or `space dimension`",
                    ));
                }
                let v = vectors(f, "space directions")?;
                if v.len() != dimension {
                    return Err(f.error(
                        "space directions",
                        format!("{} entries for dimension {dimension}", v.len()),
                    ));
                }
                Some(v)
            }
            None if space.is_some() => {
                return Err(nrrd(
                    "field `space directions` is missing; `space` needs one per axis",
                ))
            }
            None => None,
        };
        let kind = |a: usize| kinds.as_ref().map(|k| k[a].to_ascii_lowercase());
        let spatial_kind = |k: &str| matches!(k, "domain" | "space" | "???" | "none");
        let is_spatial: Vec<bool> = (0..dimension)
            .map(|a| match &directions {
                Some(d) => d[a].is_some(),
                None => match kind(a) {
                    Some(k) => matches!(k.as_str(), "domain" | "space"),
                    None => dimension == 3,
                },
            })
            .collect();
        let spatial: Vec<usize> = (0..dimension).filter(|&a| is_spatial[a]).collect();
        if spatial.len() != 3 {
            let why = match (&directions, &kinds) {
                (Some(_), _) => "`space directions` gives",
                (None, Some(_)) => "`kinds` marks domain or space",
                (None, None) => {
                    return Err(nrrd(
                        "4 axes and neither `kinds` nor `space directions` to tell which is \
                         time; give `kinds` (e.g. domain domain domain time)",
                    ))
                }
            };
            return Err(nrrd(format!(
                "{why} {} spatial axes; a label map has 3",
                spatial.len()
            )));
        }
        for &a in &spatial {
            if let Some(k) = kind(a).filter(|k| !spatial_kind(k)) {
                return Err(nrrd(format!(
                    "`kinds`: axis {a} is spatial but its kind is `{}`",
                    excerpt(&k)
                )));
            }
        }
        let extra = match (0..dimension).find(|&a| !is_spatial[a]) {
            None => None,
            Some(a) => Some((
                a,
                match kind(a).as_deref() {
                    Some("time") => Extra::Time,
                    // A 3D Slicer sequence (`.seq.nrrd`): the list axis indexes frames by time.
                    Some("list") if h.pair(&format!("axis {a} index values")).is_some() => {
                        Extra::Time
                    }
                    Some("list" | "???" | "none") | None if h.has_segments() => Extra::Layers,
                    k => {
                        return Err(nrrd(format!(
                            "`kinds`: axis {a} is not spatial and its kind is {}; frames need \
                             `time`, a segmentation's layers `list` and SegmentN_ keys",
                            k.map_or("not given".into(), |k| format!("`{}`", excerpt(k)))
                        )))
                    }
                },
            )),
        };
        let spacing = |a: usize| {
            spacings
                .as_ref()
                .map(|s| s[a])
                .filter(|v| v.is_finite() && *v != 0.0)
        };
        let mut affine = [[0.0; 4]; 3];
        match (&directions, space) {
            (Some(d), Some(space)) => {
                let origin = match h.get("space origin") {
                    Some(f) => match vectors(f, "space origin")?.as_slice() {
                        [Some(o)] => *o,
                        _ => return Err(f.error("space origin", "not one vector")),
                    },
                    None => [0.0; 3],
                };
                for (c, &a) in spatial.iter().enumerate() {
                    let v = d[a].expect("spatial axes have a direction");
                    (0..3).for_each(|r| affine[r][c] = v[r]);
                }
                (0..3).for_each(|r| affine[r][3] = origin[r]);
                affine = match space {
                    Space::Ras | Space::Unnamed => affine,
                    Space::Lps => flip_xy(&affine),
                    Space::Las => [affine[0].map(|v| -v), affine[1], affine[2]],
                };
            }
            _ => {
                if let Some(f) = h.get("space origin") {
                    return Err(f.error("space origin", "given without `space`"));
                }
                for (c, &a) in spatial.iter().enumerate() {
                    affine[c][c] = spacing(a).unwrap_or(1.0);
                }
            }
        }
        if !affine.iter().flatten().all(|v| v.is_finite()) || det3(&affine) == 0.0 {
            return Err(nrrd(format!(
                "voxel-to-world transform from `space directions`/`space origin` (or \
                 `spacings`) is singular or not finite: {affine:?}"
            )));
        }
        let frame_interval = match extra {
            Some((a, Extra::Time)) if kind(a).as_deref() == Some("list") => {
                sequence_interval(path, h, a, sizes[a])?
            }
            Some((a, Extra::Time)) => match spacings.as_ref().map(|s| s[a]) {
                Some(dt) if dt.is_nan() || dt == 0.0 => 1.0,
                Some(dt) if dt.is_finite() && dt > 0.0 => dt,
                Some(dt) => {
                    return Err(nrrd(format!(
                        "`spacings`: time between frames (axis {a}) is {dt}"
                    )))
                }
                None => 1.0,
            },
            _ => 1.0,
        };
        Ok(Layout {
            voxel,
            encoding,
            big_endian,
            sizes,
            spatial: [spatial[0], spatial[1], spatial[2]],
            extra,
            affine,
            frame_interval,
        })
    }
}

/// The time between frames of a 3D Slicer sequence's list axis `a` of `frames` entries, from
/// its `axis A index values` key: one number per frame, evenly spaced (a label volume's frames
/// are i·interval apart). Frames are read relative to the first frame's time.
fn sequence_interval(path: &Path, h: &Header, a: usize, frames: usize) -> Result<f64> {
    let key = format!("axis {a} index values");
    let text = h.pair(&key).unwrap_or_default();
    let values: Vec<f64> = text
        .split_whitespace()
        .map(|v| v.parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect::<Option<_>>()
        .ok_or_else(|| {
            nrrd(format!(
                "`{key}`: not a list of finite numbers ({:?})",
                excerpt(text)
            ))
        })?;
    if values.len() != frames {
        return Err(nrrd(format!(
            "`{key}`: {} times for the {frames} frames of axis {a}",
            values.len()
        )));
    }
    if frames < 2 {
        return Ok(1.0);
    }
    let interval = (values[frames - 1] - values[0]) / (frames - 1) as f64;
    let even = values.windows(2).enumerate().all(|(i, w)| {
        w[1] > w[0] && (values[0] + (i + 1) as f64 * interval - w[1]).abs() <= 1e-4 * interval
    });
    if !(interval > 0.0 && even) {
        return Err(nrrd(format!(
            "`{key}`: the frame times {values:?} are not increasing and evenly spaced; a label \
             volume's frames are; list the frames in a .seq manifest instead"
        )));
    }
    if values[0] != 0.0 {
        log::warn!(
            "{}: `{key}`: the first frame is at time {}; frames are read from time 0, {interval} \
             apart",
            path.display(),
            values[0]
        );
    }
    Ok(interval)
}

/// A per-axis list of words (`kinds`), if given: one per axis.
fn per_axis(h: &Header, name: &str, dimension: usize) -> Result<Option<Vec<String>>> {
    let Some(f) = h.get(name) else {
        return Ok(None);
    };
    let words: Vec<String> = f.value.split_whitespace().map(str::to_string).collect();
    if words.len() != dimension {
        return Err(f.error(
            name,
            format!("{} entries for dimension {dimension}", words.len()),
        ));
    }
    Ok(Some(words))
}

/// The world frame of `space` / `space dimension`, if either is given.
fn space(path: &Path, h: &Header) -> Result<Option<Space>> {
    if let Some(f) = h.get("space dimension") {
        if f.value != "3" {
            return Err(f.error("space dimension", "a label map's space has 3 dimensions"));
        }
    }
    let Some(f) = h.get("space") else {
        if h.get("space dimension").is_some() {
            log::warn!(
                "{}: `space dimension: 3` names no space; its coordinates are taken as RAS",
                path.display()
            );
            return Ok(Some(Space::Unnamed));
        }
        return Ok(None);
    };
    Ok(Some(match f.value.to_ascii_lowercase().as_str() {
        "right-anterior-superior" | "ras" => Space::Ras,
        "left-anterior-superior" | "las" => Space::Las,
        "left-posterior-superior" | "lps" => Space::Lps,
        _ => {
            return Err(f.error(
                "space",
                "not supported; a label map's space is right-anterior-superior (RAS), \
                 left-anterior-superior (LAS) or left-posterior-superior (LPS)",
            ))
        }
    }))
}

/// Parses `(x,y,z) none (x,y,z) …`: finite 3-vectors or `none`.
fn vectors(f: &Field, name: &str) -> Result<Vec<Option<[f64; 3]>>> {
    let mut out = Vec::new();
    let mut rest = f.value.trim_start();
    while !rest.is_empty() {
        if let Some(inner) = rest.strip_prefix('(') {
            let close = inner
                .find(')')
                .ok_or_else(|| f.error(name, "a vector has no closing `)`"))?;
            let parts: Vec<&str> = inner[..close].split(',').map(str::trim).collect();
            let v = parts
                .iter()
                .map(|p| p.parse::<f64>().ok())
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| {
                    f.error(
                        name,
                        format!("`({})` is not a vector of numbers", &inner[..close]),
                    )
                })?;
            let v: [f64; 3] = v.try_into().map_err(|v: Vec<f64>| {
                f.error(
                    name,
                    format!("a vector has {} components; space has 3", v.len()),
                )
            })?;
            if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                return Err(f.error(name, format!("component {x} is not finite")));
            }
            out.push(Some(v));
            rest = inner[close + 1..].trim_start();
        } else {
            let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
            let word = &rest[..end];
            if !word.eq_ignore_ascii_case("none") {
                return Err(f.error(
                    name,
                    format!("`{}` is neither a vector nor none", excerpt(word)),
                ));
            }
            out.push(None);
            rest = rest[end..].trim_start();
        }
    }
    Ok(out)
}

/// One 3D Slicer segment.
struct Segment {
    /// The N of `SegmentN_`.
    index: u32,
    name: String,
    color: Option<[u8; 3]>,
    /// Its voxel value in its layer.
    value: i32,
    layer: usize,
    /// `i0 i1 j0 j1 k0 k1`, inclusive.
    extent: Option<[i64; 6]>,
    /// The label it becomes in the volume read.
    label: i32,
}

/// `SegmentN_Field` → (N, Field).
fn segment_key(key: &str) -> Option<(&str, &str)> {
    let rest = key.strip_prefix("Segment")?;
    let (n, field) = rest.split_once('_')?;
    (!n.is_empty() && n.bytes().all(|b| b.is_ascii_digit())).then_some((n, field))
}

/// The segments of a 3D Slicer segmentation with `layers` layers, in `SegmentN` order.
fn segments(h: &Header, layers: usize, layered: bool) -> Result<Vec<Segment>> {
    let mut by_index: BTreeMap<u32, HashMap<&str, (&str, usize)>> = BTreeMap::new();
    for (key, value, line) in &h.pairs {
        let Some((n, field)) = segment_key(key) else {
            continue;
        };
        let n: u32 = n.parse().map_err(|_| {
            nrrd(format!("`{key}`: segment number {n} is too large")).at_line(*line)
        })?;
        by_index
            .entry(n)
            .or_default()
            .insert(field, (value.as_str(), *line));
    }
    let mut out: Vec<Segment> = Vec::new();
    for (index, fields) in by_index {
        let bad = |field: &str, what: &str| {
            let (value, line) = fields[field];
            nrrd(format!("`Segment{index}_{field}:={value}`: {what}")).at_line(line)
        };
        let int = |field: &str| -> Result<Option<i64>> {
            fields
                .get(field)
                .map(|(v, _)| {
                    v.trim()
                        .parse::<i64>()
                        .map_err(|_| bad(field, "not an integer"))
                })
                .transpose()
        };
        let value = int("LabelValue")?;
        // As 3D Slicer reads them: without `_Layer`, segment N is in layer N (files from
        // before `_LabelValue`/`_Layer` existed hold one binary layer per segment), and without
        // `_LabelValue` its value is 1. A 3D file has one layer, so its segments are in it.
        let default_layer = if layered { i64::from(index) } else { 0 };
        let layer = int("Layer")?.unwrap_or(default_layer);
        let value = value.unwrap_or(1);
        let value = i32::try_from(value)
            .ok()
            .filter(|&v| v != 0)
            .ok_or_else(|| bad("LabelValue", "a segment's label value is a nonzero i32"))?;
        let layer = usize::try_from(layer)
            .ok()
            .filter(|&l| l < layers)
            .ok_or_else(|| {
                let what = format!("the file has {layers} layer(s)");
                match fields.get("Layer") {
                    Some(_) => bad("Layer", &what),
                    None => nrrd(format!(
                        "Segment{index} has no `_Layer`, so it is layer {index}; {what}"
                    )),
                }
            })?;
        let name = fields
            .get("Name")
            .or_else(|| fields.get("ID"))
            .map_or_else(|| format!("Segment {index}"), |(v, _)| v.to_string());
        let color = match fields.get("Color") {
            None => None,
            Some((v, _)) => {
                let c = v
                    .split_whitespace()
                    .map(|x| x.parse::<f64>().ok())
                    .collect::<Option<Vec<_>>>()
                    .filter(|c| c.len() == 3 && c.iter().all(|x| (0.0..=1.0).contains(x)))
                    .ok_or_else(|| bad("Color", "not three numbers in 0..1"))?;
                Some([0, 1, 2].map(|i| (c[i] * 255.0).round() as u8))
            }
        };
        let extent = match fields.get("Extent") {
            None => None,
            Some((v, _)) => Some(
                v.split_whitespace()
                    .map(|x| x.parse::<i64>().ok())
                    .collect::<Option<Vec<_>>>()
                    .and_then(|e| <[i64; 6]>::try_from(e).ok())
                    .ok_or_else(|| bad("Extent", "not six integers"))?,
            ),
        };
        if let Some(other) = out.iter().find(|s| (s.layer, s.value) == (layer, value)) {
            return Err(nrrd(format!(
                "Segment{index} and Segment{} both have label value {value} in layer {layer}",
                other.index
            )));
        }
        let label = if layered {
            i32::try_from(index + 1)
                .map_err(|_| nrrd(format!("Segment{index}: segment number too large")))?
        } else {
            value
        };
        out.push(Segment {
            index,
            name,
            color,
            value,
            layer,
            extent,
            label,
        });
    }
    Ok(out)
}

/// Reads the samples in file order (axis 0 fastest), checking their size first.
fn load(path: &Path, h: &Header, layout: &Layout, file: &[u8]) -> Result<Vec<i32>> {
    let width = layout.voxel.bytes();
    let sizes_text = || h.get("sizes").map_or(String::new(), |f| f.value.clone());
    let count = layout
        .sizes
        .iter()
        .try_fold(1usize, |n, &s| n.checked_mul(s))
        .filter(|&n| n <= MAX_ELEMENTS)
        .ok_or_else(|| {
            nrrd(format!(
                "`sizes: {}`: more samples than this reader's limit of {MAX_ELEMENTS}",
                sizes_text()
            ))
        })?;
    let needed = count * width; // ≤ 2³⁰ × 8: no overflow
    let detached;
    let (data, data_path): (&[u8], PathBuf) =
        match h.get("data file") {
            Some(f) => {
                let name = f.value.as_str();
                if name.starts_with("LIST") || name.split_whitespace().count() > 1 {
                    return Err(f.error("data file", "several data files are not supported"));
                }
                let target = match path.parent() {
                    Some(dir) if Path::new(name).is_relative() => dir.join(name),
                    _ => PathBuf::from(name),
                };
                // Named with the header's line too: the header may name the wrong file.
                detached = input_file::read(&target, MAX_FILE_BYTES, "an NRRD data file")
                    .map_err(|e| f.error("data file", e))?;
                (&detached, target)
            }
            None => match h.data_start {
                Some(start) => (&file[start..], path.to_path_buf()),
                None => return Err(nrrd(
                    "no blank line ends the header and no `data file` is named: there is no data",
                )),
            },
        };
    let in_data = |e: DataError| e.in_file(&data_path);
    let mut data = data;
    if let Some(f) = h.get("line skip") {
        let lines: usize = f
            .value
            .parse()
            .map_err(|_| f.error("line skip", "not a whole number ≥ 0"))?;
        for n in 0..lines {
            let eol = data.iter().position(|&b| b == b'\n').ok_or_else(|| {
                in_data(f.error("line skip", format!("the data has only {n} lines")))
            })?;
            data = &data[eol + 1..];
        }
    }
    let byte_skip = match h.get("byte skip") {
        Some(f) => {
            let n: i64 = f
                .value
                .parse()
                .map_err(|_| f.error("byte skip", "not a whole number ≥ -1"))?;
            match n {
                -1 if layout.encoding == Encoding::Raw => None,
                -1 => return Err(f.error("byte skip", "-1 (data at the end) is only for raw data")),
                n => Some(
                    usize::try_from(n)
                        .map_err(|_| f.error("byte skip", "not a whole number ≥ -1"))?,
                ),
            }
        }
        None => Some(0),
    };
    let describe = || format!("`sizes: {}` of {:?}", sizes_text(), layout.voxel);
    let truncated = |have: usize| {
        in_data(nrrd(format!(
            "truncated: the data holds {have} of the {needed} bytes that {} need",
            describe()
        )))
    };
    match layout.encoding {
        Encoding::Raw => {
            let start = match byte_skip {
                Some(skip) => skip,
                None => data
                    .len()
                    .checked_sub(needed)
                    .ok_or_else(|| truncated(data.len()))?,
            };
            let available = data.len().saturating_sub(start);
            if available < needed {
                return Err(truncated(available));
            }
            if available > needed {
                log::warn!(
                    "{}: {} bytes after the {needed} bytes of data are ignored",
                    data_path.display(),
                    available - needed
                );
            }
            let (labels, _) = decode(&data[start..start + needed], layout, count, count)
                .map_err(|e| in_data(nrrd(e)))?;
            Ok(labels)
        }
        Encoding::Gzip => {
            let skip = byte_skip.unwrap_or(0);
            let capacity = data.len().saturating_mul(MAX_DEFLATE_RATIO);
            if needed.checked_add(skip).is_none_or(|n| n > capacity) {
                return Err(in_data(nrrd(format!(
                    "{} need {needed} bytes (after a byte skip of {skip}), more than {} bytes \
                     of gzip data can hold",
                    describe(),
                    data.len()
                ))));
            }
            let corrupt = |e: std::io::Error| in_data(nrrd(format!("gzip data is corrupt: {e}")));
            let mut source = flate2::read::GzDecoder::new(data);
            let skipped = std::io::copy(&mut (&mut source).take(skip as u64), &mut std::io::sink())
                .map_err(corrupt)?;
            if skipped < skip as u64 {
                return Err(truncated(0));
            }
            // Grown as data arrives, not reserved from the header's claim: a small stream that
            // claims much is refused without its claim being allocated.
            let (labels, got) =
                decode(&mut source, layout, count, 0).map_err(|e| in_data(nrrd(e)))?;
            if got < needed {
                return Err(truncated(got));
            }
            // The rest and the gzip trailer: verifies the CRC, so a corrupted stream is an
            // error rather than silently wrong labels.
            let extra = std::io::copy(&mut source, &mut std::io::sink()).map_err(corrupt)?;
            if extra > 0 {
                log::warn!(
                    "{}: {extra} bytes after the {needed} bytes of data are ignored",
                    data_path.display()
                );
            }
            Ok(labels)
        }
    }
}

/// Decodes up to `count` samples from `source`; returns them and the bytes read. An error
/// (message) if the stream fails or a value does not fit in i32.
fn decode(
    mut source: impl Read,
    layout: &Layout,
    count: usize,
    reserve: usize,
) -> std::result::Result<(Vec<i32>, usize), String> {
    let (t, big) = (layout.voxel, layout.big_endian);
    let width = t.bytes();
    let total = count * width;
    let mut source = (&mut source).take(total as u64);
    let mut out = Vec::with_capacity(reserve);
    let mut buf = vec![0u8; 1 << 16];
    let (mut filled, mut got) = (0, 0);
    loop {
        let n = match source.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(format!("unreadable or corrupt data: {e}")),
        };
        filled += n;
        got += n;
        let whole = filled / width * width;
        t.decode_into(&buf[..whole], big, &mut out)?;
        buf.copy_within(whole..filled, 0);
        filled -= whole;
    }
    Ok((out, got))
}

/// The samples in our order (x fastest, then y, z, frame) and the frame count; the layers of a
/// segmentation merged into one label map.
fn arrange(path: &Path, layout: &Layout, raw: Vec<i32>, segments: &[Segment]) -> (Vec<i32>, usize) {
    let sizes = &layout.sizes;
    let stride: Vec<usize> = (0..sizes.len())
        .map(|a| sizes[..a].iter().product())
        .collect();
    let [ax, ay, az] = layout.spatial;
    let [nx, ny, nz] = layout.spatial.map(|a| sizes[a]);
    let (sx, sy, sz) = (stride[ax], stride[ay], stride[az]);
    match layout.extra {
        None => {
            warn_unclaimed(path, &raw, segments);
            (raw, 1)
        }
        // Frames already the slowest axis: the file order is ours.
        Some((3, Extra::Time)) => {
            warn_unclaimed(path, &raw, segments);
            (raw, sizes[3])
        }
        Some((e, Extra::Time)) => {
            let mut out = Vec::with_capacity(raw.len());
            for f in 0..sizes[e] {
                for k in 0..nz {
                    for j in 0..ny {
                        let base = f * stride[e] + k * sz + j * sy;
                        out.extend((0..nx).map(|i| raw[base + i * sx]));
                    }
                }
            }
            warn_unclaimed(path, &out, segments);
            (out, sizes[e])
        }
        Some((e, Extra::Layers)) => (merge_layers(path, layout, &raw, &stride, e, segments), 1),
    }
}

/// One label map from the layers: each segment's voxels get its label, a later layer's
/// segment winning where segments of several layers overlap (counted in a warning).
fn merge_layers(
    path: &Path,
    layout: &Layout,
    raw: &[i32],
    stride: &[usize],
    e: usize,
    segments: &[Segment],
) -> Vec<i32> {
    let layers = layout.sizes[e];
    let mut lookup: Vec<HashMap<i32, i32>> = vec![HashMap::new(); layers];
    for s in segments {
        lookup[s.layer].insert(s.value, s.label);
    }
    let [ax, ay, az] = layout.spatial;
    let [nx, ny, nz] = layout.spatial.map(|a| layout.sizes[a]);
    let mut out = Vec::with_capacity(nx * ny * nz);
    let mut overlapping = 0usize;
    let mut unclaimed: BTreeMap<(usize, i32), usize> = BTreeMap::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let base = i * stride[ax] + j * stride[ay] + k * stride[az];
                let mut label = 0;
                let mut overlap = false;
                for (l, map) in lookup.iter().enumerate() {
                    let v = raw[base + l * stride[e]];
                    if v == 0 {
                        continue;
                    }
                    match map.get(&v) {
                        Some(&s) => {
                            overlap |= label != 0;
                            label = s;
                        }
                        None => *unclaimed.entry((l, v)).or_default() += 1,
                    }
                }
                overlapping += usize::from(overlap);
                out.push(label);
            }
        }
    }
    if overlapping > 0 {
        log::warn!(
            "{}: {overlapping} voxels belong to segments of more than one layer; each gets the \
             segment of the last layer",
            path.display()
        );
    }
    if !unclaimed.is_empty() {
        let list: Vec<String> = unclaimed
            .iter()
            .map(|((l, v), n)| format!("value {v} in layer {l} ({n} voxels)"))
            .collect();
        log::warn!(
            "{}: no segment has {}; those voxels are left background",
            path.display(),
            list.join(", ")
        );
    }
    out
}

/// Warns about nonzero values that no segment of a single-layer segmentation names (they are
/// kept, as `label N`).
fn warn_unclaimed(path: &Path, labels: &[i32], segments: &[Segment]) {
    if segments.is_empty() {
        return;
    }
    let known: std::collections::HashSet<i32> = segments.iter().map(|s| s.label).collect();
    let mut unclaimed: BTreeMap<i32, usize> = BTreeMap::new();
    for &v in labels {
        if v != 0 && !known.contains(&v) {
            *unclaimed.entry(v).or_default() += 1;
        }
    }
    if !unclaimed.is_empty() {
        let list: Vec<String> = unclaimed
            .iter()
            .map(|(v, n)| format!("{v} ({n} voxels)"))
            .collect();
        log::warn!(
            "{}: no segment has label value {}; kept as unnamed labels",
            path.display(),
            list.join(", ")
        );
    }
}

/// Warns about voxels that lie outside their segment's `_Extent` (3D Slicer crops a segment to
/// its extent; they are kept here).
fn check_extents(path: &Path, v: &LabelVolume, segments: &[Segment]) {
    let extents: HashMap<i32, ([i64; 6], &Segment)> = segments
        .iter()
        .filter_map(|s| s.extent.map(|e| (s.label, (e, s))))
        .collect();
    if extents.is_empty() {
        return;
    }
    let [nx, ny, nz] = v.dims;
    let mut outside: BTreeMap<u32, usize> = BTreeMap::new();
    for (n, &label) in v.labels.iter().enumerate() {
        let Some((e, s)) = extents.get(&label) else {
            continue;
        };
        let (i, j, k) = (
            (n % nx) as i64,
            (n / nx % ny) as i64,
            (n / (nx * ny) % nz) as i64,
        );
        if i < e[0] || i > e[1] || j < e[2] || j > e[3] || k < e[4] || k > e[5] {
            *outside.entry(s.index).or_default() += 1;
        }
    }
    for (index, n) in outside {
        log::warn!(
            "{}: {n} voxels of Segment{index} lie outside its Segment{index}_Extent (3D Slicer \
             would crop them); they are kept",
            path.display()
        );
    }
}
