"""Server configuration: defaults in code, overridable by a TOML file and by command-line flags."""

from __future__ import annotations

import dataclasses
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from protocol.params import ServerParams, parameter_set

TIMING_MODES = ("sync", "realtime")
HANG_POLICIES = ("continue", "stop")


@dataclass(frozen=True)
class ServerConfig:
    """Everything a ``keepaway server`` process needs besides its parameter table."""

    params: ServerParams = field(default_factory=lambda: parameter_set("classic"))
    host: str = "127.0.0.1"
    players_port: int = 6000
    coach_port: int = 6001
    monitor_port: int = 6002
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
    max_message_bytes: int = 4 * 1024 * 1024

    def __post_init__(self) -> None:
        problems = []
        if self.mode not in TIMING_MODES:
            problems.append(f"mode must be one of {TIMING_MODES}, not {self.mode!r}")
        if self.on_hang not in HANG_POLICIES:
            problems.append(f"on_hang must be one of {HANG_POLICIES}, not {self.on_hang!r}")
        if self.start_on not in ("players", "coach"):
            problems.append(f"start_on must be 'players' or 'coach', not {self.start_on!r}")
        if not 1 <= self.keepers <= 11 or not 1 <= self.takers <= 11:
            problems.append("keepers and takers must each be between 1 and 11")
        for name in ("players_port", "coach_port", "monitor_port"):
            port = getattr(self, name)
            if not 0 <= port <= 65535:
                problems.append(f"{name} must be in 0..65535 (0 picks a free port), not {port}")
        if not self.cycle_timeout_s > 0:
            problems.append("cycle_timeout_s must be positive")
        if self.max_missed_cycles < 1:
            problems.append("max_missed_cycles must be at least 1")
        if self.episodes is not None and self.episodes < 1:
            problems.append("episodes must be at least 1")
        if self.max_message_bytes < 1024:
            problems.append("max_message_bytes must be at least 1024")
        if problems:
            raise ValueError("; ".join(problems))

    def replace(self, **changes: Any) -> "ServerConfig":
        return dataclasses.replace(self, **changes)

    def summary(self) -> dict[str, Any]:
        """A plain map of the configuration (for log headers and ``init_ok``)."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "params"}
        out["log_dir"] = str(self.log_dir) if self.log_dir is not None else None
        out["parameter_set"] = self.params.name
        return out


def load_toml(path: Path) -> dict[str, Any]:
    """Read a TOML config file: top-level keys are ServerConfig fields, ``[params]`` overrides parameters.

    Errors name the file and the offending key in one line.
    """
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"cannot read config {path}: {exc}") from None
    known = {f.name for f in dataclasses.fields(ServerConfig)} | {"parameter_set"}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValueError(f"{path}: unknown setting(s) {', '.join(unknown)}")
    return data
