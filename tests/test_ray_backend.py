"""`keepaway train --backend ray` and `keepaway run --backend ray`: arenas placed by Ray (a local Ray
here), driven like any other, playing the games a local arena plays.

Ray is an optional extra (`pip install 'keepaway[ray]'`): without it this module is skipped, and the
CLI tests check the one-line error instead.
"""

from __future__ import annotations

import importlib.util
import json
import signal
import subprocess
import time

import pytest
from click.testing import CliRunner

from conftest import keepaway_command, process_tree, running
from keepaway.cli import main
from runner.job import Behaviours
from trainer.train import TrainConfig

HAVE_RAY = importlib.util.find_spec("ray") is not None


@pytest.mark.skipif(HAVE_RAY, reason="checks the message shown when Ray is missing")
@pytest.mark.parametrize("command", ["train", "run"])
def test_without_ray_the_backend_is_refused_in_one_line(tmp_path, command):
    done = CliRunner().invoke(main, [command, "--mode", "distributed", "--backend", "ray", "--out", str(tmp_path / "t")])
    assert done.exit_code == 2
    assert "pip install 'keepaway[ray]'" in done.output


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
    assert "the arena plays on a Ray node, its logs in " in said
    key = lambda summary: [(e["episode"], e["start_cycle"], e["end_cycle"], e["end"]) for e in summary["episodes"]]
    assert len(key(on_ray)) == 4 and key(on_ray) == key(here)
    assert on_ray["cycles_per_s"] > 0  # measured on the node, between its first and last episode end
    for log in ("ray", "here"):
        assert {p.name for p in (tmp_path / log / "processes").glob("*.log")} >= {"server.log", "coach.log", "taker_2.log"}
    assert (tmp_path / "ray" / "keepaway.kwy").read_bytes() == (tmp_path / "here" / "keepaway.kwy").read_bytes()
    # every cycle of the game log, but the result line, which carries the time of day
    game_log = lambda out: [l for l in (out / "keepaway.rcg").read_text().splitlines() if "(result " not in l]
    assert len(game_log(tmp_path / "ray")) > 100 and game_log(tmp_path / "ray") == game_log(tmp_path / "here")


@pytest.mark.skipif(not HAVE_RAY, reason="Ray is not installed (pip install 'keepaway[ray]')")
@pytest.mark.timeout(600)
def test_ray_places_arenas_that_play_like_local_ones(tmp_path):
    import ray

    from runner.distributed import DistributedBackend
    from runner.ray_backend import ray_launcher

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
    time.sleep(8.0)  # some episodes
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
