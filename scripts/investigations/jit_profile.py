#!/usr/bin/env python3
"""Summary of a scripts/investigations/jit_profile.sh folder: the share of samples in the JIT code, its loops
(backward jumps; nested loops are listed each), the hottest straight-line blocks, and the
instruction mix of the hottest block, with the samples that land after each kind of instruction
(perf's skid puts a sample on the instruction after the one that stalled).
Usage: scripts/investigations/jit_profile.py OUT_DIR [BLOCKS]"""
import bisect, collections, re, sys

out = sys.argv[1]
top = int(sys.argv[2]) if len(sys.argv) > 2 else 12
ins = []
for line in open(f"{out}/dis.txt"):
    m = re.match(r"\s*([0-9a-f]+):\s+((?:[0-9a-f]{2} )+)\s*(.*)", line)
    if m and m.group(3).strip():
        ins.append((int(m.group(1), 16), m.group(3).strip()))
samples, total = collections.Counter(), 0
for line in open(f"{out}/ips.txt"):
    count, addr, dso = line.split()[:3]
    total += int(count)
    if "perf-" in dso or "JIT" in dso:
        samples[int(addr, 16)] += int(count)
jit = sum(samples.values()) or 1
addrs = [a for a, _ in ins]
print(f"samples: {total}, in JIT code {jit} ({100 * jit / max(total, 1):.1f} %), {len(ins)} instructions")

def span(lo, hi):
    i0, i1 = bisect.bisect_left(addrs, lo), bisect.bisect_right(addrs, hi)
    return range(i0, i1)

print("\nloops (first, last address; instructions; calls; share of JIT samples):")
for a, t in ins:
    m = re.match(r"(j\w+)\s+0x([0-9a-f]+)", t)
    if m and int(m.group(2), 16) < a:
        r = span(int(m.group(2), 16), a)
        share = sum(samples.get(addrs[i], 0) for i in r) / jit
        if len(r) > 15 and share > 0.005:
            calls = sum(ins[i][1].startswith("call") for i in r)
            print(f"  {int(m.group(2), 16):x}..{a:x} {len(r):5d} ins {calls:2d} calls {100 * share:5.1f} %")

targets = {int(m.group(1), 16) for _, t in ins for m in [re.match(r"j\w+\s+0x([0-9a-f]+)", t)] if m}
blocks, cur = [], None
for a, t in ins:
    if cur is None or a in targets:
        cur = [a, a, 0, 0]
        blocks.append(cur)
    cur[1], cur[3], cur[2] = a, cur[3] + 1, cur[2] + samples.get(a, 0)
    if t.startswith("j") or t.startswith("ret"):
        cur = None
blocks.sort(key=lambda b: -b[2])
print("\nhottest blocks (straight-line code between jumps):")
for b in blocks[:top]:
    print(f"  {b[0]:x}..{b[1]:x} {b[3]:5d} ins {100 * b[2] / jit:5.1f} %")

b = blocks[0]
r = span(b[0], b[1])
mix, cost = collections.Counter(), collections.Counter()
for k, i in enumerate(r):
    op = ins[i][1].split()[0]
    args = ins[i][1].split(None, 1)[1] if " " in ins[i][1] else ""
    if op.startswith("vmov"):
        op += "-store" if "(" in args.split(",")[-1] else "-load" if "(" in args else "-reg"
    mix[op] += 1
    if k + 1 < len(r):
        cost[op] += samples.get(addrs[r[k + 1]], 0)
print(f"\nhottest block {b[0]:x}: instruction mix (count, samples after it)")
for op, n in mix.most_common(14):
    print(f"  {op:18s} {n:4d} {100 * cost[op] / max(b[2], 1):5.1f} %")
