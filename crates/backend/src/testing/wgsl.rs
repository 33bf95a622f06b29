//! Law-level and layout checks of WGSL against Rust: run one WGSL function on the GPU for a
//! sample of inputs ([`eval_wgsl`]), and read a WGSL struct's layout with naga
//! ([`wgsl_struct`], [`assert_mirrors`]) so that a `#[repr(C)]` mirror cannot drift silently.

use bytemuck::Pod;

use crate::gpu::{DISPATCH_WGSL, GpuBuffer, Kernel, KernelDesc, run_pass};
use crate::{Error, GpuContext, Result};

/// Size and member offsets of a WGSL struct, as the WGSL rules lay it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WgslStruct {
    /// Size in bytes (the struct's span, padding included).
    pub size: u32,
    /// `(member name, byte offset)` in declaration order.
    pub members: Vec<(String, u32)>,
}

/// Reads the layout of struct `name` from WGSL `source` (the pieces a kernel concatenates).
pub fn wgsl_struct(source: &str, name: &str) -> Result<WgslStruct> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| {
        Error::Gpu(format!(
            "parsing WGSL for struct {name}: {}",
            e.emit_to_string(source)
        ))
    })?;
    for (_, ty) in module.types.iter() {
        if ty.name.as_deref() != Some(name) {
            continue;
        }
        if let naga::TypeInner::Struct { members, span } = &ty.inner {
            return Ok(WgslStruct {
                size: *span,
                members: members
                    .iter()
                    .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                    .collect(),
            });
        }
    }
    Err(Error::invalid(
        "WGSL struct",
        name,
        "not declared in the given source",
    ))
}

/// Refuses a Rust mirror `T` whose size differs from WGSL struct `name` in `source` (the
/// GPU would read shifted values silently); `what` names the mirror in the error.
///
/// Errors: the struct is missing or does not parse, or the sizes differ (naming both).
pub fn check_struct_size<T: Pod>(source: &str, name: &str, what: &str) -> Result<()> {
    let layout = wgsl_struct(source, name)?;
    let rust = std::mem::size_of::<T>();
    if layout.size as usize != rust {
        return Err(Error::invalid(
            format!("WGSL struct {name} of {what}"),
            format!("{} bytes", layout.size),
            format!(
                "must have the size of its Rust mirror ({rust} bytes); declare the same \
                 fields as the mirror, f32 scalars only"
            ),
        ));
    }
    Ok(())
}

/// One field of a Rust mirror: its name in the WGSL struct and its Rust byte offset
/// (`std::mem::offset_of!`).
pub type FieldOffset = (&'static str, usize);

/// Panics with a field-by-field report unless the Rust type `T` (size `size_of::<T>()`) and
/// the listed field offsets match WGSL struct `name` exactly: same size, same members in
/// the same order at the same offsets.
///
/// ```ignore
/// assert_mirrors::<Params>(PARAMS_WGSL, "Params", &[("nx", offset_of!(Params, nx)), ...]);
/// ```
pub fn assert_mirrors<T: Pod>(source: &str, name: &str, fields: &[FieldOffset]) {
    let wgsl = wgsl_struct(source, name).unwrap_or_else(|e| panic!("{e}"));
    let rust: Vec<(String, u32)> = fields
        .iter()
        .map(|&(n, o)| (n.to_string(), o as u32))
        .collect();
    let size = std::mem::size_of::<T>() as u32;
    assert!(
        wgsl.members == rust && wgsl.size == size,
        "Rust mirror {} of WGSL struct {name} differs:\n  WGSL: size {} members {:?}\n  Rust: size {size} members {rust:?}",
        std::any::type_name::<T>(),
        wgsl.size,
        wgsl.members,
    );
}

/// Evaluates a WGSL expression on the GPU for every input and returns the results in order.
///
/// `sources` are the WGSL pieces that define the function under test (and the types it
/// uses); `input_type` and `output_type` name WGSL types whose layouts match `I` and `O`
/// (a scalar, a vector or a struct declared in `sources`); `expression` computes the output
/// from the input `x`, e.g. `"normal_force(x.k, x.gamma, x.delta, x.vn)"`.
pub fn eval_wgsl<I: Pod, O: Pod>(
    ctx: &GpuContext,
    sources: &[&str],
    input_type: &str,
    output_type: &str,
    expression: &str,
    inputs: &[I],
) -> Result<Vec<O>> {
    if inputs.is_empty() {
        return Ok(Vec::new());
    }
    let input = GpuBuffer::from_slice(ctx, "law inputs", inputs)?;
    run_harness(
        ctx,
        sources,
        &[("x", input_type, input.binding())],
        output_type,
        expression,
        inputs.len(),
    )
}

/// [`eval_wgsl`] with two inputs per evaluation, `x` from `inputs` and `y` from `args`
/// (WGSL types `types.0` and `types.1`), e.g. a law's coefficient struct and the distance
/// it is evaluated at: `"md_pair_force_energy(x, y)"`. Both slices have one entry per
/// evaluation.
///
/// Errors: slices of different lengths, and those of [`eval_wgsl`].
pub fn eval_wgsl2<A: Pod, B: Pod, O: Pod>(
    ctx: &GpuContext,
    sources: &[&str],
    types: (&str, &str),
    output_type: &str,
    expression: &str,
    inputs: &[A],
    args: &[B],
) -> Result<Vec<O>> {
    if inputs.len() != args.len() {
        return Err(Error::invalid(
            "eval_wgsl2 arguments",
            args.len(),
            format!("must be as many as the inputs ({})", inputs.len()),
        ));
    }
    if inputs.is_empty() {
        return Ok(Vec::new());
    }
    let a = GpuBuffer::from_slice(ctx, "law inputs", inputs)?;
    let b = GpuBuffer::from_slice(ctx, "law arguments", args)?;
    run_harness(
        ctx,
        sources,
        &[("x", types.0, a.binding()), ("y", types.1, b.binding())],
        output_type,
        expression,
        inputs.len(),
    )
}

/// Runs `expression` once per index `i < count` with each input `(name, WGSL type,
/// buffer)` bound as `name = law_in_<k>[i]`, and downloads the outputs.
fn run_harness<O: Pod>(
    ctx: &GpuContext,
    sources: &[&str],
    inputs: &[(&str, &str, wgpu::BindingResource<'_>)],
    output_type: &str,
    expression: &str,
    count: usize,
) -> Result<Vec<O>> {
    let mut decls = String::new();
    let mut lets = String::new();
    for (k, (name, ty, _)) in inputs.iter().enumerate() {
        decls += &format!("@group(0) @binding({k}) var<storage, read> law_in_{k}: array<{ty}>;\n");
        lets += &format!("let {name} = law_in_{k}[i];\n");
    }
    let out = inputs.len();
    let harness = format!(
        "{decls}\
         @group(0) @binding({out}) var<storage, read_write> law_out: array<{output_type}>;\n\
         @compute @workgroup_size(64)\n\
         fn law_main(@builtin(workgroup_id) wid: vec3<u32>, \
                     @builtin(num_workgroups) nwg: vec3<u32>, \
                     @builtin(local_invocation_index) lid: u32) {{\n\
             let i = linear_workgroup(wid, nwg) * 64u + lid;\n\
             if i >= arrayLength(&law_out) {{ return; }}\n\
             {lets}\
             law_out[i] = {expression};\n\
         }}\n"
    );
    let mut all: Vec<&str> = vec![DISPATCH_WGSL];
    all.extend_from_slice(sources);
    all.push(&harness);
    let kernel = Kernel::new(
        ctx,
        &KernelDesc {
            label: "law under test",
            sources: &all,
            entry: "law_main",
            workgroup_size: 64,
            constants: &[],
        },
    )?;
    let output = GpuBuffer::<O>::zeroed(ctx, "law outputs", count)?;
    let mut resources: Vec<wgpu::BindingResource<'_>> =
        inputs.iter().map(|(_, _, b)| b.clone()).collect();
    resources.push(output.binding());
    let bind = kernel.bind(ctx, &resources)?;
    run_pass(ctx, "law under test", |pass| {
        kernel.dispatch_items(ctx, pass, &bind, count as u64)
    })?;
    output.download(ctx)
}
