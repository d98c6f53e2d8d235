//! Class colours: the one place every figure (slice pictures, charts, 3D renderings) takes a
//! class's colour from, so a class looks the same in all of them.

use plotters::style::RGBColor;

/// The colour of class `index` (0-based, the order of the sequence's or model's classes):
/// `given` (the input's display colour, e.g. from a `.seg.nrrd`, an RTSTRUCT or a model file's
/// `class_colors`) when known, else the one palette's entry `index`
/// ([`dynaslice_sequence::palette`], shared with the segmentation writers and colour tables).
pub fn class_color(index: usize, given: Option<[u8; 3]>) -> RGBColor {
    let [r, g, b] = dynaslice_sequence::palette::class_color(index, given);
    RGBColor(r, g, b)
}

/// `c` halfway to white: the fill under a line of colour `c`.
pub(crate) fn lighten(c: RGBColor) -> RGBColor {
    let m = |v: u8| (v as u16 + (255 - v as u16) / 2) as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn given_colours_win_and_the_palette_is_the_shared_one() {
        assert_eq!(class_color(3, Some([1, 2, 3])), RGBColor(1, 2, 3));
        let [r, g, b] = dynaslice_sequence::palette::PALETTE[0];
        assert_eq!(class_color(0, None), RGBColor(r, g, b));
        // 64 classes (a model's most): no two the same, none too close to the white background.
        let colours: Vec<RGBColor> = (0..64).map(|i| class_color(i, None)).collect();
        for (i, a) in colours.iter().enumerate() {
            assert!(
                u32::from(a.0) + u32::from(a.1) + u32::from(a.2) < 3 * 230,
                "{i}: {a:?}"
            );
            for b in &colours[i + 1..] {
                assert_ne!(a, b);
            }
        }
        assert_eq!(lighten(RGBColor(0, 100, 255)), RGBColor(127, 177, 255));
    }
}
