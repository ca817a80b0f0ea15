"""Server benchmarks: the simulation server and the protocol.

(a) batched physics + perception throughput, arena-cycles per second, batch 1 (baseline) and 1024, one
    core: every cycle every player dashes or turns, and each player gets a see on 2 of 3 cycles; cycles
    run in compiled chunks of 100, as the batched mode runs them. (``benchmarks/players.py`` also
    measures it with the aural sensor: every player says 10 characters every cycle, as in the game, and
    the server delivers the hears.)
(b) synchronous-mode cycles per second of the real ``keepaway server`` process with five minimal client
    processes that answer every think with one dash; baseline in the same invocation: a bare ZeroMQ
    ROUTER loop doing the same message exchange with no simulation (the ceiling of a server and clients
    in Python), and the same loop in C (``benchmarks/bare_loop.c``: libzmq alone, the ceiling of any
    design over ZeroMQ on this machine; built with the C compiler if there is one).

Run: ``python benchmarks/server.py [--cycles N] [--seconds S]``. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import ctypes.util
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from keepaway.agents.say import new_talk  # noqa: E402
from keepaway.core.jit import borrowing  # noqa: E402
from keepaway.core.objects import CMD_DASH, CMD_TURN  # noqa: E402
from keepaway.protocol.params import parameter_set  # noqa: E402
from keepaway.runner.batched import deliver_says  # noqa: E402
from keepaway.runner.launch import LISTEN_RE  # noqa: E402
from keepaway.server.perception import SeeBuffers, SenseBodyBuffers, see_batch, sense_body_batch  # noqa: E402
from keepaway.server.referee import new_referee_state, start_game  # noqa: E402
from keepaway.server.simulation import new_causes, simulate_cycle  # noqa: E402
from keepaway.server.world import Commands, new_world  # noqa: E402

SAY_LENGTH = 10  # characters: what the hand-coded players say every cycle (9-10, measured in the game)


@borrowing(cache=False)
def _server_cycles(first: int, n: int, w, c, r, kp, causes, width, due_patterns, mains, args, body_out,
                   see_out, talk, hear_scratch, hear) -> None:
    """Cycles ``first .. first + n - 1`` of :func:`batched_throughput`, compiled: no Python between
    cycles, as in the batched mode's chunks, and without numba's reference counting, as the batched
    mode's ``run_chunk`` (with them, this loop's own counts took 13 % of the time on a first-generation
    EPYC)."""
    for i in range(first, first + n):
        k = i % mains.shape[0]
        for b in range(mains.shape[1]):
            for o in range(mains.shape[2]):
                c.main[b, o] = mains[k, b, o]
                c.arg1[b, o] = args[k, b, o]
        simulate_cycle(w, c, r, kp, causes)
        if hear:
            for b in range(w.pos.shape[0]):
                deliver_says(b, w, talk, kp, hear_scratch)
        sense_body_batch(w, body_out)
        see_batch(w, width, due_patterns[i % 3], kp, see_out)


def batched_throughput(batch: int, seconds: float, chunk: int = 100, hear: bool = False) -> float:
    """Arena-cycles per second of simulate_cycle + sense_body + see (2 of 3 cycles) for ``batch`` arenas,
    ``chunk`` cycles per compiled call; with ``hear``, every player also says a 10-character message every
    cycle and the server delivers them after the step, as the batched mode does (``deliver_says``)."""
    params = parameter_set("classic")
    kp = params.kernel()
    w = new_world(params, 3, 2, batch=batch, seed=1)
    w.enabled[:] = True
    r = new_referee_state(batch)
    for b in range(batch):
        start_game(b, w, r, kp)
    c = Commands.empty(batch, w.n_objects)
    see_out = SeeBuffers.empty(batch, w.n_objects, kp)
    body_out = SenseBodyBuffers.empty(batch, w.n_objects)
    causes = new_causes(batch)
    width = np.ones((batch, w.n_objects - 1))
    due_patterns = np.zeros((3, batch, w.n_objects - 1), dtype=np.bool_)
    due_patterns[0] = True
    due_patterns[2] = True
    rng = np.random.default_rng(0)
    mains = rng.choice([CMD_DASH, CMD_TURN], size=(64, batch, w.n_objects)).astype(np.int8)
    args = rng.uniform(-100, 100, size=(64, batch, w.n_objects))
    talk = new_talk(batch * (w.n_objects - 1))
    talk.said_len[:] = SAY_LENGTH
    talk.said[:, :SAY_LENGTH] = rng.integers(0, 10, size=(talk.said.shape[0], SAY_LENGTH))
    hear_scratch = np.zeros((2, talk.said.shape[0]), dtype=np.int64)
    state = (w, c, r, kp, causes, width, due_patterns, mains, args, body_out, see_out, talk, hear_scratch, hear)
    _server_cycles(0, 3, *state)  # compile / load the cache
    cycles, start = 3, time.perf_counter()
    while time.perf_counter() - start < seconds:
        _server_cycles(cycles, chunk, *state)
        cycles += chunk
    return (cycles - 3) * batch / (time.perf_counter() - start)


MINIMAL_CLIENT = r'''
import sys, time, msgpack, zmq
endpoint, team = sys.argv[1], sys.argv[2]
sock = zmq.Context().socket(zmq.DEALER); sock.setsockopt(zmq.LINGER, 0); sock.connect(endpoint)
sock.send(msgpack.packb({"type": "init", "version": 1, "team": team}))
pack, unpack = msgpack.packb, msgpack.unpackb
first = None; cycles = 0
while True:
    msg = unpack(sock.recv())
    kind = msg["type"]
    if kind == "think":
        if first is None: first = time.perf_counter()
        cycles += 1
        sock.send(pack({"type": "command", "cycle": msg["cycle"], "commands": [["dash", 100.0]]}))
    elif kind == "shutdown":
        break
elapsed = time.perf_counter() - first
print(f"{cycles} {elapsed}", flush=True)
'''

NULL_SERVER = (r'''
import sys, msgpack, zmq
n_players, cycles = int(sys.argv[1]), int(sys.argv[2])
sock = zmq.Context().socket(zmq.ROUTER); sock.setsockopt(zmq.LINGER, 0)
port = sock.bind_to_random_port("tcp://127.0.0.1")
print(f"keepaway server listening players=tcp://127.0.0.1:{port} coach=tcp://127.0.0.1:0 '''
               r'''monitor=tcp://127.0.0.1:0", flush=True)
pack, unpack = msgpack.packb, msgpack.unpackb
ids = []
while len(ids) < n_players:
    ident, data = sock.recv_multipart(); unpack(data); ids.append(ident)
    sock.send_multipart([ident, pack({"type": "init_ok", "cycle": 0})])
for t in range(cycles):
    for ident in ids:
        sock.send_multipart([ident, pack({"type": "sense_body", "cycle": t, "speed": [0.0, 0]})])
        sock.send_multipart([ident, pack({"type": "think", "cycle": t})])
    answered = 0
    while answered < n_players:
        ident, data = sock.recv_multipart(); unpack(data); answered += 1
for ident in ids:
    sock.send_multipart([ident, pack({"type": "shutdown", "cycle": cycles, "reason": "done"})])
''')


def sync_cycles_per_second(server_args: list[str], n_players: int = 5) -> float:
    """Cycles per second seen by the first minimal client (from its first think to the shutdown)."""
    server = subprocess.Popen(server_args, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=REPO,
                              start_new_session=True)
    clients: list[subprocess.Popen] = []
    try:
        line = server.stdout.readline().decode()
        match = LISTEN_RE.search(line)
        if not match:
            raise RuntimeError(f"server did not start: {line!r}")
        teams = (["keepers"] * 3 + ["takers"] * 2)[:n_players]
        clients = [subprocess.Popen([sys.executable, "-c", MINIMAL_CLIENT, match.group(1), team],
                                    stdout=subprocess.PIPE, cwd=REPO) for team in teams]
        cycles, elapsed = map(float, clients[0].communicate(timeout=600)[0].split())
        server.wait(timeout=60)
        return cycles / elapsed
    finally:
        for proc in [server, *clients]:
            if proc.poll() is None:
                proc.kill()
                proc.wait()


def _libzmq_link_args() -> list[str] | None:
    """How to link the libzmq pyzmq uses: its wheel's bundled copy (by path, found again at run time), else
    the system's; None if there is neither."""
    import zmq

    bundled = sorted((Path(zmq.__file__).resolve().parent.parent / "pyzmq.libs").glob("libzmq*.so*"))
    if bundled:
        return [str(bundled[0]), f"-Wl,-rpath,{bundled[0].parent}"]
    return ["-lzmq"] if ctypes.util.find_library("zmq") else None


def c_loop(cycles: int) -> tuple[float, float] | str:
    """(cycles per second, CPU ms per cycle of the server and its clients) of ``bare_loop.c``, built in a
    temporary directory; or, in one line, why it could not run."""
    compiler = shutil.which("cc") or shutil.which("gcc")
    link = _libzmq_link_args()
    if compiler is None or link is None:
        return "skipped: no C compiler" if compiler is None else "skipped: no libzmq to link"
    with tempfile.TemporaryDirectory() as tmp:
        binary = Path(tmp) / "bare_loop"
        build = subprocess.run([compiler, "-O2", "-o", str(binary), str(REPO / "benchmarks" / "bare_loop.c"), *link],
                               capture_output=True, text=True)
        if build.returncode != 0:
            return f"skipped: the build failed ({(build.stderr.strip().splitlines() or ['?'])[-1]})"
        loop = subprocess.Popen([str(binary), str(cycles)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)  # its clients in its process group
        try:
            out, err = loop.communicate(timeout=600)
        except subprocess.TimeoutExpired:
            os.killpg(loop.pid, signal.SIGKILL)
            loop.wait()
            return "skipped: no answer from its clients in 600 s"
    if loop.returncode != 0:
        return f"skipped: it failed ({(err.strip().splitlines() or ['?'])[-1]})"
    rate, cpu_ms = map(float, out.split())
    return rate, cpu_ms


def c_loop_line(result: tuple[float, float] | str, python_loop: float, embedded: float | None = None) -> str:
    """A :func:`c_loop` result beside the Python loop's ``python_loop`` cycles/s (and the embedded mode's
    ``embedded``, if given), in one line."""
    if isinstance(result, str):
        return result
    rate, cpu_ms = result
    beside_embedded = f", {rate / embedded:.2f}x embedded" if embedded is not None else ""
    return (f"{rate:,.0f} cycles/s ({rate / python_loop:.1f}x the Python loop{beside_embedded}; "
            f"{cpu_ms:.2f} ms CPU a cycle in all)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cycles", type=int, default=3000, help="cycles per synchronous-mode run")
    parser.add_argument("--seconds", type=float, default=3.0, help="seconds per batched measurement")
    opts = parser.parse_args()
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    print("(a) batched physics + perception, one core (arena-cycles/s)")
    base = batched_throughput(1, opts.seconds)
    print(f"    batch    1: {base:12,.0f}   (baseline)")
    big = batched_throughput(1024, opts.seconds)
    print(f"    batch 1024: {big:12,.0f}   ({big / base:.1f}x baseline; target >= 100,000)")
    print("(b) synchronous mode, 5 minimal client processes answering every think with one dash (cycles/s)")
    null = sync_cycles_per_second([sys.executable, "-c", NULL_SERVER, "5", str(opts.cycles)])
    print(f"    bare ZeroMQ loop, no simulation: {null:8,.0f}   (baseline: the ceiling of Python processes)")
    print(f"    the same loop in C (libzmq):     {c_loop_line(c_loop(opts.cycles), null)}")
    real = sync_cycles_per_second([sys.executable, "-m", "keepaway", "server", "--players-port", "0",
                                   "--coach-port", "0", "--monitor-port", "0", "--max-cycles",
                                   str(opts.cycles)])
    print(f"    keepaway server:                 {real:8,.0f}   ({real / null:.0%} of baseline; target >= 3,000)")


if __name__ == "__main__":
    main()
