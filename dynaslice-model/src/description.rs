//! What `dynaslice info` says of a model, line by line, so every front end describes a model
//! in the same words and figures.

use dynaslice_core::{Model, Weights};

/// The description of `model`, whose file has `size` bytes: its size and weights, sine layer
/// widths, a motion model's motion network (its sine layer widths and own ω_t^max), classes,
/// cost per point (both networks'), world bounds, its time range and ω_t^max (normalised time)
/// or that it is static, each class with its source label, and its metadata lines. A model
/// without motion is described in the same lines as before motion models existed.
pub fn describe(model: &Model, size: usize) -> Vec<String> {
    let layout = model.layout();
    let d = model.domain();
    let (lo, hi) = d.bounds();
    let (t0, t1) = d.time_range();
    let dtype = match model.weights() {
        Weights::F32(_) => "f32",
        Weights::F16(_) => "f16",
    };
    let motion = model.motion();
    let weights = match &motion {
        Some(m) => format!(
            "{} shape + {} motion weights",
            layout.param_count(),
            m.layout().param_count()
        ),
        None => format!("{} weights", layout.param_count()),
    };
    let mut lines = vec![
        format!("size         {size} bytes ({weights}, {dtype})"),
        format!("sine layers  {:?}", layout.widths()),
    ];
    if let Some(m) = &motion {
        lines.push(format!(
            "motion       sine layers {:?}, ω_t^max {} (normalised time): f = g(x + u(x, t), t)",
            m.layout().widths(),
            m.omega_t_max()
        ));
    }
    let macs = layout.macs_per_point() + motion.map_or(0, |m| m.layout().macs_per_point());
    lines.extend([
        format!("classes      {}", layout.num_classes()),
        format!("cost         {macs} multiply-adds per point for f (x4 with ∇ₓf)"),
        format!(
            "bounds       [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        ),
    ]);
    // A static model (ModelFile::is_static): ω_t^max = 0 (the motion network's too), no time
    // axis.
    if model.is_static() {
        lines.push(format!(
            "time         none: a static model (trained on one timestep, ω_t^max = 0), the same \
             at every time; its outputs are one frame, at t = {t0}"
        ));
    } else {
        lines.push(format!("time range   {t0} .. {t1}"));
        lines.push(format!(
            "ω_t^max      {} (normalised time)",
            model.omega_t_max()
        ));
    }
    for (k, class) in model.classes().enumerate() {
        lines.push(format!(
            "class {:<6} {:?} (source label {})",
            k + 1,
            class.name,
            class.label
        ));
    }
    if !model.metadata().is_empty() {
        lines.push("metadata".into());
        lines.extend(model.metadata().lines().map(|line| format!("  {line}")));
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::describe;
    use dynaslice_core::format::ModelWriter;
    use dynaslice_core::ModelBytes;

    fn lines(w: &ModelWriter) -> Vec<String> {
        let bytes = ModelBytes::copy_from(&w.to_bytes());
        describe(&bytes.model().unwrap(), bytes.len())
    }

    /// A model without motion keeps its lines; a motion model adds its motion network's widths
    /// and ω_t^max and counts both networks' weights and cost.
    #[test]
    fn motion_models_show_their_motion_network() {
        let still = ModelWriter::random_siren(&[16, 8], 2, 1);
        let moving = ModelWriter::random_motion(&[16, 8], 2, &[12, 6], 1);
        let (a, b) = (lines(&still), lines(&moving));
        assert!(a[0].ends_with("(234 weights, f32)"), "{}", a[0]);
        assert!(!a.iter().any(|l| l.starts_with("motion")), "{a:?}");
        assert!(
            b[0].ends_with("(234 shape + 159 motion weights, f32)"),
            "{}",
            b[0]
        );
        assert_eq!(
            b[2],
            "motion       sine layers [12, 6], ω_t^max 12.566371 (normalised time): \
             f = g(x + u(x, t), t)"
        );
        // Cost: 4·16 + 16·8 + 8·2 = 208, plus the motion network's 4·12 + 12·6 + 6·3 = 138.
        assert!(a.contains(&"cost         208 multiply-adds per point for f (x4 with ∇ₓf)".into()));
        assert!(b.contains(&"cost         346 multiply-adds per point for f (x4 with ∇ₓf)".into()));
    }

    /// A motion model whose shape network has ω_t^max = 0 still moves when its motion network
    /// does not: it is static only when both bounds are 0.
    #[test]
    fn a_motion_model_is_static_only_when_both_networks_are() {
        let mut w = ModelWriter::random_motion(&[8], 1, &[8], 2);
        w.omega_t_max = 0.0;
        assert!(lines(&w).iter().any(|l| l.starts_with("time range")));
        if let Some(m) = &mut w.motion {
            m.omega_t_max = 0.0;
        }
        assert!(lines(&w).iter().any(|l| l.starts_with("time         none")));
    }
}
