//! Class colours: the one place every figure (slice pictures, charts, 3D renderings) takes a
//! class's colour from, so a class looks the same in all of them.

use plotters::style::RGBColor;

/// The fixed palette for classes without a colour of their own: Tableau 10 (familiar, readable
/// on white), then ten of Kelly's colours of maximum contrast that differ from those.
pub const PALETTE: [RGBColor; 20] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(243, 195, 0),
    RGBColor(0, 103, 165),
    RGBColor(190, 0, 50),
    RGBColor(0, 136, 86),
    RGBColor(96, 78, 151),
    RGBColor(194, 178, 128),
    RGBColor(136, 45, 23),
    RGBColor(141, 182, 0),
    RGBColor(179, 68, 108),
    RGBColor(43, 61, 38),
];

/// The colour of class `index` (0-based, the order of the sequence's or model's classes):
/// `given` (the input's display colour, e.g. from a `.seg.nrrd` or RTSTRUCT) when known, else
/// palette entry `index` and, past the palette, hues spaced by the golden angle at alternating
/// brightness (distinct from their neighbours, the same for the same index every time).
pub fn class_color(index: usize, given: Option<[u8; 3]>) -> RGBColor {
    if let Some([r, g, b]) = given {
        return RGBColor(r, g, b);
    }
    if let Some(&c) = PALETTE.get(index) {
        return c;
    }
    let i = index - PALETTE.len();
    let hue = (i as f64 * 0.618_033_988_75).fract() * 6.0;
    let (saturation, value) = if i.is_multiple_of(2) {
        (0.7, 0.85)
    } else {
        (0.8, 0.6)
    };
    hsv(hue, saturation, value)
}

/// HSV to RGB, hue in sextants [0, 6).
fn hsv(h: f64, s: f64, v: f64) -> RGBColor {
    let c = v * s;
    let x = c * (1.0 - ((h % 2.0) - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let byte = |f: f64| ((f + m) * 255.0).round().clamp(0.0, 255.0) as u8;
    RGBColor(byte(r), byte(g), byte(b))
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
    fn given_colours_win_and_the_palette_is_stable_and_distinct() {
        assert_eq!(class_color(3, Some([1, 2, 3])), RGBColor(1, 2, 3));
        assert_eq!(class_color(0, None), PALETTE[0]);
        assert_eq!(class_color(41, None), class_color(41, None));
        // 60 classes: no two the same, and none too close to the white background.
        let colours: Vec<RGBColor> = (0..60).map(|i| class_color(i, None)).collect();
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
