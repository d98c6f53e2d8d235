//! The loss weights of Eq. 5–8 as command-line options, shared by `train` and the lab's
//! `results`: the rows `dynaslice_train::flags::LOSS` of the training options' table.

use crate::options::flag_args;
use dynaslice_train::flags::LOSS;

flag_args!(
    /// λ_n, λ_d, λ_r and α, with the table's help, defaults and limits.
    LossArgs,
    LOSS
);
