//! [`SamplingIndex`]: everything the samplers need, precomputed once per sequence.

use rayon::prelude::*;

use dynaslice_geometry::boolean::region_area;
use dynaslice_geometry::PolygonSdf;
use dynaslice_sequence::{Plane, Sequence};

/// How many times at most [`SamplingIndex::with_progress`] reports progress.
const PROGRESS_STEPS: usize = 50;

/// One (plane, class) annotation with its distance structure.
#[derive(Debug)]
pub(crate) struct AnnotationEntry {
    /// Index into `SamplingIndex::planes`.
    pub plane: usize,
    pub class: u32,
    /// `None` when the class is absent from the plane.
    pub sdf: Option<PolygonSdf>,
}

/// A plane with its timestep's time.
#[derive(Debug)]
pub(crate) struct PlaneEntry {
    pub plane: Plane,
    pub time: f64,
}

/// Per class: annotation indices, split into contoured and absent, the contoured ones'
/// cumulative perimeters (for drawing contour points uniformly by arc length), and the class's
/// width.
#[derive(Debug, Default)]
pub(crate) struct ClassEntry {
    pub contoured: Vec<usize>,
    pub absent: Vec<usize>,
    pub cum_perimeter: Vec<f64>,
    /// The median over its contoured annotations of 2·area/perimeter (world units): a disc's
    /// radius, a strip's or a ring's width. Near-contour samples spread no wider than a
    /// fraction of it, so a small or thin structure's samples fall on it, not around it.
    pub width: f64,
    /// Neighbouring planes of one frame that both outline the class (annotation indices, the
    /// first below the second along the planes' normal), where the planes are parallel
    /// ([`SamplingIndex::with_neighbour_pairs`]).
    pub between: Vec<(usize, usize)>,
}

/// Precomputed sampling structures for a [`Sequence`]: a [`PolygonSdf`] for every contoured
/// (plane, class) annotation, built in parallel, and per-class tables. Build it once; every
/// sampler call afterwards only reads it.
#[derive(Debug)]
pub struct SamplingIndex {
    pub(crate) planes: Vec<PlaneEntry>,
    pub(crate) annotations: Vec<AnnotationEntry>,
    pub(crate) classes: Vec<ClassEntry>,
}

impl SamplingIndex {
    /// Builds the index (cost: one grid per contoured annotation; parallel over annotations).
    pub fn new(seq: &Sequence) -> Self {
        Self::with_progress(seq, &mut |_, _| {})
    }

    /// [`SamplingIndex::new`], calling `progress(done, total)` as the annotations' exact
    /// distances are built (the part that takes seconds on large inputs), from this thread.
    pub fn with_progress(seq: &Sequence, progress: &mut dyn FnMut(usize, usize)) -> Self {
        let planes: Vec<PlaneEntry> = seq
            .frames()
            .iter()
            .flat_map(|f| {
                f.planes.iter().map(move |p| PlaneEntry {
                    plane: p.clone(),
                    time: f.time,
                })
            })
            .collect();
        let jobs: Vec<(usize, usize)> = planes
            .iter()
            .enumerate()
            .flat_map(|(pi, p)| (0..p.plane.annotations.len()).map(move |ai| (pi, ai)))
            .collect();
        // In parallel chunks, so that progress is told from this thread between them.
        let chunk = jobs
            .len()
            .div_ceil(PROGRESS_STEPS)
            .max(4 * rayon::current_num_threads());
        let mut annotations: Vec<AnnotationEntry> = Vec::with_capacity(jobs.len());
        for part in jobs.chunks(chunk) {
            annotations.par_extend(part.par_iter().map(|&(pi, ai)| {
                let plane = &planes[pi].plane;
                let a = &plane.annotations[ai];
                AnnotationEntry {
                    plane: pi,
                    class: a.class as u32,
                    sdf: PolygonSdf::new(&a.polygons, Some((plane.roi.min, plane.roi.max))),
                }
            }));
            progress(annotations.len(), jobs.len());
        }
        let mut classes: Vec<ClassEntry> = (0..seq.classes().len())
            .map(|_| ClassEntry::default())
            .collect();
        let mut widths: Vec<Vec<f64>> = vec![Vec::new(); classes.len()];
        for (i, a) in annotations.iter().enumerate() {
            let c = &mut classes[a.class as usize];
            match &a.sdf {
                Some(sdf) => {
                    let acc = c.cum_perimeter.last().copied().unwrap_or(0.0) + sdf.perimeter();
                    c.contoured.push(i);
                    c.cum_perimeter.push(acc);
                    let (pi, ai) = jobs[i];
                    let area = region_area(&planes[pi].plane.annotations[ai].polygons).abs();
                    widths[a.class as usize]
                        .push(2.0 * area / sdf.perimeter().max(f64::MIN_POSITIVE));
                }
                None => c.absent.push(i),
            }
        }
        for (c, mut w) in classes.iter_mut().zip(widths) {
            w.sort_by(f64::total_cmp);
            c.width = w.get(w.len() / 2).copied().unwrap_or(0.0);
        }
        SamplingIndex {
            planes,
            annotations,
            classes,
        }
    }

    /// Each class's total contour length over all planes and timesteps (world units; 0 for a
    /// class never outlined), which sets its share of a shared sample budget.
    pub fn contour_lengths(&self) -> Vec<f64> {
        self.classes
            .iter()
            .map(|c| c.cum_perimeter.last().copied().unwrap_or(0.0))
            .collect()
    }

    /// The exact in-plane signed distance of class `class` at plane coordinates `p` on plane
    /// `plane` (planes numbered in sequence order, timestep by timestep), or `None` if that
    /// plane does not outline the class.
    pub fn plane_sdf(&self, plane: usize, class: usize, p: [f64; 2]) -> Option<f64> {
        self.annotations
            .iter()
            .find(|a| a.plane == plane && a.class as usize == class)
            .and_then(|a| a.sdf.as_ref())
            .map(|s| s.distance(p))
    }
}
