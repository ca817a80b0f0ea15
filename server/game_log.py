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
--getopen-notes target|values``, docs/protocol.md ``command``); the note of a step's commands goes with the
show after that step.

The core is sans-IO: :class:`RcgFormatter` turns shows and events into text lines, :func:`parse_rcg`
turns text back into :class:`Show` frames. Writing a show line is most of a game log's cost, paid every
cycle by the server's one thread: writers take a :class:`ShowTable` (the world's arrays, read once) and
:func:`show_line` formats all of its numbers in one ``%`` format (tests/test_show_line.py pins it to the
format's definition, number by number); :class:`RcgLog` is the thin file sink the server and
``keepaway run`` use, :func:`read_rcg` the reader the viewer's replay and ``keepaway render`` share.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cache, lru_cache
from pathlib import Path
from typing import NamedTuple

import numpy as np

from protocol import messages as m
from protocol.params import ServerParams
from server.arena import REFEREE_EPISODE_MESSAGE, VIEW_WIDTHS, Arena
from server.episode_log import EpisodeRecord, LineLog, cpp_number, read_kwy
from server.world import COLLIDED_BALL, COLLIDED_PLAYER, COUNT_KICK, N_COUNTS, PARKED_Y, World

RCG_SUFFIX = ".rcg"
RCG_VERSION_LINE = "ULG5"
MAX_UNUM = 11  # players per side in every show (rcssserver's MAX_PLAYER)
N_RCG_COUNTS = 11  # kick dash turn catch move turn_neck change_view say tackle pointto attentionto
POS_PREC = 0.0001  # rcssserver's SerializerMonitorStdv3::PREC (positions, velocities)
ANGLE_PREC = 0.001  # ... DPREC (body, neck, view angle)
# A player's numbers in a show, in PlayerShow's order, each with the precision rcssserver quantizes it to
# (SerializerMonitorStdv3) or None
PLAYER_NUMBERS = {"x": POS_PREC, "y": POS_PREC, "vx": POS_PREC, "vy": POS_PREC, "body": ANGLE_PREC,
                  "neck": ANGLE_PREC, "view_angle": ANGLE_PREC, "stamina": None, "effort": None, "recovery": None,
                  "capacity": None}
N_ROW = len(PLAYER_NUMBERS) + N_RCG_COUNTS  # a player's numbers in a ShowTable
MSG_BOARD = 1  # rcssserver's BoardType
LOG_BOARD = 2
REFEREE_NAME = "referee"
GETOPEN_NOTE = "getopen"
PLAY_ON = "play_on"

# Player state bits (rcssserver's PlayerState)
STATE_DISABLE = 0x0
STATE_STAND = 0x1
STATE_KICK = 0x2
STATE_KICK_FAULT = 0x4
STATE_BALL_COLLIDE = 0x400
STATE_PLAYER_COLLIDE = 0x800

# Our parameter names that rcssserver's server_param spells otherwise; parameters rcssserver does not
# have (our modelling switches, the pitch size) are left out of the server_param line.
RCSS_PARAM_NAMES = {
    "simulator_step_ms": "simulator_step", "sense_body_step_ms": "sense_body_step", "send_step_ms": "send_step",
    "min_moment": "minmoment", "max_moment": "maxmoment", "min_neck_moment": "minneckmoment",
    "max_neck_moment": "maxneckmoment", "min_neck_angle": "minneckang", "max_neck_angle": "maxneckang",
    "min_power": "minpower", "max_power": "maxpower",
}
NOT_IN_RCSSSERVER = frozenset({
    "name", "pitch_length", "pitch_width", "movement_noise", "kick_noise", "failed_kick_uses_slot", "effort_max",
    "effort_inc_uses_dec_thr", "dir_chg_step", "dist_chg_step", "unum_far_length", "unum_too_far_length",
    "team_far_length", "team_too_far_length", "team_loss_probabilistic", "see_behind_strict", "take_cycles",
    "reset_restores_stamina",
})
# The heterogeneous type every player of ours is (type 0, rcssserver's default type), from our table.
PLAYER_TYPE_PARAMS = ("player_speed_max", "stamina_inc_max", "player_decay", "inertia_moment", "dash_power_rate",
                      "player_size", "kickable_margin", "kick_rand", "extra_stamina", "effort_max", "effort_min",
                      "kick_power_rate")


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
    """A show as its line is written (:func:`show_line`): all of its players' numbers in one array, so that
    a line costs a few array operations and one ``%`` format however many players it has. The players
    are those on the pitch, in rcssserver's order (``l 1`` to ``l 11``, then ``r 1`` to ``r 11``), each
    once. :class:`WorldShows` makes tables from a world's arrays, :meth:`of` from a :class:`Show`."""

    cycle: int
    ball: np.ndarray  # (4,): x y vx vy
    players: tuple[tuple[str, int, int], ...]  # (side, unum, state) of each player
    rows: np.ndarray  # (P, N_ROW): a player's PLAYER_NUMBERS, then its N_RCG_COUNTS counts (floats, exact below 2**53)

    @classmethod
    def of(cls, show: Show) -> ShowTable:
        """The table of ``show``: of two entries of one player the last counts, and a player none of
        rcssserver's 22 places has is left out."""
        by_id = {(p.side, p.unum): p for p in show.players}
        players = [by_id[slot] for slot in _SLOTS if slot in by_id]
        rows = np.array([(*p[3:3 + len(PLAYER_NUMBERS)], *p.counts) for p in players], dtype=float).reshape(-1, N_ROW)
        return cls(show.cycle, np.asarray(show.ball, dtype=float), tuple((p.side, p.unum, p.state) for p in players),
                   rows)

    def show(self) -> Show:
        """This show with its players as :class:`PlayerShow`."""
        n = len(PLAYER_NUMBERS)
        players = tuple(PlayerShow(side, unum, state, *row[:n], tuple(int(c) for c in row[n:]))
                        for (side, unum, state), row in zip(self.players, self.rows.tolist()))
        return Show(self.cycle, tuple(self.ball.tolist()), players)


class WorldShows:
    """Shows of the arenas of a :class:`server.world.World` (any batch), one cycle after another.

    A kick that did not reach the ball is ``KICK | KICK_FAULT``, as in rcssserver: the world marks every
    kick command (``world.kicked``) and counts only those that reached the ball, so the kick count of the
    previous show tells them apart; :meth:`table` therefore remembers each arena's counts."""

    def __init__(self, world: World, visible_angle: float) -> None:
        self.world = world
        self.visible_angle = visible_angle
        self._kicks = world.counts[:, :, COUNT_KICK].copy()
        self._sides = [world.side(i) for i in range(1, world.n_objects)]
        self._unums = [world.unum(i) for i in range(1, world.n_objects)]
        self._view_angles = np.full((world.n_objects - 1, 1), float(visible_angle))
        self._no_counts = np.zeros((world.n_objects - 1, N_RCG_COUNTS - N_COUNTS))  # tackle pointto attentionto: never

    def table(self, b: int = 0, view_factors: Sequence[float] | None = None) -> ShowTable:
        """Arena ``b`` now; ``view_factors`` per player object (1 normal, 0.5 narrow, 2 wide; default 1)."""
        w = self.world
        kicks = w.counts[b, :, COUNT_KICK]
        faulted = (kicks == self._kicks[b]).tolist()
        self._kicks[b] = kicks
        states = [(STATE_STAND if enabled else STATE_DISABLE)
                  | ((STATE_KICK | (STATE_KICK_FAULT if fault else 0)) if kicked else 0)
                  | (STATE_BALL_COLLIDE if collision & COLLIDED_BALL else 0)
                  | (STATE_PLAYER_COLLIDE if collision & COLLIDED_PLAYER else 0)
                  for enabled, kicked, fault, collision
                  in zip(w.enabled[b, 1:].tolist(), w.kicked[b, 1:].tolist(), faulted[1:], w.collision[b, 1:].tolist())]
        view = (self._view_angles if view_factors is None
                else self.visible_angle * np.asarray(view_factors, dtype=float)[1:, None])
        rows = np.concatenate((w.pos[b, 1:], w.vel[b, 1:], w.body[b, 1:, None], w.neck[b, 1:, None], view,
                               w.stamina[b, 1:, None], w.effort[b, 1:, None], w.recovery[b, 1:, None],
                               w.capacity[b, 1:, None], w.counts[b, 1:], self._no_counts), axis=1)
        return ShowTable(int(w.time[b]), np.concatenate((w.pos[b, 0], w.vel[b, 0])),
                         tuple(zip(self._sides, self._unums, states)), rows)

    def show(self, b: int = 0, view_factors: Sequence[float] | None = None) -> Show:
        """:meth:`table` as a :class:`Show`."""
        return self.table(b, view_factors).show()


# -- writing ---------------------------------------------------------------------------------------------
@cache
def _quanta(n_players: int) -> tuple[np.ndarray, np.ndarray]:
    """What each number of a line with ``n_players`` players (:func:`_line_numbers`) is quantized to, and
    whether it is: the ball's numbers and each player's positions, velocities and angles are."""
    row = [*PLAYER_NUMBERS.values(), *[None] * N_RCG_COUNTS]
    precs = [POS_PREC] * 4 + row * n_players
    quantized = np.array([prec is not None for prec in precs])
    return np.array([prec or 1.0 for prec in precs]), quantized


def _line_numbers(table: ShowTable) -> list[float]:
    """The numbers of ``table``'s line in order, the ball's then each player's, those that rcssserver
    quantizes quantized by its ``Quantize(value, prec)``, ``rint(value / prec) * prec`` (half to even;
    -0.1 gives -0, printed "-0" as in C++)."""
    numbers = np.concatenate((table.ball, table.rows.ravel()))
    quantum, quantized = _quanta(len(table.players))
    return np.where(quantized, np.rint(numbers / quantum) * quantum, numbers).tolist()


def _entry_template(side: str, unum: int, state: int) -> str:
    """A player's entry of a v5 show (``serializePlayer*``) as a ``%`` template of its numbers: 6
    significant digits as a default C++ ostream prints them (``%.6g`` formats as ``cpp_number``), the
    counts as integers, the state in hex with C++'s ``showbase``, which prints 0 bare."""
    state_text = f"{state:#x}" if state else "0"
    counts = " ".join(["%d"] * N_RCG_COUNTS)
    return (f" (({side} {unum}) 0 {state_text} %.6g %.6g %.6g %.6g %.6g %.6g (v h %.6g) "
            f"(s %.6g %.6g %.6g %.6g) (c {counts}))")


def _parked_entry(side: str, unum: int) -> str:
    player = parked(side, unum)
    table = ShowTable.of(Show(0, (0.0,) * 4, (player,)))
    return _entry_template(side, unum, player.state) % tuple(_line_numbers(table)[4:])


_PARKED_ENTRIES = {slot: _parked_entry(*slot) for slot in _SLOTS}


@lru_cache(maxsize=4096)
def _show_template(players: tuple[tuple[str, int, int], ...]) -> str:
    """The ``%`` template of a show line with ``players`` (side, unum, state) on the pitch and the others
    parked; its arguments are the cycle and :func:`_line_numbers`. The states are written in: a game has
    few sets of them, so few templates."""
    states = {(side, unum): state for side, unum, state in players}
    if [slot for slot in _SLOTS if slot in states] != [(side, unum) for side, unum, _ in players]:
        raise ValueError("a show table's players go in rcssserver's order, each once")
    entries = (_entry_template(*slot, states[slot]) if slot in states else _PARKED_ENTRIES[slot] for slot in _SLOTS)
    return "(show %d ((b) %.6g %.6g %.6g %.6g)" + "".join(entries) + ")"


def show_line(show: Show | ShowTable) -> str:
    """``(show T ((b) x y vx vy) ((l 1) ...) ... ((r 11) ...))``: all 22 players, those not in the show
    parked (module docstring); one ``%`` format of all the show's numbers."""
    table = show if isinstance(show, ShowTable) else ShowTable.of(show)
    return _show_template(table.players) % (table.cycle, *_line_numbers(table))


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
    """What a game log holds: its shows (in order), the cycles at which episodes start (the first show,
    then each referee ``training Keepaway`` message, or the ``.kwy``'s start cycles), the GetOpen notes by
    cycle, the play modes and the team names."""

    shows: list[Show]
    episode_starts: list[int]
    notes: dict[int, list[GetOpenNote]]
    play_modes: list[tuple[int, str]]
    teams: tuple[str, str]
    server_param: dict[str, str] = field(default_factory=dict)  # the header's, by rcssserver's names

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
    return GameRecord(shows, sorted(set(starts)), notes, modes, teams, server_param)


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
        record.episode_starts = sorted({r.start_cycle for r in episodes} | set(record.episode_starts[:1]))
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
    "parse_rcg",
    "parse_show",
    "read_rcg",
    "show_from_frame",
    "show_line",
]
