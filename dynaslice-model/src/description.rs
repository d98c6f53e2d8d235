//! What `dynaslice info` says of a model, line by line, so every front end describes a model
//! in the same words and figures.

use dynaslice_core::{Model, Weights};

/// The description of `model`, whose file has `size` bytes: its size and weights, sine layer
/// widths, classes, cost per point, world bounds, its time range and ω_t^max (normalised time)
/// or that it is static, each class with its source label, and its metadata lines.
pub fn describe(model: &Model, size: usize) -> Vec<String> {
    let layout = model.layout();
    let d = model.domain();
    let (lo, hi) = d.bounds();
    let (t0, t1) = d.time_range();
    let dtype = match model.weights() {
        Weights::F32(_) => "f32",
        Weights::F16(_) => "f16",
    };
    let mut lines = vec![
        format!(
            "size         {size} bytes ({} weights, {dtype})",
            layout.param_count()
        ),
        format!("sine layers  {:?}", layout.widths()),
        format!("classes      {}", layout.num_classes()),
        format!(
            "cost         {} multiply-adds per point for f (x4 with ∇ₓf)",
            layout.macs_per_point()
        ),
        format!(
            "bounds       [{:.4}, {:.4}, {:.4}] .. [{:.4}, {:.4}, {:.4}]",
            lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]
        ),
    ];
    // A static model (ModelFile::is_static): ω_t^max = 0, no time axis.
    if model.omega_t_max() == 0.0 {
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
