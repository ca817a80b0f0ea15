"""Fair, bounded input: how many messages of each peer the server reads (docs/protocol.md §1, "Budgets";
docs/design.md, "Fair input and rejoin").

A poller loop that reads a socket until it is empty can be held there by one client that sends faster
than the server answers, and the game stops. So the server's loop (``server/app.py``) reads at most
:data:`ROUND_MESSAGES` frames of a socket per poll round (ZeroMQ's ROUTER takes them from the peers in
turn), serves the seated peers' messages (players, coaches) before the others', and keeps each peer to
a budget per window:

* A seated peer's window is one cycle (or :data:`WINDOW_S` of wall time while the clock stands still):
  a player answers every cycle, however fast the cycles go. What it sends beyond its budget waits, in
  order, for the next windows (a keeper's burst of report chunks at an episode boundary arrives whole),
  up to :data:`BACKLOG` messages; beyond that it is dropped.
* Any other peer's window is :data:`WINDOW_S` of wall time: it needs a message or two to join, and a
  flood from it costs the same whatever the game's speed. What it sends beyond its budget is dropped.

A dropped message is read but never decoded; when the window ends the peer gets one ``over_budget``
error with the count and the server logs one (rate-limited) line. Without sockets: :class:`Intake` only
counts and queues.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

# Frames read from one socket per poll round; the rest wait in ZeroMQ's queues for the next round.
ROUND_MESSAGES = 256
# Longest budget window (s) while no step ends it: paused, or waiting for a player in synchronous mode.
WINDOW_S = 0.1
# Messages of a seated peer that may wait for later windows; more are dropped.
BACKLOG = 64

Frames = list[bytes]


@dataclass
class Intake:
    """The budgets of one port: ``seated`` messages per window for a peer that has joined (None: no
    budget, the coach port's coaches), ``unseated`` for any other peer (module docstring)."""

    seated: int | None
    unseated: int
    _counts: dict[bool, dict[bytes, int]] = field(default_factory=lambda: {True: {}, False: {}})
    _dropped: dict[bool, dict[bytes, int]] = field(default_factory=lambda: {True: {}, False: {}})
    _waiting: dict[bytes, deque[Frames]] = field(default_factory=dict)

    def budget(self, seated: bool) -> int | None:
        return self.seated if seated else self.unseated

    def admit(self, ident: bytes, seated: bool, frames: Frames) -> bool:
        """Whether to serve ``frames`` of ``ident`` now; if not, they wait (a seated peer's, while its
        backlog has room) or are dropped and counted."""
        if seated and ident in self._waiting:  # behind what already waits: the peer's order holds
            return self._wait(ident, frames)
        counts = self._counts[seated]
        n = counts.get(ident, 0) + 1
        budget = self.seated if seated else self.unseated
        if budget is None or n <= budget:
            counts[ident] = n
            return True
        if seated:
            return self._wait(ident, frames)
        self._drop(ident, seated)
        return False

    def _wait(self, ident: bytes, frames: Frames) -> bool:
        queue = self._waiting.setdefault(ident, deque())
        if len(queue) < BACKLOG:
            queue.append(frames)
        else:
            self._drop(ident, True)
        return False

    def _drop(self, ident: bytes, seated: bool) -> None:
        dropped = self._dropped[seated]
        dropped[ident] = dropped.get(ident, 0) + 1
        self._counts[seated].setdefault(ident, 0)  # the window has something to report

    def due(self) -> list[Frames]:
        """The waiting messages that fit their peers' budgets of this window, in order (counted)."""
        if not self._waiting:
            return []
        out: list[Frames] = []
        counts = self._counts[True]
        for ident, queue in list(self._waiting.items()):
            n = counts.get(ident, 0)
            while queue and n < self.seated:
                out.append(queue.popleft())
                n += 1
            counts[ident] = n
            if not queue:
                del self._waiting[ident]
        return out

    def spent(self, ident: bytes) -> bool:
        """Whether seated ``ident`` has used its whole budget of this window: what it sends next waits,
        so a synchronous server does not wait for its answer (a player flooding the server cannot hold
        the game)."""
        return self.seated is not None and (ident in self._waiting
                                            or self._counts[True].get(ident, 0) >= self.seated)

    def close_window(self, seated: bool) -> dict[bytes, int]:
        """End the seated (or unseated) peers' window: the messages dropped per peer in it; their counts
        start again from 0 (what waits is served from the next round on)."""
        if not self._counts[seated]:
            return {}
        dropped = self._dropped[seated]
        self._counts[seated], self._dropped[seated] = {}, {}
        return dropped


__all__ = ["BACKLOG", "Intake", "ROUND_MESSAGES", "WINDOW_S"]
