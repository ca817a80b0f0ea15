"""One line per second per kind of log line: a ``logging.Filter`` that counts what it holds back.

A server waiting for a silent player logs "missed cycle" once per cycle timeout: 50 lines a second at
``--cycle-timeout 0.02``, enough to bury the log (and to fill an unread stderr pipe). Lines of one kind
go out at most once per ``interval_s``; the next one that goes out says how many were held back since
the last, and :meth:`RepeatLimit.flush` (at shutdown) lets out the latest held-back line of each kind
with the count of the others, so no line vanishes without being counted.

Two lines are of one kind when they share logger, level, template (``record.msg``) and the arguments
that are not numbers: "keeper 1 missed cycle 7 (3 in a row)" and "... cycle 8 (4 in a row)" are, the
same line about keeper 2 is not, nor are two protocol errors of different codes logged with one template.
A caller may name the kind itself (``extra={KIND_ATTR: ...}``) when a line carries text that varies
without making it another kind, e.g. a decoder's message naming the bad value.

A flood of lines costs little: a held-back line is a dictionary look-up and a counter, and the kinds
whose window has passed without held-back lines are forgotten once more than :data:`MAX_KINDS` are kept,
so lines of ever new kinds (a client under ever new identities) cannot grow the filter without bound.
"""

from __future__ import annotations

import logging
import numbers
import threading
import time
from dataclasses import dataclass
from typing import Callable

# Set on a record that flush() lets out, so that the filter passes it on the way through the logger.
FLUSHED_ATTR = "repeat_limit_flushed"
# Set on a record (``extra=``) to name its kind instead of deriving it (module docstring).
KIND_ATTR = "repeat_kind"
# Kinds kept before those without held-back lines and past their window are forgotten.
MAX_KINDS = 1024


@dataclass
class _Window:
    opened: float  # when the last line of this kind went out (clock seconds)
    held: int = 0  # lines of this kind held back since
    latest: logging.LogRecord | None = None  # the last of them


def held_back_note(count: int, span_s: float) -> str:
    """The text appended to a line that follows ``count`` held-back lines of its kind (no ``%`` in it,
    so the record's own %-formatting is unaffected)."""
    return f" ... and {count} more like this in the last {span_s:.1f} s"


def kind_of(record: logging.LogRecord) -> tuple:
    """What makes two records repetitions of each other (module docstring)."""
    named = getattr(record, KIND_ATTR, None)
    if named is not None:
        return record.name, record.levelno, named
    args = record.args if isinstance(record.args, tuple) else (record.args,)
    words = tuple(str(a) for a in args if not isinstance(a, numbers.Number))
    return record.name, record.levelno, str(record.msg), words


class RepeatLimit(logging.Filter):
    """Lets the first line of each kind through, then at most one per ``interval_s``; ``clock`` returns
    seconds (``time.monotonic``; a test passes a fake one)."""

    def __init__(self, interval_s: float = 1.0, clock: Callable[[], float] = time.monotonic) -> None:
        super().__init__()
        self.interval_s = interval_s
        self.clock = clock
        self._windows: dict[tuple, _Window] = {}
        self._lock = threading.Lock()

    def filter(self, record: logging.LogRecord) -> bool:
        if getattr(record, FLUSHED_ATTR, False):
            return True
        key = kind_of(record)
        now = self.clock()
        with self._lock:
            window = self._windows.get(key)
            if window is not None and now - window.opened < self.interval_s:
                window.held += 1
                window.latest = record
                return False
            if window is None and len(self._windows) >= MAX_KINDS:
                self._forget_quiet(now)
            self._windows[key] = _Window(opened=now)
        if window is not None and window.held:
            record.msg = f"{record.msg}{held_back_note(window.held, now - window.opened)}"
        return True

    def _forget_quiet(self, now: float) -> None:
        """Drop the kinds past their window with nothing held back (they would pass at once anyway)."""
        quiet = [k for k, w in self._windows.items() if not w.held and now - w.opened >= self.interval_s]
        for key in quiet:
            del self._windows[key]

    def flush(self) -> None:
        """Let out the latest held-back line of each kind, noting how many others were held back."""
        now = self.clock()
        with self._lock:
            pending = [w for w in self._windows.values() if w.held]
            self._windows.clear()
        for window in pending:
            record = window.latest
            if window.held > 1:
                record.msg = f"{record.msg}{held_back_note(window.held - 1, now - window.opened)}"
            setattr(record, FLUSHED_ATTR, True)
            logging.getLogger(record.name).handle(record)
