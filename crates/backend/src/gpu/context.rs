//! Adapter choice and the device/queue pair every GPU backend runs on.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use crate::{Error, Result};

/// Environment variable holding a case-insensitive substring of the adapter name to use
/// (e.g. `SIMKIT_ADAPTER=llvmpipe` or `SIMKIT_ADAPTER=nvidia`).
pub const ADAPTER_ENV: &str = "SIMKIT_ADAPTER";

/// Loop iterations per shader invocation after which llvmpipe ends all loops (see
/// [`GpuContext::shader_loop_limit`]).
pub const LLVMPIPE_LOOP_LIMIT: u64 = 65_535;

/// A description of one adapter, as found by [`GpuContext::list_adapters`].
#[derive(Clone, Debug)]
pub struct AdapterSummary {
    /// Adapter name as the driver reports it (e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`).
    pub name: String,
    /// Kind of device (discrete, integrated, CPU, ...).
    pub device_type: wgpu::DeviceType,
    /// Graphics API backend (Vulkan, Metal, DX12).
    pub backend: wgpu::Backend,
    /// Driver name and version.
    pub driver: String,
    /// Whether the adapter supports 64-bit floats in shaders.
    pub shader_f64: bool,
}

impl std::fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} [{:?}, {:?}, driver {}{}]",
            self.name,
            self.device_type,
            self.backend,
            self.driver,
            if self.shader_f64 { ", f64" } else { "" }
        )
    }
}

struct Inner {
    adapter: wgpu::Adapter,
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    features: wgpu::Features,
    faults: Arc<Faults>,
    /// Every pipeline compiled on this device, by source, entry point and constants
    /// ([`GpuContext::pipeline`]).
    pipelines: Mutex<HashMap<PipelineKey, Pipeline>>,
}

/// What identifies a compiled pipeline: the WGSL source, the entry point and the override
/// constants (values as bits).
type PipelineKey = (String, String, Vec<(String, u64)>);

/// A compute pipeline and its group-0 bind-group layout (both cheap handles to clone).
pub(crate) type Pipeline = (wgpu::ComputePipeline, wgpu::BindGroupLayout);

/// GPU failures that wgpu reports outside an error scope, kept for the next call.
#[derive(Default)]
struct Faults {
    /// The first error no scope captured since the last [`GpuContext::health`] call.
    uncaptured: Mutex<Option<String>>,
    /// Set for good when the device is lost.
    lost: Mutex<Option<String>>,
}

fn note(slot: &Mutex<Option<String>>, message: String) {
    let mut slot = slot.lock().unwrap_or_else(|p| p.into_inner());
    slot.get_or_insert(message);
}

/// A GPU device and queue with the limits and features simkit needs.
///
/// Cheap to clone (shared handle). Created once per program and passed to the GPU backends
/// through [`Backend::Gpu`](crate::Backend).
#[derive(Clone)]
pub struct GpuContext {
    inner: Arc<Inner>,
    /// The longest [`GpuContext::wait`] waits for the device.
    wait_limit: std::time::Duration,
}

/// How long [`GpuContext::wait`] waits for the device by default: 10 minutes, far beyond
/// any one submission of simkit's (a recorded stretch of steps) on a working device, and
/// short enough that a hung device ends a run with an error instead of blocking it forever.
pub const DEFAULT_WAIT_LIMIT: std::time::Duration = std::time::Duration::from_secs(600);

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.inner.info.name)
            .finish()
    }
}

fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if std::env::var_os("WGPU_BACKEND").is_none() {
        // Compute needs a modern API; the GL backend is left out unless asked for.
        desc.backends = wgpu::Backends::PRIMARY;
    }
    wgpu::Instance::new(desc)
}

fn preference(device_type: wgpu::DeviceType) -> u8 {
    match device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

fn summary(adapter: &wgpu::Adapter) -> AdapterSummary {
    let info = adapter.get_info();
    AdapterSummary {
        name: info.name.clone(),
        device_type: info.device_type,
        backend: info.backend,
        driver: format!("{} {}", info.driver, info.driver_info)
            .trim()
            .to_string(),
        shader_f64: adapter.features().contains(wgpu::Features::SHADER_F64),
    }
}

fn compute_capable(adapter: &wgpu::Adapter) -> bool {
    adapter
        .get_downlevel_capabilities()
        .flags
        .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
}

impl GpuContext {
    /// Lists every compute-capable adapter, best first (the order [`GpuContext::new`] uses).
    pub fn list_adapters() -> Vec<AdapterSummary> {
        Self::sorted_adapters().iter().map(summary).collect()
    }

    fn sorted_adapters() -> Vec<wgpu::Adapter> {
        let instance = instance();
        let mut adapters: Vec<wgpu::Adapter> =
            pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()))
                .into_iter()
                .filter(compute_capable)
                .collect();
        adapters.sort_by_key(|a| {
            let info = a.get_info();
            // Prefer real GPUs, then Vulkan over other APIs.
            (
                preference(info.device_type),
                info.backend != wgpu::Backend::Vulkan,
            )
        });
        adapters
    }

    /// Opens the best adapter: a real GPU if there is one, else a CPU Vulkan driver
    /// (lavapipe). `SIMKIT_ADAPTER=<substring>` picks an adapter by name instead.
    pub fn new() -> Result<Self> {
        let wanted = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty());
        Self::with_adapter_name(wanted.as_deref())
    }

    /// Opens the adapter for the process with local rank `local_rank` on its machine
    /// (`Comm::local_rank`), so that the ranks of a distributed run share the machine's
    /// GPUs round-robin: with `SIMKIT_ADAPTER=<substring>` set, that adapter (every rank
    /// alike); else the adapters of the best kind present (real GPUs before CPU drivers
    /// such as lavapipe) through the preferred API, the `local_rank % count`-th of them.
    ///
    /// Errors: no compute-capable adapter, no adapter matching `SIMKIT_ADAPTER`, or a
    /// device the adapter refuses.
    pub fn for_local_rank(local_rank: usize) -> Result<Self> {
        if let Some(name) = std::env::var(ADAPTER_ENV).ok().filter(|s| !s.is_empty()) {
            return Self::with_adapter_name(Some(&name));
        }
        let adapters = Self::sorted_adapters();
        // One entry per device: the best kind, through the best API (a GPU listed under
        // two APIs counts once).
        let kind = |a: &wgpu::Adapter| {
            let info = a.get_info();
            (preference(info.device_type), info.backend)
        };
        let Some(best) = adapters.first().map(kind) else {
            return Err(Error::NoAdapter(
                "wgpu found no compute-capable adapter".into(),
            ));
        };
        let mut same: Vec<wgpu::Adapter> =
            adapters.into_iter().filter(|a| kind(a) == best).collect();
        let k = local_rank % same.len();
        Self::open(same.swap_remove(k))
    }

    /// Opens the best adapter whose name contains `name` (case-insensitive), or the best
    /// adapter overall with `None`.
    pub fn with_adapter_name(name: Option<&str>) -> Result<Self> {
        let adapters = Self::sorted_adapters();
        if adapters.is_empty() {
            return Err(Error::NoAdapter(
                "wgpu found no compute-capable adapter".into(),
            ));
        }
        let found: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        let adapter = match name {
            None => adapters.into_iter().next(),
            Some(pat) => {
                let pat = pat.to_lowercase();
                adapters
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&pat))
            }
        };
        let adapter = adapter.ok_or_else(|| {
            Error::NoAdapter(format!(
                "no adapter name contains {:?} (from {ADAPTER_ENV}); found: {}",
                name.unwrap_or_default(),
                found.join(", ")
            ))
        })?;
        Self::open(adapter)
    }

    fn open(adapter: wgpu::Adapter) -> Result<Self> {
        let info = adapter.get_info();
        // Ask for everything the adapter offers: large storage buffers, the largest
        // workgroup storage, and 64-bit floats in shaders when present.
        let limits = adapter.limits();
        let features = adapter.features() & wgpu::Features::SHADER_F64;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("simkit"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| Error::NoAdapter(format!("adapter {} refused a device: {e}", info.name)))?;
        // wgpu's default handler for errors outside an error scope panics; keep them instead
        // and return them as `Err` from the next call (see `health`).
        let faults = Arc::new(Faults::default());
        let sink = Arc::clone(&faults);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            note(&sink.uncaptured, e.to_string());
        }));
        let sink = Arc::clone(&faults);
        device.set_device_lost_callback(move |reason, message| {
            note(&sink.lost, format!("{reason:?}: {message}"));
        });
        let limits = device.limits();
        let features = device.features();
        Ok(Self {
            inner: Arc::new(Inner {
                adapter,
                device,
                queue,
                info,
                limits,
                features,
                faults,
                pipelines: Mutex::default(),
            }),
            wait_limit: DEFAULT_WAIT_LIMIT,
        })
    }

    /// The same device with another limit on [`GpuContext::wait`] (the handle is shared;
    /// the limit is this copy's).
    pub fn with_wait_limit(mut self, limit: std::time::Duration) -> Self {
        self.wait_limit = limit;
        self
    }

    /// The longest [`GpuContext::wait`] waits ([`DEFAULT_WAIT_LIMIT`] unless set with
    /// [`GpuContext::with_wait_limit`]).
    pub fn wait_limit(&self) -> std::time::Duration {
        self.wait_limit
    }

    /// The wgpu device.
    pub fn device(&self) -> &wgpu::Device {
        &self.inner.device
    }

    /// The wgpu queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.inner.queue
    }

    /// The wgpu adapter the device was opened on.
    pub fn adapter(&self) -> &wgpu::Adapter {
        &self.inner.adapter
    }

    /// Information about the adapter (name, type, driver).
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.inner.info
    }

    /// A printable summary of the adapter.
    pub fn summary(&self) -> AdapterSummary {
        summary(&self.inner.adapter)
    }

    /// The limits the device was opened with.
    pub fn limits(&self) -> &wgpu::Limits {
        &self.inner.limits
    }

    /// The features the device was opened with.
    pub fn features(&self) -> wgpu::Features {
        self.inner.features
    }

    /// Whether shaders may use `f64`.
    pub fn has_f64(&self) -> bool {
        self.inner.features.contains(wgpu::Features::SHADER_F64)
    }

    /// Whether this adapter is a CPU implementation (lavapipe, SwiftShader, WARP).
    pub fn is_cpu_adapter(&self) -> bool {
        self.inner.info.device_type == wgpu::DeviceType::Cpu
    }

    /// The most loop iterations one shader invocation may run on this adapter, counted over
    /// all loops of the shader together, or `None` where the driver imposes no such limit.
    ///
    /// Mesa's llvmpipe (the driver under lavapipe) stops a shader's loops once 65,535
    /// iterations have run in one invocation: one counter, shared by every loop of the
    /// shader, nested ones included (gallivm's `LP_MAX_TGSI_LOOP_ITERATIONS`). The shader
    /// then goes on with wrong data and no error. Kernels whose loops could run longer
    /// (per-cell scans over dense cells, all-pairs sums over many particles) check their
    /// worst case against this and refuse the work with an error on such an adapter; the
    /// backend's tests measure the limit.
    pub fn shader_loop_limit(&self) -> Option<u64> {
        let info = &self.inner.info;
        let llvmpipe = [&info.name, &info.driver]
            .iter()
            .any(|s| s.to_ascii_lowercase().contains("llvmpipe"));
        llvmpipe.then_some(LLVMPIPE_LOOP_LIMIT)
    }

    /// Largest storage buffer, in bytes, a single binding may cover.
    pub fn max_storage_bytes(&self) -> u64 {
        let l = &self.inner.limits;
        l.max_storage_buffer_binding_size.min(l.max_buffer_size)
    }

    /// `Err` when the device was lost (for good: every later call fails too) or an error
    /// was raised outside an error scope since the last call (reported once), naming the
    /// adapter. [`GpuContext::checked`], [`GpuContext::wait`] and every download call it, so
    /// a failure surfaces as `Err` from the next simkit call instead of a panic.
    pub fn health(&self) -> Result<()> {
        let name = &self.inner.info.name;
        let lost = self
            .inner
            .faults
            .lost
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if let Some(msg) = lost.as_ref() {
            return Err(Error::Gpu(format!(
                "the device on adapter '{name}' was lost ({msg}); create a new GpuContext \
                 and resume from a checkpoint"
            )));
        }
        drop(lost);
        let mut uncaptured = self
            .inner
            .faults
            .uncaptured
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        match uncaptured.take() {
            Some(msg) => Err(Error::Gpu(format!("adapter '{name}': {msg}"))),
            None => Ok(()),
        }
    }

    /// Blocks until all submitted work has finished, at most [`GpuContext::wait_limit`];
    /// errors as [`GpuContext::health`], and [`Error::Gpu`] naming the limit when the device
    /// has not finished by then (a hung device, or work far longer than the limit: raise it
    /// with [`GpuContext::with_wait_limit`]).
    pub fn wait(&self) -> Result<()> {
        self.health()?;
        let name = &self.inner.info.name;
        self.inner
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: Some(self.wait_limit),
            })
            .map(|_| ())
            .map_err(|e| match e {
                wgpu::PollError::Timeout => Error::Gpu(format!(
                    "the device on adapter '{name}' did not finish its work within {:?} \
                     (GpuContext::wait_limit): it may be hung; raise the limit with \
                     GpuContext::with_wait_limit if the work is that long",
                    self.wait_limit
                )),
                e => Error::Gpu(format!(
                    "waiting for the device on adapter '{name}' failed: {e}"
                )),
            })?;
        self.health()
    }

    /// Runs `f` inside a validation error scope and turns any captured validation or
    /// out-of-memory error into [`Error::Gpu`] instead of wgpu's default panic.
    pub fn checked<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T> {
        let oom = self
            .inner
            .device
            .push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self
            .inner
            .device
            .push_error_scope(wgpu::ErrorFilter::Validation);
        let out = f();
        let v = pollster::block_on(validation.pop());
        let o = pollster::block_on(oom.pop());
        match v.or(o) {
            None => self.health().map(|()| out),
            Some(e) => Err(Error::Gpu(format!(
                "{what} on adapter '{}': {e}",
                self.inner.info.name
            ))),
        }
    }

    /// The pipeline of `source`'s `entry` with override `constants`, compiled by `compile`
    /// (given the source) the first time it is asked for on this device and shared afterwards: every engine of
    /// a process (the runs of a parameter sweep, a restart, the replicas of an ensemble)
    /// reuses the pipelines of the first one instead of having the driver compile them
    /// again. Pipelines are kept for the device's lifetime, one per distinct source and set
    /// of constants; a failed compilation is not kept.
    pub(crate) fn pipeline(
        &self,
        source: String,
        entry: &str,
        constants: &[(&str, f64)],
        compile: impl FnOnce(&str) -> Result<Pipeline>,
    ) -> Result<Pipeline> {
        let key: PipelineKey = (
            source,
            entry.to_owned(),
            constants
                .iter()
                .map(|&(name, value)| (name.to_owned(), value.to_bits()))
                .collect(),
        );
        let cache = || {
            self.inner
                .pipelines
                .lock()
                .unwrap_or_else(|p| p.into_inner())
        };
        if let Some(hit) = cache().get(&key) {
            return Ok(hit.clone());
        }
        // Compiled outside the lock: two threads asking at once both compile, and the
        // first one's pipeline is kept.
        let compiled = compile(&key.0)?;
        Ok(cache().entry(key).or_insert(compiled).clone())
    }

    /// Submits an encoder's commands.
    pub fn submit(&self, encoder: wgpu::CommandEncoder) {
        self.inner.queue.submit(Some(encoder.finish()));
    }

    /// A new command encoder.
    pub fn encoder(&self, label: &str) -> wgpu::CommandEncoder {
        self.inner
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(label) })
    }
}
