"""The same games as ever: ``keepaway run --episodes 100 --seed 0`` plays the episodes it played before the
package moved under the keepaway namespace and its modules were split by role. A change that alters what
the server or a player does changes this fingerprint, and must say so in docs/design.md and record the
new one here, with the trace replays, the kernel-equivalence tests and distributed == embedded still
green."""

from __future__ import annotations

import hashlib
import subprocess

import pytest

from conftest import keepaway_command

# sha256 of the episode lines of keepaway.kwy (its "#" header lines left out): 100 episodes, seed 0,
# 3 keepers and 2 takers with the hand-coded policies, the classic parameters, distributed mode.
EPISODES_SHA256 = "820adc5ff2ccea1ae44b83e2c3109aee77b00c3d3b23d80ef930dcd7338bf517"


def episode_lines_sha256(text: str) -> str:
    lines = [line for line in text.splitlines(keepends=True) if not line.startswith("#")]
    return hashlib.sha256("".join(lines).encode()).hexdigest()


@pytest.mark.slow
def test_keepaway_run_plays_the_recorded_episodes(processes, tmp_path):
    run = processes.popen(keepaway_command("run", "--episodes", "100", "--seed", "0", "--no-game-log",
                                           "--no-progress", "--out", str(tmp_path)), stdout=subprocess.DEVNULL)
    assert run.wait(timeout=600) == 0, processes.stderr_tail(run)
    kwy = (tmp_path / "keepaway.kwy").read_text()
    assert sum(not line.startswith("#") for line in kwy.splitlines()) == 100
    assert episode_lines_sha256(kwy) == EPISODES_SHA256
