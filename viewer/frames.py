"""What the viewer page is sent, and the replay of a game log: sans-IO (no sockets, no clock).

The page draws one JSON ``frame`` at a time, whether it comes from a game log (:class:`Replay`) or live
from an arena's monitor port (:func:`live_frame`); ``info`` says once what is shown. Both use the
game log's :class:`server.game_log.Show`, so a live frame and a replayed one look the same.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from keepaway.protocol import messages as m
from keepaway.server.game_log import GameRecord, GetOpenNote, Show, show_from_frame

SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0)  # replay speeds the page offers (x real time)


def frame_message(show: Show, episode: int, start: int, notes: list[GetOpenNote] = (),
                  step_ms: float = 100.0) -> dict[str, Any]:
    """One frame for the page: the ball, the players on the pitch ``[side, unum, x, y, body, neck,
    state]``, the episode, the cycle, the hold time so far (s)
    and the keepers' GetOpen notes ``[unum, [tx, ty], [x, y, value, ...]]``."""
    return {
        "type": "frame",
        "cycle": show.cycle,
        "episode": episode,
        "hold_s": round((show.cycle - start) * step_ms / 1000.0, 1),
        "ball": [show.ball[0], show.ball[1]],
        "players": [[p.side, p.unum, p.x, p.y, p.body, p.neck, p.state] for p in show.players],
        "getopen": [[n.unum, list(n.target), list(n.values)] for n in notes],
    }


def info_message(mode: str, source: str, region: tuple[float, float], episodes: int | None = None,
                 cycles: int | None = None) -> dict[str, Any]:
    """What the page shows: ``replay`` (with its episodes and cycles) or ``live``; the region's size."""
    return {"type": "info", "mode": mode, "source": source, "region": list(region), "episodes": episodes,
            "cycles": cycles, "speeds": list(SPEEDS)}


@dataclass
class Replay:
    """A game log played back: a position, playing or paused, a speed. :meth:`command` takes the page's
    requests; :meth:`advance` moves one show on while playing (the caller's clock calls it every
    :attr:`interval_s`); :meth:`frame` is the show at the position."""

    record: GameRecord
    step_ms: float = 100.0
    index: int = 0
    playing: bool = True
    speed: float = 1.0

    @property
    def interval_s(self) -> float:
        return self.step_ms / 1000.0 / self.speed

    @property
    def at_end(self) -> bool:
        return self.index >= len(self.record.shows) - 1

    def info(self, source: str) -> dict[str, Any]:
        return info_message("replay", source, self.record.region(), len(self.record.episode_starts),
                            len(self.record.shows))

    def frame(self) -> dict[str, Any]:
        show = self.record.shows[self.index]
        episode, start = self.record.episode_at(show.cycle)
        message = frame_message(show, episode, start, self.record.notes.get(show.cycle, []), self.step_ms)
        message.update(playing=self.playing, speed=self.speed, index=self.index)
        return message

    def advance(self) -> bool:
        """One show on if playing; at the end it pauses. Whether the position moved."""
        if not self.playing:
            return False
        if self.at_end:
            self.playing = False
            return False
        self.index += 1
        return True

    def command(self, request: Any) -> None:
        """A page's request: ``{"command": "play" | "pause" | "step" (n, default 1, may be negative) |
        "speed" (one of SPEEDS) | "episode" (n from 1) | "seek" (cycle)}``. ValueError for anything else."""
        if not isinstance(request, dict) or not isinstance(request.get("command"), str):
            raise ValueError("a request is a map with a command")
        command, value = request["command"], request.get("value")
        if command == "play":
            self.playing = True
        elif command == "pause":
            self.playing = False
        elif command == "step":
            self.playing = False
            self._go(self.index + _integer(value if value is not None else 1, "step"))
        elif command == "speed":
            if value not in SPEEDS:
                raise ValueError(f"speed must be one of {', '.join(f'{s:g}' for s in SPEEDS)}")
            self.speed = float(value)
        elif command == "episode":
            number = _integer(value, "episode")
            starts = self.record.episode_starts
            if not 1 <= number <= len(starts):
                raise ValueError(f"episode must be in 1..{len(starts)}")
            self._go(self._index_of(starts[number - 1]))
        elif command == "seek":
            self._go(self._index_of(_integer(value, "seek")))
        else:
            raise ValueError(f"unknown command {command!r}")

    def _go(self, index: int) -> None:
        self.index = min(max(index, 0), len(self.record.shows) - 1)

    def _index_of(self, cycle: int) -> int:
        """The index of the first show at or after ``cycle``."""
        shows = self.record.shows
        low, high = 0, len(shows)
        while low < high:
            mid = (low + high) // 2
            if shows[mid].cycle < cycle:
                low = mid + 1
            else:
                high = mid
        return low


def _integer(value: Any, what: str) -> int:
    if type(value) is not int:
        raise ValueError(f"{what} needs an integer")
    return value


def live_frame(frame: m.Frame, step_ms: float = 100.0) -> dict[str, Any]:
    """A monitor frame for the page; its ``episode_start`` gives the hold time even of the episode under
    way when the viewer joined; its GetOpen notes (an arena asked for them) are drawn as a replay's are."""
    notes = [GetOpenNote.from_numbers(frame.cycle, unum, note) for unum, note in frame.getopen]
    return frame_message(show_from_frame(frame), frame.episode, frame.episode_start, notes, step_ms)


__all__ = ["Replay", "SPEEDS", "frame_message", "info_message", "live_frame"]
