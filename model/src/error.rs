//! Error types of the model crate.

use thiserror::Error;

/// Errors of model construction and of a dynamics step.
///
/// Every variant is a small `Copy` value so that the hot path (one control
/// period) can return it without allocating.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum ModelError {
    /// A body field is out of its accepted range.
    #[error("invalid body: `{field}` {reason}")]
    InvalidBody {
        /// Name of the offending field.
        field: &'static str,
        /// What is wrong and the accepted range.
        reason: &'static str,
    },
    /// A numerical or discretization parameter is out of its accepted range.
    #[error("invalid parameter `{name}` = {value}: accepted range is {range}")]
    InvalidParameter {
        /// Name of the parameter.
        name: &'static str,
        /// Value given.
        value: f64,
        /// Accepted range, in words.
        range: &'static str,
    },
    /// A quantity became non-finite (NaN or infinite) during a step.
    #[error("non-finite {quantity} at t = {time} s (the time step is probably too large)")]
    NonFinite {
        /// Which quantity.
        quantity: &'static str,
        /// Simulated time (s).
        time: f64,
    },
    /// The integration diverged (a quantity exceeded 1000 in SI units):
    /// the time step is too large for this gait.
    #[error("integration diverged: {quantity} exceeds 1e3 (SI) at t = {time} s; reduce dt")]
    Diverged {
        /// Which quantity.
        quantity: &'static str,
        /// Simulated time (s).
        time: f64,
    },
    /// The head inertia tensor (30) is not positive definite.
    #[error("head inertia tensor (30) is not positive definite at t = {time} s")]
    SingularInertia {
        /// Simulated time (s).
        time: f64,
    },
    /// A buffer passed to the model has the wrong size.
    #[error("size mismatch for `{what}`: expected {expected}, got {got}")]
    SizeMismatch {
        /// Which buffer.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Length given.
        got: usize,
    },
}

/// Result alias of the model crate.
pub type Result<T> = core::result::Result<T, ModelError>;
