//! The shape of the network (paper Eq. 1, 9) and where each parameter lives.
//!
//! f_θ = L ∘ S^d ∘ … ∘ S^0 with S^i(y) = sin(W^i y + b^i): `num_sine_layers() = d + 1` sine layers
//! (the first one reads (x, y, z, t), Eq. 2) and an affine output layer L with K channels.
//!
//! Parameters are stored layer after layer; each layer is its transposed weight matrix Wᵀ
//! (`fan_in` rows of `fan_out` values, row-major) followed by its bias (`fan_out` values). For the
//! first layer the four rows of Wᵀ are ω_x (three rows: x, y, z) and ω_t (the fourth row), so the
//! temporal frequencies of Eq. 2 are one contiguous row that evaluation clamps (Eq. 4).
//! Storing Wᵀ makes one layer over a batch a plain row-major matrix product H·Wᵀ.

use crate::Error;

/// Most sine layers (the first layer and up to 7 hidden layers).
pub const MAX_SINE_LAYERS: usize = 8;
/// Widest sine layer.
pub const MAX_WIDTH: usize = 512;
/// Most classes (output channels).
pub const MAX_CLASSES: usize = 64;

/// Inputs of the first layer: x, y, z, t.
pub const INPUT_DIM: usize = 4;

/// Validated network dimensions.
///
/// Invariant relied on by evaluation: `1 <= num_classes <= MAX_CLASSES`,
/// `1 <= num_sine_layers <= MAX_SINE_LAYERS` and every used width is in `1..=MAX_WIDTH`, so every
/// offset below fits comfortably in `usize` even on 32-bit targets (< 2^22 scalars).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    num_classes: usize,
    num_sine_layers: usize,
    widths: [usize; MAX_SINE_LAYERS],
}

impl Layout {
    /// Checks and builds a layout from the sine layers' widths and the class count K.
    pub fn new(widths: &[u32], num_classes: u32) -> Result<Layout, Error> {
        let dim = |what, value: u64, max: usize| {
            if value == 0 || value > max as u64 {
                Err(Error::BadDimension {
                    what,
                    value,
                    max: max as u64,
                })
            } else {
                Ok(value as usize)
            }
        };
        let num_sine_layers = dim("sine layer count", widths.len() as u64, MAX_SINE_LAYERS)?;
        let num_classes = dim("class count", num_classes as u64, MAX_CLASSES)?;
        let mut w = [0usize; MAX_SINE_LAYERS];
        for (slot, &width) in w.iter_mut().zip(widths) {
            *slot = dim("layer width", width as u64, MAX_WIDTH)?;
        }
        Ok(Layout {
            num_classes,
            num_sine_layers,
            widths: w,
        })
    }

    /// K, the number of output channels (classes).
    pub fn num_classes(&self) -> usize {
        self.num_classes
    }

    /// d + 1, the number of sine layers (the first one included).
    pub fn num_sine_layers(&self) -> usize {
        self.num_sine_layers
    }

    /// Widths of the sine layers.
    pub fn widths(&self) -> &[usize] {
        &self.widths[..self.num_sine_layers]
    }

    /// Number of layers with parameters: the sine layers and the output layer.
    pub fn num_layers(&self) -> usize {
        self.num_sine_layers + 1
    }

    /// (fan_in, fan_out) of layer `l` (`0..num_layers()`; the last one is the output layer).
    pub fn layer_dims(&self, l: usize) -> (usize, usize) {
        let fan_in = if l == 0 {
            INPUT_DIM
        } else {
            self.widths[l - 1]
        };
        let fan_out = if l >= self.num_sine_layers {
            self.num_classes
        } else {
            self.widths[l]
        };
        (fan_in, fan_out)
    }

    /// Offset (in scalars) of layer `l`'s Wᵀ; its bias follows at `+ fan_in * fan_out`.
    pub fn layer_offset(&self, l: usize) -> usize {
        (0..l)
            .map(|i| {
                let (a, b) = self.layer_dims(i);
                (a + 1) * b
            })
            .sum()
    }

    /// Total number of parameters (scalars in the weight section).
    pub fn param_count(&self) -> usize {
        self.layer_offset(self.num_layers())
    }

    /// Multiply-adds for one point's value f (all K channels): Σ fan_in·fan_out over the layers.
    /// The gradient ∇ₓf costs 4x this in matrix products (primal + 3 tangents), f with ∇ₓf and
    /// ∂f/∂t 5x; sines add one sin/cos per hidden unit.
    pub fn macs_per_point(&self) -> usize {
        (0..self.num_layers())
            .map(|l| {
                let (a, b) = self.layer_dims(l);
                a * b
            })
            .sum()
    }

    /// The widest layer (sets the scratch each row needs).
    pub fn max_width(&self) -> usize {
        self.widths()
            .iter()
            .copied()
            .max()
            .unwrap_or(0)
            .max(self.num_classes)
    }
}
