//! Backend and precision arguments (`backend="cpu" | "gpu"`, `precision="f64" | "f32"`).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use simkit::backend::{Backend, Precision};

#[cfg(feature = "gpu")]
use simkit::backend::GpuContext;

/// The GPU context of this process: opened on the first `backend="gpu"` and shared by every
/// simulation after it (a device is expensive to open, and a context is a shared handle).
#[cfg(feature = "gpu")]
static GPU: std::sync::OnceLock<Result<GpuContext, String>> = std::sync::OnceLock::new();

/// The backend named by `name`: `"cpu"` or `"gpu"` (the best adapter, or the one named by
/// the `SIMKIT_ADAPTER` environment variable).
pub(crate) fn backend(name: &str) -> PyResult<Backend<'static>> {
    match name {
        "cpu" => Ok(Backend::Cpu),
        #[cfg(feature = "gpu")]
        "gpu" => Ok(Backend::Gpu(gpu_context()?)),
        #[cfg(not(feature = "gpu"))]
        "gpu" => Err(pyo3::exceptions::PyRuntimeError::new_err(
            "backend='gpu': this build of simkit has no GPU support (built without the `gpu` \
             feature); use backend='cpu'",
        )),
        other => Err(PyValueError::new_err(format!(
            "invalid backend: {other:?} (use 'cpu' or 'gpu')"
        ))),
    }
}

/// The process's GPU context, opened on first use (a failure to open is remembered: install
/// a driver and restart Python).
#[cfg(feature = "gpu")]
pub(crate) fn gpu_context() -> PyResult<&'static GpuContext> {
    match GPU.get_or_init(|| GpuContext::new().map_err(|e| e.to_string())) {
        Ok(ctx) => Ok(ctx),
        Err(message) => Err(pyo3::exceptions::PyRuntimeError::new_err(message.clone())),
    }
}

/// `"f64"` or `"f32"`.
pub(crate) fn precision(name: &str) -> PyResult<Precision> {
    match name {
        "f64" => Ok(Precision::F64),
        "f32" => Ok(Precision::F32),
        other => Err(PyValueError::new_err(format!(
            "invalid precision: {other:?} (use 'f64' or 'f32')"
        ))),
    }
}

/// The name of a precision, as the keyword takes it.
pub(crate) fn precision_name(p: Precision) -> &'static str {
    match p {
        Precision::F64 => "f64",
        Precision::F32 => "f32",
    }
}

/// The GPU adapters this process can use, best first (name, device type, API, driver and
/// whether it offers f64 in shaders); empty when there is none or without GPU support.
#[pyfunction]
pub(crate) fn adapters() -> Vec<String> {
    #[cfg(feature = "gpu")]
    {
        GpuContext::list_adapters()
            .iter()
            .map(ToString::to_string)
            .collect()
    }
    #[cfg(not(feature = "gpu"))]
    {
        Vec::new()
    }
}

/// Whether this build has the GPU backends (`backend="gpu"`); an adapter is needed as well
/// (see `adapters()`).
#[pyfunction]
pub(crate) fn has_gpu_support() -> bool {
    cfg!(feature = "gpu")
}
