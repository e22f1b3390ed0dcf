//! A rewrite of the optimized kernel modules for Mesa's SPIR-V front end: a selection whose true
//! arm is one block that hands `OpUndef` to the merge's phis gets its arms swapped (the
//! condition negated), so the arm with the values comes first.
//!
//! Why: rust-gpu lowers `while c { body }` to a loop whose every iteration is a selection, "exit"
//! (an empty block) or `body`, merged before the back edge; on the exit path the loop-carried
//! values are dead, so the merge's phis take `OpUndef` from it. Mesa (lavapipe) orders a phi's
//! sources by block, then-arm first, and drops a phi whose sources are one value and undefs only
//! when that value comes first (`nir_opt_remove_phis`). With the exit arm first, every field of
//! a loop-carried struct that the loop never changes (a traversal's ray, its grid bounds) stays a
//! phi, and lavapipe stores each one to memory, under the lane mask, in every iteration. With the
//! value arm first those phis fold away. Swapping the arms of a selection and negating its
//! condition changes nothing a module computes: the same bytes on every device.

use std::collections::{HashMap, HashSet};

const OP_LINE: u32 = 8;
const OP_UNDEF: u32 = 1;
const OP_TYPE_BOOL: u32 = 20;
const OP_FUNCTION: u32 = 54;
const OP_FUNCTION_END: u32 = 56;
const OP_LOGICAL_NOT: u32 = 168;
const OP_PHI: u32 = 245;
const OP_SELECTION_MERGE: u32 = 247;
const OP_LABEL: u32 = 248;
const OP_BRANCH: u32 = 249;
const OP_BRANCH_CONDITIONAL: u32 = 250;
const OP_NO_LINE: u32 = 317;
/// Words of the module header (magic, version, generator, id bound, schema).
const HEADER: usize = 5;

/// One instruction: where it starts, its opcode and its word count.
#[derive(Clone, Copy)]
struct Inst {
    at: usize,
    op: u32,
    len: usize,
}

/// The instructions of `words` after the header, or why they cannot be read.
fn instructions(words: &[u32]) -> Result<Vec<Inst>, String> {
    if words.len() < HEADER || words[0] != 0x0723_0203 {
        return Err("not a SPIR-V module (magic number)".into());
    }
    let mut out = Vec::new();
    let mut at = HEADER;
    while at < words.len() {
        let (len, op) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if len == 0 || at + len > words.len() {
            return Err(format!("malformed instruction at word {at}"));
        }
        out.push(Inst { at, op, len });
        at += len;
    }
    Ok(out)
}

/// `words` with every selection whose true arm is one block that branches straight to the merge
/// and gives at least one of the merge's phis an `OpUndef` swapped (arms exchanged, condition
/// negated by a new `OpLogicalNot`), and the number of selections swapped.
pub fn undef_arms_last(words: &[u32]) -> Result<(Vec<u32>, usize), String> {
    let insts = instructions(words)?;
    let undefs: HashSet<u32> = insts
        .iter()
        .filter(|i| i.op == OP_UNDEF && i.len == 3)
        .map(|i| words[i.at + 2])
        .collect();
    let Some(bool_type) = insts
        .iter()
        .find(|i| i.op == OP_TYPE_BOOL && i.len == 2)
        .map(|i| words[i.at + 1])
    else {
        // No boolean type: no conditional branch.
        return Ok((words.to_vec(), 0));
    };
    // Each block's first instruction (its label) and last (its terminator), inside functions.
    let mut label_at: HashMap<u32, usize> = HashMap::new();
    let mut last_of: HashMap<u32, usize> = HashMap::new();
    let mut block = None;
    for (k, i) in insts.iter().enumerate() {
        match i.op {
            OP_FUNCTION | OP_FUNCTION_END => block = None,
            OP_LABEL if i.len == 2 => {
                block = Some(words[i.at + 1]);
                label_at.insert(words[i.at + 1], k);
            }
            _ => {}
        }
        if let Some(b) = block {
            last_of.insert(b, k);
        }
    }
    // The phis at the top of a block (debug lines may sit between them).
    let phis_of = |label: u32| -> Vec<Inst> {
        let mut out = Vec::new();
        let Some(&start) = label_at.get(&label) else {
            return out;
        };
        for i in &insts[start + 1..] {
            match i.op {
                OP_PHI => out.push(*i),
                OP_LINE | OP_NO_LINE => {}
                _ => break,
            }
        }
        out
    };
    let mut out = words.to_vec();
    let mut bound = words[3];
    let mut negations: HashMap<usize, [u32; 4]> = HashMap::new();
    for (k, i) in insts.iter().enumerate() {
        if i.op != OP_SELECTION_MERGE || i.len < 3 {
            continue;
        }
        let Some(b) = insts.get(k + 1) else { continue };
        if b.op != OP_BRANCH_CONDITIONAL || b.len < 4 {
            continue;
        }
        let merge = words[i.at + 1];
        let (cond, t, f) = (words[b.at + 1], words[b.at + 2], words[b.at + 3]);
        if t == f || t == merge {
            continue;
        }
        // The true arm: one block that branches to the merge.
        let Some(&t_last) = last_of.get(&t) else {
            continue;
        };
        let branch = insts[t_last];
        if branch.op != OP_BRANCH || words[branch.at + 1] != merge {
            continue;
        }
        let undef_from_t = phis_of(merge).iter().any(|p| {
            (3..p.len)
                .step_by(2)
                .any(|j| words[p.at + j + 1] == t && undefs.contains(&words[p.at + j]))
        });
        if !undef_from_t {
            continue;
        }
        let not = bound;
        bound += 1;
        negations.insert(k, [(4 << 16) | OP_LOGICAL_NOT, bool_type, not, cond]);
        out[b.at + 1] = not;
        out[b.at + 2] = f;
        out[b.at + 3] = t;
        if b.len == 6 {
            // Branch weights follow the targets.
            out.swap(b.at + 4, b.at + 5);
        }
    }
    if negations.is_empty() {
        return Ok((out, 0));
    }
    let mut rewritten = Vec::with_capacity(out.len() + 4 * negations.len());
    rewritten.extend_from_slice(&out[..HEADER]);
    rewritten[3] = bound;
    for (k, i) in insts.iter().enumerate() {
        if let Some(not) = negations.get(&k) {
            rewritten.extend_from_slice(not);
        }
        rewritten.extend_from_slice(&out[i.at..i.at + i.len]);
    }
    Ok((rewritten, negations.len()))
}
