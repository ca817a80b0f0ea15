"""``examples/protocol_taker.py``, a taker written from docs/protocol.md alone, plays a real server's game
beside the project's keepers and taker: the documented protocol is enough to write a player."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from conftest import keepaway_command
from keepaway.server.episode_log import read_jsonl

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "protocol_taker.py"


def test_the_example_needs_nothing_of_the_project():
    imported = set()
    for node in ast.walk(ast.parse(EXAMPLE.read_text())):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add((node.module or "").split(".")[0])
    assert imported == {"__future__", "argparse", "sys", "msgpack", "zmq"}


def test_a_taker_written_from_the_protocol_alone_plays_every_cycle_of_whole_episodes(processes, tmp_path):
    srv = processes.start_server(tmp_path, "--episodes", "3", "--seed", "3")
    for team in ["keepers"] * 3 + ["takers"]:
        processes.popen(keepaway_command("player", "--team", team, "--server", srv.players_endpoint, "--seed", "3"),
                        stdout=subprocess.DEVNULL)
    example = processes.popen([sys.executable, str(EXAMPLE), "--server", srv.players_endpoint],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out, err = example.communicate(timeout=300)
    assert example.returncode == 0, err.decode()
    assert srv.wait(timeout=60) == 0, srv.stderr_text()[-2000:]
    lines = out.decode().splitlines()
    assert lines[0] in ("protocol-taker: joined as taker 1 (before_kick_off)",  # whichever taker joins first
                        "protocol-taker: joined as taker 2 (before_kick_off)")
    _, episodes = read_jsonl(srv.log_dir / "keepaway.jsonl")
    assert len(episodes) == 3
    assert all(not e.missed for e in episodes)  # it answered every cycle in time
    played = episodes[-1].end_cycle
    assert (lines[-1].startswith("protocol-taker: the server shut down (")
            and lines[-1].endswith(f"after {played} cycles"))
    assert err.decode() == ""
