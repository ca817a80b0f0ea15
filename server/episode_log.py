"""Episode logs: rcssserver's ``.kwy`` file and a JSON-lines log with the run's seed and parameters.

Both write one line per episode and flush it at once, so nothing already logged is lost if the process
is killed (docs/protocol.md §12, "Episode logs"; docs/players.md §1 for what an episode's hold time is).

A log never overwrites an earlier one: a log file that already exists when a new one opens under its
name (a resumed training, a second server on the same log directory) is first moved to the next free
numbered name beside it, ``keepaway.jsonl`` to ``keepaway.1.jsonl``, then ``keepaway.2.jsonl``, ...
(numbered in the order they were set aside; :func:`set_aside`), so the newest log is always under the
plain name and every earlier one is kept whole.
"""

from __future__ import annotations

import json
import time
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Self, TextIO

from keepaway.protocol.params import CLASSIC
from keepaway.rcss.param_text import cpp_number

END_OUT = "out"
END_TAKEN = "taken"
_KWY_CODES = {END_OUT: "o", END_TAKEN: "t"}

KWY_SUFFIX = ".kwy"
KWY_INCOMPLETE_NAME = "incomplete"
KWY_DATE_FORMAT = "%Y%m%d%H%M%S-"  # CURRENT's log_date_format (CLASSIC: "%Y%m%d%H%M-")
KWY_ABSENT_TEAM = "null"  # rcssserver's name for a side no team connected to

JSONL_FORMAT = "keepaway-episodes"
JSONL_VERSION = 1


@dataclass(frozen=True)
class EpisodeRecord:
    """One finished episode: number, start and end cycle, and why it ended ("out" or "taken")."""

    episode: int
    start_cycle: int
    end_cycle: int
    end: str
    simulator_step_ms: float = CLASSIC.simulator_step_ms
    # (player, cycles): the players some steps of the episode were played without ("keeper 1"), and
    # how many (an empty seat, a given-up connection, a synchronous-mode cycle not answered in time)
    missed: tuple[tuple[str, int], ...] = ()

    def __post_init__(self) -> None:
        if self.end not in _KWY_CODES:
            raise ValueError(f"episode end must be {END_OUT!r} or {END_TAKEN!r}, not {self.end!r}")
        if self.end_cycle < self.start_cycle:
            raise ValueError(f"episode {self.episode} ends (cycle {self.end_cycle}) before it starts "
                             f"(cycle {self.start_cycle})")

    @property
    def duration(self) -> int:
        """Length in cycles (simulator steps): the hold time as the kwy log counts it."""
        return self.end_cycle - self.start_cycle

    @property
    def hold_time_s(self) -> float:
        """Hold time in simulated seconds (docs/players.md §1: cycles / 10 at 100 ms per step)."""
        return self.duration * self.simulator_step_ms / 1000.0


def numbered(path: Path, number: int) -> Path:
    """``dir/keepaway.jsonl`` numbered 2: ``dir/keepaway.2.jsonl``."""
    return path.with_name(f"{path.stem}.{number}{path.suffix}")


def free_name(path: Path) -> Path:
    """``path`` if nothing is there, else its first numbered name (:func:`numbered`) that is free."""
    candidate, number = path, 0
    while candidate.exists():
        number += 1
        candidate = numbered(path, number)
    return candidate


def set_aside(path: Path) -> Path | None:
    """Move an existing file at ``path`` to its first free numbered name (module docstring) and return
    that name; None when there was nothing to move."""
    if not path.exists():
        return None
    target = free_name(path)
    path.rename(target)
    return target


class LineLog:
    """A text file written one flushed line at a time; ``close`` is idempotent. An earlier file under
    the same name is set aside first (:func:`set_aside`), never overwritten."""

    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        set_aside(path)
        self._path = path
        self._file: TextIO | None = open(path, "w", encoding="utf-8", newline="\n")

    @property
    def path(self) -> Path:
        """Where the log is now (after :meth:`close`, its final name)."""
        return self._path

    @property
    def closed(self) -> bool:
        return self._file is None

    def _write_line(self, line: str) -> None:
        self._write_lines((line,))

    def _write_lines(self, lines: Iterable[str]) -> None:
        """Write ``lines`` and flush them together."""
        if self._file is None:
            raise ValueError(f"log {self._path} is closed")
        self._file.write("".join(line + "\n" for line in lines))
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class KwyLog(LineLog):
    """rcssserver's Keepaway log, byte for byte (rcssserver src/referee.cpp, ``KeepawayRef::logHeader``, and
    src/logger.cpp).

    With ``fixed_name`` the file is ``<directory>/<fixed_name>.kwy``; otherwise it is written as
    ``<directory>/incomplete.kwy`` and renamed at :meth:`close` to
    ``<directory>/<YYYYmmddHHMMSS>-<left>_<score>-vs-<right>_<score>.kwy`` (CURRENT's naming, dated by
    the time the log was opened; a team of ``None`` is written ``null`` as rcssserver does).
    The header is written when the log is opened, i.e. at the first play_on.
    """

    def __init__(
        self,
        directory: Path | str,
        n_keepers: int,
        n_takers: int,
        length: float,
        width: float,
        fixed_name: str | None = None,
        left_team: str | None = "keepers",
        right_team: str | None = "takers",
    ) -> None:
        self._directory = Path(directory)
        self._fixed = fixed_name is not None
        self._teams = (left_team, right_team)
        self._opened_at = time.localtime()
        name = fixed_name if fixed_name is not None else KWY_INCOMPLETE_NAME
        super().__init__(self._directory / (name + KWY_SUFFIX))
        self._write_line(kwy_header(n_keepers, n_takers, length, width))

    def write(self, record: EpisodeRecord) -> None:
        """One tab-separated line: number, start, end, duration, o|t (``KeepawayRef::logEpisode``)."""
        self._write_line(f"{record.episode}\t{record.start_cycle}\t{record.end_cycle}\t"
                         f"{record.duration}\t{_KWY_CODES[record.end]}")

    def close(self, left_score: int = 0, right_score: int = 0) -> None:
        """Close, and give an unfixed log its final name with the teams' scores (``renameLogs``)."""
        if self.closed:
            return
        super().close()
        if not self._fixed:
            left, right = (f"{team}_{score}" if team is not None else KWY_ABSENT_TEAM
                           for team, score in zip(self._teams, (left_score, right_score)))
            final = self._directory / (time.strftime(KWY_DATE_FORMAT, self._opened_at)
                                       + f"{left}-vs-{right}{KWY_SUFFIX}")
            final = free_name(final)
            self._path.rename(final)
            self._path = final


def read_kwy(path: Path | str) -> list[EpisodeRecord]:
    """The episodes of a ``.kwy`` log (ours or rcssserver's): ValueError in one line if it is malformed;
    a last line cut short is skipped, as in :func:`read_jsonl`."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror}") from None
    lines = text.split("\n")
    partial = lines.pop()
    codes = {code: end for end, code in _KWY_CODES.items()}
    records = []
    for number, line in enumerate(lines + [partial], 1):
        if not line.strip() or line.startswith("#"):
            continue
        fields = line.split()
        try:
            episode, start, end, _duration = (int(v) for v in fields[:4])
            records.append(EpisodeRecord(episode, start, end, codes[fields[4]]))
        except (ValueError, KeyError, IndexError):
            if number > len(lines):  # the last line, without its newline
                break
            raise ValueError(f"{path}:{number}: malformed kwy line {line[:40]!r}") from None
    return records


def kwy_header(n_keepers: int, n_takers: int, length: float, width: float) -> str:
    """The kwy header lines (without the final newline), as ``KeepawayRef::logHeader`` writes them."""
    return "\n".join([
        f"# Keepers: {n_keepers}",
        f"# Takers:  {n_takers}",
        f"# Region:  {cpp_number(length)} x {cpp_number(width)}",
        "#",
        "# Description of Fields:",
        "# 1) Episode number",
        "# 2) Start time in simulator steps (100ms)",
        "# 3) End time in simulator steps (100ms)",
        "# 4) Duration in simulator steps (100ms)",
        "# 5) (o)ut of bounds / (t)aken away",
        "#",
    ])


class JsonlLog(LineLog):
    """A JSON-lines episode log: a header line with the seed, the run's configuration and the server
    parameters, then one line per episode with its hold time in seconds."""

    def __init__(self, path: Path | str, seed: int, config: Mapping[str, Any],
                 params: Mapping[str, Any]) -> None:
        super().__init__(Path(path))
        self._write_line(json.dumps({"type": "header", "format": JSONL_FORMAT, "version": JSONL_VERSION,
                                     "seed": seed, "config": dict(config), "params": dict(params)}))

    def write(self, record: EpisodeRecord) -> None:
        """One episode line; ``missed`` maps the players some of its steps were played without to how
        many (``{}``: a full episode; logs written before the field existed have no ``missed``)."""
        self._write_line(json.dumps({"type": "episode", "episode": record.episode,
                                     "start_cycle": record.start_cycle, "end_cycle": record.end_cycle,
                                     "duration": record.duration, "hold_time_s": record.hold_time_s,
                                     "end": record.end, "missed": dict(record.missed)}))


def read_jsonl(path: Path | str) -> tuple[dict[str, Any], list[EpisodeRecord]]:
    """The header and the episodes of a :class:`JsonlLog` file.

    A last line without its newline (the writer was killed mid-line) is skipped when it does not
    parse; any other malformed line is a ValueError. An episode line without ``missed`` (written before
    the field existed) reads as a full episode.
    """
    text = Path(path).read_text(encoding="utf-8")
    lines = text.split("\n")
    partial = lines.pop()  # "" when the file ends with a newline
    entries = [_parse_line(path, n, line) for n, line in enumerate(lines, 1)]
    if partial:
        try:
            entries.append(_parse_line(path, len(lines) + 1, partial))
        except ValueError:
            pass
    if not entries or entries[0].get("type") != "header" or entries[0].get("format") != JSONL_FORMAT:
        raise ValueError(f"{path}: not a {JSONL_FORMAT} log (no header line)")
    header = entries[0]
    if header.get("version") != JSONL_VERSION:
        raise ValueError(f"{path}: unsupported {JSONL_FORMAT} version {header.get('version')!r}")
    step_ms = header.get("params", {}).get("simulator_step_ms", CLASSIC.simulator_step_ms)
    episodes = [EpisodeRecord(episode=e["episode"], start_cycle=e["start_cycle"], end_cycle=e["end_cycle"],
                              end=e["end"], simulator_step_ms=step_ms,
                              missed=tuple((str(k), int(v)) for k, v in e.get("missed", {}).items()))
                for e in entries[1:] if e.get("type") == "episode"]
    return header, episodes


def _parse_line(path: Path | str, number: int, line: str) -> dict[str, Any]:
    try:
        entry = json.loads(line)
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}:{number}: malformed line: {e}") from None
    if not isinstance(entry, dict):
        raise ValueError(f"{path}:{number}: expected a JSON object")
    return entry


__all__ = [
    "END_OUT",
    "END_TAKEN",
    "EpisodeRecord",
    "JsonlLog",
    "KwyLog",
    "LineLog",
    "cpp_number",
    "free_name",
    "kwy_header",
    "read_jsonl",
    "read_kwy",
    "set_aside",
]
