"""Where the batched game's time goes, by compiled kernel: a flat ``perf`` profile with numba's symbols.

``perf`` alone names numba's compiled functions ``[unknown]``: they live in memory that LLVM's JIT
filled, with no symbol file. gdb learns their names through the JIT interface numba registers them
with, so this script plays 64 hand-coded arenas (``benchmarks/arena_batched.py``'s game) in a child
process, samples it with ``perf record`` once its kernels are loaded, asks gdb for the child's minimal
symbols (``maint print msymbols``), and files each unnamed sample under the JIT symbol whose range holds
its address. With ``--callers FUNC`` it records call graphs instead and prints who calls ``FUNC`` (a
libm function such as ``hypot``: perf unwinds libm, and the return address names the kernel; in this
mode fewer samples land in libm than in the flat profile, so compare its shares with each other only).

Needs Linux ``perf`` (perf_event_paranoid <= 2 for your own processes) and ``gdb``; measures nothing
else. Run: ``python benchmarks/profile.py [--seconds S] [--pass P] [--getopen G] [--callers FUNC]``.
"""

from __future__ import annotations

import argparse
import bisect
import collections
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

# The child: load the kernels, say so, then play until killed.
_GAME = """
import os, sys
os.environ.setdefault("NUMBA_NUM_THREADS", "1")
sys.path.insert(0, {repo!r})
from keepaway.protocol.params import parameter_set
from keepaway.runner.batched import BatchedArenas
arenas = BatchedArenas(parameter_set("classic"), 64, 0, pass_policy={pass_policy!r},
                       getopen_policy={getopen_policy!r}, threads=1)
arenas.run(max_cycles=1)
print("ready", flush=True)
while True:
    arenas.run(max_cycles=1000)
"""

_MSYMBOL = re.compile(r"\[\s*\d+\]\s+\S+\s+0x([0-9a-f]+)\s+(\S+)")
_NUMBA_NAME = re.compile(r"^_ZN((?:\d+\w+?)+?)B\d+v\d+")


class SymbolMap:
    """Start addresses and names of the minimal symbols gdb printed, to name an address by."""

    def __init__(self, msymbols_text: str) -> None:
        pairs = sorted((int(m.group(1), 16), m.group(2)) for m in map(_MSYMBOL.match, msymbols_text.splitlines())
                       if m)
        self.starts = [start for start, _ in pairs]
        self.names = [name for _, name in pairs]

    def name(self, address: int) -> str:
        """The symbol at or below ``address``, numba's mangling read back into ``module.function``."""
        i = bisect.bisect_right(self.starts, address) - 1
        return readable(self.names[i]) if i >= 0 else "?"


def readable(symbol: str) -> str:
    """``_ZN8keepaway6agents12interception6travelB4v253B36...`` -> ``keepaway.agents.interception.travel``; other names
    unchanged."""
    m = _NUMBA_NAME.match(symbol)
    if not m:
        return symbol
    parts, rest = [], m.group(1)
    while rest:
        size = re.match(r"\d+", rest)
        if not size:
            break
        n, rest = int(size.group()), rest[size.end():]
        parts.append(rest[:n])
        rest = rest[n:]
    return ".".join(parts)


def samples_of(script_text: str, stacks: bool) -> list[list[tuple[int, str]]]:
    """``perf script -F ip,sym`` output: one list of (address, symbol) frames per sample, innermost first.
    Without call graphs (``stacks`` false) each line is a sample; with them a blank line ends each."""
    samples, frames = [], []
    for line in script_text.splitlines():
        fields = line.split(maxsplit=1)
        if fields:
            try:
                frames.append((int(fields[0], 16), fields[1] if len(fields) > 1 else ""))
            except ValueError:
                pass
        if frames and (not fields or not stacks):
            samples.append(frames)
            frames = []
    if frames:
        samples.append(frames)
    return samples


def frame_name(address: int, symbol: str, symbols: SymbolMap) -> str:
    """The name perf gave a frame, or the JIT symbol holding its address where perf had none."""
    return symbols.name(address) if not symbol or "[unknown]" in symbol else symbol.split("+0x")[0]


def flat_profile(samples: list[list[tuple[int, str]]], symbols: SymbolMap) -> collections.Counter:
    return collections.Counter(frame_name(*frames[0], symbols) for frames in samples)


def callers_of(function: str, samples: list[list[tuple[int, str]]], symbols: SymbolMap) -> collections.Counter:
    """Of the samples inside ``function`` (any frame of libm's whose name holds it, e.g. a wrapper and
    its ``__ieee754_`` body), the first frame outside it."""
    counts: collections.Counter = collections.Counter()
    for frames in samples:
        if function not in frames[0][1]:
            continue
        outside = [frame for frame in frames if function not in frame[1]]
        counts[frame_name(*outside[0], symbols) if outside else "(unwound no further)"] += 1
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=15.0, help="seconds sampled")
    parser.add_argument("--pass", dest="pass_policy", default="handcoded")
    parser.add_argument("--getopen", dest="getopen_policy", default="handcoded")
    parser.add_argument("--callers", metavar="FUNC", help="print who calls FUNC (e.g. hypot) instead")
    parser.add_argument("--top", type=int, default=40)
    opts = parser.parse_args()
    game = _GAME.format(repo=str(HERE.parent), pass_policy=opts.pass_policy, getopen_policy=opts.getopen_policy)
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "perf.data")
        child = subprocess.Popen([sys.executable, "-c", game], stdout=subprocess.PIPE, text=True)
        try:
            if child.stdout.readline().strip() != "ready":
                sys.exit("profile: the game did not start")
            time.sleep(1.0)
            graph = ["--call-graph", "dwarf,4096"] if opts.callers else []
            subprocess.run(["perf", "record", "-F", "499", *graph, "-p", str(child.pid), "-o", data, "--",
                            "sleep", str(opts.seconds)], check=True, capture_output=True)
            msyms = os.path.join(tmp, "msymbols.txt")
            subprocess.run(["gdb", "-p", str(child.pid), "-batch", "-ex", f"maint print msymbols {msyms}"],
                           check=True, capture_output=True)
            symbols = SymbolMap(Path(msyms).read_text())
        finally:
            child.kill()
            child.wait()
        script = subprocess.run(["perf", "script", "-i", data, "-F", "ip,sym"], check=True, capture_output=True,
                                text=True).stdout
    samples = samples_of(script, stacks=bool(opts.callers))
    counts = callers_of(opts.callers, samples, symbols) if opts.callers else flat_profile(samples, symbols)
    what = f"callers of {opts.callers}" if opts.callers else "flat profile"
    print(f"P:{opts.pass_policy}-GO:{opts.getopen_policy}, 64 arenas, one thread, {len(samples)} samples; {what}, "
          f"share of all samples:")
    for name, count in counts.most_common(opts.top):
        print(f"{100.0 * count / len(samples):6.1f} %  {name}")


if __name__ == "__main__":
    main()
