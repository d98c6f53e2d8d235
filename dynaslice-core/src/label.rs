//! The non-overlapping label map of Eq. 11.

/// Label reported when any channel is NaN (a NaN or infinite query): no class can be chosen.
pub const UNDEFINED_LABEL: u32 = u32::MAX;

/// ℓ = argmin over {0, 1, …, K} of (0, f¹, …, f^K) (Eq. 11): the background is a constant-0
/// channel, so a point belongs to class k exactly when f^k is negative and the smallest.
///
/// Ties go to the lowest index: a point where f^k = 0 is background, and where f^j = f^k < 0 it
/// is class min(j, k). This makes the partition deterministic and independent of evaluation
/// order. Any NaN channel gives [`UNDEFINED_LABEL`].
#[inline]
pub fn argmin_label(f: &[f32]) -> u32 {
    let mut best = 0u32;
    let mut best_value = 0.0f32;
    for (k, &v) in f.iter().enumerate() {
        if v.is_nan() {
            return UNDEFINED_LABEL;
        }
        if v < best_value {
            best = k as u32 + 1;
            best_value = v;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn background_ties_and_nan() {
        assert_eq!(argmin_label(&[0.5, 0.1]), 0);
        assert_eq!(argmin_label(&[0.0, 0.0]), 0);
        assert_eq!(argmin_label(&[-0.1, -0.3, -0.3]), 2);
        assert_eq!(argmin_label(&[-0.1, f32::NAN]), UNDEFINED_LABEL);
        assert_eq!(argmin_label(&[]), 0);
    }
}
