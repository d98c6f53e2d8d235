//! Class colours: the one palette every output takes a class's display colour from when the
//! input gave it none (figures, 3D Slicer segmentations and sequences, colour tables), so a
//! class looks the same everywhere; and the `#rrggbb` notation model files record colours in.
//!
//! The palette is [`PALETTE`] (64 entries, as many as a model holds classes): Tableau 10 first
//! (matplotlib's `tab10`, familiar and readable on white and on black), then 54 colours picked
//! greedily, each the one farthest in CIELAB (D65, ΔE*ab) from all those before it, among the
//! sRGB colours whose components are multiples of 17 and whose lightness L* lies in (25, 85),
//! so none is lost on a white figure or on 3D Slicer's black background. Any two of the 64 are
//! at least ΔE 23 apart (tested). Past 64, hues step by the golden angle at alternating
//! brightness: distinct from their neighbours, but they may come close to earlier entries.

/// The 64 class colours (sRGB), in order; see the [module docs](self).
pub const PALETTE: [[u8; 3]; 64] = [
    // Tableau 10.
    [0x1f, 0x77, 0xb4],
    [0xff, 0x7f, 0x0e],
    [0x2c, 0xa0, 0x2c],
    [0xd6, 0x27, 0x28],
    [0x94, 0x67, 0xbd],
    [0x8c, 0x56, 0x4b],
    [0xe3, 0x77, 0xc2],
    [0x7f, 0x7f, 0x7f],
    [0xbc, 0xbd, 0x22],
    [0x17, 0xbe, 0xcf],
    // Farthest-point picks in CIELAB.
    [0x00, 0x00, 0xff],
    [0xff, 0x22, 0xff],
    [0x00, 0xee, 0x00],
    [0x22, 0x44, 0x00],
    [0x44, 0x11, 0xaa],
    [0xff, 0xbb, 0x88],
    [0x00, 0xee, 0xbb],
    [0xdd, 0xcc, 0xff],
    [0xff, 0x00, 0x77],
    [0xbb, 0xdd, 0x99],
    [0x88, 0x66, 0x00],
    [0x77, 0x00, 0x55],
    [0x00, 0x77, 0xff],
    [0x00, 0x88, 0x66],
    [0xdd, 0x00, 0xaa],
    [0xbb, 0x66, 0xff],
    [0x00, 0x44, 0x44],
    [0xff, 0x77, 0x88],
    [0xff, 0xbb, 0x00],
    [0x99, 0x00, 0x33],
    [0x88, 0x33, 0x00],
    [0x44, 0x33, 0x66],
    [0x00, 0xee, 0x77],
    [0x99, 0xdd, 0x00],
    [0x99, 0x11, 0xee],
    [0x00, 0x33, 0x99],
    [0x77, 0x88, 0x44],
    [0xdd, 0x99, 0xaa],
    [0xcc, 0xcc, 0xbb],
    [0x88, 0x22, 0x99],
    [0xff, 0x00, 0x00],
    [0x00, 0x44, 0xff],
    [0xdd, 0x77, 0x44],
    [0x88, 0xaa, 0xff],
    [0x99, 0xdd, 0x66],
    [0x00, 0xbb, 0xff],
    [0x55, 0x44, 0x11],
    [0xdd, 0xaa, 0x44],
    [0x99, 0x55, 0x77],
    [0x88, 0xaa, 0xcc],
    [0x55, 0xbb, 0x77],
    [0x66, 0x88, 0x00],
    [0xbb, 0x00, 0x66],
    [0xaa, 0x88, 0x55],
    [0x77, 0xaa, 0x99],
    [0x00, 0x66, 0x00],
    [0x00, 0x44, 0x66],
    [0x00, 0xbb, 0x00],
    [0xee, 0x88, 0xff],
    [0x00, 0x77, 0x88],
    [0xdd, 0xaa, 0xff],
    [0x44, 0x66, 0x44],
    [0x55, 0x33, 0x44],
    [0xaa, 0x88, 0xbb],
];

/// The display colour (sRGB) of the class at position `index` (0-based, the order of the
/// sequence's or model's classes) when it has none of its own: [`PALETTE`] entry `index`, and
/// past it golden-angle hues. The same for the same index every time.
pub fn palette(index: usize) -> [u8; 3] {
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

/// The colour of class `index`: `given` (the input's, e.g. from a `.seg.nrrd`, an RTSTRUCT or a
/// model file's `class_colors`) when known, else [`palette`]`(index)`.
pub fn class_color(index: usize, given: Option<[u8; 3]>) -> [u8; 3] {
    given.unwrap_or_else(|| palette(index))
}

/// `#rrggbb`, lower case.
pub fn to_hex([r, g, b]: [u8; 3]) -> String {
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// The colour of `#rrggbb` (either case); `None` for anything else.
pub fn parse_hex(text: &str) -> Option<[u8; 3]> {
    let digits = text.strip_prefix('#')?;
    if digits.len() != 6 || !digits.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let byte = |i: usize| u8::from_str_radix(&digits[i..i + 2], 16).ok();
    Some([byte(0)?, byte(2)?, byte(4)?])
}

/// HSV to sRGB bytes, hue in sextants [0, 6).
fn hsv(h: f64, s: f64, v: f64) -> [u8; 3] {
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
    [byte(r), byte(g), byte(b)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// sRGB → CIELAB (D65).
    fn lab(c: [u8; 3]) -> [f64; 3] {
        let lin = c.map(|v| {
            let v = f64::from(v) / 255.0;
            if v <= 0.04045 {
                v / 12.92
            } else {
                ((v + 0.055) / 1.055).powf(2.4)
            }
        });
        let m = [
            [0.4124, 0.3576, 0.1805],
            [0.2126, 0.7152, 0.0722],
            [0.0193, 0.1192, 0.9505],
        ];
        let white = [0.95047, 1.0, 1.08883];
        let f = |i: usize| {
            let t = (0..3).map(|j| m[i][j] * lin[j]).sum::<f64>() / white[i];
            let d: f64 = 6.0 / 29.0;
            if t > d.powi(3) {
                t.cbrt()
            } else {
                t / (3.0 * d * d) + 4.0 / 29.0
            }
        };
        let (x, y, z) = (f(0), f(1), f(2));
        [116.0 * y - 16.0, 500.0 * (x - y), 200.0 * (y - z)]
    }

    fn delta_e(a: [u8; 3], b: [u8; 3]) -> f64 {
        let (a, b) = (lab(a), lab(b));
        (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>().sqrt()
    }

    /// The table is what the module docs say: Tableau 10, then each entry the farthest
    /// candidate from all before it (recomputed here), all far apart and of moderate lightness.
    #[test]
    fn palette_is_the_documented_farthest_point_sequence() {
        assert_eq!(PALETTE[0], [31, 119, 180]);
        assert_eq!(PALETTE[9], [23, 190, 207]);
        let levels: Vec<u8> = (0..=15).map(|i| i * 17).collect();
        let mut candidates = Vec::new();
        for &r in &levels {
            for &g in &levels {
                for &b in &levels {
                    let l = lab([r, g, b])[0];
                    if l > 25.0 && l < 85.0 {
                        candidates.push([r, g, b]);
                    }
                }
            }
        }
        let mut nearest: Vec<f64> = candidates
            .iter()
            .map(|&c| {
                PALETTE[..10]
                    .iter()
                    .map(|&p| delta_e(c, p))
                    .fold(f64::INFINITY, f64::min)
            })
            .collect();
        for (n, &entry) in PALETTE.iter().enumerate().skip(10) {
            // The first candidate of the largest distance, as the table was made.
            let best =
                (0..candidates.len()).fold(
                    0,
                    |best, i| {
                        if nearest[i] > nearest[best] {
                            i
                        } else {
                            best
                        }
                    },
                );
            assert_eq!(entry, candidates[best], "entry {n}");
            for (i, &c) in candidates.iter().enumerate() {
                nearest[i] = nearest[i].min(delta_e(c, entry));
            }
        }
        let mut closest = f64::INFINITY;
        for (i, &a) in PALETTE.iter().enumerate() {
            for &b in &PALETTE[i + 1..] {
                closest = closest.min(delta_e(a, b));
            }
        }
        assert!(closest > 23.0, "closest pair ΔE {closest}");
    }

    #[test]
    fn given_colours_win_and_indices_past_the_table_are_stable() {
        assert_eq!(class_color(3, Some([1, 2, 3])), [1, 2, 3]);
        assert_eq!(class_color(3, None), PALETTE[3]);
        assert_eq!(palette(100), palette(100));
        let past: Vec<[u8; 3]> = (64..80).map(palette).collect();
        for w in past.windows(2) {
            assert!(delta_e(w[0], w[1]) > 10.0, "{w:?}");
        }
    }

    #[test]
    fn hex_round_trips_and_refuses_malformed_text() {
        for c in [[0, 0, 0], [255, 255, 255], [0x1f, 0x77, 0xb4]] {
            assert_eq!(parse_hex(&to_hex(c)), Some(c));
        }
        assert_eq!(to_hex([0xe6, 0x19, 0x4b]), "#e6194b");
        assert_eq!(parse_hex("#E6194B"), Some([0xe6, 0x19, 0x4b]));
        for bad in ["e6194b", "#e6194", "#e6194bb", "#g6194b", "#é6194", ""] {
            assert_eq!(parse_hex(bad), None, "{bad}");
        }
    }
}
