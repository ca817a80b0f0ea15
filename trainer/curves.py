"""Learning curves: per trial a CSV of evaluations, over trials a mean with a standard-error band as PNG
(spec `keepaway-task.md` 8: every 2,500 episodes a frozen evaluation; report mean and standard error over
at least 20 trials).

Every file is written atomically (a temporary file in the same directory, then ``os.replace``), so a
killed training never leaves a half-written curve behind.
"""

from __future__ import annotations

from typing import Any

import csv
import io
import math
import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

CSV_HEADER = ("episodes", "mean_hold_time_s", "stderr_hold_time_s")


@dataclass(frozen=True)
class CurvePoint:
    """One frozen evaluation: after ``episodes`` training episodes, the mean hold time and its standard
    error over the evaluation episodes (or, for an aggregate, over trials)."""

    episodes: int
    mean_hold_time_s: float
    stderr_hold_time_s: float


def write_atomic(path: Path, data: bytes) -> None:
    """Replace ``path`` by ``data`` in one step: readers see the old or the new file, never a part."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_curve_csv(path: Path, points: Sequence[CurvePoint]) -> None:
    """The evaluation curve as CSV: ``episodes,mean_hold_time_s,stderr_hold_time_s``, one row per point."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(CSV_HEADER)
    for p in points:
        writer.writerow((p.episodes, repr(p.mean_hold_time_s), repr(p.stderr_hold_time_s)))
    write_atomic(path, text.getvalue().encode())


def read_curve_csv(path: Path) -> list[CurvePoint]:
    """A curve written by :func:`write_curve_csv`; ValueError if the header is not ours."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows or tuple(rows[0]) != CSV_HEADER:
        raise ValueError(f"{path}: not a learning-curve CSV (header {rows[0] if rows else None})")
    return [CurvePoint(int(e), float(m), float(s)) for e, m, s in rows[1:]]


def mean_curve(trials: Sequence[Sequence[CurvePoint]]) -> list[CurvePoint]:
    """Point by point over trials: the mean of the trials' mean hold times and its standard error
    (sample standard deviation / sqrt(trials); NaN for one trial). Only points every trial has."""
    if not trials:
        return []
    n = min(len(t) for t in trials)
    out = []
    for i in range(n):
        values = [t[i].mean_hold_time_s for t in trials]
        episodes = {t[i].episodes for t in trials}
        if len(episodes) != 1:
            raise ValueError(f"trials disagree on the episodes of evaluation {i}: {sorted(episodes)}")
        mean = sum(values) / len(values)
        se = (math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1) / len(values))
              if len(values) > 1 else float("nan"))
        out.append(CurvePoint(episodes.pop(), mean, se))
    return out


def draw_curve(ax: Any, label: str, points: Sequence[CurvePoint]) -> None:
    """One mean curve on matplotlib axes ``ax``, with its standard-error band where it is defined."""
    x = [p.episodes for p in points]
    y = [p.mean_hold_time_s for p in points]
    se = [0.0 if math.isnan(p.stderr_hold_time_s) else p.stderr_hold_time_s for p in points]
    (line,) = ax.plot(x, y, marker="o", markersize=3, label=label)
    ax.fill_between(x, [a - b for a, b in zip(y, se)], [a + b for a, b in zip(y, se)],
                    color=line.get_color(), alpha=0.25, linewidth=0)


def plot_curves(path: Path, curves: dict[str, Sequence[CurvePoint]], title: str) -> None:
    """A PNG of learning curves (hold time against training episodes), each with its standard-error
    band where it is defined, written atomically."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.5), dpi=100)
    ax = fig.add_subplot()
    for label, points in curves.items():
        draw_curve(ax, label, points)
    ax.set_xlabel("training episodes")
    ax.set_ylabel("mean hold time (s)")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    write_atomic(path, buffer.getvalue())


__all__ = ["CSV_HEADER", "CurvePoint", "draw_curve", "mean_curve", "plot_curves", "read_curve_csv", "write_atomic",
           "write_curve_csv"]
