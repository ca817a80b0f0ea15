"""Our physics reproduces every rcssserver 19.0.0 physics trace (traces README: "build a test that replays
each file"). The traces come from ``$KEEPAWAY_RCSS_TRACES``, else ``../shared/rcss-traces`` beside the
repository, else the vendored copy in ``tests/data/rcss-traces``."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from click.testing import CliRunner

from keepaway.server.cli import replay_trace_command
from keepaway.server.trace_replay import is_physics_trace, replay_trace

REPO = Path(__file__).resolve().parent.parent
VENDORED = REPO / "tests" / "data" / "rcss-traces"


def trace_directory() -> Path:
    if os.environ.get("KEEPAWAY_RCSS_TRACES"):
        return Path(os.environ["KEEPAWAY_RCSS_TRACES"])
    shared = REPO.parent / "shared" / "rcss-traces"
    return shared if shared.is_dir() else VENDORED


TRACE_FILES = sorted(p for p in trace_directory().glob("*.json")
                     if is_physics_trace(json.loads(p.read_text())))


def test_trace_directory_has_physics_traces():
    assert len(TRACE_FILES) >= 13


@pytest.mark.parametrize("path", TRACE_FILES, ids=lambda p: p.stem)
def test_trace_replays_within_print_precision(path: Path):
    data = json.loads(path.read_text())
    report = replay_trace(path)
    assert report.cycles == len(data["trace"])
    assert report.ok, "\n".join(map(str, report.mismatches[:10]))


def test_non_physics_file_is_rejected(tmp_path: Path):
    path = tmp_path / "see-samples.json"
    path.write_text(json.dumps({"runs": []}))
    with pytest.raises(ValueError, match="not a physics trace"):
        replay_trace(path)


def test_cli_reports_ok_for_a_trace():
    result = CliRunner().invoke(replay_trace_command, [str(VENDORED / "a_dash100_straight.json")])
    assert result.exit_code == 0, result.output
    assert result.output.startswith("OK a_dash100_straight 31 cycles, max error ")


def test_cli_fails_on_a_perturbed_trace_and_skips_other_files(tmp_path: Path):
    data = json.loads((VENDORED / "a_dash100_straight.json").read_text())
    data["trace"][1]["player"][0] = 0.61  # rcssserver printed 0.6 at cycle 2
    (tmp_path / "a_bad.json").write_text(json.dumps(data))
    (tmp_path / "see-samples.json").write_text(json.dumps({"runs": []}))
    result = CliRunner().invoke(replay_trace_command, [str(tmp_path)])
    assert result.exit_code == 1
    lines = result.output.splitlines()
    assert lines[0].startswith("FAIL a_dash100_straight: 1 mismatches")
    assert lines[1] == "  cycle 2 player.x: expected 0.61, got 0.6"
    assert lines[2] == "SKIP see-samples.json: not a physics trace"
