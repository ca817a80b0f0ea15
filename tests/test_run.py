"""``keepaway run`` end to end: real processes, the JSON summary, a dying player, determinism."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path

from conftest import keepaway_command

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


def children_of(pid: int) -> dict[int, str]:
    """pid -> command line of the direct children of ``pid`` (from /proc)."""
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            ppid = int(stat.rsplit(")", 1)[1].split()[1])
            if ppid == pid:
                found[int(entry.name)] = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (OSError, ValueError, IndexError):
            continue
    return found


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
    args = ["--episodes", "4", "--seed", "9"]
    distributed = run_json(processes, *args, "--out", str(tmp_path / "d"))
    embedded = run_json(processes, *args, "--mode", "embedded", "--out", str(tmp_path / "e"))
    key = lambda s: [(e["episode"], e["start_cycle"], e["end_cycle"], e["end"]) for e in s["episodes"]]
    assert key(distributed) == key(embedded)
    assert (tmp_path / "d" / "keepaway.kwy").read_text() == (tmp_path / "e" / "keepaway.kwy").read_text()


def test_a_killed_player_is_named_and_the_run_fails_without_hanging(processes, tmp_path):
    proc = processes.popen(keepaway_command("run", "--episodes", "100000", "--no-progress", "--out", str(tmp_path)),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 180
    victim = None
    while time.monotonic() < deadline and victim is None:
        kids = children_of(proc.pid)
        players = sorted(pid for pid, cmd in kids.items() if "player --team takers" in cmd)
        # wait until the game runs (an episode was logged), then kill the second taker
        if len(players) == 2 and episodes_logged(tmp_path) >= 1:
            victim = players[1]
        time.sleep(0.2)
    assert victim is not None, "the arena did not start"
    os.kill(victim, signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    message = err.decode().strip().splitlines()[-1]
    assert message.startswith("keepaway run: taker ") and f"(pid {victim}) was killed by SIGKILL" in message
    time.sleep(0.5)
    assert not children_of(proc.pid)


def test_batched_run_reports_the_same_summary_shape(processes, tmp_path):
    summary = run_json(processes, "--mode", "batched", "--batch", "8", "--episodes", "16", "--seed", "1",
                       "--out", str(tmp_path))
    assert set(summary) == SUMMARY_KEYS and summary["mode"] == "batched"
    assert len(summary["episodes"]) == 16


def test_bad_options_are_one_line_errors(processes, tmp_path):
    bad_policy = tmp_path / "bad.npz"
    bad_policy.write_bytes(b"not a policy")
    for args, text in [
        (["--episodes", "0"], "--episodes must be at least 1"),
        (["--mode", "embedded", "--realtime"], "--realtime needs --mode distributed"),
        (["--getopen", "learned", "--policy", str(bad_policy)], "bad.npz"),
        (["--field-size", "nan"], "not a finite number"),
    ]:
        proc = processes.popen(keepaway_command("run", *args, "--out", str(tmp_path)),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        _, err = proc.communicate(timeout=120)
        assert proc.returncode == 2, err
        assert text in err.decode() and "Traceback" not in err.decode()


def test_four_versus_three_on_a_larger_field_runs_distributed(processes, tmp_path):
    summary = run_json(processes, "--keepers", "4", "--takers", "3", "--field-size", "30", "--episodes", "2",
                       "--out", str(tmp_path))
    assert len(summary["episodes"]) == 2
    header = (tmp_path / "keepaway.kwy").read_text().splitlines()[:3]
    assert header == ["# Keepers: 4", "# Takers:  3", "# Region:  30 x 30"]


def test_ctrl_c_stops_every_process_of_the_arena(processes, tmp_path):
    proc = processes.popen(keepaway_command("run", "--episodes", "100000", "--no-progress", "--out", str(tmp_path)),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 180
    kids: dict[int, str] = {}
    while time.monotonic() < deadline:
        kids = children_of(proc.pid)
        if len(kids) == 7 and episodes_logged(tmp_path) >= 1:
            break
        time.sleep(0.2)
    assert len(kids) == 7, kids
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "interrupted; every process was stopped" in err.decode()
    for pid in kids:
        assert not Path(f"/proc/{pid}").exists() or "zombie" in Path(f"/proc/{pid}/status").read_text()
