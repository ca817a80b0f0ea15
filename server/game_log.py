"""rcssserver's game log (``.rcg``, text version 5): one definition of the format, written and read here.

The format is what rcssserver 19 writes with ``game_log_version 5`` (``initsenderlogger.cpp``,
``serializermonitor.cpp``, ``dispsender.cpp``) and what rcssmonitor, soccerwindow2 (librcsc's
``rcg/parser_v4.cpp``) and the reference's own analysis script read: a header (``ULG5``, one
``server_param``, one ``player_param`` and the ``player_type`` lines), then ``(playmode T mode)`` and
``(team T left right score_l score_r)`` whenever they change, one ``(show T ...)`` line per cycle and
``(msg T board "text")`` lines. A show lists the ball and all 22 players, as rcssserver does: the players
that do not exist in a Keepaway game (keepers beyond K, takers beyond T) stand where rcssserver parks
them, with state 0 (librcsc's fast parser reads exactly 22 players a show). Keepers are the left team,
takers the right team, as in keepaway-0.6.

**Episodes.** rcssserver's Keepaway referee resets the field inside the step that ends an episode, so
the show of an episode's end cycle is already the next episode's start (docs/rules.md §8); a game log
marks nothing else. With ``record_messages`` rcssserver also logs the referee's words as
``(msg T 1 "(referee training Keepaway 1)")`` before that show: we always write them (rcssmonitor shows
them on its message board), and :func:`read_rcg` finds the episodes by them; a log without them (the
reference's runs) takes its episodes from the ``.kwy`` beside it (:func:`read_kwy`).

**Notes.** A keeper's GetOpen decision of a cycle, its target point and optionally the grid points'
values, is written as ``(msg T 2 "(getopen (l U) TX TY [X1 Y1 V1 ...])")`` on the log board (board 2),
which rcssmonitor and soccerwindow2 list and otherwise ignore; ``keepaway view`` and ``keepaway render``
draw them. Our keepers send them with their commands when the server asks for notes (``keepaway server
--getopen-notes target|values``; docs/protocol.md §5, "command"); the note of a step's commands goes with the
show after that step.

The core is sans-IO: :class:`RcgFormatter` turns shows and events into text lines, :func:`parse_rcg`
turns text back into :class:`Show` frames. Writing a show line is most of a game log's cost, paid every
cycle by the server's one thread: writers take a :class:`ShowTable` (the world's arrays, read by a
kernel) and :func:`show_line` writes it with the kernel of ``server.show_text`` (tests/test_show_line.py
pins it to the format's definition, number by number); :class:`RcgLog` is the thin file sink the server
and ``keepaway run`` use, :func:`read_rcg` the reader the viewer's replay and ``keepaway render`` share.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from typing import NamedTuple

import numpy as np

from keepaway.core.jit import SteadyCall
from keepaway.protocol import messages as m
from keepaway.protocol.params import ServerParams
from keepaway.rcss.params import NOT_IN_RCSSSERVER, PLAYER_TYPE_PARAMS, RCSS_PARAM_NAMES
from keepaway.server.arena import REFEREE_EPISODE_MESSAGE, VIEW_WIDTHS, Arena
from keepaway.server.arena import compile_kernels as compile_arena_kernels
from keepaway.server.episode_log import EpisodeRecord, LineLog, cpp_number, read_kwy
from keepaway.server.show_text import (
    BAD_ORDER,
    HOLE_NUMBER,
    MAX_HOLES,
    MAX_LINE_BYTES,
    MAX_UNUM,
    N_NUMBERS,
    N_RCG_COUNTS,
    N_ROW,
    N_SLOTS,
    STATE_DISABLE,
    STATE_KICK,
    STATE_KICK_FAULT,
    STATE_STAND,
    world_table,
    write_show,
)
from keepaway.server.world import COUNT_KICK, PARKED_Y, World, new_world

RCG_SUFFIX = ".rcg"
RCG_VERSION_LINE = "ULG5"
MSG_BOARD = 1  # rcssserver's BoardType
LOG_BOARD = 2
REFEREE_NAME = "referee"
GETOPEN_NOTE = "getopen"
PLAY_ON = "play_on"


class PlayerShow(NamedTuple):
    """One player of a show, as the v5 line carries it (global frame, degrees; neck relative to body)."""

    side: str  # "l" keepers, "r" takers
    unum: int
    state: int  # STATE_* bits; 0: not on the pitch
    x: float
    y: float
    vx: float
    vy: float
    body: float
    neck: float
    view_angle: float = 360.0  # the view cone's width (deg)
    stamina: float = 8000.0
    effort: float = 1.0
    recovery: float = 1.0
    capacity: float = -1.0
    counts: tuple[int, ...] = (0,) * N_RCG_COUNTS


class Show(NamedTuple):
    """One cycle's state: the ball (x, y, vx, vy) and the players on the pitch."""

    cycle: int
    ball: tuple[float, float, float, float]
    players: tuple[PlayerShow, ...]


_SLOTS = tuple((side, unum) for side in "lr" for unum in range(1, MAX_UNUM + 1))  # a show's players, in order


class GetOpenNote(NamedTuple):
    """A keeper's GetOpen decision of one cycle: its target point and, if it sent them, the grid points
    with their values, flat: x1, y1, v1, x2, y2, v2, ..."""

    cycle: int
    unum: int
    target: tuple[float, float]
    values: tuple[float, ...] = ()

    @classmethod
    def from_numbers(cls, cycle: int, unum: int, numbers: Sequence[float]) -> GetOpenNote:
        """A note from its flat numbers, the target first: as a keeper's command carries it
        (``protocol.messages.getopen_note``) and as the log line writes it (:func:`getopen_text`)."""
        return cls(cycle, unum, tuple(numbers[:2]), tuple(numbers[2:]))


def parked(side: str, unum: int) -> PlayerShow:
    """A player that is not in the game, where rcssserver's logs show it (x = -3 unum on the left,
    +3 unum on the right, y = -37, state 0)."""
    return PlayerShow(side, unum, STATE_DISABLE, (-3.0 if side == "l" else 3.0) * unum, PARKED_Y, 0.0, 0.0, 0.0, 0.0,
                      stamina=8000.0, capacity=130600.0)


def show_from_frame(frame: m.Frame) -> Show:
    """The show of a monitor ``frame`` (docs/protocol.md §8): its players are on the pitch and standing;
    a frame carries no kick or collision flags and no command counts."""
    players = tuple(PlayerShow(side, unum, STATE_STAND, x, y, vx, vy, body, neck, stamina=stamina, effort=effort,
                               recovery=recovery, capacity=capacity)
                    for side, unum, x, y, vx, vy, body, neck, stamina, effort, recovery, capacity in frame.players)
    return Show(frame.cycle, tuple(frame.ball), players)


class ShowTable(NamedTuple):
    """A show as its line is written (:func:`show_line`, by ``server.show_text.write_show``): the players on
    the pitch, each with its slot in rcssserver's order (``l 1`` to ``l 11`` are slots 0 to 10, ``r 1`` to
    ``r 11`` slots 11 to 21; increasing), its state and a row of its numbers. :class:`WorldShows` makes
    tables from a world's arrays, :meth:`of` from a :class:`Show`."""

    cycle: int
    ball: np.ndarray  # (4,): x y vx vy
    slots: np.ndarray  # (P,) int64
    states: np.ndarray  # (P,) int64, STATE_* bits
    rows: np.ndarray  # (P, N_ROW): a player's PLAYER_NUMBERS, then its N_RCG_COUNTS counts (floats, exact below 2**53)

    @classmethod
    def of(cls, show: Show) -> ShowTable:
        """The table of ``show``: of two entries of one player the last counts, and a player none of
        rcssserver's 22 places has is left out."""
        by_id = {(p.side, p.unum): p for p in show.players}
        slots = [slot for slot, place in enumerate(_SLOTS) if place in by_id]
        players = [by_id[_SLOTS[slot]] for slot in slots]
        rows = np.array([(*p[3:3 + N_NUMBERS], *p.counts) for p in players], dtype=float).reshape(-1, N_ROW)
        return cls(show.cycle, np.asarray(show.ball, dtype=float), np.array(slots, dtype=np.int64),
                   np.array([p.state for p in players], dtype=np.int64), rows)

    def show(self) -> Show:
        """This show with its players as :class:`PlayerShow`."""
        players = tuple(PlayerShow(*_SLOTS[slot], state, *row[:N_NUMBERS], tuple(int(c) for c in row[N_NUMBERS:]))
                        for slot, state, row in zip(self.slots.tolist(), self.states.tolist(), self.rows.tolist()))
        return Show(self.cycle, tuple(self.ball.tolist()), players)


class WorldShows:
    """Shows of the arenas of a :class:`server.world.World` (any batch), one cycle after another
    (``server.show_text.world_table``, which remembers each arena's kick counts to tell a kick that
    missed the ball)."""

    def __init__(self, world: World, visible_angle: float) -> None:
        self.world = world
        self.visible_angle = float(visible_angle)
        n_players = world.n_objects - 1
        self._last_kicks = world.counts[:, :, COUNT_KICK].copy()
        self._slots = np.array([_SLOTS.index((world.side(o), world.unum(o))) for o in range(1, world.n_objects)],
                               dtype=np.int64)
        self._factors = np.ones(world.n_objects)
        self._ball = np.zeros(4)
        self._states = np.zeros(n_players, dtype=np.int64)
        self._rows = np.zeros((n_players, N_ROW))
        self._fill = SteadyCall(world_table)

    def table(self, b: int = 0, view_factors: Sequence[float] | None = None) -> ShowTable:
        """Arena ``b`` now; ``view_factors`` per player object (1 normal, 0.5 narrow, 2 wide; default 1)."""
        self._factors[:] = 1.0 if view_factors is None else view_factors
        self._fill(self.world, b, self._factors, self.visible_angle, self._last_kicks, self._ball, self._states,
                   self._rows)
        return ShowTable(int(self.world.time[b]), self._ball.copy(), self._slots, self._states.copy(),
                         self._rows.copy())

    def show(self, b: int = 0, view_factors: Sequence[float] | None = None) -> Show:
        """:meth:`table` as a :class:`Show`."""
        return self.table(b, view_factors).show()


# -- writing ---------------------------------------------------------------------------------------------
_ORDER_ERROR = "a show table's players go in rcssserver's order, each once"


class _ShowWriter:
    """One thread's buffers for ``write_show``: a table's arrays are copied in (a few hundred nanoseconds
    each), so that its :class:`SteadyCall` calls the kernel with the same arrays every line."""

    def __init__(self, parked: np.ndarray, parked_at: np.ndarray) -> None:
        self.out = np.zeros(MAX_LINE_BYTES, np.uint8)
        self.entry_at = np.zeros(N_SLOTS + 1, np.int64)
        self.holes = np.zeros((MAX_HOLES, 3))
        self.ball = np.zeros(4)
        self.slots = np.zeros(N_SLOTS, np.int64)
        self.states = np.zeros(N_SLOTS, np.int64)
        self.rows = np.zeros((N_SLOTS, N_ROW))
        self.parked, self.parked_at = parked, parked_at
        self.write = SteadyCall(write_show)

    def line(self, table: ShowTable) -> str:
        """The table's line: written by the kernel, its holes (if any) filled by Python's format."""
        n = len(table.slots)
        if n > N_SLOTS:
            raise ValueError(_ORDER_ERROR)
        self.ball[:] = table.ball
        self.slots[:n] = table.slots
        self.states[:n] = table.states
        self.rows[:n] = table.rows
        length, n_holes = self.write(self.out, self.entry_at, self.holes, table.cycle, self.ball, n, self.slots,
                                     self.states, self.rows, self.parked, self.parked_at)
        if length == BAD_ORDER:
            raise ValueError(_ORDER_ERROR)
        text = self.out[:length].tobytes().decode("ascii")
        if not n_holes:
            return text
        pieces, at = [], 0
        for offset, value, kind in self.holes[:n_holes].tolist():
            pieces += [text[at:int(offset)], format(value, ".6g") if kind == HOLE_NUMBER else "%d" % value]
            at = int(offset)
        return "".join(pieces) + text[at:]


@cache
def _parked_entries() -> tuple[np.ndarray, np.ndarray]:
    """The text of the 22 parked players' entries back to back and where each starts (and the end):
    written once by the kernel itself, from a table of all 22."""
    table = ShowTable.of(Show(0, (0.0,) * 4, tuple(parked(*slot) for slot in _SLOTS)))
    writer = _ShowWriter(np.zeros(0, np.uint8), np.zeros(N_SLOTS + 1, np.int64))
    writer.line(table)
    start, end = writer.entry_at[0], writer.entry_at[N_SLOTS]
    return writer.out[start:end].copy(), writer.entry_at - start


_writers = threading.local()


def show_line(show: Show | ShowTable) -> str:
    """``(show T ((b) x y vx vy) ((l 1) ...) ... ((r 11) ...))``: all 22 players, those not in the show
    parked (module docstring), written by ``server.show_text.write_show``."""
    table = show if isinstance(show, ShowTable) else ShowTable.of(show)
    writer = getattr(_writers, "writer", None)
    if writer is None:
        writer = _writers.writer = _ShowWriter(*_parked_entries())
    return writer.line(table)


def compile_kernels(params: ServerParams, keepers: int, takers: int) -> None:
    """Compile (or load) every kernel of a server that writes a game log: the arena's
    (``server.arena.compile_kernels``) and the show's, on a scratch world's show."""
    compile_arena_kernels(params, keepers, takers)
    world = new_world(params, keepers, takers)
    show_line(WorldShows(world, params.visible_angle).table(0, [1.0] * world.n_objects))


def msg_line(cycle: int, board: int, text: str) -> str:
    """``(msg T board "text")``; newlines become spaces (``DispSenderLoggerV4::sendMsg``)."""
    return f'(msg {cycle} {board} "{text.replace(chr(10), " ")}")'


def getopen_text(unum: int, target: Sequence[float], values: Sequence[float] = ()) -> str:
    """A keeper's GetOpen note (module docstring), numbers with 6 significant digits."""
    numbers = " ".join(cpp_number(v) for v in (*target, *values))
    return f"({GETOPEN_NOTE} (l {unum}) {numbers})"


@dataclass
class RcgFormatter:
    """The lines of one game log, in order (sans-IO). ``start_game`` with the kick-off's show, then
    ``cycle`` for every later show, ``end`` last; each returns the lines to write."""

    params: ServerParams
    left: str = "keepers"
    right: str = "takers"
    play_mode: str | None = field(default=None, init=False)

    def header(self) -> list[str]:
        """``ULG5``, ``server_param``, ``player_param`` and the one ``player_type`` (``InitSenderLoggerV5``)."""
        values = self.params.to_dict()
        server = {RCSS_PARAM_NAMES.get(k, k): v for k, v in values.items() if k not in NOT_IN_RCSSSERVER}
        server.update(keepaway=1, game_log_version=5, game_logging=1)
        player_type = {"id": 0, **{k: values[k] for k in PLAYER_TYPE_PARAMS}}
        return [RCG_VERSION_LINE, _param_line("server_param", server),
                _param_line("player_param", {"player_types": 1, "pt_max": 1, "subs_max": 0}),
                _param_line("player_type", player_type)]

    def start_game(self, show: Show | ShowTable, referee: Iterable[str] = (), mode: str = PLAY_ON) -> list[str]:
        """The kick-off: play mode, teams, the referee's words, the first show."""
        self.play_mode = mode
        return [f"(playmode {show.cycle} {mode})", self._team_line(show.cycle),
                *self._referee_lines(show.cycle, referee), show_line(show)]

    def cycle(self, show: Show | ShowTable, referee: Iterable[str] = (), notes: Iterable[GetOpenNote] = (),
              mode: str = PLAY_ON) -> list[str]:
        """One cycle: a play-mode change, the referee's words (``record_messages``) and the GetOpen notes
        of the keepers' commands that acted in the step to this cycle, then the show."""
        lines = [] if mode == self.play_mode else [f"(playmode {show.cycle} {mode})"]
        self.play_mode = mode
        lines += self._referee_lines(show.cycle, referee)
        lines += [msg_line(show.cycle, LOG_BOARD, getopen_text(n.unum, n.target, n.values)) for n in notes]
        lines.append(show_line(show))
        return lines

    def end(self, cycle: int, left_score: int = 0, right_score: int = 0) -> list[str]:
        """The result line and the last team line (``Logger::renameLogs``)."""
        stamp = time.strftime("%Y%m%d%H%M")
        return [msg_line(cycle, MSG_BOARD, f"(result {stamp} {self.left}_{left_score}-vs-{self.right}_{right_score})"),
                self._team_line(cycle, left_score, right_score)]

    @staticmethod
    def _referee_lines(cycle: int, referee: Iterable[str]) -> list[str]:
        return [msg_line(cycle, MSG_BOARD, f"({REFEREE_NAME} {text})") for text in referee]

    def _team_line(self, cycle: int, left_score: int = 0, right_score: int = 0) -> str:
        return f"(team {cycle} {self.left} {self.right} {left_score} {right_score})"


def _param_line(name: str, values: dict) -> str:
    def text(v: object) -> str:
        if isinstance(v, bool):
            return str(int(v))
        return cpp_number(v) if isinstance(v, float) else str(v)

    return f"({name} " + "".join(f"({k} {text(v)})" for k, v in values.items()) + ")"


class RcgLog(LineLog):
    """A game log file (``<directory>/<name>.rcg``), each cycle's lines flushed at once; an earlier log
    of that name is set aside, never overwritten (``server.episode_log.set_aside``)."""

    def __init__(self, path: Path | str, params: ServerParams, left: str = "keepers", right: str = "takers") -> None:
        super().__init__(Path(path))
        self.formatter = RcgFormatter(params, left, right)
        self.last_cycle = 0
        self._write_lines(self.formatter.header())

    def start_game(self, show: Show | ShowTable, referee: Iterable[str] = ()) -> None:
        self.last_cycle = show.cycle
        self._write_lines(self.formatter.start_game(show, referee))

    def cycle(self, show: Show | ShowTable, referee: Iterable[str] = (), notes: Iterable[GetOpenNote] = ()) -> None:
        self.last_cycle = show.cycle
        self._write_lines(self.formatter.cycle(show, referee, notes))

    def close(self) -> None:
        if not self.closed:
            self._write_lines(self.formatter.end(self.last_cycle))
        super().close()


class ArenaGameLog:
    """The game log of one :class:`server.arena.Arena` (the server's and the embedded mode's): open it
    before the kick-off, call :meth:`start_game` after it and :meth:`step` after every step."""

    def __init__(self, path: Path | str, arena: Arena) -> None:
        self.arena = arena
        self.log = RcgLog(path, arena.params)
        self.shows = WorldShows(arena.world, arena.params.visible_angle)
        arena.keep_referee_log()

    @property
    def path(self) -> Path:
        return self.log.path

    def table(self) -> ShowTable:
        """The show of the arena now, with each player's view width."""
        factors = [1.0] + [VIEW_WIDTHS[s.view_width] for s in self.arena.slots]
        return self.shows.table(0, factors)

    def start_game(self) -> None:
        self.log.start_game(self.table(), self.arena.take_referee_log())

    def step(self) -> None:
        """The show after the arena's step, with the referee's words and the keepers' GetOpen notes
        sent with the commands of that step (``Arena.step_notes``)."""
        show = self.table()
        notes = [GetOpenNote.from_numbers(show.cycle, unum, note) for unum, note in self.arena.step_notes]
        self.log.cycle(show, self.arena.take_referee_log(), notes)

    def close(self) -> None:
        self.log.close()


# -- reading ---------------------------------------------------------------------------------------------
_NUMBER = r"(-?[0-9.]+(?:e[-+]?[0-9]+)?|[-+]?(?:nan|inf))"
_SHOW_RE = re.compile(r"^\(show (\d+)$")
_BALL_RE = re.compile(r"^b\) " + " ".join([_NUMBER] * 4) + r"\)$")
# one player entry of a show, after its opening " ((" (the ``serializePlayer*`` calls of a v5 show)
_PLAYER_RE = re.compile(
    r"([lr]) (\d+)\) (\d+) (0x[0-9a-f]+|0) " + " ".join([_NUMBER] * 6)
    + r"(?: \S+ \S+)? \(v ([hl]) " + _NUMBER + r"\)(?: \(fp \S+ \S+\))? \(s " + _NUMBER + " " + _NUMBER + " "
    + _NUMBER + r"(?: " + _NUMBER + r")?\)(?: \(f [lr] \d+\))? \(c ([0-9 ]+)\)\)")
_MSG_RE = re.compile(r'^\(msg (\d+) (\d+) "(.*)"\)$')
_PLAYMODE_RE = re.compile(r"^\(playmode (\d+) ([a-z_A-Z]+)\)$")
_TEAM_RE = re.compile(r"^\(team (\d+) (\S+) (\S+) (-?\d+) (-?\d+)")
_PARAM_RE = re.compile(r"\(([a-z_0-9]+) ([^()]*)\)")
_GETOPEN_RE = re.compile(r"^\(" + GETOPEN_NOTE + r" \(l (\d+)\) ([-0-9.e+ ]+)\)$")


def parse_show(line: str) -> Show:
    """A ``(show ...)`` line; only the players on the pitch (state not 0) are read (the others are
    rcssserver's parked places). ValueError if it is not a v5 show."""
    parts = line.split(" ((")
    if len(parts) < 2 or not parts[-1].endswith(")"):
        raise ValueError("not a v5 show line")
    parts[-1] = parts[-1][:-1]  # the show's own closing parenthesis
    cycle, ball = _SHOW_RE.match(parts[0]), _BALL_RE.match(parts[1])
    if cycle is None or ball is None:
        raise ValueError("not a v5 show line (time or ball)")
    players = []
    for entry in parts[2:]:
        if entry.split(" ", 4)[3:4] == ["0"]:
            continue
        p = _PLAYER_RE.fullmatch(entry)
        if p is None:
            raise ValueError(f"unreadable player entry {entry[:12]!r}")
        g = p.groups()
        x, y, vx, vy, body, neck = map(float, g[4:10])
        capacity = float(g[15]) if g[15] is not None else -1.0
        players.append(PlayerShow(g[0], int(g[1]), int(g[3], 16), x, y, vx, vy, body, neck, float(g[11]),
                                  float(g[12]), float(g[13]), float(g[14]), capacity,
                                  tuple(int(c) for c in g[16].split())))
    return Show(int(cycle.group(1)), tuple(map(float, ball.groups())), tuple(players))


@dataclass
class GameRecord:
    """What a game log holds: its shows (in order), the cycles at which the episodes it plays start (the
    first show, then each referee ``training Keepaway`` message, or the ``.kwy``'s start cycles), the GetOpen
    notes by cycle, the play modes and the team names. ``episodes_end`` is the cycle at which the last
    episode ended (the referee's message that follows it), None if the log stops during it."""

    shows: list[Show]
    episode_starts: list[int]
    notes: dict[int, list[GetOpenNote]]
    play_modes: list[tuple[int, str]]
    teams: tuple[str, str]
    server_param: dict[str, str] = field(default_factory=dict)  # the header's, by rcssserver's names
    episodes_end: int | None = None

    def region(self) -> tuple[float, float]:
        """The Keepaway region's length and width (m); rcssserver's defaults if the header lacks them."""
        return (float(self.server_param.get("keepaway_length", 20.0)),
                float(self.server_param.get("keepaway_width", 20.0)))

    def episode_at(self, cycle: int) -> tuple[int, int]:
        """(episode number from 1, its start cycle) of the show at ``cycle``."""
        index = int(np.searchsorted(self.episode_starts, cycle, side="right"))
        if index == 0:
            return 0, self.shows[0].cycle if self.shows else 0
        return index, self.episode_starts[index - 1]


def parse_rcg(lines: Iterable[str], source: str = "game log") -> GameRecord:
    """The :class:`GameRecord` of a v5 game log's lines (sans-IO). A malformed line is a ValueError naming
    ``source`` and the line; a last line cut short (the writer was killed mid-line) is skipped."""
    shows: list[Show] = []
    starts: list[int] = []
    notes: dict[int, list[GetOpenNote]] = {}
    modes: list[tuple[int, str]] = []
    teams = ("", "")
    server_param: dict[str, str] = {}
    for number, raw in enumerate(lines, 1):
        line = raw.rstrip("\r\n")
        if number == 1:
            if line != RCG_VERSION_LINE:
                raise ValueError(f"{source}:1: not a text game log of version 5 (it starts {line[:8]!r}, not "
                                 f"{RCG_VERSION_LINE!r})")
            continue
        try:
            if line.startswith("(show "):
                show = parse_show(line)
                if not shows:
                    starts.append(show.cycle)
                shows.append(show)
            elif line.startswith("(msg "):
                _take_msg(line, starts, notes)
            elif line.startswith("(playmode "):
                found = _PLAYMODE_RE.match(line)
                if found is None:
                    raise ValueError("malformed playmode line")
                modes.append((int(found.group(1)), found.group(2)))
            elif line.startswith("(team "):
                found = _TEAM_RE.match(line)
                if found is None:
                    raise ValueError("malformed team line")
                teams = (found.group(2), found.group(3))
            elif line.startswith("(server_param "):
                server_param = dict(_PARAM_RE.findall(line))
            elif line and not line.startswith(("(player_param", "(player_type", "(team_graphic")):
                raise ValueError(f"unknown line {line[:30]!r}")
        except ValueError as exc:
            if raw.endswith("\n"):  # else it is the last line, cut short by a killed writer: skipped
                raise ValueError(f"{source}:{number}: {exc}") from None
    if not shows:
        raise ValueError(f"{source}: the game log has no show")
    played, end = _episodes_played(starts, shows[-1].cycle)
    return GameRecord(shows, played, notes, modes, teams, server_param, end)


def _episodes_played(boundaries: Iterable[int], last_cycle: int) -> tuple[list[int], int | None]:
    """The starts of the episodes a log plays, and the cycle the last one ended at (None: the log stops
    during it). The first boundary is the first show's cycle; a later one at or after the last show starts
    no episode: the referee's message when the run's last episode ended (only the reset show follows it), or
    a ``.kwy`` cycle beyond a log cut short."""
    ordered = sorted(set(boundaries))
    played = ordered[:1] + [cycle for cycle in ordered[1:] if cycle < last_cycle]
    after = ordered[len(played):]
    return played, after[0] if after else None


def _take_msg(line: str, starts: list[int], notes: dict[int, list[GetOpenNote]]) -> None:
    found = _MSG_RE.match(line)
    if found is None:
        raise ValueError("malformed msg line")
    cycle, text = int(found.group(1)), found.group(3)
    if text == f"({REFEREE_NAME} {REFEREE_EPISODE_MESSAGE})":
        starts.append(cycle)
        return
    note = _GETOPEN_RE.match(text)
    if note is not None:
        numbers = tuple(float(v) for v in note.group(2).split())
        if len(numbers) >= 2:
            notes.setdefault(cycle, []).append(GetOpenNote.from_numbers(cycle, int(note.group(1)), numbers))


def read_rcg(path: Path | str, kwy: Path | str | None = None) -> GameRecord:
    """The game log at ``path``. Episodes: from its referee messages, else from ``kwy`` (default: the
    ``.kwy`` of the same name beside it, if there is one). ValueError in one line if it cannot be read."""
    path = Path(path)
    try:
        with open(path, encoding="latin-1", newline="") as fh:
            record = parse_rcg(fh, str(path))
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    kwy_path = Path(kwy) if kwy is not None else path.with_suffix(".kwy")
    if len(record.episode_starts) <= 1 and (kwy is not None or kwy_path.exists()):
        episodes: list[EpisodeRecord] = read_kwy(kwy_path)
        boundaries = [r.start_cycle for r in episodes] + [r.end_cycle for r in episodes[-1:]]
        record.episode_starts, record.episodes_end = _episodes_played(
            boundaries + record.episode_starts[:1], record.shows[-1].cycle)
    return record


__all__ = [
    "ArenaGameLog",
    "GameRecord",
    "GetOpenNote",
    "PlayerShow",
    "STATE_KICK",
    "STATE_KICK_FAULT",
    "RcgFormatter",
    "RcgLog",
    "Show",
    "ShowTable",
    "WorldShows",
    "compile_kernels",
    "parse_rcg",
    "parse_show",
    "read_rcg",
    "show_from_frame",
    "show_line",
]
