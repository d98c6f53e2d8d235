//! The trainable network: the core's [`Layout`] with its parameters in an owned vector.
//!
//! Parameters use exactly the core's order (per layer Wᵀ then b; see `dynaslice_core::Layout`),
//! so exporting a model is a copy, and the trainer's f and ∇ₓf can be checked against the
//! core's evaluation of the exported file.

use crate::spatial_bound::{self, PlaneBand};
use crate::temporal_bound;
use dynaslice_core::format::{ModelWriter, MotionWriter, WeightType};
use dynaslice_core::{Domain, Layout};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// SIREN's ω₀ (Sitzmann et al. 2020), the paper's initialisation: used by the gradient checks
/// and the step benchmark. The trainer's default is ω₀ = 20 (`spec::DEFAULT_OMEGA_0`, measured in
/// lab/notes/2026-12-04-omega.md).
pub const OMEGA_0: f32 = 30.0;

/// Layout, parameters and the band limits of a network being trained.
#[derive(Clone, Debug, PartialEq)]
pub struct Network {
    /// Dimensions (validated by the core).
    pub layout: Layout,
    /// Parameters in the core's order.
    pub params: Vec<f32>,
    /// ω_t^max of Eq. 4 in normalised time; `f32::INFINITY` disables temporal control.
    pub omega_t_max: f32,
    /// The bound on ω_x across the data's parallel planes (`spatial_bound`), if they are.
    pub plane_band: Option<PlaneBand>,
    /// The motion network u of a motion model (`crate::warp`): f(x, t) = g(x + u(x, t), t), this
    /// network being g. `None`: f = g.
    pub motion: Option<Box<Network>>,
}

impl Network {
    /// SIREN initialisation (vsitzmann/siren, modules.py) with ω₀ (SIREN uses 30) folded into the weights,
    /// which is the same function: sin(ω₀(Wx + b)) = sin((ω₀W)x + ω₀b).
    /// - First layer: ω₀·U(−1/fan_in, 1/fan_in) for ω_x (fan_in = 4 inputs); ω_t from the same
    ///   range cut to ω_t^max, U(−min(ω₀/4, ω_t^max), …), so inside [−ω_t^max, ω_t^max] (Eq. 4);
    ///   without temporal control (ω_t^max = ∞) exactly like ω_x.
    /// - Hidden layers: ω₀·U(−√(6/fan_in)/ω₀, √(6/fan_in)/ω₀) = U(−√(6/fan_in), √(6/fan_in)).
    /// - Output layer: U(−√(6/fan_in)/ω₀, …) as SIREN's last linear layer, i.e. small outputs.
    /// - Biases: PyTorch's default U(−1/√fan_in, 1/√fan_in), times ω₀ for sine layers.
    /// - `offset` is added to every output bias, so every channel starts near f = +offset
    ///   (normalised units), i.e. outside. SIREN's small output layer starts f ≈ 0 everywhere,
    ///   and regions the data hardly reaches (the domain's corners, between frames) then drift to
    ///   either sign: a negative drift is a spurious structure that the losses near the data never
    ///   see. Starting outside makes "outside unless the data says otherwise" the default
    ///   (lab/notes/training.md measures it).
    pub fn siren(
        layout: Layout,
        omega_0: f32,
        offset: f32,
        omega_t_max: f32,
        seed: u64,
    ) -> Network {
        let mut rng = Pcg64Mcg::seed_from_u64(seed);
        let mut params = Vec::with_capacity(layout.param_count());
        for l in 0..layout.num_layers() {
            let (fan_in, fan_out) = layout.layer_dims(l);
            let is_output = l + 1 == layout.num_layers();
            let bound = if l == 0 {
                omega_0 / fan_in as f32
            } else if is_output {
                (6.0 / fan_in as f32).sqrt() / omega_0
            } else {
                (6.0 / fan_in as f32).sqrt()
            };
            for i in 0..fan_in {
                let b = if l == 0 && i == 3 {
                    temporal_bound::initial_limit(bound, omega_t_max)
                } else {
                    bound
                };
                params.extend((0..fan_out).map(|_| rng.random_range(-b..=b)));
            }
            let bias_scale = if is_output { 1.0 } else { omega_0 };
            let bb = bias_scale / (fan_in as f32).sqrt();
            let shift = if is_output { offset } else { 0.0 };
            params.extend((0..fan_out).map(|_| shift + rng.random_range(-bb..=bb)));
        }
        let mut net = Network {
            layout,
            params,
            omega_t_max,
            plane_band: None,
            motion: None,
        };
        net.project_band_limits();
        net
    }

    /// A motion network u: (x, t) → R³ in the normalised frame, SIREN-initialised with its own
    /// ω₀ ([`Network::siren`]) but with two changes:
    /// - its ω_t drawn over its whole band, U(−ω_t^max, ω_t^max): the motion's time dependence
    ///   is what the network is for, and SIREN's U(−ω₀/4, …) (±1.25 at the motion's ω₀ = 5)
    ///   starts it far below the frequencies a cycle needs. Started there, the swaying tube's
    ///   motion ran ahead of the truth after the first annotated time and behind it before the
    ///   last, and its worst frame was 0.73 IoU; started over the band, 0.86
    ///   (lab/notes/2026-12-07-motion-model.md);
    /// - a zero output layer, so the motion starts as the identity (u = 0: the model starts as
    ///   the shape network alone) and its first steps move only what the data ask to move.
    pub fn motion_siren(widths: &[u32], omega_0: f32, omega_t_max: f32, seed: u64) -> Network {
        let layout = Layout::new(widths, 3).expect("motion widths within the core's limits");
        let mut net = Network::siren(layout, omega_0, 0.0, omega_t_max, seed);
        if omega_t_max.is_finite() {
            let range = net.omega_t_range();
            let mut rng = Pcg64Mcg::seed_from_u64(seed);
            for v in &mut net.params[range] {
                *v = rng.random_range(-omega_t_max..=omega_t_max);
            }
        }
        let last = net.layout.num_layers() - 1;
        let start = net.layout.layer_offset(last);
        net.params[start..].fill(0.0);
        net
    }

    /// This network carried by `motion` (see [`Network::motion`]).
    pub fn with_motion(mut self, motion: Option<Network>) -> Network {
        self.motion = motion.map(Box::new);
        self
    }

    /// Every trained parameter: this network's, then its motion network's (the vector Adam and
    /// the checkpoint hold).
    pub fn all_params(&self) -> Vec<f32> {
        let mut all = Vec::with_capacity(self.all_params_len());
        self.all_params_into(&mut all);
        all
    }

    /// [`Network::all_params`] into `all`, replacing its contents (no allocation once it has
    /// the capacity: the trainer refills one vector every step).
    pub fn all_params_into(&self, all: &mut Vec<f32>) {
        all.clear();
        all.extend_from_slice(&self.params);
        if let Some(m) = &self.motion {
            all.extend_from_slice(&m.params);
        }
    }

    /// Number of trained parameters ([`Network::all_params`]'s length).
    pub fn all_params_len(&self) -> usize {
        self.params.len() + self.motion.as_ref().map_or(0, |m| m.params.len())
    }

    /// Sets every trained parameter from `all` (laid out as [`Network::all_params`]).
    pub fn set_all_params(&mut self, all: &[f32]) {
        let (own, rest) = all.split_at(self.params.len());
        self.params.copy_from_slice(own);
        if let Some(m) = &mut self.motion {
            m.params.copy_from_slice(rest);
        }
    }

    /// This network with ω_x bounded across parallel planes (`band`), projected into it at
    /// once and after every optimiser step.
    pub fn with_plane_band(mut self, band: Option<PlaneBand>) -> Network {
        self.plane_band = band;
        self.project_band_limits();
        self
    }

    /// The ω_t row of the first layer's Wᵀ (Eq. 2).
    pub fn omega_t_range(&self) -> std::ops::Range<usize> {
        let width = self.layout.layer_dims(0).1;
        3 * width..4 * width
    }

    /// The largest |ω_t| of the first layer: the temporal band the network actually uses.
    pub fn largest_omega_t(&self) -> f32 {
        self.params[self.omega_t_range()]
            .iter()
            .fold(0.0f32, |m, v| m.max(v.abs()))
    }

    /// Projects ω_t back into [−ω_t^max, ω_t^max] (Eq. 4) and ω_x into the plane band, if any;
    /// called after every optimiser step.
    pub fn project_band_limits(&mut self) {
        let range = self.omega_t_range();
        temporal_bound::project(&mut self.params[range], self.omega_t_max);
        if let Some(band) = &self.plane_band {
            let width = self.layout.layer_dims(0).1;
            let (x, rest) = self.params[..3 * width].split_at_mut(width);
            let (y, z) = rest.split_at_mut(width);
            spatial_bound::project([x, y, z], band);
        }
        if let Some(m) = &mut self.motion {
            m.project_band_limits();
        }
    }

    /// The model file contents for this network.
    pub fn to_writer(
        &self,
        domain: Domain,
        classes: Vec<(String, i32)>,
        metadata: String,
    ) -> ModelWriter {
        ModelWriter {
            widths: self.widths(),
            classes,
            domain,
            omega_t_max: self.stored_omega_t_max(),
            params: self.params.clone(),
            metadata,
            weight_type: WeightType::F32,
            motion: self.motion.as_deref().map(|m| MotionWriter {
                widths: m.widths(),
                omega_t_max: m.stored_omega_t_max(),
                params: m.params.clone(),
            }),
        }
    }

    fn widths(&self) -> Vec<u32> {
        self.layout.widths().iter().map(|&w| w as u32).collect()
    }

    /// ω_t^max as the file keeps it: a disabled band limit is stored as the largest ω_t
    /// present, so the file still evaluates exactly this network.
    fn stored_omega_t_max(&self) -> f32 {
        if self.omega_t_max.is_finite() {
            self.omega_t_max
        } else {
            self.largest_omega_t()
        }
    }
}
