"""Repeated log lines are rate-limited and counted (core/log_limit.py), in a real server too."""

from __future__ import annotations

import logging
import re
import time

import pytest

from keepaway.protocol import messages as m
from scripted import ScriptedCoach, ScriptedPlayer
from keepaway.core.log_limit import KIND_ATTR, MAX_KINDS, RepeatLimit

MISSED = "%s missed cycle %d (%d in a row)"


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def limited(request):
    """A logger of its own with a RepeatLimit on a fake clock; ``lines`` collects what it prints."""
    logger = logging.getLogger(f"test.log_limit.{request.node.name}")
    logger.propagate = False
    logger.setLevel(logging.INFO)
    clock = FakeClock()
    limit = RepeatLimit(interval_s=1.0, clock=clock)
    lines: list[str] = []
    handler = logging.Handler()
    handler.emit = lambda record: lines.append(record.getMessage())
    logger.addHandler(handler)
    logger.addFilter(limit)
    yield logger, clock, limit, lines
    logger.removeHandler(handler)
    logger.removeFilter(limit)


def test_a_burst_prints_one_line_a_second_and_counts_the_rest(limited):
    logger, clock, limit, lines = limited
    for cycle in range(150):  # a missed cycle every 20 ms for 3 s
        clock.now = cycle * 20 / 1000
        logger.warning(MISSED, "keeper 1", cycle, cycle + 1)
    assert lines == [
        "keeper 1 missed cycle 0 (1 in a row)",
        "keeper 1 missed cycle 50 (51 in a row) ... and 49 more like this in the last 1.0 s",
        "keeper 1 missed cycle 100 (101 in a row) ... and 49 more like this in the last 1.0 s",
    ]
    clock.now = 3.0
    limit.flush()  # cycles 101..149 were held back: the last goes out with the count of the 48 others
    assert lines[3:] == ["keeper 1 missed cycle 149 (150 in a row) ... and 48 more like this in the last 1.0 s"]
    assert len(lines) + 49 + 49 + 48 == 150


def test_lines_of_other_kinds_are_not_held_back(limited):
    logger, clock, limit, lines = limited
    logger.warning(MISSED, "keeper 1", 0, 1)
    logger.warning(MISSED, "keeper 2", 0, 1)  # another player: other words
    logger.error(MISSED, "keeper 1", 0, 1)  # another level
    logger.warning("client %s: %s: %s", "ab12", "malformed", "not msgpack")
    logger.warning("client %s: %s: %s", "ab12", "bad_value", "dash power is NaN")  # another code
    clock.now = 0.5
    logger.warning(MISSED, "keeper 1", 1, 2)  # held back
    assert lines == ["keeper 1 missed cycle 0 (1 in a row)", "keeper 2 missed cycle 0 (1 in a row)",
                     "keeper 1 missed cycle 0 (1 in a row)", "client ab12: malformed: not msgpack",
                     "client ab12: bad_value: dash power is NaN"]


def test_a_named_kind_holds_back_lines_whose_text_varies(limited):
    logger, clock, limit, lines = limited
    for n in range(5):  # a decoder's message names the bad position: the kind is the client and the code
        logger.warning("client %s: %s: %s", "ab12", "bad_value", f"commands[{n}] is NaN",
                       extra={KIND_ATTR: ("ab12", "bad_value")})
    logger.warning("client %s: %s: %s", "ab12", "malformed", "x", extra={KIND_ATTR: ("ab12", "malformed")})
    clock.now = 1.0
    logger.warning("client %s: %s: %s", "ab12", "bad_value", "commands[9] is NaN",
                   extra={KIND_ATTR: ("ab12", "bad_value")})
    assert lines == ["client ab12: bad_value: commands[0] is NaN", "client ab12: malformed: x",
                     "client ab12: bad_value: commands[9] is NaN ... and 4 more like this in the last 1.0 s"]


def test_kinds_of_ever_new_clients_do_not_pile_up(limited):
    logger, clock, limit, lines = limited
    for n in range(3 * MAX_KINDS):  # a client under ever new identities, one line each
        clock.now = n * 0.01
        logger.warning("client %s: %s: %s", f"{n:x}", "not_initialised", "send init first")
    assert len(lines) == 3 * MAX_KINDS  # every line is of a new kind: none is held back
    assert len(limit._windows) <= MAX_KINDS + 100  # those past their second are forgotten


def test_a_line_after_a_quiet_spell_reports_what_was_held_back_since_the_last(limited):
    logger, clock, limit, lines = limited
    logger.info("paused at cycle %d", 10)
    clock.now = 0.25
    logger.info("paused at cycle %d", 11)
    clock.now = 0.75
    logger.info("paused at cycle %d", 12)
    clock.now = 7.5
    logger.info("paused at cycle %d", 13)
    clock.now = 8.0
    logger.info("paused at cycle %d", 14)
    assert lines == ["paused at cycle 10", "paused at cycle 13 ... and 2 more like this in the last 7.5 s"]
    clock.now = 9.25
    limit.flush()  # one held back: it goes out as it was
    assert lines[2:] == ["paused at cycle 14"]
    limit.flush()  # nothing more
    logger.info("paused at cycle %d", 15)  # and a flush starts every kind afresh
    assert lines[2:] == ["paused at cycle 14", "paused at cycle 15"]


def test_the_note_leaves_the_lines_own_formatting_alone(limited):
    logger, clock, limit, lines = limited
    logger.warning("%s: 100%% done", "a")
    logger.warning("%s: 100%% done", "a")
    clock.now = 2.0
    logger.warning("%s: 100%% done", "a")
    logger.warning("no arguments, 100% literal")
    assert lines == ["a: 100% done", "a: 100% done ... and 1 more like this in the last 2.0 s",
                     "no arguments, 100% literal"]


def test_a_server_waiting_for_a_silent_player_logs_seconds_not_cycles(processes, tmp_path):
    cycles = 150  # 3 s at --cycle-timeout 0.02: 150 "missed cycle" warnings without the limit
    srv = processes.start_server(tmp_path, "--keepers", "1", "--takers", "1", "--start-on", "coach",
                                 "--cycle-timeout", "0.02", "--max-missed", "1000000", "--max-cycles", str(cycles))
    silent = ScriptedPlayer(srv.players_endpoint)
    assert isinstance(silent.init("keepers"), m.InitOk)
    coach = ScriptedCoach(srv.coach_endpoint)
    coach.init()
    started = time.monotonic()
    coach.send(m.Start())
    assert srv.wait(60) == 0
    elapsed_s = time.monotonic() - started
    lines = [line for line in srv.stderr_text().splitlines() if "keeper 1 missed cycle" in line]
    held = [int(n) for line in lines for n in re.findall(r"and (\d+) more like this in the last", line)]
    assert 2 <= len(lines) <= elapsed_s + 2  # one a second, and the last held back one at shutdown
    assert held and len(lines) + sum(held) == cycles  # every missed cycle is counted
    assert f"keeper 1 missed cycle {cycles - 1} ({cycles} in a row)" in lines[-1]
