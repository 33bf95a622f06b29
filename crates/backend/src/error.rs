//! The error type shared by every simkit crate.

use thiserror::Error as ThisError;

/// Everything that can go wrong in a simkit call.
///
/// Every variant carries a message that names the offending value and, where there is one,
/// the fix. Library code returns this instead of panicking on user data.
#[derive(Debug, Clone, PartialEq, ThisError)]
pub enum Error {
    /// A parameter or input value is outside its valid range (NaN, negative size, ...).
    #[error("invalid {name}: {value} ({reason})")]
    InvalidParameter {
        /// Which parameter (e.g. `"cutoff"`, `"position[17].x"`).
        name: String,
        /// The offending value, formatted.
        value: String,
        /// What is wrong and how to fix it.
        reason: String,
    },
    /// A time step above the stability bound of the scheme.
    #[error(
        "time step dt = {dt:e} exceeds the stability bound {bound:e} ({reason}); \
         use dt <= {bound:e} or explicitly override the guard"
    )]
    Unstable {
        /// Requested time step.
        dt: f64,
        /// Largest stable (or safe) time step.
        bound: f64,
        /// Which criterion produced the bound.
        reason: String,
    },
    /// No GPU adapter could be found or opened.
    #[error(
        "no GPU adapter available: {0}. Install a Vulkan driver (for a CPU-only machine: \
         `apt-get install mesa-vulkan-drivers` gives lavapipe) or use the CPU backend"
    )]
    NoAdapter(String),
    /// A buffer would exceed a device limit.
    #[error(
        "buffer '{label}' needs {bytes} bytes, over the device limit {limit_name} = {limit} bytes; \
         use a smaller system or split it"
    )]
    BufferTooLarge {
        /// Buffer label.
        label: String,
        /// Requested size in bytes.
        bytes: u64,
        /// Name of the wgpu limit that was exceeded.
        limit_name: &'static str,
        /// The limit's value.
        limit: u64,
    },
    /// A failure reported by the GPU stack (device lost, mapping failed, shader error).
    #[error("GPU error: {0}")]
    Gpu(String),
    /// A feature the request needs is not present on this device or build.
    #[error("unsupported: {0}")]
    Unsupported(String),
    /// A run turned non-finite or left its physical limits during `step(n)`.
    ///
    /// The simulation is rolled back to `rolled_back_to`, the last step whose state passed the
    /// check: `state()` returns that state and `steps_done()` that step.
    #[error(
        "blow-up detected by step {step}: {what}; likely cause: {cause}. The run was rolled \
         back to step {rolled_back_to}, the last state that passed the check (state() returns \
         it); fix the cause and step again, or resume from a checkpoint"
    )]
    BlowUp {
        /// The step at which the check found the bad state (the damage happened after
        /// `rolled_back_to` and at or before this step).
        step: u64,
        /// The first bad particle, cell or quantity and its value.
        what: String,
        /// The likely cause and the usual fix (time step too large, overlap, ...).
        cause: String,
        /// The step of the state the simulation now holds.
        rolled_back_to: u64,
    },
    /// A checkpoint could not be read: not a checkpoint, another format version or model,
    /// or a corrupt file.
    #[error("checkpoint {source_name}: {reason}")]
    Checkpoint {
        /// The file (or `"<bytes>"` for an in-memory checkpoint).
        source_name: String,
        /// What is wrong and what to do.
        reason: String,
    },
    /// An I/O failure while writing outputs.
    #[error("I/O error on {path}: {message}")]
    Io {
        /// File involved.
        path: String,
        /// The operating system's message.
        message: String,
    },
}

impl Error {
    /// Shorthand for [`Error::InvalidParameter`].
    pub fn invalid(
        name: impl Into<String>,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> Self {
        Error::InvalidParameter {
            name: name.into(),
            value: value.to_string(),
            reason: reason.into(),
        }
    }
}

impl Error {
    /// An [`Error::Checkpoint`] about checkpoint bytes (not a file): what is wrong and what
    /// to do. [`crate::Restart::resume_file`] replaces the source with the file's path.
    pub fn checkpoint(reason: impl Into<String>) -> Self {
        Error::Checkpoint {
            source_name: "<bytes>".into(),
            reason: reason.into(),
        }
    }
}

/// Result alias used across simkit.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Checks that `value` is finite; otherwise an [`Error::InvalidParameter`] naming it.
pub fn require_finite(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(Error::invalid(name, value, "must be a finite number"))
    }
}

/// Checks that `value` is finite and strictly positive.
pub fn require_positive(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(Error::invalid(name, value, "must be finite and > 0"))
    }
}

/// Checks that `value` is finite and non-negative.
pub fn require_non_negative(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(Error::invalid(name, value, "must be finite and >= 0"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_value_and_fix() {
        let e = require_positive("cutoff", -1.0).unwrap_err();
        let s = e.to_string();
        assert!(
            s.contains("cutoff") && s.contains("-1") && s.contains("> 0"),
            "{s}"
        );
        assert!(require_finite("x", f64::NAN).is_err());
        assert!(require_non_negative("x", 0.0).is_ok());
        let e = Error::Unstable {
            dt: 0.5,
            bound: 0.25,
            reason: "D dt/h^2 <= 1/4".into(),
        };
        assert!(e.to_string().contains("2.5e-1"), "{e}");
        assert!(
            Error::NoAdapter("none".into())
                .to_string()
                .contains("mesa-vulkan-drivers")
        );
    }
}
