//! The lattice surfaces are extracted on: cubic cells of side h covering the model's world box.
//!
//! Lattice vertices are addressed by integer indices `v = [i, j, k]` with `0 <= v[a] <= cells[a]`
//! and packed into one `u64` key (20 bits per axis), which is what the sparse sample store and
//! the polygoniser hash.

use anyhow::{ensure, Result};

/// Bits per axis in a packed vertex key.
const KEY_BITS: u32 = 20;

/// Largest resolution accepted: far beyond what fits in memory, and it keeps every vertex index
/// within `KEY_BITS` bits and an edge key (vertex key · 8 + direction) within 63 bits.
pub const MAX_RESOLUTION: u32 = 1 << 16;
/// Smallest resolution accepted: one cell along the longest axis has no inside vertex, so no
/// surface.
pub const MIN_RESOLUTION: u32 = 2;
/// The resolution every front end meshes and measures at unless told otherwise: cells of
/// under 1 % of the longest side, a few seconds per class on a 2-core machine.
pub const DEFAULT_RESOLUTION: u32 = 128;

/// A lattice of cubic cells in world coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    /// World position of vertex [0, 0, 0].
    pub origin: [f64; 3],
    /// Cell side in world units.
    pub h: f64,
    /// Number of cells along each axis (vertices run from 0 to `cells[a]` inclusive).
    pub cells: [u32; 3],
}

impl Lattice {
    /// Cubic cells with `resolution` cells along the longest side of the box `lo..hi`; the other
    /// axes get the whole number of cells that covers them, centred on the box.
    pub fn covering(lo: [f32; 3], hi: [f32; 3], resolution: u32) -> Result<Lattice> {
        ensure!(
            (MIN_RESOLUTION..=MAX_RESOLUTION).contains(&resolution),
            "resolution {resolution} is outside {MIN_RESOLUTION}..={MAX_RESOLUTION}"
        );
        let extent: [f64; 3] = std::array::from_fn(|a| hi[a] as f64 - lo[a] as f64);
        ensure!(
            extent.iter().all(|e| e.is_finite() && *e > 0.0),
            "the box {lo:?}..{hi:?} is empty or not finite"
        );
        let longest = extent.iter().copied().fold(0.0, f64::max);
        let h = longest / resolution as f64;
        // The 1e-9 keeps an axis that is an exact multiple of h from gaining a cell to rounding.
        let cells = extent.map(|e| ((e / h - 1e-9).ceil() as u32).clamp(1, resolution));
        let origin = std::array::from_fn(|a| {
            (lo[a] as f64 + hi[a] as f64) / 2.0 - cells[a] as f64 * h / 2.0
        });
        Ok(Lattice { origin, h, cells })
    }

    /// Number of lattice vertices: what a dense evaluation of this lattice costs.
    pub fn vertex_count(&self) -> u64 {
        self.cells.iter().map(|&c| c as u64 + 1).product()
    }

    /// World position of lattice vertex `v`.
    #[inline]
    pub fn point(&self, v: [u32; 3]) -> [f32; 3] {
        std::array::from_fn(|a| (self.origin[a] + v[a] as f64 * self.h) as f32)
    }

    /// World box that the extracted surfaces are clipped to: the lattice inset by half a cell, so
    /// the outermost lattice vertices are always strictly outside and every surface closes.
    pub fn clip_box(&self) -> ([f32; 3], [f32; 3]) {
        let lo = std::array::from_fn(|a| (self.origin[a] + self.h / 2.0) as f32);
        let hi = std::array::from_fn(|a| {
            (self.origin[a] + (self.cells[a] as f64 - 0.5) * self.h) as f32
        });
        (lo, hi)
    }

    /// True when `v` is a vertex of this lattice.
    #[inline]
    pub fn contains(&self, v: [u32; 3]) -> bool {
        (0..3).all(|a| v[a] <= self.cells[a])
    }
}

/// Packs a lattice vertex into a key (see the module documentation).
#[inline]
pub fn key(v: [u32; 3]) -> u64 {
    (v[0] as u64) | (v[1] as u64) << KEY_BITS | (v[2] as u64) << (2 * KEY_BITS)
}

/// The lattice vertex of a key made by [`key`].
#[inline]
pub fn unkey(k: u64) -> [u32; 3] {
    let mask = (1u64 << KEY_BITS) - 1;
    [
        (k & mask) as u32,
        (k >> KEY_BITS & mask) as u32,
        (k >> (2 * KEY_BITS) & mask) as u32,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn covers_the_box_with_cubic_cells_centred() {
        let g = Lattice::covering([-2.0, -1.0, 0.0], [2.0, 1.0, 0.5], 8).unwrap();
        assert_eq!(g.h, 0.5);
        assert_eq!(g.cells, [8, 4, 1]);
        assert_eq!(g.point([0, 0, 0]), [-2.0, -1.0, 0.0]);
        assert_eq!(g.point([8, 4, 1]), [2.0, 1.0, 0.5]);
        assert_eq!(g.vertex_count(), 9 * 5 * 2);
        // An axis that is not a whole number of cells is rounded up and centred.
        let g = Lattice::covering([0.0; 3], [1.0, 0.3, 1.0], 4).unwrap();
        assert_eq!(g.cells, [4, 2, 4]);
        assert!((g.origin[1] - (0.15 - 0.25)).abs() < 1e-7);
        let (lo, hi) = g.clip_box();
        assert_eq!((lo[0], hi[0]), (0.125, 0.875));
    }

    #[test]
    fn keys_round_trip_and_bad_lattices_are_refused() {
        for v in [[0, 0, 0], [1, 2, 3], [MAX_RESOLUTION; 3]] {
            assert_eq!(unkey(key(v)), v);
        }
        assert!(Lattice::covering([0.0; 3], [1.0; 3], 1).is_err());
        assert!(Lattice::covering([0.0; 3], [1.0, 0.0, 1.0], 8).is_err());
        assert!(Lattice::covering([0.0; 3], [f32::NAN; 3], 8).is_err());
    }
}
