"""Flood benchmark (issue 12, "A hardened arena", item 1): synchronous-mode cycles per second of the real
``keepaway server`` with five minimal client processes that answer every think with one dash, without a
flood and while one client floods it with small messages:

* no flood (the baseline);
* an unseated client (connected, never sent ``init``) sending 3,000 and 30,000 ``command`` messages a
  second (each answered ``not_initialised`` within its budget, the rest dropped and counted);
* a seated player (one of the five) sending 3,000 and 30,000 extra ``command`` messages a second besides
  its answers.

Each run measures the cycles the first client sees in ``--seconds`` after ``--warm-up`` seconds of play,
on loopback, ports 0. The flooder is a process of its own and competes for the same cores as the server
and the players, so part of any slow-down is its own CPU use, not the server's handling. Other jobs on
the machine move every figure; compare the ratios of one invocation.

Run: ``python benchmarks/flood.py [--seconds S] [--warm-up W] [--repeats N]``. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import os
import selectors
import signal
import statistics
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the repository, before benchmarks/

from keepaway.runner.launch import LISTEN_RE  # noqa: E402

# A player: answers every think with one dash; with a flood rate > 0 it also sends that many extra
# commands a second (in bursts every 10 ms). The reporting player prints "start" `warm` seconds after its
# first think, then the thinks it got in the next `seconds` seconds and the time they took; it looks at
# the clock at least every 100 ms, so a frozen game is reported as such (0 thinks).
PLAYER = r'''
import sys, time, msgpack, zmq
endpoint, team, flood, warm, seconds, report = sys.argv[1:7]
flood, warm, seconds, report = float(flood), float(warm), float(seconds), report == "1"
sock = zmq.Context().socket(zmq.DEALER); sock.setsockopt(zmq.LINGER, 0); sock.connect(endpoint)
pack, unpack = msgpack.packb, msgpack.unpackb
sock.send(pack({"type": "init", "version": 1, "team": team}))
burst = max(1, round(flood / 100)); period = burst / flood if flood else None
first = start = None; counted = 0; cycle = 0; next_burst = time.monotonic()
while True:
    wait = 100 if period is None else min(100, max(0, int((next_burst - time.monotonic()) * 1000)))
    if sock.poll(wait):
        while True:
            try:
                msg = unpack(sock.recv(zmq.NOBLOCK))
            except zmq.Again:
                break
            kind = msg["type"]
            if kind == "think":
                cycle = msg["cycle"]
                sock.send(pack({"type": "command", "cycle": cycle, "commands": [["dash", 100.0]]}))
                first = first or time.monotonic()
                counted += 1
            elif kind == "shutdown":
                sys.exit(0)
    now = time.monotonic()
    if report and first is not None and start is None and now - first >= warm:
        start, counted = now, 0
        print("start", flush=True)
    if report and start is not None and now - start >= seconds:
        print(f"{counted} {now - start}", flush=True)
        report = False
    if period is not None and now >= next_burst:
        extra = pack({"type": "command", "cycle": cycle, "commands": [["turn", 1.0]]})
        for _ in range(burst):
            sock.send(extra)
        next_burst += period
'''

# An unseated client: sends ``rate`` commands a second (bursts every 10 ms) and reads the errors back.
FLOODER = r'''
import sys, time, msgpack, zmq
endpoint, rate = sys.argv[1], float(sys.argv[2])
sock = zmq.Context().socket(zmq.DEALER); sock.setsockopt(zmq.LINGER, 0); sock.connect(endpoint)
data = msgpack.packb({"type": "command", "cycle": 0, "commands": [["dash", 100.0]]})
burst = max(1, round(rate / 100)); period = burst / rate; next_burst = time.monotonic()
while True:
    for _ in range(burst):
        sock.send(data)
    next_burst += period
    while sock.poll(max(0, int((next_burst - time.monotonic()) * 1000))):
        sock.recv()
'''

TEAMS = ["keepers"] * 3 + ["takers"] * 2
START_TIMEOUT_S = 120.0  # from the server's start to the reporting player's first think


def line_within(stream, timeout_s: float) -> bytes:
    """The next line of a child's stdout pipe, stripped; b"" if none comes within ``timeout_s``."""
    with selectors.DefaultSelector() as selector:
        selector.register(stream, selectors.EVENT_READ)
        if not selector.select(timeout_s):
            return b""
    return stream.readline().strip()


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of process ``pid`` so far (Linux ``/proc``)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def cycles_per_second(unseated_rate: float, seated_rate: float, seconds: float, warm: float,
                      repo: Path = REPO) -> tuple[float, float]:
    """Cycles per second seen by the first player in the measurement window, and the server's CPU time
    per cycle in it (ms); the server is ``repo``'s."""
    server = subprocess.Popen([sys.executable, "-m", "keepaway", "server", "--players-port", "0",
                               "--coach-port", "0", "--monitor-port", "0"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=repo, start_new_session=True)
    others: list[subprocess.Popen] = []
    try:
        line = server.stdout.readline().decode()
        match = LISTEN_RE.search(line)
        if not match:
            raise RuntimeError(f"server did not start: {line!r}")
        endpoint = match.group(1)
        if unseated_rate:
            others.append(subprocess.Popen([sys.executable, "-c", FLOODER, endpoint, str(unseated_rate)], cwd=REPO))
        for i, team in enumerate(TEAMS):
            flood = seated_rate if i == len(TEAMS) - 1 else 0.0  # the last taker floods
            others.append(subprocess.Popen([sys.executable, "-c", PLAYER, endpoint, team, str(flood), str(warm),
                                            str(seconds), "1" if i == 0 else "0"],
                                           stdout=subprocess.PIPE if i == 0 else subprocess.DEVNULL, cwd=REPO))
        reporter = others[1 if unseated_rate else 0]
        if line_within(reporter.stdout, START_TIMEOUT_S + warm) != b"start":
            return 0.0, float("nan")  # the game never got going
        cpu = cpu_seconds(server.pid)
        cycles, elapsed = map(float, line_within(reporter.stdout, seconds + 30.0).split())
        ms = (cpu_seconds(server.pid) - cpu) * 1000.0 / cycles if cycles else float("nan")
        return cycles / elapsed, ms
    finally:
        if server.poll() is None:
            server.send_signal(signal.SIGTERM)
            try:
                server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
        for proc in [server, *others]:
            if proc.poll() is None:
                proc.kill()
            proc.wait()


SCENARIOS = [  # label, unseated flood rate, seated flood rate, target ratio to no flood
    ("no flood", 0, 0, None),
    ("unseated client,  3,000 msg/s", 3000, 0, 0.5),
    ("unseated client, 30,000 msg/s", 30000, 0, 0.5),
    ("seated player,    3,000 msg/s", 0, 3000, 0.8),
    ("seated player,   30,000 msg/s", 0, 30000, 0.8),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=float, default=5.0, help="length of each measurement window")
    parser.add_argument("--warm-up", type=float, default=2.0, help="seconds of play before the window")
    parser.add_argument("--repeats", type=int, default=3,
                        help="runs per scenario, interleaved; the median is shown (the machine's load drifts)")
    parser.add_argument("--repo", type=Path, default=REPO,
                        help="the checkout whose server is measured (e.g. an older one, to compare)")
    opts = parser.parse_args()
    rates: dict[str, list[float]] = {label: [] for label, *_ in SCENARIOS}
    cpu: dict[str, list[float]] = {label: [] for label, *_ in SCENARIOS}
    for _ in range(opts.repeats):
        for label, unseated, seated, _target in SCENARIOS:
            rate, ms = cycles_per_second(unseated, seated, opts.seconds, opts.warm_up, opts.repo)
            rates[label].append(rate)
            cpu[label].append(ms)
    print("synchronous mode, 5 minimal players answering every think with one dash: cycles/s (median of "
          f"{opts.repeats} runs, all in brackets) and the server's CPU time per cycle (median)")
    base = statistics.median(rates["no flood"])
    for label, _unseated, _seated, target in SCENARIOS:
        rate = statistics.median(rates[label])
        runs = ", ".join(f"{r:,.0f}" for r in rates[label])
        ratio = "" if target is None else f"{rate / base:4.0%} of no flood (target >= {target:.0%})"
        print(f"    {label:30s} {rate:7,.0f}  {statistics.median(cpu[label]):5.2f} ms/cycle  {ratio:34s} [{runs}]")


if __name__ == "__main__":
    main()
