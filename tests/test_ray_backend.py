"""`keepaway train --backend ray` and `keepaway run --backend ray`: arenas placed by Ray (a local Ray
here), driven like any other, playing the games a local arena plays.

Ray is an optional extra (`pip install 'keepaway[ray]'`): without it this module is skipped, and the
CLI tests check the one-line error instead.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from types import SimpleNamespace

import pytest
from click.testing import CliRunner

from conftest import keepaway_command, process_tree, running
from keepaway.cli import main
from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec
from keepaway.runner.job import Behaviours
from keepaway.runner.ray_backend import LogMirror, LogPiece, RunHost
from keepaway.trainer.train import TrainConfig

HAVE_RAY = importlib.util.find_spec("ray") is not None


@pytest.mark.parametrize("command", ["train", "run"])
def test_without_ray_the_backend_is_refused_in_one_line(tmp_path, monkeypatch, command):
    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed: its import fails
    done = CliRunner().invoke(main, [command, "--mode", "distributed", "--backend", "ray",
                                     "--out", str(tmp_path / "t")])
    assert done.exit_code == 2
    assert "pip install 'keepaway[ray]'" in done.output


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.parametrize("command", ["train", "run"])
def test_a_ray_address_where_nothing_answers_is_refused_in_one_line_at_once(tmp_path, command):
    """Ray retries such an address for minutes, printing warnings; the command checks the port first."""
    with socket.socket() as s:  # a loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        address = f"127.0.0.1:{s.getsockname()[1]}"
    done = CliRunner().invoke(main, [command, "--mode", "distributed", "--backend", "ray", "--ray-address", address,
                                     "--out", str(tmp_path / "t")])
    assert done.exit_code == 2
    assert done.output.splitlines()[-1] == (f"Error: no Ray cluster answers at {address}: Connection refused; start "
                                            "one there (ray start --head) or give another --ray-address")
    assert not (tmp_path / "t").exists()


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_a_run_on_ray_plays_the_games_of_a_local_run_and_brings_its_logs_back(processes, tmp_path):
    def run(out, *backend):
        proc = processes.popen(keepaway_command("run", "--json", "--episodes", "4", "--seed", "5", "--out", str(out),
                                                *backend), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        stdout, stderr = proc.communicate(timeout=500)
        assert proc.returncode == 0, stderr.decode()[-2000:]
        return json.loads(stdout), stderr.decode()

    on_ray, said = run(tmp_path / "ray", "--backend", "ray")
    here, _ = run(tmp_path / "here")
    assert said.startswith("keepaway: joined a new local Ray: 1 node, ")  # and none of Ray's own start-up lines
    assert said.splitlines()[1].startswith("keepaway: the arena plays on a Ray node, its logs in ")
    key = lambda summary: [(e["episode"], e["start_cycle"], e["end_cycle"], e["end"]) for e in summary["episodes"]]
    assert len(key(on_ray)) == 4 and key(on_ray) == key(here)
    assert on_ray["cycles_per_s"] > 0  # measured on the node, between its first and last episode end
    for log in ("ray", "here"):
        assert ({p.name for p in (tmp_path / log / "processes").glob("*.log")}
                >= {"server.log", "coach.log", "taker_2.log"})
    assert (tmp_path / "ray" / "keepaway.kwy").read_bytes() == (tmp_path / "here" / "keepaway.kwy").read_bytes()
    # every cycle of the game log, but the result line, which carries the time of day
    game_log = lambda out: [l for l in (out / "keepaway.rcg").read_text().splitlines() if "(result " not in l]
    assert len(game_log(tmp_path / "ray")) > 100 and game_log(tmp_path / "ray") == game_log(tmp_path / "here")


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_ray_places_arenas_that_play_like_local_ones(tmp_path):
    import ray

    from keepaway.runner.distributed import DistributedBackend
    from keepaway.runner.ray_backend import ray_launcher

    config = TrainConfig(mode="distributed", arenas=2)
    job = Behaviours("random", "handcoded")
    try:
        backend = ray_launcher(None)(config.game(), config.parameter_set, config.arenas, config.chunk_episodes)
        try:
            on_ray = backend.play(job, 21, 4, "greedy")[0]
        finally:
            backend.close()
    finally:
        ray.shutdown()
    with DistributedBackend.start_local(config.game(), 1, tmp_path, "classic") as local:
        here = local.play(job, 21, 4, "greedy")[0]
    assert [(e.end_cycle - e.start_cycle, e.end) for e in on_ray.episodes] == \
        [(e.end_cycle - e.start_cycle, e.end) for e in here.episodes]


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_a_process_dying_in_an_arena_on_ray_is_named_with_where_its_logs_are():
    """The trainer watches the arenas Ray placed as it watches its own: a dead player is named at once (not
    after the server's 60 s cycle timeout, nor, for a dead coach, the 900 s an attached arena is given)."""
    import ray

    from keepaway.runner.launch import ArenaFailure
    from keepaway.runner.ray_backend import ray_launcher

    config = TrainConfig(mode="distributed", arenas=1)
    try:
        backend = ray_launcher(None)(config.game(), config.parameter_set, 1, config.chunk_episodes)
        try:
            # a local Ray's processes are this process's descendants, the arena's theirs; a forked player
            # takes its name soon after it starts
            deadline, takers = time.monotonic() + 60, []
            while time.monotonic() < deadline and not takers:
                takers = [pid for pid, name in process_tree(os.getpid()).items() if name == "taker 2"]
                time.sleep(0.1)
            assert len(takers) == 1
            os.kill(takers[0], signal.SIGKILL)
            with pytest.raises(ArenaFailure) as failure:
                backend.play(Behaviours("handcoded", "handcoded"), 3, 100, "greedy")
        finally:
            backend.close()
    finally:
        ray.shutdown()
    assert re.fullmatch(rf"arena 0 \(tcp://\S+\): taker 2 \(pid {takers[0]}\) was killed by SIGKILL; "
                        r"logs in \S+:/\S+/keepaway-arena-00-\S+", str(failure.value)), str(failure.value)


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_an_arena_whose_port_this_machine_cannot_reach_is_refused_at_once_and_stopped(monkeypatch):
    """A trainer that cannot reach a node's ports (a firewall, a driver outside the cluster) learns it when
    the arenas start, in one line, instead of after each request's 900 s; the arenas are stopped."""
    import ray

    from keepaway.runner.launch import ArenaFailure
    from keepaway.runner.ray_backend import ray_launcher

    arena: set[int] = set()  # the arena's server and coach (a local Ray's processes are this one's descendants)

    def unreachable(host: str, port: int) -> str:
        arena.update(pid for pid, name in process_tree(os.getpid()).items()
                     if " keepaway server " in f" {name} " or " keepaway coach " in f" {name} ")
        return "No route to host"

    from keepaway.runner import ray_backend
    monkeypatch.setattr(ray_backend, "unreachable", unreachable)
    config = TrainConfig(mode="distributed", arenas=1)
    try:
        with pytest.raises(ArenaFailure) as failure:
            ray_launcher(None)(config.game(), config.parameter_set, 1, config.chunk_episodes)
        assert len(arena) == 2 and not running(arena, timeout_s=30.0)
    finally:
        ray.shutdown()
    assert re.fullmatch(r"arena 0 \(tcp://\S+\): this machine cannot reach its port: No route to host; the trainer "
                        r"must reach the ports of every Ray node \(a firewall between them\?\)", str(failure.value))


def test_a_ray_error_is_told_by_one_of_its_lines_without_terminal_colours():
    from keepaway.runner.ray_backend import error_line

    died = RuntimeError("The actor died because of an error raised in its creation task, \x1b[36mray::ArenaHost."
                        "__init__()\x1b[39m (pid=7, ip=10.0.0.6)\n  File \"x.py\", line 1\n\nModuleNotFoundError: "
                        "No module named 'runner'\n")
    assert error_line(died, last=False) == ("The actor died because of an error raised in its creation task, "
                                            "ray::ArenaHost.__init__() (pid=7, ip=10.0.0.6)")
    assert error_line(died, last=True) == "ModuleNotFoundError: No module named 'runner'"
    assert error_line(RuntimeError(""), last=True) == "RuntimeError"


def test_unreachable_says_why_in_one_line():
    from keepaway.runner.ray_backend import unreachable

    with socket.socket() as s:  # a loopback port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert unreachable("127.0.0.1", port) == "Connection refused"
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        assert unreachable("127.0.0.1", s.getsockname()[1]) is None


class Unimportable(RunHost):
    """A RunHost defined in this test module, which a Ray worker cannot import: as a node without keepaway
    installed cannot import the package."""


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_an_actor_that_cannot_be_created_is_named_in_one_line(tmp_path, monkeypatch):
    """Its error's last line reaches the command, not Ray's traceback, nor the error of stopping an actor
    that does not exist."""
    import ray

    from keepaway.runner import ray_backend
    from keepaway.runner.launch import ArenaFailure
    from keepaway.runner.ray_backend import ray_run
    from keepaway.runner.run import RunOptions
    monkeypatch.setattr(ray_backend, "RunHost", Unimportable)
    ray.init(num_cpus=1, log_to_driver=False)
    try:
        with pytest.raises(ArenaFailure) as failure:
            list(ray_run(None)(RunOptions(ArenaSpec(parameter_set("classic")), 1, out=tmp_path), None))
    finally:
        ray.shutdown()
    assert str(failure.value) == ("Ray could not create the arena on its node: ModuleNotFoundError: No module named "
                                  "'test_ray_backend'; every node needs this version of keepaway installed (pip "
                                  "install 'keepaway[ray]')")


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_sigterm_stops_a_run_on_ray_with_its_summary_and_logs(processes, tmp_path):
    """A Ray driver exits at once on SIGTERM unless ``keepaway run`` keeps its own handler: the arena on the
    node stopped, its logs brought back, the summary of what finished, exit 130, nothing left running."""
    proc = processes.popen(keepaway_command("run", "--backend", "ray", "--episodes", "100000", "--no-progress",
                                            "--out", str(tmp_path)), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    arena = lambda tree: {pid for pid, name in tree.items()
                          if name.startswith(("keeper ", "taker ")) or " keepaway server " in f" {name} "
                          or " keepaway coach " in f" {name} "}
    deadline = time.monotonic() + 300
    tree: dict[int, str] = {}
    while time.monotonic() < deadline and len(arena(tree)) < 7:
        tree = process_tree(proc.pid)  # a local Ray's processes are the run's, the arena's theirs
        time.sleep(0.2)
    assert len(arena(tree)) == 7, tree
    # the logs come as they grow, not only at the end: episodes in the local copy of the JSON-lines log
    copied = lambda: len(path.read_text().splitlines()) - 1 if (path := tmp_path / "keepaway.jsonl").exists() else 0
    while time.monotonic() < deadline and copied() < 3:
        time.sleep(0.2)
    assert copied() >= 3
    tree = process_tree(proc.pid)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err.decode()[-2000:]
    message = err.decode().strip().splitlines()[-1]
    logged = len((tmp_path / "keepaway.jsonl").read_text().splitlines()) - 1  # its header, then the episodes
    assert logged >= 1
    assert message == (f"keepaway run: interrupted; every process was stopped; the summary covers the {logged} of "
                       "100000 episodes that finished")
    assert f"episodes        {logged}\n" in out.decode()
    assert not running(tree, timeout_s=30.0)


def test_the_logs_of_a_run_elsewhere_are_copied_as_they_grow_and_never_overwrite_earlier_ones(tmp_path, monkeypatch):
    """``RunHost.logs_since`` (on the node) and ``LogMirror`` (in the driver's --out), without Ray: pieces of a
    few bytes at a time give byte-for-byte copies, an earlier run's log of the same name is set aside as the
    server does, a process's log is appended to as a resumed local run's."""
    from keepaway.runner import ray_backend
    monkeypatch.setattr(ray_backend, "LOG_PIECE", 5)
    node, out = tmp_path / "node", tmp_path / "out"
    (node / "processes").mkdir(parents=True)
    (out / "processes").mkdir(parents=True)
    (out / "keepaway.kwy").write_bytes(b"an earlier run's log\n")
    (out / "processes" / "server.log").write_bytes(b"an earlier run\n")
    host = SimpleNamespace(opts=SimpleNamespace(out=node))
    mirror = LogMirror(out)
    logs_since = lambda: RunHost.logs_since(host, mirror.sizes)  # type: ignore[arg-type]

    (node / "keepaway.kwy").write_bytes(b"0\t1\t")
    (node / "processes" / "server.log").write_bytes(b"listening\n")
    (node / "processes" / "taker_1.log").write_bytes(b"")
    while mirror.take(logs_since()):
        pass
    assert (out / "keepaway.kwy").read_bytes() == b"0\t1\t"
    assert (out / "keepaway.1.kwy").read_bytes() == b"an earlier run's log\n"
    assert (out / "processes" / "server.log").read_bytes() == b"an earlier run\nlistening\n"
    assert (out / "processes" / "taker_1.log").read_bytes() == b""

    with open(node / "keepaway.kwy", "ab") as f:  # the log grows; a new one appears
        f.write(b"37\t2\n1\t38\t90\t52\t3\n")
    (node / "keepaway.jsonl").write_bytes(b'{"seed": 5}\n')
    pieces = logs_since()
    assert sum(len(piece.data) for piece in pieces) == 5 and pieces[0] == LogPiece("keepaway.jsonl", 0, b'{"see')
    mirror.take(pieces)
    while mirror.take(logs_since()):
        pass
    for name in ("keepaway.kwy", "keepaway.jsonl", "processes/taker_1.log"):
        assert (out / name).read_bytes() == (node / name).read_bytes()
    assert sorted(p.name for p in out.iterdir()) == ["keepaway.1.kwy", "keepaway.jsonl", "keepaway.kwy", "processes"]


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_arenas_waiting_for_a_cpu_on_ray_are_announced_and_then_placed(monkeypatch):
    """A cluster without a free CPU leaves an arena's actor waiting: the command says so in one line (with the
    cluster's CPUs) instead of falling silent, and again once the arena is placed and started."""
    import ray

    from keepaway.runner import ray_backend
    from keepaway.runner.ray_backend import ray_launcher
    monkeypatch.setattr(ray_backend, "PLACEMENT_NOTICE_S", 1.0)
    config = TrainConfig(mode="distributed", arenas=1)
    said: list[str] = []
    launched = []
    ray.init(num_cpus=1, log_to_driver=False)
    try:
        blocker = ray.remote(num_cpus=1)(type("Blocker", (), {})).remote()  # holds the cluster's one CPU
        ray.get(blocker.__ray_ready__.remote())
        launch = ray_launcher(None, announce=said.append)
        thread = threading.Thread(target=lambda: launched.append(
            launch(config.game(), config.parameter_set, 1, config.chunk_episodes)), daemon=True)
        thread.start()
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not said:
            time.sleep(0.1)
        assert said == ["the Ray cluster has not placed the arena after 1 s: each arena needs 1 CPU, the cluster "
                        "has 1 (0 free); waiting (Ctrl-C gives up)"]
        assert thread.is_alive()
        ray.kill(blocker)
        thread.join(timeout=300)
        assert launched, said
        backend = launched[0]
        try:
            episodes = backend.play(Behaviours("handcoded", "handcoded"), 3, 2, "greedy")[0].episodes
        finally:
            backend.close()
        assert len(episodes) == 2
        assert said[1].startswith("the Ray cluster placed the arena after ") and len(said) == 2
    finally:
        ray.shutdown()


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_sigterm_stops_training_on_ray_as_it_stops_a_local_training(processes, tmp_path):
    """Ray's driver would exit on SIGTERM at once (SIGABRT, no checkpoint kept): ``keepaway train`` keeps its
    own handler, stops its arenas, says how to continue and exits 130, leaving nothing running."""
    out = tmp_path / "t"
    proc = processes.popen(keepaway_command("train", "--mode", "distributed", "--backend", "ray", "--arenas", "1",
                                            "--pass", "learned", "--getopen", "handcoded", "--episodes", "100000",
                                            "--schedule", "pass:100000", "--no-progress", "--out", str(out)),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 300
    tree: dict[int, str] = {}
    while time.monotonic() < deadline and not any(name.startswith("keeper ") for name in tree.values()):
        tree = process_tree(proc.pid)
        time.sleep(0.2)
    time.sleep(3.0)  # the arena plays
    tree = process_tree(proc.pid)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err.decode()[-2000:]
    assert err.decode().strip().splitlines()[-1] == f"keepaway train: interrupted; continue with --resume {out}"
    assert not running(tree, timeout_s=30.0)
