//! The classes of a label map, counted in one pass over its voxels before any plane is cut, and
//! the refusal of a map with more of them than a model holds.
//!
//! Every reader that turns a label map into classes ([`crate::input::read`], [`crate::nifti::read`])
//! checks it right after reading the voxels: tracing the contours of thousands of values (the
//! CT or MR image given where its segmentation belongs) would take minutes before the model's
//! class limit refused them. The refusal says what the map looks like: the count, the voxel
//! type, and, where the values look like intensities ([`Census::image_signs`]), that it seems to
//! be an image, with the two ways on (its label map, or `--labels`).

use std::collections::HashSet;

use crate::frame_range::FrameRange;
use crate::label_volume::LabelVolume;
use crate::voxel_type::VoxelType;
use dynaslice_sequence::error::{ErrorKind, Result};

/// The most classes a model holds: dynaslice-core's `format::MAX_CLASSES`, which the input side
/// does not depend on (dynaslice-train's `model_file` tests that the two agree).
pub const MAX_CLASSES: usize = 64;

/// Distinct values beyond which a label map looks like an image (segmentations rarely hold a
/// thousand structures; a CT slab holds thousands of intensities).
const MANY_VALUES: usize = 1000;

/// A range of values (max − min) this wide, in a 16-bit or wider type, with more than
/// [`WIDE_RANGE_VALUES`] distinct values, looks like intensities: an atlas's sparse codes (e.g.
/// 1000–2035) span as much with a few hundred labels at most.
const WIDE_RANGE: i64 = 1024;

/// See [`WIDE_RANGE`].
const WIDE_RANGE_VALUES: usize = 256;

/// Values spanned at most by the bit set that counts them; a wider range is counted in a hash
/// set, up to [`HASHED_VALUES`].
const MAX_BITSET_RANGE: u64 = 1 << 27;

/// Distinct values a hash-set count stops past: the count is then "over" this many.
const HASHED_VALUES: usize = 1 << 16;

/// Words of a header's description that say it holds an image, not labels.
const IMAGE_WORDS: [&str; 14] = [
    "image",
    "intensity",
    "ct",
    "mr",
    "mri",
    "t1",
    "t2",
    "t1w",
    "t2w",
    "flair",
    "pet",
    "bold",
    "dwi",
    "scan",
];

/// What a label map's file says of its values besides the values: for the wording of a
/// refusal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stored {
    /// The voxel type the file stores.
    pub voxel: VoxelType,
    /// What in its header says it holds an image, in words (`its description "CT abdomen"`),
    /// if anything does.
    pub says_image: Option<String>,
}

impl Stored {
    /// `voxel`, and `description` (a NIfTI `descrip` or `intent_name`, an NRRD `content`,
    /// named in words by `what`) where one of its words names an image (`IMAGE_WORDS`).
    pub fn new(voxel: VoxelType, what: &str, description: &str) -> Stored {
        let says = description
            .split(|c: char| !c.is_ascii_alphanumeric())
            .any(|w| IMAGE_WORDS.contains(&w.to_ascii_lowercase().as_str()));
        Stored {
            voxel,
            says_image: says.then(|| {
                format!(
                    "its {what} {:?} says image",
                    dynaslice_sequence::error::excerpt(description.trim())
                )
            }),
        }
    }
}

/// The values of some frames of a label map, counted in one pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Census {
    /// Distinct nonzero values: the classes they would make.
    pub count: usize,
    /// Whether [`Census::count`] is exact; otherwise there are more (a huge range, counted up
    /// to `HASHED_VALUES`).
    pub exact: bool,
    /// The smallest and largest value, background included (`None`: no voxel).
    pub range: Option<(i32, i32)>,
}

impl Census {
    /// Counts the distinct nonzero values of `frames` of `volume`, in time linear in the voxels
    /// and independent of the values (a bit set over their range, or a bounded hash set where
    /// the range is huge). Frames beyond the voxels held are left to the readers' checks.
    pub fn of(volume: &LabelVolume, frames: FrameRange) -> Census {
        let voxels = volume.dims.iter().product::<usize>();
        let chunks: Vec<&[i32]> = frames
            .indices(volume.frames)
            .into_iter()
            .filter_map(|f| volume.labels.get(f * voxels..(f + 1) * voxels))
            .collect();
        let values = || chunks.iter().flat_map(|c| c.iter().copied());
        let range = values().fold(None, |r: Option<(i32, i32)>, v| {
            Some(r.map_or((v, v), |(lo, hi)| (lo.min(v), hi.max(v))))
        });
        let Some((lo, hi)) = range else {
            return Census {
                count: 0,
                exact: true,
                range,
            };
        };
        let span = (i64::from(hi) - i64::from(lo)) as u64 + 1;
        let (count, exact) = if span <= MAX_BITSET_RANGE {
            let mut bits = vec![0u64; span.div_ceil(64) as usize];
            for v in values() {
                let i = (i64::from(v) - i64::from(lo)) as usize;
                bits[i / 64] |= 1 << (i % 64);
            }
            let all = bits.iter().map(|w| w.count_ones() as usize).sum::<usize>();
            // The background is no class.
            let zero = lo <= 0 && 0 <= hi && {
                let i = (-i64::from(lo)) as usize;
                bits[i / 64] >> (i % 64) & 1 == 1
            };
            (all - usize::from(zero), true)
        } else {
            let mut seen = HashSet::new();
            for v in values().filter(|&v| v != 0) {
                seen.insert(v);
                if seen.len() > HASHED_VALUES {
                    break;
                }
            }
            (seen.len().min(HASHED_VALUES), seen.len() <= HASHED_VALUES)
        };
        Census {
            count,
            exact,
            range,
        }
    }

    /// Why these values look like an image's intensities rather than labels, in words: many
    /// values, negative values, a wide range in a 16-bit or wider type, or what the file's
    /// header says (`stored`); empty where nothing does.
    pub fn image_signs(&self, stored: &Stored) -> Vec<String> {
        let mut signs = Vec::new();
        if self.count > MANY_VALUES {
            signs.push("many values".to_string());
        }
        let (lo, hi) = self.range.unwrap_or((0, 0));
        if lo < 0 {
            signs.push("negative values".to_string());
        }
        if stored.voxel.bytes() >= 2
            && i64::from(hi) - i64::from(lo) >= WIDE_RANGE
            && self.count > WIDE_RANGE_VALUES
        {
            signs.push(format!(
                "a {}-bit type with a wide range",
                stored.voxel.bytes() * 8
            ));
        }
        signs.extend(stored.says_image.clone());
        signs
    }
}

/// Refuses a label map whose classes are more than a model holds ([`MAX_CLASSES`]): the
/// `labels` selected (`--labels`) where given, else every distinct nonzero value of `frames`
/// ([`Census::of`]). The message gives the count, the voxel type and range, and where the values
/// look like intensities ([`Census::image_signs`]) that the file seems to be an image.
pub fn check_classes(
    volume: &LabelVolume,
    frames: FrameRange,
    labels: Option<&[i32]>,
    stored: &Stored,
) -> Result<()> {
    if let Some(labels) = labels {
        let picked = labels.iter().collect::<HashSet<_>>().len();
        if picked > MAX_CLASSES {
            return Err(ErrorKind::TooManyClasses(format!(
                "--labels picks {picked} labels; a model holds at most {MAX_CLASSES} classes"
            ))
            .into());
        }
        return Ok(());
    }
    let census = Census::of(volume, frames);
    if census.count <= MAX_CLASSES {
        return Ok(());
    }
    let count = if census.exact {
        census.count.to_string()
    } else {
        format!("over {}", census.count)
    };
    let (lo, hi) = census.range.unwrap_or((0, 0));
    let found = format!(
        "{count} distinct nonzero values ({} voxels, {lo} to {hi}); a model holds at most \
         {MAX_CLASSES} classes",
        stored.voxel
    );
    let signs = census.image_signs(stored);
    let message = if signs.is_empty() {
        format!(
            "{found}: pick at most {MAX_CLASSES} of its labels with --labels (labels= in Python)"
        )
    } else {
        format!(
            "{found}; this seems to be an image, not a segmentation ({}): give its label map \
             instead, or pick at most {MAX_CLASSES} values as classes with --labels (labels= in \
             Python)",
            signs.join(", ")
        )
    };
    Err(ErrorKind::TooManyClasses(message).into())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn volume(labels: Vec<i32>) -> LabelVolume {
        LabelVolume {
            dims: [labels.len(), 1, 1],
            frames: 1,
            affine: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            frame_interval: 1.0,
            labels,
        }
    }

    fn stored(voxel: VoxelType) -> Stored {
        Stored::new(voxel, "description", "")
    }

    #[test]
    fn distinct_nonzero_values_are_counted_whatever_their_range() {
        let count = |labels: Vec<i32>| {
            let c = Census::of(&volume(labels), FrameRange::ALL);
            (c.count, c.exact, c.range)
        };
        assert_eq!(count(vec![0, 3, 3, 7, 0]), (2, true, Some((0, 7))));
        assert_eq!(count(vec![-5, 0, 5, -5]), (2, true, Some((-5, 5))));
        assert_eq!(count(vec![4, 4]), (1, true, Some((4, 4))));
        assert_eq!(count(vec![0, 0]), (0, true, Some((0, 0))));
        assert_eq!(count(vec![]), (0, true, None));
        // Beyond the bit set's range: hashed, exactly while few.
        let wide = vec![i32::MIN, 0, i32::MAX, 7, 7];
        assert_eq!(count(wide), (3, true, Some((i32::MIN, i32::MAX))));
        let mut many: Vec<i32> = (1..=HASHED_VALUES as i32 + 10).collect();
        many.push(i32::MAX);
        let (n, exact, _) = count(many);
        assert_eq!((n, exact), (HASHED_VALUES, false));
    }

    #[test]
    fn only_the_selected_frames_count() {
        let mut v = volume(vec![1, 2, 3, 4, 5, 6]);
        v.dims = [3, 1, 1];
        v.frames = 2;
        let second: FrameRange = "1:2:1".parse().unwrap();
        assert_eq!(Census::of(&v, second).count, 3);
        assert_eq!(Census::of(&v, second).range, Some((4, 6)));
    }

    #[test]
    fn an_image_is_refused_as_one_and_a_large_segmentation_with_the_labels_hint() {
        let noise: Vec<i32> = (-1024..3072).collect();
        let e = check_classes(
            &volume(noise),
            FrameRange::ALL,
            None,
            &stored(VoxelType::Int16),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("4095 distinct nonzero values (int16 voxels, -1024 to 3071)"),
            "{e}"
        );
        assert!(e.contains("seems to be an image"), "{e}");
        assert!(
            e.contains("many values, negative values, a 16-bit type with a wide range"),
            "{e}"
        );
        assert!(
            e.contains("give its label map") && e.contains("--labels"),
            "{e}"
        );
        let parcels: Vec<i32> = (0..200).collect();
        let e = check_classes(
            &volume(parcels.clone()),
            FrameRange::ALL,
            None,
            &stored(VoxelType::Uint8),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("199 distinct nonzero values (uint8 voxels, 0 to 199)"),
            "{e}"
        );
        assert!(!e.contains("image") && e.contains("--labels"), "{e}");
        // What the header says counts too.
        let described = Stored::new(VoxelType::Uint8, "description", "CT abdomen");
        let e = check_classes(&volume(parcels.clone()), FrameRange::ALL, None, &described)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(r#"its description "CT abdomen" says image"#),
            "{e}"
        );
        // --labels picks the classes: within the limit the map is read as asked.
        let some: Vec<i32> = (1..=64).collect();
        let picked = Some(&some[..]);
        assert!(check_classes(
            &volume(parcels.clone()),
            FrameRange::ALL,
            picked,
            &described
        )
        .is_ok());
        let all: Vec<i32> = (1..=65).collect();
        let e = check_classes(&volume(parcels), FrameRange::ALL, Some(&all), &described)
            .unwrap_err()
            .to_string();
        assert!(e.contains("--labels picks 65 labels"), "{e}");
        let few: Vec<i32> = (0..=MAX_CLASSES as i32).collect();
        assert!(check_classes(
            &volume(few),
            FrameRange::ALL,
            None,
            &stored(VoxelType::Int32)
        )
        .is_ok());
    }

    #[test]
    fn only_image_words_of_a_description_say_image() {
        let says = |d: &str| {
            Stored::new(VoxelType::Int16, "description", d)
                .says_image
                .is_some()
        };
        assert!(says("T1w MRI") && says("ct_abdomen") && says("Image"));
        assert!(!says("TotalSegmentator structures") && !says("") && !says("segmentation"));
    }
}
