//! The kernel build's selection rewrite ([`undef_arms::undef_arms_last`]) on hand-assembled
//! modules: which selections it swaps, how, and what it leaves alone.

#[path = "../src/undef_arms.rs"]
mod undef_arms;

use undef_arms::undef_arms_last;

/// One instruction's words: opcode and operands.
fn inst(op: u32, operands: &[u32]) -> Vec<u32> {
    let mut w = vec![((operands.len() as u32 + 1) << 16) | op];
    w.extend_from_slice(operands);
    w
}

// Ids of the test module.
const VOID: u32 = 1;
const BOOL: u32 = 2;
const FN_TYPE: u32 = 3;
const INT: u32 = 4;
const COND: u32 = 5;
const SEVEN: u32 = 6;
const UNDEF: u32 = 7;
const FUNCTION: u32 = 8;
const HEAD: u32 = 9;
const ARM_T: u32 = 10;
const ARM_F: u32 = 11;
const MERGE: u32 = 12;
const PHI: u32 = 13;
const EXTRA: u32 = 14;
const BOUND: u32 = 15;

/// A function with one selection `if COND { ARM_T } else { ARM_F }` whose merge has the phi
/// `PHI = phi(from_t from ARM_T, SEVEN from ARM_F)`; ARM_T branches to `t_target` (the merge, or
/// EXTRA, a block that then branches to the merge).
fn module(from_t: u32, t_target: u32, weights: bool) -> Vec<u32> {
    let mut w = vec![0x0723_0203, 0x0001_0500, 0, BOUND, 0];
    w.extend(inst(17, &[1])); // OpCapability Shader
    w.extend(inst(14, &[0, 1])); // OpMemoryModel Logical GLSL450
    w.extend(inst(19, &[VOID])); // OpTypeVoid
    w.extend(inst(20, &[BOOL])); // OpTypeBool
    w.extend(inst(33, &[FN_TYPE, VOID])); // OpTypeFunction
    w.extend(inst(21, &[INT, 32, 0])); // OpTypeInt 32 0
    w.extend(inst(41, &[BOOL, COND])); // OpConstantTrue
    w.extend(inst(43, &[INT, SEVEN, 7])); // OpConstant 7
    w.extend(inst(1, &[INT, UNDEF])); // OpUndef
    w.extend(inst(54, &[VOID, FUNCTION, 0, FN_TYPE])); // OpFunction
    w.extend(inst(248, &[HEAD])); // OpLabel
    w.extend(inst(247, &[MERGE, 0])); // OpSelectionMerge
    if weights {
        w.extend(inst(250, &[COND, ARM_T, ARM_F, 1, 9])); // OpBranchConditional, weights
    } else {
        w.extend(inst(250, &[COND, ARM_T, ARM_F])); // OpBranchConditional
    }
    w.extend(inst(248, &[ARM_T]));
    w.extend(inst(249, &[t_target])); // OpBranch
    let t_pred = if t_target == MERGE {
        ARM_T
    } else {
        w.extend(inst(248, &[EXTRA]));
        w.extend(inst(249, &[MERGE]));
        EXTRA
    };
    w.extend(inst(248, &[ARM_F]));
    w.extend(inst(249, &[MERGE]));
    w.extend(inst(248, &[MERGE]));
    w.extend(inst(245, &[INT, PHI, from_t, t_pred, SEVEN, ARM_F])); // OpPhi
    w.extend(inst(253, &[])); // OpReturn
    w.extend(inst(56, &[])); // OpFunctionEnd
    w
}

/// The operands of the first instruction with opcode `op`, if any.
fn find(words: &[u32], op: u32) -> Option<Vec<u32>> {
    let mut at = 5;
    while at < words.len() {
        let len = (words[at] >> 16) as usize;
        if words[at] & 0xffff == op {
            return Some(words[at + 1..at + len].to_vec());
        }
        at += len;
    }
    None
}

#[test]
fn an_arm_that_hands_undef_to_the_merge_goes_second() {
    let (out, swapped) = undef_arms_last(&module(UNDEF, MERGE, false)).unwrap();
    assert_eq!(swapped, 1);
    // A new id for the negated condition, right before the selection's merge instruction.
    assert_eq!(out[3], BOUND + 1);
    assert_eq!(find(&out, 168), Some(vec![BOOL, BOUND, COND]));
    assert_eq!(find(&out, 250), Some(vec![BOUND, ARM_F, ARM_T]));
    let not_at = out
        .windows(4)
        .position(|w| w == [(4 << 16) | 168, BOOL, BOUND, COND]);
    let merge_at = out
        .windows(3)
        .position(|w| w == [(3 << 16) | 247, MERGE, 0]);
    assert_eq!(not_at.map(|a| a + 4), merge_at);
    // Everything else as it was: the module grew by the one instruction.
    assert_eq!(out.len(), module(UNDEF, MERGE, false).len() + 4);
    assert_eq!(
        find(&out, 245),
        Some(vec![INT, PHI, UNDEF, ARM_T, SEVEN, ARM_F])
    );
}

#[test]
fn branch_weights_follow_their_arms() {
    let (out, swapped) = undef_arms_last(&module(UNDEF, MERGE, true)).unwrap();
    assert_eq!(swapped, 1);
    assert_eq!(find(&out, 250), Some(vec![BOUND, ARM_F, ARM_T, 9, 1]));
}

#[test]
fn other_selections_are_left_alone() {
    // The true arm hands a value, not undef.
    let m = module(SEVEN, MERGE, false);
    assert_eq!(undef_arms_last(&m).unwrap(), (m.clone(), 0));
    // The true arm is two blocks.
    let m = module(UNDEF, EXTRA, false);
    assert_eq!(undef_arms_last(&m).unwrap(), (m.clone(), 0));
}

#[test]
fn malformed_modules_are_refused() {
    let mut m = module(UNDEF, MERGE, false);
    assert!(undef_arms_last(&m[..3]).is_err());
    // An instruction running past the end.
    let last = m.len() - 1;
    m[last] = (9 << 16) | 56;
    assert!(undef_arms_last(&m).is_err());
    // A zero word count.
    m[last] = 56;
    assert!(undef_arms_last(&m).is_err());
    m[0] = 0;
    assert!(undef_arms_last(&m).is_err());
}
