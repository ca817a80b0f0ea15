"""`keepaway train --mode distributed`: arenas of real server, coach and player processes driven through
the coaches' arena ports (runner/distributed.py, runner/coached.py)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import zmq

from conftest import arena_members, keepaway_command, process_tree, running
from keepaway.agents.policy_file import load_policy
from keepaway.protocol import encode
from keepaway.protocol import messages as m
from keepaway.protocol.arena import RunEpisodes, decode_from_trainer
from keepaway.runner import distributed
from keepaway.runner.distributed import DistributedBackend
from keepaway.runner.job import GREEDY, Behaviours, Job, chunk_seeds
from keepaway.runner.launch import ArenaFailure
from keepaway.trainer.cem import CEMConfig
from keepaway.trainer.schedule import PASS, Phase
from keepaway.trainer.train import TrainConfig, train

pytestmark = pytest.mark.timeout(600)


def test_chunks_cover_a_job_with_their_own_seeds():
    plan = chunk_seeds(7, 60, 25)
    assert [n for n, _ in plan] == [25, 25, 10]
    assert len({s for _, s in plan}) == 3
    assert chunk_seeds(7, 60, 25) == plan  # a pure function of the job


@pytest.fixture
def fake_coach():
    """A ROUTER on a free loopback port standing in for a coach's arena port."""
    sock = zmq.Context.instance().socket(zmq.ROUTER)
    sock.setsockopt(zmq.LINGER, 0)
    port = sock.bind_to_random_port("tcp://127.0.0.1")
    yield sock, f"tcp://127.0.0.1:{port}"
    sock.close(linger=0)


def test_an_attached_arena_that_never_answers_is_given_up_in_one_line(fake_coach, monkeypatch):
    monkeypatch.setattr(distributed, "ATTACHED_TIMEOUT_S", 0.5)
    _, endpoint = fake_coach
    backend = DistributedBackend.attach(TrainConfig().game(), [endpoint])
    try:
        with pytest.raises(ArenaFailure, match=r"arena 0 \(tcp://127.0.0.1:\d+\): no answer for \d+ s"):
            backend.play(Behaviours("handcoded", "handcoded"), 1, 3, "greedy")
    finally:
        backend.close()


def test_an_arena_whose_socket_takes_no_request_is_given_up_instead_of_blocking(monkeypatch):
    # A DEALER with no peer blocks a plain send for ever: that is what a CURVE arena does to a trainer
    # without the key (it drops the connection after the refused handshake). The request must wait
    # under the same bound as an unanswered one.
    monkeypatch.setattr(distributed, "ATTACHED_TIMEOUT_S", 0.5)
    sock = zmq.Context.instance().socket(zmq.DEALER)
    sock.setsockopt(zmq.LINGER, 0)
    backend = DistributedBackend(TrainConfig().game(), [distributed.Arena("arena 0", "nowhere", sock)])
    try:
        with pytest.raises(ArenaFailure, match=r"arena 0: no answer for \d+ s"):
            backend.play(Behaviours("handcoded", "handcoded"), 1, 3, "greedy")
    finally:
        backend.close()


def test_a_refused_run_is_named_with_the_coach_error(fake_coach):
    sock, endpoint = fake_coach
    backend = DistributedBackend.attach(TrainConfig().game(), [endpoint])
    try:
        def refuse():
            ident, data = sock.recv_multipart()
            assert isinstance(decode_from_trainer(data), RunEpisodes)
            sock.send_multipart([ident, encode(m.Error(cycle=0, code="reports_missing",
                                                       message="keeper 2's snapshot"))])

        thread = threading.Thread(target=refuse)
        thread.start()
        with pytest.raises(ArenaFailure, match="the coach refused a run: reports_missing: keeper 2's snapshot"):
            backend.play(Behaviours("handcoded", "handcoded"), 1, 3, "greedy")
        thread.join()
    finally:
        backend.close()


def test_a_watched_arena_names_its_dead_process_while_a_run_waits_and_before_the_coach_error(fake_coach):
    """An arena whose processes can be watched (started here, or by a Ray actor: ``Arena.watch``) names the
    process that died: while its run waits (instead of the 900 s an attached arena is given) and in place
    of the coach's refusal that the death caused."""
    sock, endpoint = fake_coach
    backend = DistributedBackend.attach(TrainConfig().game(), [endpoint])
    death = "taker 2 (pid 9) was killed by SIGKILL; logs in 10.0.0.6:/tmp/keepaway-arena-00-x"
    deaths: list[str | None] = [None, None, death]  # what the watch says, call by call (then the last again)
    backend.arenas[0].watch = lambda: deaths.pop(0) if len(deaths) > 1 else deaths[0]
    try:
        with pytest.raises(ArenaFailure) as failure:
            backend.play(Behaviours("handcoded", "handcoded"), 1, 3, "greedy")  # the fake coach never answers
        assert str(failure.value) == f"arena 0 ({endpoint}): {death}"
        sock.recv_multipart()  # that run's request

        def refuse():
            ident, _ = sock.recv_multipart()
            sock.send_multipart([ident, encode(m.Error(cycle=0, code="arena_stopped", message="taker 2 is gone"))])

        thread = threading.Thread(target=refuse)
        thread.start()
        backend.arenas[0].watched_at = time.monotonic() + 3600  # only the refusal asks the watch now
        with pytest.raises(ArenaFailure) as failure:
            backend.play(Behaviours("handcoded", "handcoded"), 1, 3, "greedy")
        thread.join()
        assert str(failure.value) == f"arena 0 ({endpoint}): {death}"
    finally:
        backend.close()


@pytest.mark.slow
def test_a_chunk_plays_the_same_in_any_arena_whatever_it_played_before(tmp_path):
    # Random Pass and GetOpen draw from the players' own streams, so this checks the players' reseeding
    # as well as the server's. Two arenas split the job's chunks; then one arena that has played
    # something else meanwhile plays every chunk alone: the episodes must be the same.
    game = TrainConfig().game()
    job = Behaviours("random", "random")
    with DistributedBackend.start_local(game, 2, tmp_path, "classic", chunk_episodes=2) as backend:
        split = backend.play(job, 11, 6, "greedy")[0]
        backend.play(Behaviours("handcoded", "handcoded"), 5, 3, "greedy")
        alone = DistributedBackend(game, backend.arenas[1:], chunk_episodes=2).play(job, 11, 6, "greedy")[0]
        other_seed = backend.play(job, 12, 6, "greedy")[0]
    durations = [(e.end_cycle - e.start_cycle, e.end) for e in split.episodes]
    assert len(durations) == 6
    assert durations == [(e.end_cycle - e.start_cycle, e.end) for e in alone.episodes]
    assert durations != [(e.end_cycle - e.start_cycle, e.end) for e in other_seed.episodes]


@pytest.mark.slow
def test_cem_candidates_share_their_chunk_seeds_across_arenas(tmp_path):
    # Three GO:L candidates with a learned (fresh) Pass, frozen; the first and the last are the same net:
    # on common seeds they must play the same episodes, whichever arena ran their chunks.
    game = TrainConfig().game()
    rng = np.random.default_rng(1)
    nets = [rng.normal(size=91), rng.normal(size=91)]
    candidates = [Behaviours("learned", "learned", theta) for theta in (nets[0], nets[1], nets[0])]
    with DistributedBackend.start_local(game, 2, tmp_path, "classic", chunk_episodes=2) as backend:
        played = backend.play_all([Job(c, 9, 4, GREEDY) for c in candidates])
    durations = [[(e.end_cycle - e.start_cycle, e.end) for e in p.result.episodes] for p in played]
    assert [len(d) for d in durations] == [4, 4, 4]
    assert durations[0] == durations[2]
    assert durations[0] != durations[1]


# P:L-GO:HC for 60 episodes in two Pass blocks of 30 (chunks of 25 + 5), evaluations of 6 episodes at 0,
# 30 and 60.
TRAIN_ARGS = ["train", "--mode", "distributed", "--pass", "learned", "--getopen", "handcoded", "--episodes", "60",
              "--eval-every", "30", "--eval-episodes", "6", "--seed", "3", "--no-progress"]


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    """The training of TRAIN_ARGS on two arenas of processes, run in this process."""
    config = TrainConfig(pass_policy="learned", getopen_policy="handcoded", schedule=(Phase(PASS, 60),),
                         eval_every=30, eval_episodes=6, arenas=2, seed=3, mode="distributed", cem=CEMConfig())
    out = tmp_path_factory.mktemp("distributed") / "train"
    train(config, out, progress=False)
    return out


def tree_with_members(pid: int, members: int) -> dict[int, str]:
    """``process_tree(pid)`` (with the players' fork server) once it holds ``members`` arena processes:
    an arena's players are forked one after another, and a chunk's arena may still be starting."""
    tree: dict[int, str] = {}

    def complete() -> bool:
        nonlocal tree
        tree = process_tree(pid)
        return len(arena_members(tree)) == members

    wait_for(complete, 60, f"{members} arena processes")
    return tree


def wait_for(condition, timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.2)


@pytest.mark.slow
def test_pass_learns_in_distributed_arenas_and_the_policy_reloads_and_plays(trained, tmp_path):
    out = trained
    summary = json.loads((out / "summary.json").read_text())
    assert [p["episodes"] for p in summary["curve"]] == [0, 30, 60]
    assert all(p["mean_hold_time_s"] > 0 for p in summary["curve"])
    trial = out / "trial_000"
    trace = [json.loads(line) for line in (trial / "trace.jsonl").read_text().splitlines()]
    assert [(t["phase"], t["episodes"]) for t in trace] == [(PASS, 30), (PASS, 60)]

    # the traces: every keeper's SMDP transitions of each block, none lost
    terminal = 0
    for block in ("pass_to_000030.npz", "pass_to_000060.npz"):
        with np.load(trial / "transitions" / block) as data:
            for k in (1, 2, 3):
                state, action = data[f"keeper{k}_state"], data[f"keeper{k}_action"]
                assert state.ndim == 2 and state.shape[1] == 13 and len(action) == len(state)
                assert set(np.unique(action)) <= {0, 1, 2}
                assert (data[f"keeper{k}_reward"] >= 0).all()
                assert int(data[f"keeper{k}_dropped"]) == 0
                terminal += int(data[f"keeper{k}_terminal"].sum())
    # an episode ends a learning episode for every keeper that decided in it (at least the first holder)
    assert terminal >= 30

    # the snapshots: each keeper's own learned weights, in the policy file
    policy = load_policy(trial / "policy.npz")
    weights = [policy.pass_arrays["pass_weights"]] + [policy.pass_arrays[f"pass_keeper{k}_weights"] for k in (2, 3)]
    assert all(np.count_nonzero(w) > 0 for w in weights)
    assert not np.array_equal(weights[0], weights[1])

    # the saved policy plays again, in player processes and in the batched mode
    played = subprocess.run(keepaway_command("run", "--mode", "distributed", "--pass", "learned", "--getopen",
                                             "handcoded", "--policy", str(trial / "policy.npz"), "--episodes", "3",
                                             "--out", str(tmp_path / "replay"), "--json", "--no-progress"),
                            capture_output=True, text=True, timeout=300)
    assert played.returncode == 0, played.stderr
    assert len(json.loads(played.stdout)["episodes"]) == 3
    evaluated = subprocess.run(keepaway_command("evaluate", "--policy", str(out), "--episodes", "6", "--json",
                                                "--no-progress"), capture_output=True, text=True, timeout=300)
    assert evaluated.returncode == 0, evaluated.stderr
    assert json.loads(evaluated.stdout)["pass"] == "learned"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds the arena processes through /proc")
@pytest.mark.slow
def test_a_terminated_training_stops_its_arenas_and_resumes_to_the_same_result_on_one_arena(trained, tmp_path,
                                                                                             processes):
    out = tmp_path / "one_arena"
    trainer = processes.popen(keepaway_command(*TRAIN_ARGS, "--arenas", "1", "--out", str(out)),
                              stderr=subprocess.PIPE)
    wait_for(lambda: (out / "trial_000" / "checkpoint.npz").exists(), 300, "the first checkpoint")
    arena = tree_with_members(trainer.pid, 7)  # server, coach, 3 keepers, 2 takers
    trainer.send_signal(signal.SIGTERM)
    assert trainer.wait(60) == 130
    assert "--resume" in trainer.stderr.read().decode()
    assert not running(arena_members(arena))  # stopped before the trainer exited
    assert not running(arena, timeout_s=10.0)  # the players' fork server, once it sees the trainer gone
    resumed = subprocess.run(keepaway_command("train", "--resume", str(out), "--no-progress"), capture_output=True,
                             text=True, timeout=600)
    assert resumed.returncode == 0, resumed.stderr
    # chunks restart their arena from their own seeds: one arena, interrupted, gives what two gave
    assert (out / "trial_000" / "curve.csv").read_text() == (trained / "trial_000" / "curve.csv").read_text()
    mine, theirs = load_policy(out / "trial_000" / "policy.npz"), load_policy(trained / "trial_000" / "policy.npz")
    assert all(np.array_equal(mine.pass_arrays[k], theirs.pass_arrays[k]) for k in theirs.pass_arrays)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="finds the arena processes through /proc")
@pytest.mark.slow
def test_a_killed_trainer_leaves_no_arena_process_behind(tmp_path, processes):
    out = tmp_path / "killed"
    trainer = processes.popen(keepaway_command(*TRAIN_ARGS, "--arenas", "2", "--out", str(out)))
    wait_for(lambda: (out / "trial_000").exists(), 300, "the arenas to play")
    arenas = tree_with_members(trainer.pid, 14)  # two arenas of seven processes
    os.kill(trainer.pid, signal.SIGKILL)
    trainer.wait(30)
    assert not running(arenas, timeout_s=30.0), "orphaned arena processes went on"


def test_where_a_training_runs_is_checked_against_its_mode(tmp_path):
    from click.testing import CliRunner

    from keepaway.cli import main

    runner = CliRunner()
    done = runner.invoke(main, ["train", "--arena", "tcp://127.0.0.1:6003", "--out", str(tmp_path / "a")])
    assert done.exit_code == 2 and "add --mode distributed" in done.output
    done = runner.invoke(main, ["train", "--mode", "distributed", "--arena", "tcp://127.0.0.1:6003", "--backend",
                                "ray", "--out", str(tmp_path / "b")])
    assert done.exit_code == 2 and "choose one" in done.output
    batched = tmp_path / "batched"
    batched.mkdir()
    (batched / "config.json").write_text(json.dumps(TrainConfig().to_dict()))
    done = runner.invoke(main, ["train", "--resume", str(batched), "--arena", "tcp://127.0.0.1:6003"])
    assert done.exit_code == 2 and "this training is batched" in done.output
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
