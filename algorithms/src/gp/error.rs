//! Why a GP could not be fitted, loaded or configured; shared by the kernels,
//! the likelihood and the model, and depending on none of them.

use thiserror::Error;

use crate::training_data::DataError;

/// Why a GP could not be fitted, loaded or configured. Each message says what to do.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GpError {
    #[error("{points} training point(s): a GP needs at least 2, add samples")]
    TooFewPoints { points: usize },
    #[error(transparent)]
    Data(#[from] DataError),
    #[error(
        "all outputs equal {value}: a constant response has nothing to fit; check the output \
         column, or use the constant as the model"
    )]
    ConstantOutput { value: f64 },
    #[error("invalid settings: {0}")]
    InvalidSettings(String),
    #[error("unknown kernel {0:?}: use one of \"se\", \"matern12\", \"matern32\", \"matern52\"")]
    UnknownKernel(String),
    #[error(
        "the kernel matrix is not positive definite even with a jitter of 1e-4 times its \
         diagonal: remove duplicated inputs, or raise the lower noise bound (or the fixed noise)"
    )]
    NotPositiveDefinite,
    #[error(
        "no hyperparameter start gave a finite likelihood: check the data for duplicates with \
         different outputs and widen the noise bounds"
    )]
    FitFailed,
    #[error("cannot load the GP model: {0}; re-save it with this version of acq")]
    InvalidModel(String),
}
