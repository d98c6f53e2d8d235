//! The affine map between world units (millimetres, seconds) and the network's normalised domain.
//!
//! The network is trained on x_n = (x − c) / s ∈ [−1, 1]³ and t_n = (t − t₀) / τ ∈ [0, 1] (the
//! paper normalises time to [0, 1], which is what makes ω_t^max ∝ π/Δt meaningful, Eq. 4), and
//! predicts distances in normalised units. Queries and answers are in world units:
//! f_world = σ f_n, ∇ₓf_world = σ ∇ₓₙ f_n ⊘ s, ∂f/∂t_world = σ ∂f_n/∂t_n / τ.
//! With an isotropic s (what the trainer writes) and σ = s, ‖∇ₓf‖ ≈ 1 in world units.

use crate::Error;

/// Largest normalised coordinate or time the network is evaluated at (2²⁰): see
/// [`Domain::normalise`].
pub const NORMALISED_LIMIT: f32 = 1_048_576.0;

/// World ↔ normalised coordinates of one model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Domain {
    /// World point mapped to the origin of the normalised cube.
    pub center: [f32; 3],
    /// World half-extent per axis mapped to 1.
    pub scale: [f32; 3],
    /// World time mapped to t_n = 0.
    pub time_origin: f32,
    /// World duration mapped to 1 (t₁ − t₀).
    pub time_span: f32,
    /// Factor from normalised distances to world distances (σ).
    pub output_scale: f32,
}

impl Domain {
    /// The identity map: world = normalised.
    pub const IDENTITY: Domain = Domain {
        center: [0.0; 3],
        scale: [1.0; 3],
        time_origin: 0.0,
        time_span: 1.0,
        output_scale: 1.0,
    };

    /// Checks that every field is finite and every scale positive (and not so small or large
    /// that its reciprocal overflows).
    pub fn validate(&self) -> Result<(), Error> {
        let positive = |v: f32| v.is_finite() && v > 1e-30 && v < 1e30;
        if !self.center.iter().all(|v| v.is_finite()) {
            return Err(Error::BadHeaderValue("domain centre is not finite"));
        }
        if !self.scale.iter().all(|&v| positive(v)) {
            return Err(Error::BadHeaderValue(
                "domain scale is not a positive finite number",
            ));
        }
        if !self.time_origin.is_finite() {
            return Err(Error::BadHeaderValue("time origin is not finite"));
        }
        if !positive(self.time_span) {
            return Err(Error::BadHeaderValue(
                "time span is not a positive finite number",
            ));
        }
        if !positive(self.output_scale) {
            return Err(Error::BadHeaderValue(
                "output scale is not a positive finite number",
            ));
        }
        Ok(())
    }

    /// World point and time to normalised (x_n, y_n, z_n, t_n), each clamped to
    /// ±[`NORMALISED_LIMIT`]; NaN or ±∞ inputs give NaN.
    ///
    /// The clamp keeps the network's first layer finite for every finite query: (x − c)/s
    /// overflows to ±∞ near f32::MAX when s < 1, and ∞ − ∞ in a layer's sum is NaN. Beyond
    /// the limit (2²⁰ half-extents, 1 km for a 1 mm domain) a query gets the answer at the
    /// clamped point.
    #[inline]
    pub fn normalise(&self, x: [f32; 3], t: f32) -> [f32; 4] {
        let map = |v: f32, origin: f32, scale: f32| {
            if v.is_finite() {
                ((v - origin) / scale).clamp(-NORMALISED_LIMIT, NORMALISED_LIMIT)
            } else {
                f32::NAN
            }
        };
        [
            map(x[0], self.center[0], self.scale[0]),
            map(x[1], self.center[1], self.scale[1]),
            map(x[2], self.center[2], self.scale[2]),
            map(t, self.time_origin, self.time_span),
        ]
    }

    /// Factors turning derivatives of the normalised network into world derivatives, for the
    /// inputs x, y, z, t: σ/s_x, σ/s_y, σ/s_z, σ/τ.
    #[inline]
    pub fn derivative_factors(&self) -> [f32; 4] {
        let s = self.output_scale;
        [
            s / self.scale[0],
            s / self.scale[1],
            s / self.scale[2],
            s / self.time_span,
        ]
    }

    /// World bounding box (min, max) of the normalised cube [−1, 1]³.
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let lo = core::array::from_fn(|i| self.center[i] - self.scale[i]);
        let hi = core::array::from_fn(|i| self.center[i] + self.scale[i]);
        (lo, hi)
    }

    /// World time range (t₀, t₁) of the normalised [0, 1].
    pub fn time_range(&self) -> (f32, f32) {
        (self.time_origin, self.time_origin + self.time_span)
    }

    /// The one rule for a requested time, which every front end applies (the command line,
    /// Python, the C ABI): `t` must lie in [`Domain::time_range`], to a rounding slack of 10⁻⁴
    /// of the range. Outside it the network was never fitted and extrapolates freely, so a
    /// time there is refused, never evaluated silently. NaN is outside.
    pub fn contains_time(&self, t: f32) -> bool {
        let (t0, t1) = self.time_range();
        let slack = 1e-4 * libm::fabsf(t1 - t0).max(1e-6);
        t >= t0 - slack && t <= t1 + slack
    }
}
