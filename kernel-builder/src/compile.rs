//! Compiles the `kernels` crate with rust-gpu to one SPIR-V module per entry point and
//! optimizes the modules with spirv-opt's performance passes in parallel (one module per
//! thread), then validates each.
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
//! After spirv-opt, [`crate::undef_arms::undef_arms_last`] puts the arm of a selection that
//! hands `OpUndef` to the merge second, where Mesa folds the loop phis of values a loop never
//! changes (see that module; the same results, lavapipe's jackknife about 15 % faster per ray).

use crate::BoxError;
use spirv_builder::{Capability, CompileResult, ModuleResult, SpirvBuilder};
use spirv_tools::val::Validator;
use spirv_tools::TargetEnv;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Compiles `kernels` (the crate's folder) with rust-gpu; returns spirv-builder's result (one
/// unoptimized module per entry point).
pub fn compile(kernels: &Path) -> Result<CompileResult, BoxError> {
    let builder = SpirvBuilder::new(kernels, "spirv-unknown-vulkan1.2")
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
    Ok(builder.build()?)
}

/// spirv-opt's performance passes (what rust-gpu's linker runs at opt-level 3 without debug
/// info) on every module, largest first, on `jobs` threads; the optimized modules are validated
/// and written to `out/<entry>.spv`. Returns entry name -> optimized module path.
pub fn optimize_all(
    result: &CompileResult,
    out: &Path,
    jobs: usize,
) -> Result<HashMap<String, PathBuf>, BoxError> {
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
    let jobs = jobs.clamp(1, work.len().max(1));
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
    let (optimized, _swapped) = crate::undef_arms::undef_arms_last(&optimized)
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
