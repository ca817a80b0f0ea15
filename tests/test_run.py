"""``keepaway run`` end to end: real processes, the JSON summary, a dying player, determinism."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import arena_members, keepaway_command, process_tree, running
from keepaway.agents.policy_file import getopen_theta_size, save_policy
from keepaway.server.episode_log import read_jsonl
from keepaway.server.game_log import read_rcg

SUMMARY_KEYS = {"mode", "seed", "episodes", "mean_hold_time_s", "stderr_hold_time_s", "cycles_per_s",
                "episodes_per_s"}


def run_json(processes, *args: str, timeout: float = 600) -> dict:
    proc = processes.popen(keepaway_command("run", "--json", *args), stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE)
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, err.decode()[-2000:]
    return json.loads(out)


def episodes_logged(out: Path) -> int:
    kwy = out / "keepaway.kwy"
    return sum(1 for l in kwy.read_text().splitlines() if l and l[0] != "#") if kwy.exists() else 0


@pytest.mark.slow
def test_distributed_run_plays_twenty_episodes_and_writes_logs(processes, tmp_path):
    summary = run_json(processes, "--episodes", "20", "--seed", "4", "--out", str(tmp_path))
    assert set(summary) == SUMMARY_KEYS
    assert summary["mode"] == "distributed" and summary["seed"] == 4
    episodes = summary["episodes"]
    assert [e["episode"] for e in episodes] == list(range(1, 21))
    assert all(e["end"] in ("out", "taken") for e in episodes)
    assert all(e["hold_time_s"] == (e["end_cycle"] - e["start_cycle"]) / 10 for e in episodes)
    mean = sum(e["hold_time_s"] for e in episodes) / 20
    assert abs(summary["mean_hold_time_s"] - mean) < 1e-9
    kwy = [l for l in (tmp_path / "keepaway.kwy").read_text().splitlines() if l and l[0] != "#"]
    assert len(kwy) == 20
    assert summary["cycles_per_s"] > 0 and summary["episodes_per_s"] > 0


def test_distributed_and_embedded_runs_give_identical_episodes(processes, tmp_path):
    args = ["--episodes", "4", "--seed", "9", "--getopen-notes", "values"]
    distributed = run_json(processes, *args, "--out", str(tmp_path / "d"))
    embedded = run_json(processes, *args, "--mode", "embedded", "--out", str(tmp_path / "e"))
    key = lambda s: [(e["episode"], e["start_cycle"], e["end_cycle"], e["end"]) for e in s["episodes"]]
    assert key(distributed) == key(embedded)
    assert (tmp_path / "d" / "keepaway.kwy").read_text() == (tmp_path / "e" / "keepaway.kwy").read_text()
    # the game logs too, every cycle (but the result line, which carries the time of day)
    game_log = lambda mode: [l for l in (tmp_path / mode / "keepaway.rcg").read_text().splitlines()
                             if "(result " not in l]
    assert game_log("d")[0] == "ULG5" and sum(l.startswith("(show ") for l in game_log("d")) > 4
    assert sum('"(getopen (l ' in l for l in game_log("d")) > 20  # the keepers' notes, sent over the wire
    assert game_log("d") == game_log("e")


@pytest.mark.slow
def test_a_killed_player_is_named_and_the_run_fails_without_hanging(processes, tmp_path):
    proc = processes.popen(keepaway_command("run", "--episodes", "100000", "--no-progress", "--out", str(tmp_path)),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 180
    victim = None
    while time.monotonic() < deadline and victim is None:
        kids = process_tree(proc.pid)
        players = sorted(pid for pid, name in kids.items() if name.startswith("taker "))
        # wait until the game runs (an episode was logged), then kill the second taker
        if len(players) == 2 and episodes_logged(tmp_path) >= 1:
            victim = players[1]
        time.sleep(0.2)
    assert victim is not None, "the arena did not start"
    os.kill(victim, signal.SIGKILL)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    message = err.decode().strip().splitlines()[-1]
    assert message.startswith("keepaway run: taker ") and f"(pid {victim}) was killed by SIGKILL" in message
    # the summary of the episodes that did finish, as many as the server logged
    logged = episodes_logged(tmp_path)
    assert f"the summary covers the {logged} of 100000 episodes that finished" in message
    assert f"episodes        {logged}\n" in out.decode()
    # every process of the arena is gone (the run reaped them before it exited), and the players' fork
    # server ends once it sees the run gone
    assert len(arena_members(kids)) == 7
    assert not running(arena_members(kids))
    assert not running(kids, timeout_s=10.0)


def test_batched_run_reports_the_same_summary_shape(processes, tmp_path):
    summary = run_json(processes, "--mode", "batched", "--batch", "8", "--episodes", "16", "--seed", "1",
                       "--game-log-arenas", "3", "--out", str(tmp_path))
    assert set(summary) == SUMMARY_KEYS and summary["mode"] == "batched"
    assert len(summary["episodes"]) == 16
    # the chosen arena's game log: every cycle of its two episodes, each started by the referee's message
    record = read_rcg(tmp_path / "keepaway-arena3.rcg")
    assert [s.cycle for s in record.shows] == list(range(len(record.shows)))
    assert len(record.episode_starts) == 2 and record.episodes_end == record.shows[-1].cycle
    assert [p.name for p in tmp_path.glob("*.rcg")] == ["keepaway-arena3.rcg"]


def test_no_game_log_writes_none(processes, tmp_path):
    run_json(processes, "--mode", "embedded", "--episodes", "1", "--no-game-log", "--out", str(tmp_path))
    assert (tmp_path / "keepaway.kwy").exists() and not list(tmp_path.glob("*.rcg"))


def test_bad_options_are_one_line_errors(processes, tmp_path):
    bad_policy = tmp_path / "bad.npz"
    bad_policy.write_bytes(b"not a policy")
    for args, text in [
        (["--episodes", "0"], "--episodes must be at least 1"),
        (["--mode", "embedded", "--realtime"], "--realtime needs --mode distributed"),
        (["--getopen", "learned", "--policy", str(bad_policy)], "bad.npz"),
        (["--field-size", "nan"], "not a finite number"),
        (["--mode", "batched", "--batch", "8", "--game-log-arenas", "8"], "arenas are numbered 0..7"),
        (["--game-log-arenas", "0"], "--game-log-arenas needs --mode batched"),
        (["--mode", "embedded", "--view"], "--view follows an arena's monitor port: it needs --mode distributed"),
        (["--mode", "batched", "--game-log-arenas", "1,x"], "expected arena numbers separated by commas"),
        (["--mode", "embedded", "--backend", "ray"], "--backend ray places the distributed mode's arena"),
        (["--backend", "ray", "--view"], "--view serves a viewer of an arena on this machine"),
        (["--ray-address", "auto"], "--ray-address names the Ray cluster of --backend ray"),
        (["--mode", "batched", "--getopen", "learned"],
         "--getopen learned in the batched mode plays a policy file's net: add --policy FILE"),
    ]:
        proc = processes.popen(keepaway_command("run", *args, "--out", str(tmp_path)),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 2, err
        assert text in err.decode() and "Traceback" not in err.decode()


def test_a_run_names_its_logs_and_the_names_an_earlier_runs_logs_were_set_aside_under(processes, tmp_path):
    def notes(*args: str) -> list[str]:
        proc = processes.popen(keepaway_command("run", "--episodes", "2", "--no-progress", *args, "--out",
                                                str(tmp_path)), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err.decode()[-2000:]
        return [line for line in err.decode().splitlines() if "logs in" in line]

    assert notes("--mode", "embedded") == [f"keepaway: logs in {tmp_path}: keepaway.kwy, keepaway.jsonl, keepaway.rcg"]
    first = {name: (tmp_path / name).read_bytes() for name in ("keepaway.kwy", "keepaway.jsonl", "keepaway.rcg")}
    assert notes("--mode", "batched", "--batch", "2", "--game-log-arenas", "1") == [
        f"keepaway: an earlier run's logs in {tmp_path} set aside: keepaway.kwy -> keepaway.1.kwy, "
        "keepaway.jsonl -> keepaway.1.jsonl",
        f"keepaway: logs in {tmp_path}: keepaway.kwy, keepaway.jsonl, keepaway-arena1.rcg"]
    for name in ("keepaway.kwy", "keepaway.jsonl"):
        assert (tmp_path / name.replace("keepaway.", "keepaway.1.")).read_bytes() == first[name]
    assert (tmp_path / "keepaway.rcg").read_bytes() == first["keepaway.rcg"]  # not a log this run writes


@pytest.mark.parametrize("mode", ["embedded", "batched"])
def test_the_progress_bar_ends_at_the_summarys_rate(processes, tmp_path, mode):
    proc = processes.popen(keepaway_command("run", "--mode", mode, "--batch", "4", "--episodes", "12", "--seed", "2",
                                            "--out", str(tmp_path)), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err.decode()[-2000:]
    rate = re.search(r"^episodes / s +(\S+)$", out.decode(), re.M).group(1)
    hold = re.search(r"^mean hold time +(\S+ s) ", out.decode(), re.M).group(1)
    last_bar = [drawn for drawn in re.split(r"[\r\n]+", err.decode()) if "12/12" in drawn][-1]
    assert last_bar.endswith(f", {rate} ep/s, mean hold {hold}]"), (last_bar, rate, hold)


def test_learned_policies_without_a_policy_file_are_announced_as_untrained(processes, tmp_path):
    policy = save_policy(tmp_path / "go.npz", getopen_theta=np.zeros(getopen_theta_size()),
                         config={"pass": "handcoded", "getopen": "learned"})
    runs = {"none": ["--pass", "learned", "--getopen", "learned"], "pass": ["--pass", "learned"],
            "file": ["--getopen", "learned", "--policy", str(policy)]}
    warnings = {}
    for name, args in runs.items():
        proc = processes.popen(keepaway_command("run", "--mode", "embedded", "--episodes", "1", "--no-progress",
                                                *args, "--out", str(tmp_path / name)),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        _, err = proc.communicate(timeout=600)
        assert proc.returncode == 0, err.decode()[-2000:]
        warnings[name] = [l for l in err.decode().splitlines() if "without --policy" in l]
    advice = "from zero weights (an untrained policy): add --policy FILE (e.g. a training's trial_000/policy.npz)"
    assert warnings == {
        "none": [f"keepaway run: --pass learned and --getopen learned without --policy start {advice}"],
        "pass": [f"keepaway run: --pass learned without --policy starts {advice}"],
        "file": [],
    }


@pytest.mark.slow
def test_four_versus_three_on_a_larger_field_runs_distributed(processes, tmp_path):
    summary = run_json(processes, "--keepers", "4", "--takers", "3", "--field-size", "30", "--episodes", "2",
                       "--out", str(tmp_path))
    assert len(summary["episodes"]) == 2
    header = (tmp_path / "keepaway.kwy").read_text().splitlines()[:3]
    assert header == ["# Keepers: 4", "# Takers:  3", "# Region:  30 x 30"]


@pytest.mark.slow
def test_ctrl_c_stops_every_process_of_the_arena(processes, tmp_path):
    # As from a terminal: SIGINT at its default even when the test runner was started with it ignored
    # (a shell's background job), which the child would otherwise inherit.
    proc = processes.popen(keepaway_command("run", "--episodes", "100000", "--no-progress", "--out", str(tmp_path)),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 180
    kids: dict[int, str] = {}
    while time.monotonic() < deadline:
        kids = process_tree(proc.pid)
        if len(arena_members(kids)) == 7 and episodes_logged(tmp_path) >= 1:
            break
        time.sleep(0.2)
    assert len(arena_members(kids)) == 7, kids
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "interrupted; every process was stopped" in err.decode()
    assert not running(arena_members(kids))
    assert not running(kids, timeout_s=10.0)  # the players' fork server, once it sees the run gone


@pytest.mark.slow
def test_a_player_that_misses_cycles_is_reported_on_the_console_once_and_when_it_is_back(processes, tmp_path):
    proc = processes.popen(keepaway_command("run", "--episodes", "100000", "--no-progress", "--out", str(tmp_path)),
                           stdout=subprocess.PIPE)
    deadline = time.monotonic() + 180
    victim = None
    while time.monotonic() < deadline and victim is None:
        keepers = sorted(pid for pid, name in process_tree(proc.pid).items() if name.startswith("keeper "))
        if len(keepers) == 3 and episodes_logged(tmp_path) >= 1:
            victim = keepers[1]  # one of the keepers (its uniform number is the server's choice)
        time.sleep(0.2)
    assert victim is not None, "the arena did not start"
    os.kill(victim, signal.SIGSTOP)  # late for a few cycles (1.25 s each), not long enough to be given up
    time.sleep(4)
    os.kill(victim, signal.SIGCONT)
    late_re = re.compile(r"(keeper \d) missed (\d+) of the (\d+) cycles of episode (\d+)")
    deadline = time.monotonic() + 120
    while not (late := late_re.search(processes.stderr_tail(proc))) or \
            f"{late.group(1)} played the whole of episode" not in processes.stderr_tail(proc):
        assert time.monotonic() < deadline and proc.poll() is None, processes.stderr_tail(proc)
        time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    proc.communicate(timeout=60)
    err = processes.stderr_tail(proc)
    name, missed, duration, episode = late.group(1), *map(int, late.groups()[1:])
    back = re.search(rf"{name} played the whole of episode (\d+) again", err)
    assert err.index(late.group(0)) < back.start() and int(back.group(1)) > episode
    assert len(re.findall(rf"{name} missed", err[:back.start()])) == 1, err  # one line, however many episodes
    _, records = read_jsonl(tmp_path / "keepaway.jsonl")
    marked = next(r for r in records if r.episode == episode)
    assert dict(marked.missed)[name] == missed and marked.duration == duration


# Runs the real server (argv[2:]), notes when it has exited, then keeps its process alive a while: a
# server that is slow to stop (as on a loaded machine) after every episode is logged.
SLOW_STOP = ("import subprocess, sys, time; code = subprocess.call(sys.argv[3:]); "
             "open(sys.argv[1], 'w').write(repr(time.monotonic())); time.sleep(float(sys.argv[2])); sys.exit(code)")


@pytest.mark.slow
def test_clean_exits_while_a_slow_server_stops_are_not_deaths(tmp_path, monkeypatch):
    """Players and coach exit 0 right after the server's shutdown; the server's process then takes
    longer than the launcher's grace period to go. That is success, not a death."""
    from keepaway.protocol.params import parameter_set
    from keepaway.runner import launch
    from keepaway.runner.embedded import ArenaSpec
    from keepaway.runner.launch import CLEAN_EXIT_GRACE_S
    from keepaway.runner.run import RunOptions, run

    real_argv = launch.keepaway_argv
    exited = tmp_path / "server-exited"

    def slow_server(*args: str) -> list[str]:
        argv = real_argv(*args)
        slow = str(CLEAN_EXIT_GRACE_S + 3)
        return [sys.executable, "-c", SLOW_STOP, str(exited), slow, *argv] if args[0] == "server" else argv

    monkeypatch.setattr(launch, "keepaway_argv", slow_server)
    spec = ArenaSpec(parameter_set("classic"), 3, 2, 5, "handcoded", "handcoded", None)
    result = run(RunOptions(spec, 3, out=tmp_path / "out"), progress=False)
    stopped_at = time.monotonic()
    assert [e.episode for e in result.episodes] == [1, 2, 3]
    # the server process outlived the real server by more than the launcher's grace period
    assert stopped_at - float(exited.read_text()) > CLEAN_EXIT_GRACE_S


def strict_json(text: str):
    """``text`` parsed as RFC 8259 JSON: NaN and Infinity, which Python's parser accepts, are refused."""
    def refuse(constant: str):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def test_a_one_episode_summary_has_no_nan_and_says_why_it_has_no_standard_error():
    from keepaway.runner.job import RunResult
    from keepaway.runner.report import dump_json, summary_table
    from keepaway.server.episode_log import EpisodeRecord

    # one episode of 43 cycles, no measured time: no standard error, no rates
    summary = RunResult("batched", 3, [EpisodeRecord(1, 0, 43, "taken")], 0.0, 0, 1).summary()
    assert summary["mean_hold_time_s"] == 4.3
    assert summary["stderr_hold_time_s"] is None and summary["cycles_per_s"] is None
    parsed = strict_json(dump_json(summary))
    assert parsed["stderr_hold_time_s"] is None and parsed["episodes_per_s"] is None
    table = summary_table(summary)
    assert "4.30 s +- n/a (s.e. over 1 episode)" in table and "nan" not in table.lower()
    assert strict_json(dump_json({"x": float("nan"), "y": [float("inf"), -float("inf"), 1.5]})) == \
        {"x": None, "y": [None, None, 1.5]}


def test_a_batched_run_of_one_episode_prints_strict_json(processes, tmp_path):
    proc = processes.popen(keepaway_command("run", "--json", "--mode", "batched", "--batch", "1", "--episodes", "1",
                                            "--out", str(tmp_path)), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err.decode()[-2000:]
    summary = strict_json(out)
    assert len(summary["episodes"]) == 1 and summary["stderr_hold_time_s"] is None


def batched_chunks(episodes: int, batch: int, seed: int) -> list:
    from keepaway.protocol.params import parameter_set
    from keepaway.runner.batched import BatchedArenas

    return list(BatchedArenas(parameter_set("classic"), batch, seed).chunks(total_episodes=episodes))


def test_batched_episodes_come_out_chunk_by_chunk_as_they_end(monkeypatch, tmp_path):
    from keepaway.protocol.params import parameter_set
    from keepaway.runner.batched import BatchedArenas
    from keepaway.runner.embedded import ArenaSpec
    from keepaway.runner.run import RunOptions, batched_episodes

    played = []
    real_chunk = BatchedArenas._run_chunk

    def counting(self, *args):
        played.append(1)
        real_chunk(self, *args)

    monkeypatch.setattr(BatchedArenas, "_run_chunk", counting)
    spec = ArenaSpec(parameter_set("classic"), 3, 2, 4)
    seen = [(record.episode, cycles, len(played))
            for record, cycles in batched_episodes(RunOptions(spec, 12, "batched", 3, out=tmp_path))]
    assert [episode for episode, _, _ in seen] == list(range(1, 13))  # numbered in the order they end
    assert seen[0][2] < len(played)  # the first episode came out before the last chunk was played
    n_played = len(played)
    chunks = batched_chunks(12, 3, 4)
    assert n_played == len(chunks) and seen[-1][1] == sum(c.cycles for c in chunks)  # arena-cycles so far
    assert [c for _, c, _ in seen] == sorted(c for _, c, _ in seen)


def test_batched_rates_count_the_episodes_and_arena_cycles_after_the_first_chunk_with_an_episode(tmp_path):
    from keepaway.protocol.params import parameter_set
    from keepaway.runner.embedded import ArenaSpec
    from keepaway.runner.run import RunOptions, run

    result = run(RunOptions(ArenaSpec(parameter_set("classic"), 3, 2, 4), 12, "batched", 3, out=tmp_path),
                 progress=False)
    chunks = batched_chunks(12, 3, 4)
    first = next(i for i, c in enumerate(chunks) if len(c))
    assert result.cycles == sum(c.cycles for c in chunks[first + 1:])  # arena-cycles, compilation excluded
    assert result.rate_episodes == sum(len(c) for c in chunks[first + 1:]), \
        "run() must count the episodes by the cycles the stream yields, not by each arena's own end cycle"


@pytest.mark.skipif(not hasattr(os, "SCHED_BATCH"), reason="forked players and SCHED_BATCH are Linux's")
def test_a_forked_player_runs_as_a_started_one_would(tmp_path):
    """runner/launch.py: a player forked from the fork server has its own session, its member name, the
    arena's scheduling policy and its own log, and the arena reads its exit code."""
    from keepaway.runner.launch import ArenaProcesses

    with socket.socket() as unused:
        unused.bind(("127.0.0.1", 0))  # a port that nobody listens on: the player waits for its init_ok
        endpoint = f"tcp://127.0.0.1:{unused.getsockname()[1]}"
        with ArenaProcesses(tmp_path, batch_scheduled=True) as arena:
            waiting = arena.start_player("keeper 1", ["--team", "keepers", "--server", endpoint])
            failing = arena.start_player("taker 1", ["--team", "takers", "--policy", str(tmp_path / "none.npz")])
            assert failing.proc.wait(timeout=60) == 2
            assert failing.describe_exit() == f"taker 1 (pid {failing.proc.pid}) exited with code 2"
            assert "none.npz" in (tmp_path / "taker_1.log").read_text()
            pid = waiting.proc.pid
            assert waiting.proc.poll() is None
            assert os.getsid(pid) == pid
            assert os.sched_getscheduler(pid) == os.SCHED_BATCH
            assert Path(f"/proc/{pid}/comm").read_text().strip() == "keeper 1"
        assert waiting.proc.returncode is not None  # stopped with its arena


@pytest.mark.skipif(not hasattr(os, "SCHED_BATCH"), reason="SCHED_BATCH is Linux's")
def test_a_synchronous_arenas_processes_run_batch_scheduled_and_others_as_they_were(tmp_path):
    """runner/launch.py: members of a batch-scheduled arena run under SCHED_BATCH (a woken process does
    not preempt the one that woke it); other processes keep the launcher's policy."""
    from keepaway.runner.launch import ArenaProcesses

    sleeper = [sys.executable, "-c", "import time; time.sleep(60)"]
    for batch, expected in ((True, os.SCHED_BATCH), (False, os.sched_getscheduler(0))):
        with ArenaProcesses(tmp_path / str(batch), batch_scheduled=batch) as arena:
            member = arena.start("sleeper", sleeper)
            assert os.sched_getscheduler(member.proc.pid) == expected
