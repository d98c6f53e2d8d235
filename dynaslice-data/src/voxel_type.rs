//! The integer sample types of a label volume's voxel data, as NIfTI and NRRD store them: the
//! one table of them, their widths, their ranges, and their decoding to and encoding from `i32`
//! labels. Each reader maps its format's type field (NIfTI's `datatype`, NRRD's `type`) onto
//! [`VoxelType`] and refuses floating types there, since labels are integers; each writer picks
//! the narrowest type it offers that holds the labels ([`VoxelType::narrowest`]).

/// An integer sample type of stored label values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoxelType {
    /// Unsigned 8-bit.
    Uint8,
    /// Signed 8-bit.
    Int8,
    /// Unsigned 16-bit.
    Uint16,
    /// Signed 16-bit.
    Int16,
    /// Unsigned 32-bit.
    Uint32,
    /// Signed 32-bit.
    Int32,
    /// Unsigned 64-bit.
    Uint64,
    /// Signed 64-bit.
    Int64,
}

impl std::fmt::Display for VoxelType {
    /// The type's usual name: `uint8`, `int16`, …
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            VoxelType::Uint8 => "uint8",
            VoxelType::Int8 => "int8",
            VoxelType::Uint16 => "uint16",
            VoxelType::Int16 => "int16",
            VoxelType::Uint32 => "uint32",
            VoxelType::Int32 => "int32",
            VoxelType::Uint64 => "uint64",
            VoxelType::Int64 => "int64",
        })
    }
}

impl VoxelType {
    /// The first of `offered` whose range holds every value in `lo..=hi`, or `None`.
    pub fn narrowest(lo: i32, hi: i32, offered: &[VoxelType]) -> Option<VoxelType> {
        offered.iter().copied().find(|t| t.holds(lo, hi))
    }

    /// Whether every value in `lo..=hi` is representable.
    pub fn holds(self, lo: i32, hi: i32) -> bool {
        let (min, max): (i64, i64) = match self {
            VoxelType::Uint8 => (0, u8::MAX.into()),
            VoxelType::Int8 => (i8::MIN.into(), i8::MAX.into()),
            VoxelType::Uint16 => (0, u16::MAX.into()),
            VoxelType::Int16 => (i16::MIN.into(), i16::MAX.into()),
            VoxelType::Uint32 | VoxelType::Uint64 => (0, i64::MAX),
            VoxelType::Int32 | VoxelType::Int64 => (i64::MIN, i64::MAX),
        };
        min <= i64::from(lo) && i64::from(hi) <= max
    }

    /// Bytes per sample.
    pub fn bytes(self) -> usize {
        match self {
            VoxelType::Uint8 | VoxelType::Int8 => 1,
            VoxelType::Uint16 | VoxelType::Int16 => 2,
            VoxelType::Uint32 | VoxelType::Int32 => 4,
            VoxelType::Uint64 | VoxelType::Int64 => 8,
        }
    }

    /// Appends the labels stored in `raw` to `out`, in file order. `raw` holds whole samples
    /// (a trailing partial one is ignored). Fails on the first value outside `i32`, the label
    /// type everywhere past the readers; `out` then holds the samples before it.
    pub(crate) fn decode_into(
        self,
        raw: &[u8],
        big_endian: bool,
        out: &mut Vec<i32>,
    ) -> Result<(), String> {
        fn words<const N: usize>(raw: &[u8], big: bool) -> impl Iterator<Item = [u8; N]> + '_ {
            raw.chunks_exact(N).map(move |c| {
                let mut w = [0; N];
                w.copy_from_slice(c);
                if big {
                    w.reverse();
                }
                w
            })
        }
        fn checked(v: i128) -> Result<i32, String> {
            i32::try_from(v).map_err(|_| format!("label value {v} does not fit in i32"))
        }
        fn push_checked(
            out: &mut Vec<i32>,
            values: impl Iterator<Item = i128>,
        ) -> Result<(), String> {
            for v in values {
                out.push(checked(v)?);
            }
            Ok(())
        }
        let big = big_endian;
        out.reserve(raw.len() / self.bytes());
        match self {
            VoxelType::Uint8 => out.extend(raw.iter().map(|&b| i32::from(b))),
            VoxelType::Int8 => out.extend(raw.iter().map(|&b| i32::from(b as i8))),
            VoxelType::Uint16 => {
                out.extend(words(raw, big).map(|w| i32::from(u16::from_le_bytes(w))))
            }
            VoxelType::Int16 => {
                out.extend(words(raw, big).map(|w| i32::from(i16::from_le_bytes(w))))
            }
            VoxelType::Int32 => out.extend(words(raw, big).map(i32::from_le_bytes)),
            VoxelType::Uint32 => {
                push_checked(out, words(raw, big).map(|w| u32::from_le_bytes(w).into()))?
            }
            VoxelType::Int64 => {
                push_checked(out, words(raw, big).map(|w| i64::from_le_bytes(w).into()))?
            }
            VoxelType::Uint64 => {
                push_checked(out, words(raw, big).map(|w| u64::from_le_bytes(w).into()))?
            }
        }
        Ok(())
    }

    /// Appends `labels` to `out` as little-endian samples of this type. Every label must be in
    /// the type's range ([`VoxelType::holds`]), which the writers check first; a label outside
    /// it would be stored wrapped.
    pub(crate) fn encode_le_into(self, labels: &[i32], out: &mut Vec<u8>) {
        out.reserve(labels.len() * self.bytes());
        // One loop per width, so the per-voxel loop has no branch on the type.
        match self.bytes() {
            1 => out.extend(labels.iter().map(|&v| v as u8)),
            2 => labels
                .iter()
                .for_each(|&v| out.extend((v as u16).to_le_bytes())),
            4 => labels.iter().for_each(|&v| out.extend(v.to_le_bytes())),
            _ => labels
                .iter()
                .for_each(|&v| out.extend(i64::from(v).to_le_bytes())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::VoxelType;

    fn decoded(t: VoxelType, raw: &[u8], big: bool) -> Result<Vec<i32>, String> {
        let mut out = Vec::new();
        t.decode_into(raw, big, &mut out).map(|()| out)
    }

    #[test]
    fn every_type_decodes_both_byte_orders() {
        assert_eq!(
            decoded(VoxelType::Uint8, &[255, 7], false),
            Ok(vec![255, 7])
        );
        assert_eq!(decoded(VoxelType::Int8, &[255, 7], true), Ok(vec![-1, 7]));
        assert_eq!(decoded(VoxelType::Uint16, &[1, 2], false), Ok(vec![0x0201]));
        assert_eq!(decoded(VoxelType::Uint16, &[1, 2], true), Ok(vec![0x0102]));
        assert_eq!(decoded(VoxelType::Int16, &[0xff, 0xfe], true), Ok(vec![-2]));
        assert_eq!(
            decoded(VoxelType::Int32, &(-5i32).to_be_bytes(), true),
            Ok(vec![-5])
        );
        assert_eq!(
            decoded(VoxelType::Uint32, &9u32.to_le_bytes(), false),
            Ok(vec![9])
        );
        assert_eq!(
            decoded(VoxelType::Int64, &(-3i64).to_be_bytes(), true),
            Ok(vec![-3])
        );
        assert_eq!(
            decoded(VoxelType::Uint64, &41u64.to_le_bytes(), false),
            Ok(vec![41])
        );
    }

    #[test]
    fn encoding_then_decoding_gives_the_labels_back() {
        let labels = [0, 1, 7, 127];
        for t in [
            VoxelType::Uint8,
            VoxelType::Int8,
            VoxelType::Uint16,
            VoxelType::Int16,
            VoxelType::Uint32,
            VoxelType::Int32,
            VoxelType::Uint64,
            VoxelType::Int64,
        ] {
            let mut raw = Vec::new();
            t.encode_le_into(&labels, &mut raw);
            assert_eq!(raw.len(), labels.len() * t.bytes(), "{t:?}");
            assert_eq!(decoded(t, &raw, false), Ok(labels.to_vec()), "{t:?}");
        }
        let mut raw = Vec::new();
        VoxelType::Int16.encode_le_into(&[-2, 300], &mut raw);
        assert_eq!(decoded(VoxelType::Int16, &raw, false), Ok(vec![-2, 300]));
    }

    #[test]
    fn the_narrowest_offered_type_holds_the_range() {
        let offered = [VoxelType::Uint8, VoxelType::Int16, VoxelType::Int32];
        let pick = |lo, hi| VoxelType::narrowest(lo, hi, &offered);
        assert_eq!(pick(0, 255), Some(VoxelType::Uint8));
        assert_eq!(pick(0, 256), Some(VoxelType::Int16));
        assert_eq!(pick(-1, 7), Some(VoxelType::Int16));
        assert_eq!(pick(-40000, 7), Some(VoxelType::Int32));
        assert_eq!(VoxelType::narrowest(0, 70000, &offered[..2]), None);
        assert!(VoxelType::Uint32.holds(0, i32::MAX) && !VoxelType::Uint32.holds(-1, 0));
    }

    #[test]
    fn a_trailing_partial_sample_is_ignored() {
        assert_eq!(decoded(VoxelType::Uint16, &[1, 0, 9], false), Ok(vec![1]));
    }

    #[test]
    fn values_outside_i32_are_refused_by_value() {
        let too_big = decoded(VoxelType::Uint32, &u32::MAX.to_le_bytes(), false);
        assert_eq!(
            too_big,
            Err("label value 4294967295 does not fit in i32".into())
        );
        let too_small = decoded(VoxelType::Int64, &i64::MIN.to_be_bytes(), true);
        assert_eq!(
            too_small,
            Err("label value -9223372036854775808 does not fit in i32".into())
        );
    }
}
