"""The game log (.rcg version 5, server/game_log.py): rcssserver's own lines written byte for byte, read
back as written, and read by the reference measurement's script (tests/data/rcss-behaviour/README.md)."""

from __future__ import annotations

import csv
import gzip
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from keepaway.protocol import messages as m
from keepaway.protocol.params import parameter_set
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame
from keepaway.server.game_log import (
    STATE_KICK,
    STATE_KICK_FAULT,
    STATE_STAND,
    GetOpenNote,
    PlayerShow,
    RcgFormatter,
    Show,
    WorldShows,
    parse_rcg,
    parse_show,
    read_rcg,
    show_from_frame,
    show_line,
)
from keepaway.server.show_text import STATE_BALL_COLLIDE
from keepaway.server.world import COLLIDED_BALL, COUNT_KICK, new_world

DATA = Path(__file__).parent / "data" / "rcss-behaviour"
REFERENCE = DATA / "ref_hold2_head.rcg"
PARSE_RCG = DATA / "parse_rcg.py"


def test_a_show_line_is_written_as_rcssserver_writes_it():
    keeper = PlayerShow("l", 1, STATE_STAND | STATE_KICK, 7.13534, -7.71596, 0.000049, -0.1, 78.5394, -0.0001,
                        360.0, 8000.0, 1.0, 1.0, 130600.0, (1, 34, 10, 0, 0, 44, 0, 2, 0, 0, 0))
    line = show_line(Show(3, (-6.0, -6.00004, 0.25, 0.0), (keeper,)))
    assert line.startswith("(show 3 ((b) -6 -6 0.25 0) ((l 1) 0 0x3 7.1353 -7.716 0 -0.1 78.539 -0 (v h 360) "
                           "(s 8000 1 1 130600) (c 1 34 10 0 0 44 0 2 0 0 0)) ((l 2) 0 0 -6 -37 0 0 0 0 ")
    assert line.endswith(" ((r 11) 0 0 33 -37 0 0 0 0 (v h 360) (s 8000 1 1 130600) (c 0 0 0 0 0 0 0 0 0 0 0)))")
    assert line.count(" ((") == 1 + 22  # the ball and all 22 players


def test_the_reference_game_log_is_read_and_written_back_byte_for_byte():
    lines = REFERENCE.read_text(encoding="latin-1").splitlines()
    shows = [l for l in lines if l.startswith("(show ")]
    record = parse_rcg(line + "\n" for line in lines)
    assert [s.cycle for s in record.shows] == list(range(40))
    assert record.teams == ("keepers", "takers") and record.play_modes == [(0, "play_on")]
    assert [(p.side, p.unum) for p in record.shows[0].players] == [("l", 1), ("l", 2), ("l", 3), ("r", 1), ("r", 2)]
    assert record.shows[2].players[1][:9] == ("l", 2, 1, 8.1376, 8.7827, -0.0644, -0.233, -107.7, -12.0)
    assert [show_line(s) for s in record.shows] == shows


def test_episodes_come_from_the_referee_messages_or_else_from_the_kwy(tmp_path):
    no_messages = read_rcg(REFERENCE, kwy=DATA / "ref_hold2_head.kwy")
    assert no_messages.episode_starts == [0, 25]
    assert no_messages.episode_at(24) == (1, 0) and no_messages.episode_at(25) == (2, 25)
    lines = REFERENCE.read_text(encoding="latin-1").splitlines()
    marked = lines[:40] + ['(msg 17 1 "(referee training Keepaway 1)")'] + lines[40:]
    assert parse_rcg(line + "\n" for line in marked).episode_starts == [0, 17]


def test_malformed_game_logs_are_one_line_errors_and_a_cut_last_line_is_skipped(tmp_path):
    lines = [l + "\n" for l in REFERENCE.read_text(encoding="latin-1").splitlines()]
    with pytest.raises(ValueError, match=r"^log:1: not a text game log of version 5"):
        parse_rcg(["ULG4\n"] + lines[1:], "log")
    broken = lines[:30] + [lines[30].replace("(v h 360)", "(v h)", 1)] + lines[31:]
    with pytest.raises(ValueError, match=r"^log:31: unreadable player entry"):
        parse_rcg(broken, "log")
    with pytest.raises(ValueError, match=r"^log:2: unknown line"):
        parse_rcg([lines[0], "hello\n"] + lines[1:], "log")
    assert len(parse_rcg(lines[:-1] + [lines[-1][:500]], "log").shows) == 39
    path = tmp_path / "missing.rcg"
    with pytest.raises(ValueError, match="cannot read .*missing.rcg"):
        read_rcg(path)


def test_world_shows_flag_kicks_that_missed_and_collisions():
    params = parameter_set("classic")
    world = new_world(params, 3, 2)
    world.enabled[0, 1:] = True
    shows = WorldShows(world, params.visible_angle)
    world.kicked[0, 1:3] = True
    world.counts[0, 1, COUNT_KICK] += 1  # keeper 1's kick reached the ball, keeper 2's did not
    world.collision[0, 4] = COLLIDED_BALL
    world.enabled[0, 5] = False
    players = shows.show(0, [1.0, 1.0, 0.5, 1.0, 1.0, 1.0]).players
    assert [p.state for p in players] == [STATE_STAND | STATE_KICK, STATE_STAND | STATE_KICK | STATE_KICK_FAULT,
                                          STATE_STAND, STATE_STAND | STATE_BALL_COLLIDE, 0]
    assert players[1].view_angle == params.visible_angle / 2
    assert players[0].counts == (1,) + (0,) * 10


def test_a_monitor_frame_gives_the_same_positions_as_its_show():
    frame = m.Frame(cycle=7, ball=(1.0, 2.0, 0.5, -0.5), players=(("l", 1, 3.0, 4.0, 0.1, 0.2, 45.0, -10.0, 3900.0,
                                                                    1.0, 1.0, -1.0),),
                    play_mode="play_on", episode=2, episode_start=0, take_count=0)
    show = show_from_frame(frame)
    assert parse_show(show_line(show)) == show


def test_a_game_log_read_back_gives_the_game_as_played_and_the_reference_script_reads_it(tmp_path):
    """An embedded game writes its log; our reader and the reference's parse_rcg.py both give back the
    positions of the arena's world at every cycle (to the log's precision), and the episodes it played."""
    spec = ArenaSpec(parameter_set("classic"), seed=5)
    path = tmp_path / "keepaway.rcg"
    game = EmbeddedGame(spec, game_log=path)
    w, truth, records = game.arena.world, {}, []
    while True:  # cycle -> the ball's position, keeper 2's position and body direction, from the kick-off on
        truth[game.arena.cycle] = (*w.pos[0, 0], *w.pos[0, 2], float(w.body[0, 2]))
        if len(records) == 3:
            break
        ended = game.cycle()
        if ended is not None:
            records.append(ended)
    game.game_log.close()
    record = read_rcg(path)
    assert record.episode_starts == [0] + [r.end_cycle for r in records[:-1]]
    assert record.episodes_end == records[-1].end_cycle
    last = record.shows[-1]
    assert last.cycle == records[-1].end_cycle
    kwy = tmp_path / "keepaway.kwy"
    kwy.write_text("".join(f"{r.episode}\t{r.start_cycle}\t{r.end_cycle}\t{r.duration}\t{r.end[0]}\n"
                           for r in records))
    out = tmp_path / "traj.csv.gz"
    done = subprocess.run([sys.executable, str(PARSE_RCG), "--rcg", str(path), "--kwy", str(kwy), "--out", str(out)],
                          capture_output=True, text=True, check=True)
    info = json.loads(done.stdout)
    assert info["episodes_written"] == 3 and info["players"] == ["l1", "l2", "l3", "r1", "r2"]
    with gzip.open(out, "rt") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == records[-1].end_cycle
    by_cycle = {s.cycle: s for s in record.shows}
    assert set(truth) <= set(by_cycle)  # a show of every cycle played
    for row in rows:
        cycle = int(row["cycle"])
        show = by_cycle[cycle]
        keeper2 = show.players[1]
        read = (float(row["bx"]), float(row["by"]), float(row["l2_x"]), float(row["l2_y"]), float(row["l2_body"]))
        assert read == (*show.ball[:2], keeper2.x, keeper2.y, keeper2.body)
        # the log's precision: positions quantized to 0.0001 m, directions to 0.001 deg
        assert (np.abs(np.subtract(read, truth[cycle])) <= [6e-5] * 4 + [6e-4]).all(), (cycle, read, truth[cycle])


def test_getopen_notes_are_written_on_the_log_board_and_read_back():
    params = parameter_set("classic")
    formatter = RcgFormatter(params)
    show = Show(0, (0.0, 0.0, 0.0, 0.0), ())
    note = GetOpenNote(4, 2, (3.5, -7.0), (-7.0, -7.0, 0.25, -7.0, -3.5, -1.5))
    lines = formatter.header() + formatter.start_game(show) + formatter.cycle(show._replace(cycle=4), notes=[note])
    assert '(msg 4 2 "(getopen (l 2) 3.5 -7 -7 -7 0.25 -7 -3.5 -1.5)")' in lines
    assert parse_rcg(line + "\n" for line in lines).notes == {4: [note]}


def test_keepers_note_their_getopen_decisions_without_changing_the_game(tmp_path):
    """``getopen_notes`` "values": each keeper that ran GetOpen sends its target and its policy's rating of
    the grid points (GO:HC: minus the congestion of the admissible points, whose best is its target); the
    notes reach the game log, and the game is the one played without them."""
    spec = ArenaSpec(parameter_set("classic"), seed=3)
    plain = EmbeddedGame(spec)
    noted = EmbeddedGame(spec, game_log=tmp_path / "k.rcg", getopen_notes="values")
    sent: dict[int, list] = {}
    for _ in range(400):
        assert plain.cycle() == noted.cycle()
        for unum, note in noted.arena.step_notes:
            sent.setdefault(noted.arena.cycle, []).append((unum, note))
            target, rows = np.array(note[:2]), np.array(note[2:]).reshape(-1, 3)
            assert len(rows) <= 25 and (len(note) - 2) % 3 == 0
            if len(rows):
                assert np.array_equal(rows[np.argmax(rows[:, 2]), :2], target)  # the best rated point is the target
            else:
                assert np.array_equal(target, (0.0, 0.0))  # no admissible point: the region's centre
    assert np.array_equal(plain.arena.world.pos, noted.arena.world.pos)
    assert len(sent) > 100 and {unum for notes in sent.values() for unum, _ in notes} == {1, 2, 3}
    assert sum(len(note) > 2 for notes in sent.values() for _, note in notes) > 100  # rated points
    noted.game_log.close()
    logged = read_rcg(tmp_path / "k.rcg").notes
    assert sorted(logged) == sorted(sent)
    for cycle, notes in sent.items():
        assert [(n.unum, (*n.target, *n.values)) for n in logged[cycle]] == \
            [(u, tuple(float(cpp) for cpp in (f"{v:.6g}" for v in note))) for u, note in notes]
