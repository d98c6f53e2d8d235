//! The loss weights of Eq. 5–8 as command-line options, shared by `train` and `results`.

use super::options::{non_negative_f32, MAX_WEIGHT};
use dynaslice_train::spec::TrainSpec;
use dynaslice_train::trainer::TrainOptions;

/// λ_n, λ_d, λ_r and α, each with the trainer's default; each finite and in [0, 10⁶].
#[derive(clap::Args, Debug, Clone)]
pub struct LossArgs {
    /// λ_n, orientation weight (Eq. 6).
    #[arg(long, default_value_t = TrainOptions::default().loss.orientation,
          value_parser = non_negative_f32(MAX_WEIGHT),
          allow_negative_numbers = true)]
    lambda_orientation: f32,
    /// λ_d, in-plane SDF weight (Eq. 7).
    #[arg(long, default_value_t = TrainOptions::default().loss.plane,
          value_parser = non_negative_f32(MAX_WEIGHT),
          allow_negative_numbers = true)]
    lambda_plane: f32,
    /// λ_r, space-time regulariser weight (Eq. 8).
    #[arg(long, default_value_t = TrainOptions::default().loss.regulariser,
          value_parser = non_negative_f32(MAX_WEIGHT),
          allow_negative_numbers = true)]
    lambda_regulariser: f32,
    /// α of exp(−α|f|) (Eq. 8), in normalised units.
    #[arg(long, default_value_t = TrainOptions::default().loss.alpha,
          value_parser = non_negative_f32(MAX_WEIGHT),
          allow_negative_numbers = true)]
    alpha: f32,
}

impl LossArgs {
    /// `spec` with these weights set.
    pub fn apply(&self, spec: TrainSpec) -> TrainSpec {
        TrainSpec {
            lambda_orientation: Some(self.lambda_orientation),
            lambda_plane: Some(self.lambda_plane),
            lambda_regulariser: Some(self.lambda_regulariser),
            alpha: Some(self.alpha),
            ..spec
        }
    }
}
