"""Instructions executed per step interrupt of the QEMU image, counted by QEMU.

    PYTHONPATH=<repo> .venv/bin/python firmware/tools/isr_insns.py \
        firmware/build/arm/netduinoplus2.elf [REPO_ROOT]

Runs ``tests/qemu_job.py`` (the QEMU job: lines, an arc, M3/M4, a dwell) with
QEMU logging, without ``-icount`` so that every translated block runs whole:

* ``in_asm``: each translated block (TB) and its instructions, once;
* ``exec,nochain``: every TB run, by its guest address (a TB whose run was
  stopped before it started is logged as such and not counted);
* ``int``: exception entry and return, which bound each interrupt.

``-dfilter`` keeps the TBs of the functions reachable from the handler (a
static call graph from ``arm-none-eabi-objdump``), so the log stays small.
An interrupt is the handler's exception (15, SysTick, in the QEMU build) from
its entry to its return; a UART interrupt nested in it is not counted. The
log goes through a FIFO and is read as it is written.

Prints the number of interrupts, the largest count and the functions of that
interrupt's path, and the count's percentiles. Instructions, not cycles: a
Cortex-M4 takes 1 cycle for most, 2 to 3 for loads/stores and taken branches,
12 for the exception entry and 10 for the return.
"""
from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import threading
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent

_FUNC = re.compile(r"^([0-9a-f]{8}) <([^>]+)>:$")
_CALL = re.compile(r"\s(?:bl|b\.w|b|b\.n)\s+([0-9a-f]+) <([^>+]+)>")
_TRACE = re.compile(r"^Trace \d+: \S+ \[[0-9a-f]+/([0-9a-f]+)/")
_STOPPED = re.compile(r"^Stopped execution of TB chain before \S+ \[([0-9a-f]+)\]")
_INSN = re.compile(r"^0x([0-9a-f]{8}):\s")
_ENTRY = re.compile(r"^\.\.\.taking pending (?:nonsecure |secure )?exception (\d+)")
_RETURN = re.compile(r"^Exception return: magic PC \S+ previous exception (\d+)")


def functions(elf: str) -> dict[str, tuple[int, int, set[str]]]:
    """Each text function's (start, end, callees) from the disassembly."""
    text = subprocess.run(["arm-none-eabi-objdump", "-d", elf], check=True,
                          capture_output=True, text=True).stdout
    out: dict[str, tuple[int, int, set[str]]] = {}
    name, start, last, callees = None, 0, 0, set()
    for line in text.splitlines():
        m = _FUNC.match(line)
        if m:
            if name:
                out[name] = (start, last, callees)
            name, start, last, callees = m.group(2), int(m.group(1), 16), int(m.group(1), 16), set()
            continue
        parts = line.split(":", 1)
        if name and len(parts) == 2 and parts[0].strip() and all(
                c in "0123456789abcdef" for c in parts[0].strip()):
            last = int(parts[0].strip(), 16) + 4
            c = _CALL.search(line)
            if c and c.group(2) != name:
                callees.add(c.group(2))
    if name:
        out[name] = (start, last, callees)
    return out


def reachable(funcs, root: str) -> list[str]:
    seen, todo = set(), [root]
    while todo:
        f = todo.pop()
        if f in seen or f not in funcs:
            continue
        seen.add(f)
        todo.extend(funcs[f][2])
    return sorted(seen)


def count(log_path: str, exception: int):
    """Read the QEMU log; return the instruction count of each interrupt and the worst's path."""
    tb_len: dict[int, int] = {}
    counts: list[int] = []
    worst_path: list[int] = []
    cur_tb = None
    stack: list[int] = []   # exceptions being handled, innermost last
    n = 0
    path: list[int] = []
    last_pc = None
    with open(log_path, errors="replace") as log:
        for line in log:
            if line.startswith("Trace"):
                m = _TRACE.match(line)
                pc = int(m.group(1), 16)
                if stack and stack[-1] == exception:
                    n += tb_len.get(pc, 0)
                    if pc not in tb_len:
                        raise SystemExit(f"TB at {pc:#x} run before its translation was logged")
                    path.append(pc)
                    last_pc = pc
                continue
            if line.startswith("Stopped"):
                pc = int(_STOPPED.match(line).group(1), 16)
                if stack and stack[-1] == exception and last_pc == pc:
                    n -= tb_len[pc]     # logged, never run
                    path.pop()
                    last_pc = None
                continue
            if line.startswith("IN:"):
                cur_tb = None
                continue
            m = _INSN.match(line)
            if m:
                pc = int(m.group(1), 16)
                if cur_tb is None:
                    cur_tb = pc
                    tb_len[cur_tb] = 0
                tb_len[cur_tb] += 1
                continue
            if not line.strip():
                cur_tb = None
                continue
            m = _ENTRY.match(line)
            if m:
                stack.append(int(m.group(1)))
                if stack[-1] == exception:
                    n, path, last_pc = 0, [], None
                continue
            m = _RETURN.match(line)
            if m and stack:
                done = stack.pop()
                if done == exception:
                    counts.append(n)
                    if n >= max(counts):
                        worst_path = list(path)
    return counts, worst_path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("elf")
    ap.add_argument("root", nargs="?", default=str(HERE.parents[1]))
    ap.add_argument("--handler", default="SysTick_Handler")
    ap.add_argument("--exception", type=int, default=15)
    args = ap.parse_args()
    funcs = functions(args.elf)
    reach = reachable(funcs, args.handler)
    ranges = ",".join(f"{funcs[f][0]:#x}..{funcs[f][1] - 1:#x}" for f in reach)
    tmp = tempfile.mkdtemp(prefix="labkit-isr-")
    fifo = os.path.join(tmp, "qemu.log")
    os.mkfifo(fifo)
    result = {}

    def reader():
        result["v"] = count(fifo, args.exception)

    t = threading.Thread(target=reader)
    t.start()
    env = dict(os.environ, QEMU_EXTRA=f"-d in_asm,exec,nochain,int -dfilter {ranges} -D {fifo}")
    env["PYTHONPATH"] = args.root
    job = subprocess.run([sys.executable, str(HERE.parent / "tests" / "qemu_job.py"), args.elf,
                          args.root], env=env, capture_output=True, text=True)
    t.join()
    os.unlink(fifo)
    os.rmdir(tmp)
    if job.returncode != 0:
        print(job.stdout + job.stderr, file=sys.stderr)
        return 1
    counts, path = result["v"]
    if not counts:
        print("no interrupt counted", file=sys.stderr)
        return 1
    # name each TB of the worst path by the function holding it
    starts = sorted((funcs[f][0], funcs[f][1], f) for f in reach)

    def owner(pc: int) -> str:
        for s, e, f in starts:
            if s <= pc < e:
                return f
        return hex(pc)

    print(f"functions reachable from {args.handler}: {', '.join(reach)}")
    c = sorted(counts)
    print(f"interrupts counted: {len(c)}")
    print(f"instructions per interrupt: max {c[-1]}, p99.9 {c[int(0.999 * (len(c) - 1))]}, "
          f"p99 {c[int(0.99 * (len(c) - 1))]}, median {c[len(c) // 2]}, min {c[0]}")
    seen = Counter(owner(p) for p in path)
    print("worst interrupt, TBs per function: " + ", ".join(f"{f} {k}" for f, k in seen.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
