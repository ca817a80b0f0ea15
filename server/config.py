"""Server configuration: defaults in code, overridable by a TOML file and by command-line flags."""

from __future__ import annotations

import dataclasses
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from keepaway.protocol.endpoints import MAX_MESSAGE_BYTES_LIMIT
from keepaway.protocol.messages import GETOPEN_NOTE_MODES, MAX_SEED
from keepaway.protocol.params import (
    PARAMETER_SETS,
    POSITIVE,
    TEAM_SIZE,
    OneOf,
    Range,
    ServerParams,
    check_parameter,
    parameter_set,
)

TIMING_MODES = ("sync", "realtime")
HANG_POLICIES = ("continue", "stop")
START_ON = ("players", "coach")
PORT = Range(0, 65535)  # 0 picks a free port
SEED = Range(0, MAX_SEED)  # numpy's SeedSequence takes non-negative ints; the wire carries int64
AT_LEAST_ONE = Range(1, high_open=True)


@dataclass(frozen=True)
class ServerConfig:
    """Everything a ``keepaway server`` process needs besides its parameter table."""

    params: ServerParams = field(default_factory=lambda: parameter_set("classic"))
    host: str = "127.0.0.1"
    keys: Path | None = None  # a keys directory (keepaway keys): CURVE on every port (protocol/security.py)
    players_port: int = 6000
    coach_port: int = 6001
    monitor_port: int = 6002
    rcss_port: int | None = None  # also seat rcssserver's UDP text clients here (rcss.front)
    keepers: int = 3
    takers: int = 2
    mode: str = "sync"
    seed: int = 0
    cycle_timeout_s: float = 1.25  # rcssserver's synch-mode wait before "Someone missed a cycle"
    max_missed_cycles: int = 20  # consecutive misses before a player counts as hung (rcssserver: 20)
    on_hang: str = "continue"  # continue without the hung player, or stop the server with a message
    start_on: str = "players"  # "players": when all expected players connected; "coach": on Start
    episodes: int | None = None  # stop after this many episodes (None: run until stopped)
    max_cycles: int | None = None  # stop after this many cycles
    log_dir: Path | None = None
    kwy_name: str | None = "keepaway"  # fixed .kwy name; None: incomplete.kwy renamed at shutdown
    game_log: bool = True  # with log_dir: also write the game log (<kwy_name>.rcg, server/game_log.py)
    max_message_bytes: int = 4 * 1024 * 1024
    player_budget: int = 8  # messages of a seated player served per cycle (docs/protocol.md §1, "Budgets")
    coach_budget: int = 8  # messages of a coach served per cycle (docs/protocol.md §1, "Budgets")
    unseated_budget: int = 16  # messages per 0.1 s of a client that is not (yet) a player or a coach
    # what keepers note with their commands, for the game log and the monitor (docs/protocol.md §5,
    # "command"): none (the default: nothing extra on the wire), their GetOpen target, or target and values
    getopen_notes: str = "none"

    def __post_init__(self) -> None:
        """Refuse every setting of the wrong type or outside :data:`SETTING_RANGES`, in one line."""
        problems = []
        if not isinstance(self.params, ServerParams):
            problems.append(f"params must be a ServerParams, not {type(self.params).__name__}")
        for name in SETTING_TYPES:
            try:
                check_setting(name, getattr(self, name))
            except ValueError as exc:
                problems.append(str(exc))
        if problems:
            raise ValueError("; ".join(problems))

    def replace(self, **changes: Any) -> "ServerConfig":
        return dataclasses.replace(self, **changes)

    def summary(self) -> dict[str, Any]:
        """A plain map of the configuration (for log headers and ``init_ok``)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "params"}
        for name in ("log_dir", "keys"):
            out[name] = str(getattr(self, name)) if getattr(self, name) is not None else None
        out["parameter_set"] = self.params.name
        return out


# The allowed values of the settings that have limits; the others take any value of their type.
SETTING_RANGES: dict[str, Range | OneOf] = {
    "players_port": PORT, "coach_port": PORT, "monitor_port": PORT, "rcss_port": PORT,
    "keepers": TEAM_SIZE, "takers": TEAM_SIZE,
    "mode": OneOf(TIMING_MODES), "on_hang": OneOf(HANG_POLICIES), "start_on": OneOf(START_ON),
    "seed": SEED, "cycle_timeout_s": POSITIVE, "max_missed_cycles": AT_LEAST_ONE,
    "episodes": AT_LEAST_ONE, "max_cycles": AT_LEAST_ONE, "max_message_bytes": Range(1024, MAX_MESSAGE_BYTES_LIMIT),
    "player_budget": AT_LEAST_ONE, "coach_budget": AT_LEAST_ONE, "unseated_budget": AT_LEAST_ONE,
    "getopen_notes": OneOf(GETOPEN_NOTE_MODES),
}
# Each setting's type, from the annotations of ServerConfig (the parameter table is checked by itself).
SETTING_TYPES: dict[str, Any] = {
    name: hint for name, hint in typing.get_type_hints(ServerConfig).items() if name != "params"
}
_TYPE_NAMES = {int: "an integer", float: "a number", str: "a non-empty string", Path: "a path", bool: "true or false"}


def _has_type(value: Any, kind: type) -> bool:
    """``value`` is a ``kind`` (ints count as numbers, bools as neither; strings as paths)."""
    if kind is bool:
        return type(value) is bool
    if kind is int:
        return type(value) is int
    if kind is float:
        return type(value) in (int, float)
    if kind is str:
        return isinstance(value, str) and value != ""
    return isinstance(value, (str, Path))


def check_setting(name: str, value: Any) -> None:
    """Raise ValueError (one line: the setting, the value and what is expected) unless ``value`` is of
    ``name``'s type and within its :data:`SETTING_RANGES` entry."""
    if name not in SETTING_TYPES:
        raise ValueError(f"unknown setting {name!r}")
    kinds = typing.get_args(SETTING_TYPES[name]) or (SETTING_TYPES[name],)
    if value is None and type(None) in kinds:
        return
    kind = next(k for k in kinds if k is not type(None))
    if not _has_type(value, kind):
        raise ValueError(f"{name} = {value!r} is not {_TYPE_NAMES[kind]}")
    allowed = SETTING_RANGES.get(name)
    if allowed is not None and value not in allowed:
        raise ValueError(f"{name} = {value!r} is out of range: allowed {allowed}")


def _check_toml_entry(key: str, value: Any) -> None:
    if key == "params":
        if not isinstance(value, dict):
            raise ValueError(f"params = {value!r} is not a table ([params] with NAME = VALUE lines)")
        for name, parameter in value.items():
            if name == "name":
                raise ValueError("[params] name: choose the set with parameter_set at the top level")
            try:
                check_parameter(name, parameter)
            except ValueError as exc:
                raise ValueError(f"[params] {exc}") from None
    elif key == "parameter_set":
        if not isinstance(value, str) or value not in PARAMETER_SETS:
            raise ValueError(f"parameter_set = {value!r} is not one of {', '.join(PARAMETER_SETS)}")
    else:
        check_setting(key, value)


def load_toml(path: Path) -> dict[str, Any]:
    """Read a TOML config file: top-level keys are ServerConfig fields, ``[params]`` overrides parameters.

    Every key's type and range is checked here; an error names the file, the key, the value and what is
    expected, in one line.
    """
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"cannot read config {path}: {exc}") from None
    known = set(SETTING_TYPES) | {"params", "parameter_set"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValueError(f"{path}: unknown setting(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    for key, value in data.items():
        try:
            _check_toml_entry(key, value)
        except ValueError as exc:
            raise ValueError(f"{path}: {exc}") from None
    return data
