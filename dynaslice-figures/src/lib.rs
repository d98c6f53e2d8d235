//! DynaSlice's figures: PNG line charts with a bundled font ([`plot`]), a model's labels with
//! the input contours on an input plane ([`picture`], axial and coronal planes in the
//! radiological or neurological convention, [`display`]), and shaded 3D surfaces drawn by a
//! software rasteriser ([`render3d`]). One colour per class in all of them ([`color`]).
//!
//! Every figure is drawn into memory and written atomically (temporary file, fsync, rename).

#![warn(missing_docs)]

pub mod color;
pub mod display;
mod legend;
pub mod picture;
pub mod plot;
pub mod render3d;

pub use color::class_color;

use anyhow::{anyhow, ensure, Result};
use std::path::Path;

/// The most pixels a figure may have (about 200 MB of RGB): larger requests are refused
/// before anything is allocated.
pub const MAX_PIXELS: u64 = 64 << 20;

/// A white RGB buffer of `width` × `height` pixels, after checking the size against
/// [`MAX_PIXELS`].
pub(crate) fn canvas(path: &Path, width: u32, height: u32) -> Result<Vec<u8>> {
    let pixels = u64::from(width) * u64::from(height);
    ensure!(
        width > 0 && height > 0 && pixels <= MAX_PIXELS,
        "cannot draw {}: a {width}×{height} picture is outside 1..={MAX_PIXELS} pixels",
        path.display()
    );
    Ok(vec![255; pixels as usize * 3])
}

/// Encodes an RGB buffer as PNG and writes it to `path` atomically.
pub(crate) fn save_png(path: &Path, rgb: &[u8], width: u32, height: u32) -> Result<()> {
    use image::ImageEncoder;
    let mut bytes = Vec::new();
    image::codecs::png::PngEncoder::new(&mut bytes)
        .write_image(rgb, width, height, image::ColorType::Rgb8)
        .map_err(|e| anyhow!("cannot encode {}: {e}", path.display()))?;
    dynaslice_output::write_atomically(path, &bytes)
}
