#!/usr/bin/env python3
"""Instruction profile of a firmware image under QEMU mps2-an386: executed instructions per
function, and per caller for the small helpers (sqrtf, fmaxf, compiler-builtins, ...).

QEMU has no profiler here; its execution log does the job. With `-d in_asm,exec,nochain`
QEMU logs every translated block (its instructions) and every block it executes (its start
address and function name). Under `-icount shift=0` blocks are short and every executed
instruction is counted once, so the sums are the instruction counts the benchmark reads off
SysTick, split by function (inlined code counts for the function it was inlined into).

    firmware/qemu-profile.py target/thumbv7em-none-eabihf/release/bench
    firmware/qemu-profile.py ELF --from fit_wall --to _defmt_acquire   # one window only
    firmware/qemu-profile.py ELF --log /tmp/trace.log --keep           # reuse a trace

The trace is large (about 1.5 GB for the 40-scan benchmark) and goes to a temporary file
unless --log is given. The map flash region (map and start pose) is loaded as qemu-run.sh
does.
"""
import argparse
import collections
import glob
import os
import subprocess
import sys
import tempfile

HELPERS = ("sqrtf", "fmaxf", "fminf", "floorf", "hypotf", "__aeabi", "compiler_builtins")


def run_qemu(elf, log):
    loader = []
    outs = sorted(glob.glob(os.path.join(os.path.dirname(elf), "build/firmware-testbench-*/out")),
                  key=os.path.getmtime)
    if outs:
        loader = ["-device", f"loader,file={outs[-1]}/map.bin,addr=0x00300000",
                  "-device", f"loader,file={outs[-1]}/start_pose.bin,addr=0x003FF000"]
    cmd = ["qemu-system-arm", "-machine", "mps2-an386", "-nographic",
           "-semihosting-config", "enable=on,target=native", "-icount", "shift=0",
           "-serial", "null", *loader, "-d", "in_asm,exec,nochain", "-D", log, "-kernel", elf]
    subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=600,
                   check=False)


def profile(log, start, stop):
    block_len = {}
    pc, n = None, 0
    per_fn = collections.Counter()
    per_helper = collections.Counter()
    caller = None
    counting = start is None
    with open(log, errors="replace") as f:
        for line in f:
            if line.startswith("0x"):
                if pc is None:
                    pc = int(line[:10], 16)
                n += 1
            elif line.startswith("IN:"):
                pc, n = None, 0
            elif line.startswith("Trace"):
                if pc is not None:
                    block_len[pc] = n
                    pc, n = None, 0
                close = line.index("]")
                name = line[close + 2:].strip()
                if not counting:
                    counting = start in name
                    if not counting:
                        continue
                elif stop is not None and stop in name:
                    break
                block = int(line[line.index("[") + 1:close].split("/")[1], 16)
                cost = block_len.get(block, 0)
                per_fn[name] += cost
                helper = next((h for h in HELPERS if h in name), None)
                if helper:
                    per_helper[(helper, caller)] += cost
                else:
                    caller = name
    return per_fn, per_helper


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("elf")
    ap.add_argument("--from", dest="start", help="count from the first block of this symbol")
    ap.add_argument("--to", dest="stop", help="stop at the first block of this symbol after it")
    ap.add_argument("--log", help="trace file (default: a temporary file)")
    ap.add_argument("--keep", action="store_true", help="keep and reuse the trace file")
    ap.add_argument("--top", type=int, default=30)
    a = ap.parse_args()
    log = a.log or tempfile.mktemp(suffix=".qemu-trace")
    if not (a.keep and os.path.exists(log)):
        run_qemu(a.elf, log)
    try:
        per_fn, per_helper = profile(log, a.start, a.stop)
    finally:
        if not a.keep:
            os.remove(log)
    total = sum(per_fn.values())
    print(f"{total} instructions executed")
    for name, n in per_fn.most_common(a.top):
        print(f"{n:12d} {100 * n / max(total, 1):5.1f}%  {name[:140]}")
    print("\nhelpers by caller:")
    for (helper, caller), n in per_helper.most_common(12):
        print(f"{n:12d}  {helper} <- {str(caller)[:120]}")


if __name__ == "__main__":
    sys.exit(main())
