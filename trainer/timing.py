"""What a piece of an experiment cost: the wall-clock and CPU seconds of every sitting (one run of the
command that did some of its work) in the piece's ``timing.json``, kept across interruptions, so a study
resumed across sittings still knows what it cost (docs/experiments.md, "figure3").
"""

from __future__ import annotations

import json
import os
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from keepaway.trainer.curves import read_json, write_atomic

TIMING = "timing.json"  # each sitting's wall and CPU time in a configuration's directory (Table 2's tests too)
TIMING_REFRESH_S = 30.0  # how often a sitting under way rewrites its record: what a SIGKILL can lose


def cpu_seconds() -> float:
    """User + system CPU time of this process and of its children that have ended (the distributed and
    Ray backends' players and servers are children, the batched backend's threads this process)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


@dataclass(frozen=True)
class Timing:
    """Wall-clock and CPU seconds spent on a piece of an experiment over all its sittings (a sitting: one
    run of the command that did some of its work; an interrupted one counts what it did)."""

    wall_s: float = 0.0
    cpu_s: float = 0.0
    sittings: int = 0

    @classmethod
    def read(cls, where: Path) -> Timing:
        sittings = (read_json(where / TIMING) or {"sittings": []})["sittings"]
        return cls(sum(s["wall_s"] for s in sittings), sum(s["cpu_s"] for s in sittings), len(sittings))

    def text(self) -> str:
        return f"{self.wall_s:.0f} s wall, {self.cpu_s:.0f} s CPU over {self.sittings} sitting(s)"


@contextmanager
def timed_sitting(where: Path, refresh_s: float = TIMING_REFRESH_S) -> Iterator[None]:
    """Record this sitting's wall and CPU seconds in ``where/timing.json``: when the work inside ends, also
    when it is interrupted or fails, and every ``refresh_s`` while it runs (a sitting killed by SIGKILL or
    the machine's end then keeps what it did up to its last refresh, marked ``"running": true``). A study
    resumed across sittings still knows what it cost."""
    wall, cpu = time.perf_counter(), cpu_seconds()
    where.mkdir(parents=True, exist_ok=True)
    record = read_json(where / TIMING) or {"sittings": []}
    record["sittings"].append({})
    lock, done = threading.Lock(), threading.Event()
    ended = False  # the final record is written: a refresh still under way must not replace it

    def write(running: bool) -> None:
        nonlocal ended
        with lock:
            if ended:
                return
            record["sittings"][-1] = {"ended": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                                      "wall_s": round(time.perf_counter() - wall, 3),
                                      "cpu_s": round(cpu_seconds() - cpu, 3), **({"running": True} if running else {})}
            write_atomic(where / TIMING, json.dumps(record, indent=1).encode())
            ended = not running

    def refresh() -> None:
        while not done.wait(refresh_s):
            write(running=True)

    try:  # from the first write on: an interruption right after it still ends the sitting's record
        write(running=True)
        # An interruption inside start() can leave the thread neither unstarted nor joinable (join raises
        # RuntimeError between its ident and its start flag): the end below does not wait for it.
        threading.Thread(target=refresh, name="timing", daemon=True).start()
        yield
    finally:
        done.set()
        write(running=False)


__all__ = ["TIMING", "TIMING_REFRESH_S", "Timing", "cpu_seconds", "timed_sitting"]
