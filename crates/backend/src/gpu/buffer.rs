//! Typed storage buffers with size checks, upload and download.

use std::marker::PhantomData;

use bytemuck::Pod;

use super::GpuContext;
use crate::{Error, Result};

/// A storage buffer holding `len` values of `T` on the device.
///
/// Sizes are checked against the device limits at creation: a buffer over
/// `max_storage_buffer_binding_size` (or `max_buffer_size`) is an [`Error::BufferTooLarge`],
/// never a truncated allocation. Empty buffers are allowed; they occupy 4 bytes on the device
/// so that they can still be bound.
pub struct GpuBuffer<T: Pod> {
    buffer: wgpu::Buffer,
    len: usize,
    label: String,
    _marker: PhantomData<T>,
}

impl<T: Pod> std::fmt::Debug for GpuBuffer<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuBuffer")
            .field("label", &self.label)
            .field("len", &self.len)
            .finish()
    }
}

/// Usage flags of every simkit storage buffer.
const STORAGE_USAGE: wgpu::BufferUsages = wgpu::BufferUsages::STORAGE
    .union(wgpu::BufferUsages::COPY_SRC)
    .union(wgpu::BufferUsages::COPY_DST);

/// Checks that `len` elements of `T` fit the device's storage-buffer limits.
pub fn check_storage_size<T>(ctx: &GpuContext, label: &str, len: usize) -> Result<u64> {
    let bytes = (len as u64)
        .checked_mul(size_of::<T>() as u64)
        .ok_or_else(|| {
            Error::invalid(
                format!("length of buffer '{label}'"),
                len,
                "byte size overflows u64",
            )
        })?;
    let limits = ctx.limits();
    let binding = limits.max_storage_buffer_binding_size;
    if bytes > binding {
        return Err(Error::BufferTooLarge {
            label: label.to_string(),
            bytes,
            limit_name: "max_storage_buffer_binding_size",
            limit: binding,
        });
    }
    if bytes > limits.max_buffer_size {
        return Err(Error::BufferTooLarge {
            label: label.to_string(),
            bytes,
            limit_name: "max_buffer_size",
            limit: limits.max_buffer_size,
        });
    }
    Ok(bytes)
}

/// Device bytes to allocate for `bytes` of payload: at least 4, rounded up to 4.
fn padded(bytes: u64) -> u64 {
    bytes.max(4).next_multiple_of(4)
}

impl<T: Pod> GpuBuffer<T> {
    /// A zero-filled buffer of `len` elements.
    pub fn zeroed(ctx: &GpuContext, label: &str, len: usize) -> Result<Self> {
        let bytes = check_storage_size::<T>(ctx, label, len)?;
        let buffer = ctx.checked(
            &format!("allocating buffer '{label}' ({bytes} bytes)"),
            || {
                ctx.device().create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: padded(bytes),
                    usage: STORAGE_USAGE,
                    mapped_at_creation: false,
                })
            },
        )?;
        Ok(Self {
            buffer,
            len,
            label: label.to_string(),
            _marker: PhantomData,
        })
    }

    /// A buffer initialised with `data`.
    pub fn from_slice(ctx: &GpuContext, label: &str, data: &[T]) -> Result<Self> {
        let buf = Self::zeroed(ctx, label, data.len())?;
        buf.upload(ctx, data)?;
        Ok(buf)
    }

    /// Overwrites the whole buffer with `data` (which must have exactly `len` elements).
    pub fn upload(&self, ctx: &GpuContext, data: &[T]) -> Result<()> {
        self.upload_at(ctx, 0, data)
    }

    /// Overwrites elements `offset..offset + data.len()`.
    pub fn upload_at(&self, ctx: &GpuContext, offset: usize, data: &[T]) -> Result<()> {
        let end = offset
            .checked_add(data.len())
            .filter(|&e| e <= self.len)
            .ok_or_else(|| {
                Error::invalid(
                    format!("upload range of buffer '{}'", self.label),
                    format!("{offset}..{}", offset.saturating_add(data.len())),
                    format!("must lie within 0..{}", self.len),
                )
            })?;
        if offset == end {
            return Ok(());
        }
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let start = (offset * size_of::<T>()) as u64;
        if bytes.len().is_multiple_of(4) && start.is_multiple_of(4) {
            ctx.queue().write_buffer(&self.buffer, start, bytes);
        } else {
            return Err(Error::invalid(
                format!("upload to buffer '{}'", self.label),
                format!("{} bytes at byte offset {start}", bytes.len()),
                "partial uploads must be 4-byte aligned",
            ));
        }
        Ok(())
    }

    /// Copies the whole buffer back to the host (staging buffer, map, wait).
    pub fn download(&self, ctx: &GpuContext) -> Result<Vec<T>> {
        let mut encoder = ctx.encoder("download");
        let staging = self.encode_download(ctx, &mut encoder)?;
        ctx.submit(encoder);
        staging.read(ctx)
    }

    /// Records a copy of this buffer into a new staging buffer on `encoder`; read it with
    /// [`Staging::read`] after submitting. Lets several downloads share one submission.
    ///
    /// Errors: those of [`Staging::new`].
    pub fn encode_download(
        &self,
        ctx: &GpuContext,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<Staging<T>> {
        let staging = Staging::new(ctx, self.len)?;
        self.record_copy(encoder, &staging.buffer);
        Ok(staging)
    }

    /// Records a copy of this buffer into `staging` (made for this buffer's length, e.g.
    /// once for a download every step); read it with [`Staging::read_kept`] after
    /// submitting.
    ///
    /// Errors: a staging buffer of another length.
    pub fn encode_copy_to(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        staging: &Staging<T>,
    ) -> Result<()> {
        if staging.len != self.len {
            return Err(Error::invalid(
                format!("staging buffer for '{}'", self.label),
                staging.len,
                format!("must hold the buffer's {} values", self.len),
            ));
        }
        self.record_copy(encoder, &staging.buffer);
        Ok(())
    }

    /// Records a copy of the whole buffer into `dst` (at least as large).
    fn record_copy(&self, encoder: &mut wgpu::CommandEncoder, dst: &wgpu::Buffer) {
        let bytes = (self.len * size_of::<T>()) as u64;
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(&self.buffer, 0, dst, 0, padded(bytes));
        }
    }

    /// Number of elements.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the buffer holds no elements.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The buffer's label.
    pub fn label(&self) -> &str {
        &self.label
    }

    /// The underlying wgpu buffer.
    pub fn raw(&self) -> &wgpu::Buffer {
        &self.buffer
    }

    /// The whole buffer as a bind-group resource.
    pub fn binding(&self) -> wgpu::BindingResource<'_> {
        self.buffer.as_entire_binding()
    }
}

/// A host-readable copy of a [`GpuBuffer`] recorded by [`GpuBuffer::encode_download`].
pub struct Staging<T: Pod> {
    buffer: wgpu::Buffer,
    len: usize,
    _marker: PhantomData<T>,
}

impl<T: Pod> Staging<T> {
    /// A host-readable buffer for `len` values of `T`, to be filled by
    /// [`GpuBuffer::encode_copy_to`] and read by [`Staging::read_kept`] as often as needed.
    ///
    /// Errors: a size over the device's limits (checked before allocating), or an
    /// allocation the device refuses ([`Error::Gpu`]).
    pub fn new(ctx: &GpuContext, len: usize) -> Result<Self> {
        let bytes = check_storage_size::<T>(ctx, "staging", len)?;
        let buffer = ctx.checked(
            &format!("allocating a staging buffer ({bytes} bytes)"),
            || {
                ctx.device().create_buffer(&wgpu::BufferDescriptor {
                    label: Some("staging"),
                    size: padded(bytes),
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            },
        )?;
        Ok(Self {
            buffer,
            len,
            _marker: PhantomData,
        })
    }

    /// Waits for the copy and returns the values.
    pub fn read(self, ctx: &GpuContext) -> Result<Vec<T>> {
        self.read_kept(ctx)
    }

    /// Waits for the last recorded copy and returns the values, keeping the buffer for the
    /// next copy (it is unmapped again).
    pub fn read_kept(&self, ctx: &GpuContext) -> Result<Vec<T>> {
        if self.len == 0 {
            return Ok(Vec::new());
        }
        let slice = self.buffer.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        ctx.wait()?;
        rx.recv()
            .map_err(|_| Error::Gpu("map callback never ran".into()))?
            .map_err(|e| Error::Gpu(format!("mapping a staging buffer failed: {e}")))?;
        let out = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| Error::Gpu(format!("reading a mapped buffer failed: {e}")))?;
            let bytes = &view[..self.len * size_of::<T>()];
            // The mapped range is only byte-aligned in general: copy out without casting refs.
            bytemuck::pod_collect_to_vec(bytes)
        };
        self.buffer.unmap();
        Ok(out)
    }
}

/// A small uniform buffer holding one `Pod` value (kernel parameters).
pub struct Uniform<T: Pod> {
    buffer: wgpu::Buffer,
    _marker: PhantomData<T>,
}

impl<T: Pod> Uniform<T> {
    /// A uniform buffer initialised with `value`.
    ///
    /// Errors: a value larger than the device's uniform-binding limit, or an allocation or
    /// write the device refuses ([`Error::Gpu`], captured in an error scope instead of
    /// wgpu's default panic).
    pub fn new(ctx: &GpuContext, label: &str, value: &T) -> Result<Self> {
        let bytes = bytemuck::bytes_of(value);
        let size = padded(bytes.len() as u64).next_multiple_of(16);
        let limit = ctx.limits().max_uniform_buffer_binding_size;
        if size > limit {
            return Err(Error::BufferTooLarge {
                label: label.to_string(),
                bytes: size,
                limit_name: "max_uniform_buffer_binding_size",
                limit,
            });
        }
        ctx.checked(&format!("creating uniform buffer '{label}'"), || {
            let u = Self {
                buffer: ctx.device().create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
                _marker: PhantomData,
            };
            u.set(ctx, value);
            u
        })
    }

    /// Overwrites the value (takes effect for work submitted afterwards).
    pub fn set(&self, ctx: &GpuContext, value: &T) {
        ctx.queue()
            .write_buffer(&self.buffer, 0, bytemuck::bytes_of(value));
    }

    /// The buffer as a bind-group resource.
    pub fn binding(&self) -> wgpu::BindingResource<'_> {
        self.buffer.as_entire_binding()
    }
}
