//! Boolean operations on the even-odd regions of sets of rings: the area a region shares with
//! another, and one region minus another. Nested structures (an endocardium inside an
//! epicardium, a tumour inside an organ) are detected by the first and made disjoint by the
//! second (`dynaslice-data`'s `nesting`).
//!
//! The work is `i_overlay`'s (as for [`crate::repair`]), with the even-odd fill rule on each
//! operand and its 64-bit integer engine; input vertices are kept, and the result gains only
//! the points where the two operands' rings cross.

use i_overlay::core::fill_rule::FillRule;
use i_overlay::core::overlay_rule::OverlayRule;
use i_overlay::core::solver::Solver;
use i_overlay::float::overlay::{FloatOverlay, OverlayOptions};

use crate::polygon::{orient_by_nesting, signed_area, Polygon};

/// Largest coordinate magnitude the engine's float adapter takes (see [`crate::repair`]).
const LIMIT: f64 = 1e150;

fn overlay(subject: &[Polygon], clip: &[Polygon], rule: OverlayRule) -> Option<Vec<Polygon>> {
    let finite = |p: &[Polygon]| p.iter().flatten().flatten().all(|x| x.abs() <= LIMIT);
    if !finite(subject) || !finite(clip) {
        return None;
    }
    let mut options = OverlayOptions::<f64, i64>::default();
    options.preserve_input_collinear = true;
    options.preserve_output_collinear = true;
    let shapes = FloatOverlay::<[f64; 2], i64>::from_subj_and_clip_custom(
        &subject.to_vec(),
        &clip.to_vec(),
        options,
        Solver::default(),
    )
    .overlay(rule, FillRule::EvenOdd);
    Some(
        shapes
            .into_iter()
            .flatten()
            .filter(|r| r.len() >= 3 && signed_area(r) != 0.0)
            .collect(),
    )
}

/// The area of the even-odd region of non-crossing rings (outer boundaries minus holes, by
/// nesting parity).
pub fn region_area(rings: &[Polygon]) -> f64 {
    let mut v = rings.to_vec();
    orient_by_nesting(&mut v);
    v.iter().map(|p| signed_area(p)).sum()
}

/// Rings bounding the even-odd region of `a` minus that of `b`: non-crossing (they may share a
/// vertex), orientation and order the engine's. `None` when a coordinate is not finite or
/// beyond ±1e150.
pub fn difference(a: &[Polygon], b: &[Polygon]) -> Option<Vec<Polygon>> {
    overlay(a, b, OverlayRule::Difference)
}

/// Rings bounding the intersection of the even-odd regions of `a` and `b` (as [`difference`]).
pub fn intersection(a: &[Polygon], b: &[Polygon]) -> Option<Vec<Polygon>> {
    overlay(a, b, OverlayRule::Intersect)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(c: [f64; 2], h: f64) -> Polygon {
        vec![
            [c[0] - h, c[1] - h],
            [c[0] + h, c[1] - h],
            [c[0] + h, c[1] + h],
            [c[0] - h, c[1] + h],
        ]
    }

    #[test]
    fn a_square_inside_another_becomes_its_hole() {
        let outer = vec![square([0.0, 0.0], 2.0)];
        let inner = vec![square([0.5, 0.0], 1.0)];
        let ring = difference(&outer, &inner).unwrap();
        assert_eq!(ring.len(), 2);
        assert!((region_area(&ring) - 12.0).abs() < 1e-9);
        let shared = intersection(&inner, &outer).unwrap();
        assert!((region_area(&shared) - 4.0).abs() < 1e-9);
    }

    #[test]
    fn a_square_poking_out_takes_only_the_overlap_away() {
        let outer = vec![square([0.0, 0.0], 2.0)];
        let inner = vec![square([2.0, 0.0], 1.0)];
        let rest = difference(&outer, &inner).unwrap();
        assert!((region_area(&rest) - 14.0).abs() < 1e-9);
        let shared = intersection(&inner, &outer).unwrap();
        assert!((region_area(&shared) - 2.0).abs() < 1e-9);
        assert!(difference(&[vec![[f64::NAN, 0.0], [1.0, 0.0], [0.0, 1.0]]], &inner).is_none());
    }

    #[test]
    fn holes_of_either_operand_count_by_the_even_odd_rule() {
        // A ring (square with a hole) minus a square covering the hole and part of the ring.
        let ring = vec![square([0.0, 0.0], 3.0), square([0.0, 0.0], 1.0)];
        let cut = vec![square([0.0, 0.0], 2.0)];
        let rest = difference(&ring, &cut).unwrap();
        assert!((region_area(&rest) - (36.0 - 16.0)).abs() < 1e-9);
    }
}
