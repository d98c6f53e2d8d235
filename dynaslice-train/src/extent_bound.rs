//! A structure ends where its contours end: the region of space each class's contours span,
//! beyond which the trainer holds the class outside (issue 51).
//!
//! Why: planes say "outside" only on themselves. Past a structure's first and last contour
//! plane, and in the part of the model's cubic domain no plane reaches (a third of it for an
//! axial RT Structure Set 290 mm long in a 590 mm cube), only the regulariser (Eq. 8) speaks,
//! and a network fitted to the planes fills that space at will: a BODY cut by the scan at both
//! ends grew to the cube's faces (7× its volume in the case, 10× in
//! `lab/cases/clinical_rtstruct.py`), a lung grew a second component 200 mm past its
//! contours (lab/notes/2026-12-07-clinical-extent.md). A planning system caps a structure at
//! its end contours, each contour standing for a slab one plane spacing thick (its volume is
//! the contours' areas times the spacing); SlicerRT's planar-contour-to-surface conversion ends
//! the surface there too.
//!
//! The rule: each class's extent is the box of its contour points over every plane and frame,
//! in the frame of the data's planes where they are all parallel (the planes' in-plane axes and
//! normal), grown on every side by half the planes' median spacing, the slab a contour stands
//! for. A shape inside a box has a signed distance at least the box's everywhere
//! (`box_distance`), so f^k ≥ that is a fact of the data, imposed as ReLU(b − f^k) with the
//! surface term's weight ([`crate::loss`]) on cap samples drawn around the box's faces
//! ([`ClassExtents::cap_sample`]) and on the space-time samples; an in-plane target inside the
//! class is no deeper than the box allows ([`ClassExtents::depth`]). It concerns parallel stacks
//! only: planes in several orientations (resliced label maps, long-axis views beside a
//! short-axis stack) do not bound a structure between their cuts, and nothing is imposed.

use crate::sampling::SampleRng;
use crate::spatial_bound::parallel_spacing;
use dynaslice_core::Domain;
use dynaslice_sequence::sequence::dot;
use dynaslice_sequence::Sequence;

/// Each class's extent in a frame of orthonormal axes, in the network's normalised units.
#[derive(Clone, Debug, PartialEq)]
pub struct ClassExtents {
    /// The frame's axes: the planes' in-plane axes and their normal.
    axes: [[f64; 3]; 3],
    /// Per class, the grown box of its contour points along `axes` (`None`: no contour, no
    /// bound).
    boxes: Vec<Option<([f64; 3], [f64; 3])>>,
    /// The margin the boxes were grown by, normalised units (half the planes' spacing).
    half: f64,
    /// The same in world units.
    margin: f64,
}

/// How far beyond a class's box cap samples reach, as a fraction of the box's longest side.
const CAP_REACH: f64 = 0.5;

impl ClassExtents {
    /// The extents of `seq`'s classes in `domain`'s normalised frame, or `None` where its planes
    /// are not all parallel ([`parallel_spacing`]).
    pub fn of(seq: &Sequence, domain: &Domain) -> Option<ClassExtents> {
        let (normal, spacing) = parallel_spacing(seq, domain)?;
        let first = seq.frames().iter().flat_map(|f| &f.planes).next()?;
        let axes = orthonormal_frame(first.u, normal);
        let half = 0.5 * spacing;
        let mut boxes: Vec<Option<([f64; 3], [f64; 3])>> = vec![None; seq.classes().len()];
        for plane in seq.frames().iter().flat_map(|f| &f.planes) {
            for a in &plane.annotations {
                for p in a.polygons.iter().flatten() {
                    let w = plane.to_world(*p).map(|v| v as f32);
                    let x = domain.normalise(w, domain.time_origin);
                    let x = [x[0], x[1], x[2]].map(f64::from);
                    let q: [f64; 3] = std::array::from_fn(|i| dot(axes[i], x));
                    let (lo, hi) = boxes[a.class].get_or_insert((q, q));
                    *lo = std::array::from_fn(|i| lo[i].min(q[i]));
                    *hi = std::array::from_fn(|i| hi[i].max(q[i]));
                }
            }
        }
        for (lo, hi) in boxes.iter_mut().flatten() {
            *lo = lo.map(|v| v - half);
            *hi = hi.map(|v| v + half);
        }
        Some(ClassExtents {
            axes,
            boxes,
            half,
            margin: half * f64::from(domain.scale[0]),
        })
    }

    /// How far the boxes reach past each class's outermost contour points, world units.
    pub fn margin(&self) -> f64 {
        self.margin
    }

    /// How deep inside class `class`'s box the normalised point `x` lies: its distance to the
    /// box's nearest face (0 outside the box or for a class without one). Inside the class,
    /// the 3D distance to its surface is at most this (the segment to the nearest face leaves
    /// the box, so it leaves the class on the way), which bounds an in-plane target near the
    /// class's end planes: there the 2D distance (a BODY's 100 mm on its last plane) is far
    /// more than the 3D one (half a spacing to its end).
    pub fn depth(&self, x: [f32; 4], class: usize) -> f32 {
        let Some(Some(b)) = self.boxes.get(class) else {
            return 0.0;
        };
        (-box_distance(b, self.to_frame(x))).max(0.0) as f32
    }

    /// A point near class `class`'s box, in normalised (x, y, z), and its lower bound (the
    /// box's signed distance there, `box_distance`), or `None` for a class without a box:
    /// half the time at one of the two end faces (the caps, across the planes), else at one of
    /// the four side faces drawn by area; a point uniform on the face, moved along its normal
    /// by a distance uniform from two plane spacings inside to the cap reach outside (half the
    /// box's longest side, at least two plane spacings). Uniform space-time samples rarely fall
    /// there (a lung's cap region is 0.1 % of the domain), yet that is where a surface runs on
    /// past its end planes; beside the sides, the planes themselves say where the class is not.
    pub fn cap_sample(&self, rng: &mut SampleRng, class: usize) -> Option<([f32; 3], f32)> {
        let (lo, hi) = self.boxes.get(class)?.as_ref()?;
        let side: [f64; 3] = std::array::from_fn(|i| hi[i] - lo[i]);
        // Axis 2 is the planes' normal; the side pairs by area (side[1]·side[2] normal to
        // axis 0, side[0]·side[2] to axis 1).
        let axis = if rng.uniform() < 0.5 {
            2
        } else if rng.uniform() * (side[0] + side[1]) < side[1] {
            0
        } else {
            1
        };
        let reach = (CAP_REACH * side.iter().copied().fold(0.0, f64::max)).max(4.0 * self.half);
        // From two spacings inside the face (where an end plane's interior is at most half a
        // spacing deep) to the reach outside it.
        let d = rng.range(-4.0 * self.half, reach);
        let beyond = rng.uniform() < 0.5;
        let q: [f64; 3] = std::array::from_fn(|i| {
            if i != axis {
                rng.range(lo[i], hi[i])
            } else if beyond {
                hi[i] + d
            } else {
                lo[i] - d
            }
        });
        // Back from the frame's axes to x, y, z (the axes are orthonormal: the transpose).
        let x = std::array::from_fn(|j| (0..3).map(|i| self.axes[i][j] * q[i]).sum::<f64>() as f32);
        Some((x, box_distance(&(*lo, *hi), q) as f32))
    }

    /// The normalised point's coordinates along the frame's axes.
    fn to_frame(&self, x: [f32; 4]) -> [f64; 3] {
        let p = [x[0], x[1], x[2]].map(f64::from);
        std::array::from_fn(|i| dot(self.axes[i], p))
    }

    /// Fills `out` (cleared first) with the lower bound of every class at every point of `x`
    /// (normalised), point-major (`out[i·K + k]`): the signed distance of class k's box
    /// (`box_distance`; −∞ for a class without one).
    pub fn lower_bounds(&self, x: &[[f32; 4]], out: &mut Vec<f32>) {
        out.clear();
        for p in x {
            let q = self.to_frame(*p);
            out.extend(self.boxes.iter().map(|b| match b {
                None => f32::NEG_INFINITY,
                Some(b) => box_distance(b, q) as f32,
            }));
        }
    }
}

/// The signed distance of the box `(lo, hi)` at `q` (frame coordinates): the distance to it
/// outside, minus the distance to its nearest face inside. A class inside the box has a
/// signed distance at least this everywhere (outside the box the class is at least as far;
/// inside, the segment to the nearest face leaves the class on the way), so it is a lower
/// bound of the class's f: beyond its end planes it is outside, and on an end plane it is no
/// deeper than the half spacing to its end, whatever the in-plane distance (a BODY's 100 mm).
fn box_distance((lo, hi): &([f64; 3], [f64; 3]), q: [f64; 3]) -> f64 {
    let out: [f64; 3] = std::array::from_fn(|i| (lo[i] - q[i]).max(q[i] - hi[i]));
    let outside = out.iter().map(|d| d.max(0.0).powi(2)).sum::<f64>().sqrt();
    let inside = out
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max)
        .min(0.0);
    outside + inside
}

/// Orthonormal axes (u', v', n): `u` made orthogonal to the unit `n`, then n × u'.
fn orthonormal_frame(u: [f64; 3], n: [f64; 3]) -> [[f64; 3]; 3] {
    let along = dot(u, n);
    let u = [
        u[0] - along * n[0],
        u[1] - along * n[1],
        u[2] - along * n[2],
    ];
    let len = dot(u, u).sqrt();
    let u = u.map(|c| c / len);
    let v = [
        n[1] * u[2] - n[2] * u[1],
        n[2] * u[0] - n[0] * u[2],
        n[0] * u[1] - n[1] * u[0],
    ];
    [u, v, n]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data_sampler::domain_for;
    use crate::spatial_bound::tests::benchmark;

    /// The bound is the signed distance of the class's box, which ends half a spacing past its
    /// last plane: on that plane half a spacing deep, past it the distance; mixed planes give
    /// none.
    #[test]
    fn the_bound_is_the_signed_distance_of_the_grown_box() {
        let seq = benchmark((0, 4));
        let domain = domain_for(&seq);
        let (normal, spacing) = parallel_spacing(&seq, &domain).unwrap();
        let extents = ClassExtents::of(&seq, &domain).unwrap();
        assert!((extents.margin() - 0.5 * spacing * f64::from(domain.scale[0])).abs() < 1e-9);
        // A contour point of the class on its outermost plane along n.
        let outermost = seq
            .frames()
            .iter()
            .flat_map(|f| &f.planes)
            .filter(|p| p.annotations.iter().any(|a| !a.polygons.is_empty()))
            .max_by(|a, b| dot(a.origin, normal).total_cmp(&dot(b.origin, normal)))
            .unwrap();
        let a = outermost
            .annotations
            .iter()
            .find(|a| !a.polygons.is_empty())
            .unwrap();
        let w = outermost.to_world(a.polygons[0][0]).map(|v| v as f32);
        let on = domain.normalise(w, domain.time_origin);
        let k = seq.classes().len();
        let at = |steps: f64| {
            let mut p = on;
            for i in 0..3 {
                p[i] += (steps * spacing * normal[i]) as f32;
            }
            let mut out = Vec::new();
            extents.lower_bounds(&[p], &mut out);
            assert_eq!(out.len(), k);
            out[a.class]
        };
        let near = |got: f32, want: f64| (f64::from(got) - want).abs() < 1e-5;
        assert!(
            near(at(0.0), -0.5 * spacing),
            "on the plane: half a spacing deep"
        );
        assert!(near(at(0.4), -0.1 * spacing), "within the slab");
        let past = at(2.0);
        assert!(
            (f64::from(past) - 1.5 * spacing).abs() < 1e-5,
            "{past} against {}",
            1.5 * spacing
        );
        let mixed = benchmark((1, 4));
        assert_eq!(ClassExtents::of(&mixed, &domain_for(&mixed)), None);
    }
}
