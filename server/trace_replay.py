"""Replay an rcssserver physics trace against our kernels (traces README, spec `server-physics.md` 2, 3).

A trace (``/work/shared/rcss-traces/*.json``) records one player and the trainer driving rcssserver 19.0.0
in synch mode, with every ``(fullstate T)`` printed to 6 significant digits. We rebuild the parameter set
from the file (CURRENT, the 19.0.0 defaults, plus every ``params`` key that names a ``ServerParams``
field), run the same trainer and player commands with the README's timing (commands of cycle T act in
the step T -> T+1, trainer commands before the player's) and compare every entry within the print
precision. Only left-side players in play_on are supported, which is what the traces contain.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path
from typing import Any

from keepaway.protocol.params import ServerParams, parameter_set
from keepaway.server.command_frame import CommandBuffer
from keepaway.server.command_slots import COMMAND_CODES, put_command, take_commands
from keepaway.server.physics import physics_step, place_object
from keepaway.core.objects import BALL
from keepaway.server.world import COLLIDED_BALL, COLLIDED_PLAYER, Commands, World, new_world

RELATIVE_TOLERANCE = 1e-5  # 6 significant digits as printed by the server (traces README)
ABSOLUTE_TOLERANCE = 1e-6
PHYSICS_TRACE_KEYS = ("params", "commands", "trainer_commands", "trace", "last_cycle", "player")

BALL_FIELDS = ("x", "y", "vx", "vy")
PLAYER_FIELDS = ("x", "y", "vx", "vy", "body", "neck")
ANGLE_FIELDS = ("body", "neck")
STAMINA_FIELDS = ("stamina", "effort", "recovery", "capacity")
PLAYER_COMMAND_ARITY = {"dash": (1, 2), "turn": (1,), "turn_neck": (1,), "kick": (2,)}
COUNT_FIELDS = ("kick", "dash", "turn", "catch", "move", "turn_neck", "change_view", "say")

_COMMAND_RE = re.compile(r"^\(\s*(\w+)((?:\s+[-+0-9.eE]+)*)\s*\)$")
_MOVE_RE = re.compile(r"^\(\s*move\s+\(\s*(ball|player\s+(\S+)\s+(\d+))\s*\)((?:\s+[-+0-9.eE]+)*)\s*\)$")
_PLAYER_RE = re.compile(r"^(\S+)\s+(\d+)\s+\(side\s+([lr])\)$")


@dataclasses.dataclass(frozen=True)
class Mismatch:
    """One traced value our physics does not reproduce."""

    cycle: int
    field: str
    expected: Any
    got: Any

    def __str__(self) -> str:
        return f"cycle {self.cycle} {self.field}: expected {self.expected}, got {self.got}"


@dataclasses.dataclass
class ReplayReport:
    """Outcome of one trace: how many cycles were compared, what differed, the largest numeric error."""

    scenario: str
    cycles: int
    mismatches: list[Mismatch]
    max_abs_error: float

    @property
    def ok(self) -> bool:
        return not self.mismatches


def is_physics_trace(data: Any) -> bool:
    """Whether decoded JSON has the physics trace layout (``see-samples.json`` has ``runs`` instead)."""
    return isinstance(data, dict) and all(key in data for key in PHYSICS_TRACE_KEYS)


def trace_params(data: dict[str, Any]) -> ServerParams:
    """CURRENT (the server is 19.0.0) with every ``params`` entry that is a ``ServerParams`` field."""
    known = {f.name for f in dataclasses.fields(ServerParams)} - {"name"}
    overrides = {key: float(value) for key, value in data["params"].items() if key in known}
    return parameter_set("current", keepaway_launch=False, **overrides)


def _numbers(text: str) -> list[float]:
    return [float(v) for v in text.split()]


class _Replay:
    """The world of one trace: the traced left player enabled, everyone else disabled and parked."""

    def __init__(self, data: dict[str, Any]) -> None:
        match = _PLAYER_RE.match(data["player"])
        if not match or match.group(3) != "l":
            raise ValueError(f"unsupported traced player {data['player']!r} (left side only)")
        self.team, self.unum = match.group(1), int(match.group(2))
        self.params = trace_params(data)
        self.kp = self.params.kernel()
        self.world: World = new_world(self.params, n_keepers=self.unum, n_takers=1)
        self.player = self.world.player_object("l", self.unum)
        self.world.enabled[0, self.player] = True
        self.commands = Commands.empty(1, self.world.n_objects)
        self._read = CommandBuffer.empty()  # a cycle's player commands, as the slot rules' kernel takes them
        before = data.get("initial", {}).get("fullstate_before_setup")
        if before:
            self._set_state(BALL, before["ball"])
            self._set_state(self.player, before["player"])

    def _set_state(self, obj: int, state: list[float]) -> None:
        w = self.world
        w.pos[0, obj] = state[0:2]
        w.vel[0, obj] = state[2:4]
        if obj != BALL:
            w.body[0, obj] = w.body_pending[0, obj] = state[4]
            w.neck[0, obj] = w.neck_pending[0, obj] = state[5]

    def trainer(self, text: str) -> None:
        """``(change_mode play_on)`` or a trainer move: ``(move (ball) x y dir vx vy)`` (dir ignored) or
        ``(move (player T U) x y [body [vx vy]])``, which keeps the velocity and body it does not give
        (``Stadium::movePlayer``)."""
        if re.fullmatch(r"\(\s*change_mode\s+play_on\s*\)", text):
            return
        match = _MOVE_RE.match(text)
        if not match:
            raise ValueError(f"unsupported trainer command {text!r}")
        args = _numbers(match.group(4))
        is_ball = match.group(1) == "ball"
        if len(args) not in ((5,) if is_ball else (2, 3, 5)):
            raise ValueError(f"unsupported trainer move {text!r}")
        if is_ball:
            obj, body = BALL, math.nan
        elif match.group(2) == self.team and int(match.group(3)) == self.unum:
            obj, body = self.player, (args[2] if len(args) >= 3 else math.nan)
        else:
            raise ValueError(f"trainer move of an untraced player {text!r}")
        vel = args[3:5] if len(args) == 5 else list(self.world.vel[0, obj])
        place_object(0, self.world, obj, args[0], args[1], vel[0], vel[1], body, self.kp)

    def player_commands(self, texts: list[str]) -> None:
        """Resolve the slots as rcssserver does, by the server's rules (``server.command_slots``): the
        first dash/turn/kick wins (a CLASSIC kick that cannot reach the ball leaves the slot free),
        turn_neck has its own slot (spec 1, "Commands")."""
        out = self._read
        if len(texts) > len(out.command):
            raise ValueError(f"more than {len(out.command)} player commands in a cycle: {texts!r}")
        for count, text in enumerate(texts):
            match = _COMMAND_RE.match(text)
            if not match:
                raise ValueError(f"unsupported player command {text!r}")
            name, args = match.group(1), _numbers(match.group(2))
            if name not in PLAYER_COMMAND_ARITY or len(args) not in PLAYER_COMMAND_ARITY[name]:
                raise ValueError(f"unsupported player command {text!r}")
            put_command(out, count, COMMAND_CODES[name], args)
        self.commands.clear()
        take_commands(out, len(texts), self.commands, self.player, self.world, self.kp)

    def step(self) -> None:
        physics_step(self.world, self.commands, self.kp)


class _Comparison:
    """Accumulates mismatches and the largest absolute numeric error of one trace."""

    def __init__(self) -> None:
        self.mismatches: list[Mismatch] = []
        self.max_abs_error = 0.0

    def number(self, cycle: int, field: str, expected: float, got: float, angle: bool = False) -> None:
        error = abs(got - expected)
        if angle:
            error = abs((got - expected + 180.0) % 360.0 - 180.0)
        self.max_abs_error = max(self.max_abs_error, error)
        if not error <= RELATIVE_TOLERANCE * abs(expected) + ABSOLUTE_TOLERANCE:
            self.mismatches.append(Mismatch(cycle, field, expected, float(got)))

    def exact(self, cycle: int, field: str, expected: Any, got: Any) -> None:
        if expected != got:
            self.mismatches.append(Mismatch(cycle, field, expected, got))

    def entry(self, entry: dict[str, Any], w: World, player: int) -> None:
        cycle = entry["cycle"]
        ball = (*w.pos[0, BALL], *w.vel[0, BALL])
        for name, expected, got in zip(BALL_FIELDS, entry["ball"], ball):
            self.number(cycle, f"ball.{name}", expected, got)
        state = (*w.pos[0, player], *w.vel[0, player], w.body[0, player], w.neck[0, player])
        for name, expected, got in zip(PLAYER_FIELDS, entry["player"], state):
            self.number(cycle, f"player.{name}", expected, got, angle=name in ANGLE_FIELDS)
        if "stamina" in entry:
            ours = (w.stamina[0, player], w.effort[0, player], w.recovery[0, player], w.capacity[0, player])
            for name, expected, got in zip(STAMINA_FIELDS, entry["stamina"], ours):
                self.number(cycle, f"stamina.{name}", expected, got)
        for name, expected, got in zip(COUNT_FIELDS, entry["count"], w.counts[0, player]):
            self.exact(cycle, f"count.{name}", expected, int(got))
        bits = int(w.collision[0, player])
        collided = [name for name, bit in (("ball", COLLIDED_BALL), ("player", COLLIDED_PLAYER)) if bits & bit]
        self.exact(cycle, "collision", sorted(entry["collision"]), collided)
        self.exact(cycle, "flags.k", "k" in entry.get("flags", []), bool(w.kicked[0, player]))
        self.exact(cycle, "pmode", entry.get("pmode", "play_on"), "play_on")


def _by_cycle(pairs: list[list[Any]]) -> dict[int, list[str]]:
    grouped: dict[int, list[str]] = {}
    for cycle, text in pairs:
        grouped.setdefault(int(cycle), []).append(text)
    return grouped


def replay_trace(path: str | Path) -> ReplayReport:
    """Replay one physics trace file and compare every entry; ValueError if it is not a physics trace."""
    data = json.loads(Path(path).read_text())
    if not is_physics_trace(data):
        raise ValueError(f"not a physics trace: {path}")
    replay = _Replay(data)
    trainer = _by_cycle(data["trainer_commands"])
    player = _by_cycle(data["commands"])
    entries = {int(e["cycle"]): e for e in data["trace"]}
    comparison = _Comparison()
    compared = 0
    for cycle in range(int(data["last_cycle"])):
        for text in trainer.get(cycle, []):
            replay.trainer(text)
        replay.player_commands(player.get(cycle, []))
        replay.step()
        entry = entries.get(cycle + 1)
        if entry is not None:
            comparison.entry(entry, replay.world, replay.player)
            compared += 1
    return ReplayReport(str(data.get("scenario", Path(path).stem)), compared, comparison.mismatches,
                        comparison.max_abs_error)


def trace_files(paths: tuple[str, ...]) -> list[Path]:
    """The files named by ``paths``: each file itself, each directory's ``*.json``."""
    files: list[Path] = []
    for p in map(Path, paths):
        files.extend(sorted(p.glob("*.json")) if p.is_dir() else [p])
    return files


__all__ = [
    "Mismatch",
    "ReplayReport",
    "is_physics_trace",
    "replay_trace",
    "trace_files",
    "trace_params",
]
