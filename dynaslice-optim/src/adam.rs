//! Adam (Kingma & Ba 2015), the paper's optimiser, with its state kept for checkpoints.

/// Adam hyper-parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamConfig {
    /// β₁.
    pub beta1: f32,
    /// β₂.
    pub beta2: f32,
    /// ε.
    pub eps: f32,
}

impl Default for AdamConfig {
    fn default() -> Self {
        AdamConfig {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
        }
    }
}

/// First and second moment estimates and the step count.
#[derive(Clone, Debug, PartialEq)]
pub struct Adam {
    /// Hyper-parameters.
    pub config: AdamConfig,
    /// m.
    pub m: Vec<f32>,
    /// v.
    pub v: Vec<f32>,
    /// Steps taken.
    pub t: u64,
}

impl Adam {
    /// Zero state for `n` parameters.
    pub fn new(n: usize, config: AdamConfig) -> Adam {
        Adam {
            config,
            m: vec![0.0; n],
            v: vec![0.0; n],
            t: 0,
        }
    }

    /// One step with learning rate `lr`: θ ← θ − lr·m̂/(√v̂ + ε).
    pub fn step(&mut self, params: &mut [f32], grad: &[f32], lr: f32) {
        let AdamConfig { beta1, beta2, eps } = self.config;
        self.t += 1;
        let bc1 = 1.0 - beta1.powi(self.t.min(i32::MAX as u64) as i32);
        let bc2 = 1.0 - beta2.powi(self.t.min(i32::MAX as u64) as i32);
        let step = lr / bc1;
        let bc2_sqrt = bc2.sqrt();
        for (((p, g), m), v) in params
            .iter_mut()
            .zip(grad)
            .zip(&mut self.m)
            .zip(&mut self.v)
        {
            *m = beta1 * *m + (1.0 - beta1) * g;
            *v = beta2 * *v + (1.0 - beta2) * g * g;
            *p -= step * *m / (v.sqrt() / bc2_sqrt + eps);
        }
    }
}
