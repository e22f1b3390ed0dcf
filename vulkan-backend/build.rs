//! Compiles the `kernels` crate with rust-gpu to one SPIR-V module per entry point, optimizes
//! the modules with spirv-opt's performance passes in parallel (one module per thread, as many
//! threads as cargo's jobs), and generates `kernels.rs` (in OUT_DIR): one `Kernel` variant per
//! entry point, with its module (`include_bytes!`), its name, its number of storage-buffer
//! bindings, their element strides and its push-constant size, all read from the compiled module,
//! so the host names no kernel by a string and checks its layouts at compile time.
//!
//! One module per entry point: a driver parses only the kernel it builds a pipeline for
//! (lavapipe built each pipeline from the whole 22 MB module: ~20 s each). Optimizing here, not in
//! rust-gpu's linker (`--no-spirv-opt`), because the linker runs spirv-opt on one thread and that
//! was three quarters of the kernel build (1297 of 1684 s with `-Ztime-passes` on 2 cores).
//! Validated once, after optimizing: SPIRV-Tools' validator is far above linear in a module's
//! size, and rust-gpu's unoptimized modules (validated by its linker and again by spirv-opt
//! before it starts) cost minutes each; `--no-spirv-val` and [`spirv_opt_unvalidated`] leave
//! that out (the kernel build: about 35 -> 15 minutes on 2 cores, the same optimized bytes).
//!
//! After spirv-opt, [`undef_arms::undef_arms_last`] puts the arm of a selection that hands
//! `OpUndef` to the merge second, where Mesa folds the loop phis of values a loop never changes
//! (see that module; the same results, lavapipe's jackknife about 15 % faster per ray).

use spirv_builder::{Capability, CompileResult, ModuleResult, SpirvBuilder};
use spirv_tools::val::Validator;
use spirv_tools::TargetEnv;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

#[path = "build/undef_arms.rs"]
mod undef_arms;

type BoxError = Box<dyn std::error::Error + Send + Sync>;

fn main() -> Result<(), BoxError> {
    let kernels = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../kernels");
    let mut builder = SpirvBuilder::new(kernels, "spirv-unknown-vulkan1.2")
        // PCG32 (rand_pcg's stream) needs 64-bit integers.
        .capability(Capability::Int64)
        .capability(Capability::SampledBuffer)
        .release(true)
        .multimodule(true)
        // Keep every declared binding in each entry point's module: the host's layouts name them
        // all, and the one-page variants leave the other pages' bindings unread.
        .preserve_bindings(true)
        // spirv-opt runs below, in parallel, and validates the optimized modules; validating the
        // unoptimized ones in the linker was about a third of the kernel build.
        .extra_arg("--no-spirv-opt")
        .extra_arg("--no-spirv-val");
    builder.build_script.defaults = true;
    builder.build_script.env_shader_spv_path = Some(false);
    // rustc's warnings for the SPIR-V target would only repeat that spirv-opt is off in the
    // linker (it runs below); the kernels' own warnings come from the native clippy build, and
    // errors still fail this script with rustc's output.
    builder.build_script.forward_rustc_warnings = Some(false);
    let result = builder.build()?;
    let out = PathBuf::from(std::env::var("OUT_DIR")?);
    let modules = optimize_all(&result, &out)?;
    let code = kernel_items(&result, &modules)?;
    std::fs::write(out.join("kernels.rs"), code)?;
    Ok(())
}

/// spirv-opt's performance passes (what rust-gpu's linker runs at opt-level 3 without debug
/// info) on every module, largest first, on NUM_JOBS threads; the optimized modules are validated
/// and written to `out/<entry>.spv`. Returns entry name -> optimized module path.
fn optimize_all(result: &CompileResult, out: &Path) -> Result<HashMap<String, PathBuf>, BoxError> {
    let ModuleResult::MultiModule(modules) = &result.module else {
        return Err("rust-gpu returned one module; expected one per entry point".into());
    };
    let mut work: Vec<(&String, &PathBuf, u64)> = modules
        .iter()
        .map(|(name, path)| {
            let len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
            (name, path, len)
        })
        .collect();
    work.sort_by_key(|w| std::cmp::Reverse(w.2));
    let jobs = std::env::var("NUM_JOBS")
        .ok()
        .and_then(|j| j.parse::<usize>().ok())
        .unwrap_or(1)
        .clamp(1, work.len().max(1));
    let next = AtomicUsize::new(0);
    let done: Mutex<Vec<Result<(String, PathBuf), String>>> = Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(&(name, path, _)) = work.get(i) else {
                    break;
                };
                let r = optimize_one(path, &out.join(format!("{name}.spv")))
                    .map(|p| (name.clone(), p))
                    .map_err(|e| format!("{name}: {e}"));
                done.lock().unwrap_or_else(|e| e.into_inner()).push(r);
            });
        }
    });
    let done = done.into_inner().unwrap_or_else(|e| e.into_inner());
    done.into_iter()
        .map(|r| r.map_err(BoxError::from))
        .collect()
}

/// Optimizes and validates the module at `input`, writing it to `output`.
fn optimize_one(input: &Path, output: &Path) -> Result<PathBuf, BoxError> {
    let bytes = std::fs::read(input)?;
    let words = spirv_tools::binary::to_binary(&bytes)?.to_vec();
    let optimized = spirv_opt_unvalidated(&words)?;
    let (optimized, _swapped) = undef_arms::undef_arms_last(&optimized)
        .map_err(|e| format!("reordering the selections of the optimized module: {e}"))?;
    let target = Some(TargetEnv::Vulkan_1_2);
    // Uniform blocks are laid out as Rust lays out the shared structs (std430-like), which
    // Vulkan 1.2's uniformBufferStandardLayout allows (the device enables it).
    let options = spirv_tools::val::ValidatorOptions {
        uniform_buffer_standard_layout: true,
        ..Default::default()
    };
    spirv_tools::val::create(target)
        .validate(&optimized, Some(options))
        .map_err(|e| format!("the optimized module is invalid: {e}"))?;
    let bytes: Vec<u8> = optimized.iter().flat_map(|w| w.to_le_bytes()).collect();
    std::fs::write(output, bytes)?;
    Ok(output.to_path_buf())
}

/// spirv-opt's performance passes, dead constants and debug info removed, bindings kept, WITHOUT
/// validating the input: SPIRV-Tools' validator is far above linear in a module's size, and on
/// rust-gpu's unoptimized output it was nearly all of the kernel build's spirv-opt time (`spirv-val`
/// on the unoptimized render_cs: 362 s; on the optimized one: 5 s). The output is validated by the
/// caller. The `spirv-tools` crate always validates the input (it cannot clear SPIRV-Tools'
/// `run_validator`), hence the C API of the same library here.
fn spirv_opt_unvalidated(words: &[u32]) -> Result<Vec<u32>, BoxError> {
    use spirv_tools_sys::{diagnostics, opt, shared};
    use std::os::raw::{c_char, c_void};

    extern "C" fn on_message(
        level: diagnostics::MessageLevel,
        _source: *const c_char,
        _position: *const diagnostics::Position,
        message: *const c_char,
        ctx: *mut c_void,
    ) {
        // SAFETY: `ctx` is the `String` passed to `optimizer_run` below, alive for the call;
        // SPIRV-Tools passes a NUL-terminated message or null.
        let messages = unsafe { &mut *ctx.cast::<String>() };
        let text = if message.is_null() {
            std::borrow::Cow::Borrowed("")
        } else {
            unsafe { std::ffi::CStr::from_ptr(message) }.to_string_lossy()
        };
        let _ = writeln!(messages, "{level:?}: {text}");
    }

    let mut messages = String::new();
    // SAFETY: every object is created, used and destroyed here; `binary` is only read when
    // SPIRV-Tools reports success and returned non-null, and destroyed once.
    unsafe {
        let optimizer = opt::optimizer_create(shared::TargetEnv::Vulkan_1_2);
        opt::optimizer_register_performance_passes(optimizer);
        opt::optimizer_register_pass(optimizer, opt::Passes::EliminateDeadConstant);
        opt::optimizer_register_pass(optimizer, opt::Passes::StripDebugInfo);
        let options = opt::optimizer_options_create();
        opt::optimizer_options_run_validator(options, false);
        opt::optimizer_options_preserve_bindings(options, true);
        let mut binary: *mut shared::Binary = std::ptr::null_mut();
        let result = opt::optimizer_run(
            optimizer,
            words.as_ptr(),
            words.len(),
            &mut binary,
            on_message,
            (&mut messages as *mut String).cast::<c_void>(),
            options,
        );
        opt::optimizer_options_destroy(options);
        opt::optimizer_destroy(optimizer);
        if !matches!(result, shared::SpirvResult::Success) || binary.is_null() {
            if !binary.is_null() {
                shared::binary_destroy(binary);
            }
            return Err(format!("spirv-opt failed ({result:?})\n{messages}").into());
        }
        let out = std::slice::from_raw_parts((*binary).code, (*binary).size).to_vec();
        shared::binary_destroy(binary);
        Ok(out)
    }
}

/// What the host needs to know about one entry point.
struct EntryInfo {
    /// Its optimized module.
    module: PathBuf,
    name: String,
    /// Element stride of each storage buffer, by binding number (0: not a runtime array), or the
    /// size of a uniform buffer's block.
    strides: Vec<u32>,
    /// Bit b set: binding b is a uniform buffer (else a storage buffer).
    uniforms: u32,
    /// Bit b set: binding b is a uniform texel buffer of 32-bit words.
    texel_buffers: u32,
    /// Size in bytes of the push-constant block (0: none).
    push_size: u32,
}

/// The generated Rust source: `enum Kernel` over spirv-builder's entry points, in their order.
fn kernel_items(
    result: &CompileResult,
    modules: &HashMap<String, PathBuf>,
) -> Result<String, BoxError> {
    let mut entries = Vec::new();
    for name in &result.entry_points {
        let module = modules
            .get(name)
            .ok_or_else(|| format!("entry point {name} has no module"))?;
        let spv = std::fs::read(module)?;
        let info = reflect(&spv)?
            .into_iter()
            .find(|i| &i.name == name)
            .ok_or_else(|| format!("entry point {name} is missing from its module"))?;
        entries.push(EntryInfo {
            module: module.clone(),
            ..info
        });
    }
    if entries.is_empty() {
        return Err("the kernels module has no entry points".into());
    }
    let variant = |n: &str| -> String {
        n.split('_')
            .map(|w| {
                let mut c = w.chars();
                c.next()
                    .map(|f| f.to_ascii_uppercase().to_string() + c.as_str())
                    .unwrap_or_default()
            })
            .collect()
    };
    let mut s = String::new();
    writeln!(
        s,
        "/// A compute entry point of the kernels module (generated by build.rs)."
    )?;
    writeln!(s, "#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]")?;
    writeln!(s, "pub enum Kernel {{")?;
    for e in &entries {
        writeln!(s, "    /// `{}` in kernels/src/lib.rs.", e.name)?;
        writeln!(s, "    {},", variant(&e.name))?;
    }
    writeln!(s, "}}\n\nimpl Kernel {{")?;
    writeln!(s, "    /// Every entry point of the module.")?;
    write!(s, "    pub const ALL: [Kernel; {}] = [", entries.len())?;
    for e in &entries {
        write!(s, "Kernel::{}, ", variant(&e.name))?;
    }
    writeln!(s, "];")?;
    let arms = |s: &mut String, doc: &str, sig: &str, value: &dyn Fn(&EntryInfo) -> String| {
        let _ = writeln!(
            s,
            "    /// {doc}\n    pub const fn {sig} {{\n        match self {{"
        );
        for e in &entries {
            let _ = writeln!(
                s,
                "            Kernel::{} => {},",
                variant(&e.name),
                value(e)
            );
        }
        let _ = writeln!(s, "        }}\n    }}");
    };
    arms(
        &mut s,
        "The entry-point name.",
        "name(self) -> &'static str",
        &|e| format!("{:?}", e.name),
    );
    arms(
        &mut s,
        "The SPIR-V module holding this entry point only (optimized by build.rs).",
        "spirv(self) -> &'static [u8]",
        &|e| format!("include_bytes!({:?})", e.module),
    );
    arms(
        &mut s,
        "The entry-point name for Vulkan.",
        "c_name(self) -> &'static std::ffi::CStr",
        &|e| format!("c{:?}", e.name),
    );
    arms(
        &mut s,
        "Element stride in bytes of each storage buffer of set 0, by binding.",
        "strides(self) -> &'static [u32]",
        &|e| format!("&{:?}", e.strides),
    );
    arms(
        &mut s,
        "Bit b set: binding b of set 0 is a uniform buffer (one block of `strides()[b]` bytes), \
         else a storage buffer.",
        "uniforms(self) -> u32",
        &|e| format!("{:#x}", e.uniforms),
    );
    arms(
        &mut s,
        "Bit b set: binding b of set 0 is a uniform texel buffer of 32-bit words (its stride \
         `strides()[b]` is 4).",
        "texel_buffers(self) -> u32",
        &|e| format!("{:#x}", e.texel_buffers),
    );
    arms(
        &mut s,
        "Size in bytes of the push constants.",
        "push_size(self) -> u32",
        &|e| e.push_size.to_string(),
    );
    writeln!(s, "}}")?;
    Ok(s)
}

/// Types and decorations of a SPIR-V module, enough to size push constants and buffers.
#[derive(Default)]
struct Module {
    /// Result id -> instruction operands (after the opcode word), for type and constant ops.
    types: HashMap<u32, (u32, Vec<u32>)>,
    /// (target, decoration) -> first operand.
    decorations: HashMap<(u32, u32), u32>,
    /// (struct, member) -> Offset.
    offsets: HashMap<(u32, u32), u32>,
    /// Variable id -> (pointer type, storage class).
    variables: HashMap<u32, (u32, u32)>,
}

const OP_ENTRY_POINT: u32 = 15;
const OP_DECORATE: u32 = 71;
const OP_MEMBER_DECORATE: u32 = 72;
const OP_VARIABLE: u32 = 59;
const DECORATION_ARRAY_STRIDE: u32 = 6;
const DECORATION_OFFSET: u32 = 35;
const DECORATION_BINDING: u32 = 33;
const STORAGE_UNIFORM_CONSTANT: u32 = 0;
const STORAGE_UNIFORM: u32 = 2;
const OP_TYPE_IMAGE: u32 = 25;
const DIM_BUFFER: u32 = 5;
const STORAGE_PUSH_CONSTANT: u32 = 9;
const STORAGE_STORAGE_BUFFER: u32 = 12;

/// Every entry point of the module with its bindings and push-constant size.
fn reflect(spv: &[u8]) -> Result<Vec<EntryInfo>, BoxError> {
    let words: Vec<u32> = spv
        .as_chunks::<4>()
        .0
        .iter()
        .map(|c| u32::from_le_bytes(*c))
        .collect();
    let mut m = Module::default();
    let mut entries: Vec<(String, Vec<u32>)> = Vec::new();
    let mut i = 5;
    while i < words.len() {
        let (len, op) = ((words[i] >> 16) as usize, words[i] & 0xffff);
        if len == 0 || i + len > words.len() {
            return Err("malformed SPIR-V module".into());
        }
        let ops = &words[i + 1..i + len];
        match op {
            OP_ENTRY_POINT => {
                let bytes: Vec<u8> = ops[2..].iter().flat_map(|w| w.to_le_bytes()).collect();
                let end = bytes
                    .iter()
                    .position(|&b| b == 0)
                    .ok_or("unterminated name")?;
                let name = String::from_utf8(bytes[..end].to_vec())?;
                let interface = ops[2 + end / 4 + 1..].to_vec();
                entries.push((name, interface));
            }
            OP_DECORATE if ops.len() >= 3 => {
                m.decorations.insert((ops[0], ops[1]), ops[2]);
            }
            OP_MEMBER_DECORATE if ops.len() >= 4 && ops[2] == DECORATION_OFFSET => {
                m.offsets.insert((ops[0], ops[1]), ops[3]);
            }
            OP_VARIABLE if ops.len() >= 3 => {
                m.variables.insert(ops[1], (ops[0], ops[2]));
            }
            // OpTypeInt, OpTypeFloat, OpTypeVector, OpTypeImage, OpTypeArray,
            // OpTypeRuntimeArray, OpTypeStruct, OpTypePointer (result id first), OpConstant
            // (result id second).
            21 | 22 | 23 | 25 | 28 | 29 | 30 | 32 => {
                m.types.insert(ops[0], (op, ops[1..].to_vec()));
            }
            43 if ops.len() >= 3 => {
                m.types.insert(ops[1], (op, ops[2..].to_vec()));
            }
            _ => {}
        }
        i += len;
    }
    entries
        .into_iter()
        .map(|(name, interface)| entry_info(&m, name, &interface))
        .collect()
}

/// Bindings and push-constant size of one entry point from its interface variables.
fn entry_info(m: &Module, name: String, interface: &[u32]) -> Result<EntryInfo, BoxError> {
    let mut strides: Vec<u32> = Vec::new();
    let mut uniforms = 0u32;
    let mut texel_buffers = 0u32;
    let mut push_size = 0;
    for id in interface {
        let Some(&(ptr, class)) = m.variables.get(id) else {
            continue;
        };
        let pointee = match m.types.get(&ptr) {
            Some((32, ops)) => ops[1],
            _ => return Err(format!("{name}: variable {id} is not a pointer").into()),
        };
        let stride = match class {
            STORAGE_PUSH_CONSTANT => {
                push_size = m.size_of(pointee)?;
                continue;
            }
            STORAGE_UNIFORM_CONSTANT => {
                // A sampled buffer image of 32-bit integers: a uniform texel buffer of words.
                let word_buffer = match m.types.get(&pointee) {
                    Some((OP_TYPE_IMAGE, ops)) => {
                        ops.len() >= 7
                            && ops[1] == DIM_BUFFER
                            && ops[5] == 1
                            && matches!(m.types.get(&ops[0]), Some((21, t)) if t[0] == 32)
                    }
                    _ => false,
                };
                if !word_buffer {
                    return Err(
                        format!("{name}: binding {id} is not a texel buffer of words").into(),
                    );
                }
                4
            }
            STORAGE_UNIFORM => m.size_of(pointee)?,
            STORAGE_STORAGE_BUFFER => m.runtime_stride(pointee),
            _ => continue,
        };
        let binding = *m
            .decorations
            .get(&(*id, DECORATION_BINDING))
            .ok_or_else(|| format!("{name}: resource {id} has no binding"))?
            as usize;
        if binding >= strides.len() {
            strides.resize(binding + 1, 0);
        }
        strides[binding] = stride;
        match class {
            STORAGE_UNIFORM => uniforms |= 1 << binding,
            STORAGE_UNIFORM_CONSTANT => texel_buffers |= 1 << binding,
            _ => {}
        }
    }
    Ok(EntryInfo {
        module: PathBuf::new(),
        name,
        strides,
        uniforms,
        texel_buffers,
        push_size,
    })
}

impl Module {
    /// Size in bytes of type `id` (structs: the end of their last-placed member).
    fn size_of(&self, id: u32) -> Result<u32, BoxError> {
        let (op, ops) = self.types.get(&id).ok_or("unknown type")?;
        Ok(match op {
            21 | 22 => ops[0] / 8,
            23 => ops[1] * self.size_of(ops[0])?,
            28 => {
                let len = match self.types.get(&ops[1]) {
                    Some((43, v)) => v[0],
                    _ => return Err("array length is not a constant".into()),
                };
                let stride = match self.decorations.get(&(id, DECORATION_ARRAY_STRIDE)) {
                    Some(&s) => s,
                    None => self.size_of(ops[0])?,
                };
                len * stride
            }
            30 => {
                let mut end = 0;
                for (k, &member) in ops.iter().enumerate() {
                    let offset = self.offsets.get(&(id, k as u32)).copied().unwrap_or(0);
                    end = end.max(offset + self.size_of(member)?);
                }
                end
            }
            _ => return Err(format!("cannot size SPIR-V type op {op}").into()),
        })
    }

    /// ArrayStride of the runtime array in a storage buffer's type (0 if it holds none).
    fn runtime_stride(&self, id: u32) -> u32 {
        match self.types.get(&id) {
            Some((29, _)) => self
                .decorations
                .get(&(id, DECORATION_ARRAY_STRIDE))
                .copied()
                .unwrap_or(0),
            Some((30, ops)) if ops.len() == 1 => self.runtime_stride(ops[0]),
            _ => 0,
        }
    }
}
