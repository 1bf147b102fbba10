#!/usr/bin/env python3
"""Worst-case stack depth of a Thumb firmware image, from its machine code.

For every function symbol, the frame is read from the prologue (push/push.w: 4 bytes
per register, vpush: 8 bytes per d register, sub sp by an immediate or by a register
loaded with movw/movt just before); the call graph from its bl / b.w / b targets that
are function entries. The deepest path from the entry symbol adds the frames along it.
Indirect calls (blx rN) are reported, since they are not followed.

usage: stack_depth.py IMAGE [ENTRY]     (needs llvm-objdump and llvm-nm on PATH)
"""
import re
import struct
import subprocess
import sys
from functools import lru_cache

image = sys.argv[1]
entry = sys.argv[2] if len(sys.argv) > 2 else "lfdepth_reset"

elf = open(image, "rb").read()
shoff, = struct.unpack_from("<I", elf, 0x20)
shentsize, shnum = struct.unpack_from("<HH", elf, 0x2E)
sections = []  # (address, size, file offset) of loaded sections with contents
for i in range(shnum):
    _, kind, flags, addr, off, size = struct.unpack_from("<IIIIII", elf, shoff + i * shentsize)
    if flags & 2 and kind != 8:
        sections.append((addr, size, off))


def word(addr):
    """The 32-bit word at `addr` (a literal-pool load)."""
    for base, size, off in sections:
        if base <= addr < base + size:
            return struct.unpack_from("<i", elf, off + addr - base)[0]
    return 0


symbols = {}  # address -> name
for line in subprocess.run(["llvm-nm", "--defined-only", "-C", image], capture_output=True,
                           text=True, check=True).stdout.splitlines():
    parts = line.split(" ", 2)
    if len(parts) == 3 and parts[1] in "tTwW":
        symbols[int(parts[0], 16) & ~1] = parts[2]

dis = subprocess.run(["llvm-objdump", "-d", "--no-show-raw-insn", "--triple=thumbv7em", image],
                     capture_output=True, text=True, check=True).stdout
insn = re.compile(r"^\s*([0-9a-f]+):\s+(\S+)\s*(.*)$")
body = {}  # function address -> list of (mnemonic, operands)
current = None
for line in dis.splitlines():
    m = insn.match(line)
    if not m:
        continue
    addr = int(m.group(1), 16)
    if addr in symbols:
        current = addr
        body[current] = []
    if current is not None:
        body[current].append((m.group(2), m.group(3)))


def registers(operands):
    inside = operands[operands.find("{") + 1:operands.find("}")]
    count = 0
    for item in inside.split(","):
        item = item.strip()
        if "-" in item:
            a, b = item.split("-")
            count += int(b[1:]) - int(a[1:]) + 1
        elif item:
            count += 1
    return count


def frame(code):
    size, consts = 0, {}
    for mnemonic, ops in code[:24]:
        base = mnemonic.split(".")[0]
        if base == "push":
            size += 4 * registers(ops)
        elif base == "vpush":
            size += 8 * registers(ops)
        elif base in ("movw", "mov") and "#" in ops:
            reg = ops.split(",")[0].strip()
            value = ops.split("#")[1].split()[0]
            consts[reg] = int(value, 0)
        elif base == "ldr" and "[pc" in ops and "@ 0x" in ops:
            # Thumb-1 frames beyond 508 bytes: ldr rN, =-size ; add sp, rN
            reg = ops.split(",")[0].strip()
            consts[reg] = -word(int(ops.split("@ 0x")[1].split()[0], 16))
        elif base == "add" and ops.startswith("sp, r"):
            size += consts.get(ops.split(",")[-1].strip(), 0)
        elif base == "movt" and "#" in ops:
            reg = ops.split(",")[0].strip()
            consts[reg] = consts.get(reg, 0) | (int(ops.split("#")[1].split()[0], 0) << 16)
        elif base in ("sub", "subw") and ops.startswith("sp"):
            if "#" in ops:
                size += int(ops.split("#")[1].split()[0], 0)
            else:
                reg = ops.split(",")[-1].strip()
                size += consts.get(reg, 0)
    return size


calls, indirect = {}, {}
for addr, code in body.items():
    targets = set()
    for mnemonic, ops in code:
        base = mnemonic.split(".")[0]
        if base in ("bl", "b", "blx") and ops.startswith("0x"):
            t = int(ops.split()[0], 16) & ~1
            if t in symbols and t != addr:
                targets.add(t)
        elif base == "blx":
            indirect[addr] = indirect.get(addr, 0) + 1
    calls[addr] = targets


@lru_cache(maxsize=None)
def deepest(addr, depth=0):
    if depth > 64:
        raise SystemExit("recursion: " + symbols[addr])
    best, path = 0, ()
    for t in calls.get(addr, ()):
        d, p = deepest(t, depth + 1)
        if d > best:
            best, path = d, p
    own = frame(body.get(addr, []))
    return own + best, ((symbols[addr], own),) + path


start = next(a for a, n in symbols.items() if n == entry)
total, path = deepest(start)
print(f"deepest stack from {entry}: {total} bytes")
for name, own in path:
    print(f"  {own:6d}  {name[:110]}")
reached = set()
todo = [start]
while todo:
    a = todo.pop()
    if a not in reached:
        reached.add(a)
        todo.extend(calls.get(a, ()))
ind = {symbols[a]: n for a, n in indirect.items() if a in reached}
print("indirect calls not followed:", ind if ind else "none")
