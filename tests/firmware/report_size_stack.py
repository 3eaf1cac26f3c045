#!/usr/bin/python3
"""ROM/RAM use and worst-case stack depth of every firmware image of a board.

    report_size_stack.py <board> <build-dir>/firmware [image ...]

Sizes: `arm-none-eabi-size -A` sections placed by the image's memory map
(the "Memory Configuration" of its .map file): ROM = everything loaded into
the code region (vector table, code, constants, init arrays, the load image
of .data); RAM = .data + .bss + the reserved main stack, per data region
(the STM32's three-axis image also fills AXI SRAM), each within its region.

Stack: the worst call chain, in bytes, from two roots:
  main    piezoloop_start (reset -> bsp::init -> app_main -> ...), thread mode;
  tick    piezoloop_tick_timer_isr (the control interrupt), whose indirect
          call to the registered handler is resolved to every tick handler
          the image has (ControlLoop::tick<...>, axes_tick<...>), the
          deepest counting; an image that starts the tick timer but has
          none of them fails, rather than leaving the tick out;
plus the exception frame the core pushes when the tick interrupts the main
loop (8 words, + 18 FPU words on the FPU boards (lazy stacking reserves
them), + 4 bytes of alignment). Worst total = main + frame + tick: the tick
can preempt the main loop at its deepest point. On the STM32 the tick is
the ADC's end-of-conversion interrupt (or TIM6's in loopback), whichever is
deeper, and the USB interrupt, below the tick in priority, can sit between
the two: main + frame + USB + frame + tick.
A fault taken at that point adds another frame and the fault report
(piezoloop_fault_report: one console line built on the stack); that sum is
printed as "with a fault" and must fit too.

Frame sizes and call edges come from GCC's -fstack-usage/-fcallgraph-info=su
(.ci files next to the objects, as listed by the .map's LOAD lines); what has
no .ci node (newlib, libgcc) is read from the image's disassembly: the
prologue's push/vpush/sub sp and the bl/b.w targets. Indirect calls other
than the tick handler (static constructors run once at start-up) are listed
and not followed; recursion would be reported as unbounded.

Printed for every image; the only assertions are sanity: ROM and RAM fit
their regions and the worst stack fits the reserved stack.
"""
import os
import re
import subprocess
import sys
from functools import lru_cache

# The handlers the tick interrupt calls through its pointer: the single
# axis's ControlLoop::tick<TickTiming> and the axes' axes_tick<N, TickTiming, Io>.
TICK_HANDLER_PREFIXES = ("_ZN9piezoloop2fw11ControlLoop4tickI", "_ZN9piezoloop2fw9axes_tickI")
FPU_BOARDS = {"qemu-m7", "stm32h743"}


def run(cmd):
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


def memory_regions(map_text):
    regions = []
    block = map_text.split("Memory Configuration", 1)[1].split("Linker script and memory map", 1)[0]
    for line in block.splitlines():
        m = re.match(r"^(\S+)\s+0x([0-9a-fA-F]+)\s+0x([0-9a-fA-F]+)\s*(\S*)", line)
        if m and m.group(1) != "*default*":
            regions.append((m.group(1), int(m.group(2), 16), int(m.group(3), 16), m.group(4)))
    return regions


def sections(elf):
    out = []
    for line in run(["arm-none-eabi-size", "-A", elf]).splitlines():
        m = re.match(r"^(\.\S+)\s+(\d+)\s+(\d+)", line)
        if m:
            out.append((m.group(1), int(m.group(2)), int(m.group(3))))
    return out


def region_of(regions, addr):
    for name, origin, length, attrs in regions:
        if origin <= addr < origin + length:
            return name, origin, length, attrs
    return None


def parse_ci(path):
    """nodes: title -> (bytes, qualifier); edges: list of (src, dst)."""
    nodes, edges = {}, []
    text = open(path).read()
    for m in re.finditer(r'node: \{ title: "([^"]+)" label: "([^"]*)"', text):
        size = re.search(r"\\n(\d+) bytes \(([^)]*)\)", m.group(2))
        if size:
            nodes[m.group(1)] = (int(size.group(1)), size.group(2))
    for m in re.finditer(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"', text):
        edges.append((m.group(1), m.group(2)))
    return nodes, edges


def disassembly_frames(elf):
    """symbol -> (frame bytes, [callees]) from the prologue and bl/b.w targets."""
    funcs, cur, body = {}, None, []

    def close():
        if cur is None:
            return
        frame, callees = 0, []
        for i, ins in enumerate(body):
            if i < 12:
                m = re.search(r"\b(push|stmdb)(\.w)?\s+(sp!,\s*)?\{([^}]*)\}", ins)
                if m:
                    frame += 4 * count_regs(m.group(4))
                m = re.search(r"\bvpush\s+\{([^}]*)\}", ins)
                if m:
                    frame += 8 * count_regs(m.group(1))
                m = re.search(r"\bsub(\.w)?\s+sp,\s*(sp,\s*)?#(\d+)", ins)
                if m:
                    frame += int(m.group(3))
            m = re.search(r"\b(bl|b\.w|b)\s+[0-9a-f]+ <([^>+]+)>", ins)
            if m and m.group(2) != cur:
                callees.append(m.group(2))
        funcs[cur] = (frame, callees)

    for line in run(["arm-none-eabi-objdump", "-d", "--no-show-raw-insn", elf]).splitlines():
        m = re.match(r"^[0-9a-f]+ <([^>]+)>:$", line)
        if m:
            close()
            cur, body = m.group(1), []
        elif cur is not None and line.startswith(" "):
            body.append(line)
    close()
    return funcs


def count_regs(spec):
    n = 0
    for part in spec.split(","):
        part = part.strip()
        m = re.match(r"^([rds])(\d+)-[rds](\d+)$", part)
        if m:
            n += int(m.group(3)) - int(m.group(2)) + 1
        elif part:
            n += 1
    return n


def demangle(names):
    if not names:
        return []
    return run(["c++filt"] + [n.split(":")[-1] for n in names]).splitlines()


class StackGraph:
    def __init__(self, ci_files, elf):
        self.nodes, self.edges, self.local = {}, {}, {}
        for path in ci_files:
            nodes, edges = parse_ci(path)
            self.nodes.update(nodes)
            for src, dst in edges:
                self.edges.setdefault(src, []).append(dst)
        self.asm = disassembly_frames(elf)
        self.tick_handlers = sorted(n for n in self.asm if n.startswith(TICK_HANDLER_PREFIXES))
        self.unresolved_indirect = set()
        self.dynamic = set()

    def resolve(self, name):
        if name in self.nodes:
            return name
        # A TU-local copy (static or template instance) is titled "file:sym".
        return name

    def frame(self, name):
        if name in self.nodes:
            size, qual = self.nodes[name]
            if "dynamic" in qual:
                self.dynamic.add(name)
            return size
        sym = name.split(":")[-1]
        return self.asm.get(sym, (0, []))[0]

    def callees(self, name, root_isr):
        if name in self.nodes:
            out = []
            for dst in self.edges.get(name, []):
                if dst == "__indirect_call":
                    if name == root_isr and self.tick_handlers:
                        out.extend(self.tick_handlers)
                    else:
                        self.unresolved_indirect.add(name)
                else:
                    out.append(dst)
            return out
        sym = name.split(":")[-1]
        return self.asm.get(sym, (0, []))[1]

    def worst(self, root, root_isr=None):
        """(bytes, chain) of the deepest path from root; recursion -> None."""
        on_path = set()

        @lru_cache(maxsize=None)
        def depth(name):
            if name in on_path:
                raise RecursionError(name)
            on_path.add(name)
            best, chain = 0, []
            for c in self.callees(name, root_isr):
                d, ch = depth(c)
                if d > best:
                    best, chain = d, ch
            on_path.discard(name)
            return self.frame(name) + best, [name] + chain

        try:
            return depth(root)
        except RecursionError as e:
            return None, [f"recursion through {e}"]


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    board, fw_dir = sys.argv[1], sys.argv[2]
    images = sys.argv[3:] or sorted(f[:-4] for f in os.listdir(fw_dir) if f.endswith(".elf"))
    build_root = os.path.dirname(os.path.abspath(fw_dir))
    frame = 32 + (72 if board in FPU_BOARDS else 0) + 4
    failures = 0
    print(f"board {board}: exception frame of the tick {frame} B "
          f"(8 words{' + 18 FPU words' if board in FPU_BOARDS else ''} + alignment)")
    for image in images:
        elf = os.path.join(fw_dir, image + ".elf")
        map_path = os.path.join(fw_dir, image + ".map")
        if not os.path.isfile(elf) or not os.path.isfile(map_path):
            print(f"FAIL {image}: missing {elf} or its .map (build the firmware preset first)")
            failures += 1
            continue
        map_text = open(map_path).read()
        regions = memory_regions(map_text)
        rom = stack_reserve = 0
        rom_region = None
        ram = {}  # data region -> (region, bytes)
        for name, size, addr in sections(elf):
            if size == 0 or addr == 0 and name.startswith((".debug", ".comment", ".ARM.attributes")):
                continue
            reg = region_of(regions, addr)
            if reg is None:
                continue
            if "x" in reg[3]:
                rom += size
                rom_region = reg
            else:
                ram[reg[0]] = (reg, ram.get(reg[0], (reg, 0))[1] + size)
                if name == ".data":
                    rom += size  # its load image sits in the code region
                if name == ".stack_reserve":
                    stack_reserve = size
        objs = re.findall(r"^LOAD (\S+\.obj)$", map_text, re.M)
        cis = [os.path.join(build_root, o[:-4] + ".ci") for o in objs]
        cis = [c for c in cis if os.path.isfile(c)]
        g = StackGraph(cis, elf)
        main_bytes, main_chain = g.worst("piezoloop_start")
        # The tick: the timer interrupt or (STM32, converters live) the ADC's.
        tick_bytes, tick_chain = g.worst("piezoloop_tick_timer_isr", "piezoloop_tick_timer_isr")
        if "piezoloop_adc_isr" in g.asm:
            adc_bytes, adc_chain = g.worst("piezoloop_adc_isr", "piezoloop_adc_isr")
            if adc_bytes is None or (tick_bytes is not None and adc_bytes > tick_bytes):
                tick_bytes, tick_chain = adc_bytes, adc_chain
        # Interrupts below the tick (USB): they nest between main and tick.
        low_bytes, low_chain = (0, [])
        if "piezoloop_usb_otg_fs_isr" in g.asm:
            low_bytes, low_chain = g.worst("piezoloop_usb_otg_fs_isr")
        fault_bytes, _ = g.worst("piezoloop_fault_report")
        has_tick = bool(g.tick_handlers)
        ok = True
        ram_text = ", ".join(f"{b} B of {r[2]} B ({r[0]})" for r, b in ram.values())
        line = (f"{image}: ROM {rom} B of {rom_region[2] if rom_region else '?'} B ({rom_region[0] if rom_region else '?'}), "
                f"RAM {ram_text or '?'} (incl. {stack_reserve} B reserved stack)")
        print(line)
        if rom_region is None or rom > rom_region[2] or not ram or any(b > r[2] for r, b in ram.values()):
            ok = False
            print(f"  FAIL {image}: does not fit its memory")
        if any("tick_timer_start" in n for n in g.asm) and not has_tick:
            ok = False
            print(f"  FAIL {image}: starts the tick timer, but no handler named {' or '.join(TICK_HANDLER_PREFIXES)}")
        if main_bytes is None or tick_bytes is None or fault_bytes is None or low_bytes is None:
            ok = False
            print(f"  FAIL {image}: unbounded stack: {main_chain if main_bytes is None else tick_chain}")
        else:
            total = main_bytes + (frame + tick_bytes if has_tick else 0) + (frame + low_bytes if low_chain else 0)
            with_fault = total + frame + fault_bytes
            print(f"  stack: main {main_bytes} B"
                  + (f" + USB interrupt {low_bytes} B + frame {frame} B" if low_chain else "")
                  + (f" + tick {tick_bytes} B + frame {frame} B" if has_tick else " (no control tick in this image)")
                  + f" = {total} B worst of {stack_reserve} B reserved"
                  + f" ({with_fault} B with a fault report on top)")
            print(f"    main path: {' > '.join(demangle(main_chain[:8]))}{' > ...' if len(main_chain) > 8 else ''}")
            if has_tick:
                print(f"    tick path: {' > '.join(demangle(tick_chain))}")
            if low_chain:
                print(f"    USB path: {' > '.join(demangle(low_chain[:8]))}{' > ...' if len(low_chain) > 8 else ''}")
            if with_fault > stack_reserve:
                ok = False
                print(f"  FAIL {image}: worst stack {with_fault} B exceeds the reserved {stack_reserve} B")
        if g.dynamic:
            print(f"    dynamic frames (not bounded by this estimate): {', '.join(demangle(sorted(g.dynamic)))}")
        if g.unresolved_indirect:
            print(f"    indirect calls not followed in: {', '.join(demangle(sorted(g.unresolved_indirect)))}")
        failures += 0 if ok else 1
    print(f"{len(images) - failures} passed, {failures} failed")
    return 0 if failures == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
