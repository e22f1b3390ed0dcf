//! What a kernel's SPIR-V module holds: its size in bytes and instructions, and the counts of
//! the instructions that cost a SIMD device most (branches, loops, memory accesses), so that
//! `host bench` can report the size of the code each timed ray runs beside its time.

use serde::Serialize;

/// Sizes of one SPIR-V module (the optimized module of one entry point, before the driver's
/// specialization removes the code its constants cannot reach).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ModuleStats {
    pub bytes: usize,
    pub instructions: usize,
    /// `OpBranchConditional` and `OpSwitch`.
    pub branches: usize,
    /// `OpLoopMerge`: loops.
    pub loops: usize,
    /// `OpLoad` (storage-buffer reads among them: a scalar loop per SIMD group on lavapipe).
    pub loads: usize,
    /// `OpFunction`: functions left after inlining.
    pub functions: usize,
}

const OP_FUNCTION: u32 = 54;
const OP_LOAD: u32 = 61;
const OP_LOOP_MERGE: u32 = 246;
const OP_BRANCH_CONDITIONAL: u32 = 250;
const OP_SWITCH: u32 = 251;

/// [`ModuleStats`] of a SPIR-V module given as little-endian bytes: after the five-word header
/// each instruction's first word holds its word count (high 16 bits) and opcode (low 16 bits).
/// A truncated or malformed module is counted up to where it stops making sense.
pub fn module_stats(spirv: &[u8]) -> ModuleStats {
    let words: Vec<u32> = spirv
        .as_chunks::<4>()
        .0
        .iter()
        .map(|c| u32::from_le_bytes(*c))
        .collect();
    let mut s = ModuleStats {
        bytes: spirv.len(),
        ..ModuleStats::default()
    };
    let mut i = 5;
    while i < words.len() {
        let (count, op) = ((words[i] >> 16) as usize, words[i] & 0xffff);
        if count == 0 || i + count > words.len() {
            break;
        }
        s.instructions += 1;
        match op {
            OP_FUNCTION => s.functions += 1,
            OP_LOAD => s.loads += 1,
            OP_LOOP_MERGE => s.loops += 1,
            OP_BRANCH_CONDITIONAL | OP_SWITCH => s.branches += 1,
            _ => {}
        }
        i += count;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A hand-made module: header, then OpFunction (5 words), OpLoad (4), OpLoopMerge (4),
    /// OpBranchConditional (4), OpFunctionEnd (1).
    #[test]
    fn counts_instructions_by_opcode() {
        let mut w: Vec<u32> = vec![0x0723_0203, 0x0001_0500, 0, 100, 0];
        w.extend([5 << 16 | OP_FUNCTION, 1, 2, 0, 3]);
        w.extend([4 << 16 | OP_LOAD, 1, 4, 5]);
        w.extend([4 << 16 | OP_LOOP_MERGE, 6, 7, 0]);
        w.extend([4 << 16 | OP_BRANCH_CONDITIONAL, 4, 6, 7]);
        w.push(1 << 16 | 56);
        let bytes: Vec<u8> = w.iter().flat_map(|x| x.to_le_bytes()).collect();
        let s = module_stats(&bytes);
        assert_eq!(
            s,
            ModuleStats {
                bytes: bytes.len(),
                instructions: 5,
                branches: 1,
                loops: 1,
                loads: 1,
                functions: 1,
            }
        );
        // Cut inside the last instruction but one: counting stops before it.
        let cut = module_stats(&bytes[..bytes.len() - 8]);
        assert_eq!(cut.instructions, 3);
        assert_eq!(module_stats(&bytes[..20]).instructions, 0);
    }

    /// The embedded transmittance kernel is a real module with its loops and branches.
    #[test]
    fn the_transmittance_kernel_has_code() {
        let s = module_stats(super::super::Kernel::TransmittanceCs.spirv());
        assert!(
            s.instructions > 1000 && s.loops > 0 && s.branches > 0,
            "{s:?}"
        );
    }
}
