"""Learning curves: per trial a CSV of evaluations, over trials a mean with a standard-error band as PNG
(docs/players.md §8.3: every 2,500 episodes a frozen evaluation; report mean and standard error over
at least 20 trials), and the statistics that compare trials' results: Welch's t-test (the paper's
significance test) and a ratio of means with its standard error.

A standard error that is undefined (one value) is None: an empty CSV field, ``null`` in JSON, no band in a
plot; never NaN. Over one trial there is no spread between trials, so its curve keeps the standard errors
of its own evaluations, over their episodes; :func:`stderr_over` names which kind a curve has.

Every file is written atomically (a temporary file in the same directory, then ``os.replace``), so a
killed training never leaves a half-written curve behind.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import secrets
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from keepaway.runner.report import finite_or_none

CSV_HEADER = ("episodes", "mean_hold_time_s", "stderr_hold_time_s")
OVER_TRIALS = "trials"  # a mean curve's standard errors: over its trials' means
OVER_EPISODES = "episodes"  # ... or, with one trial, over each evaluation's episodes


@dataclass(frozen=True)
class CurvePoint:
    """One frozen evaluation: after ``episodes`` training episodes, the mean hold time and its standard
    error over the evaluation episodes (or, for an aggregate, over trials); None where undefined."""

    episodes: int
    mean_hold_time_s: float
    stderr_hold_time_s: float | None


def write_atomic(path: Path, data: bytes) -> None:
    """Replace ``path`` by ``data`` in one step: readers see the old or the new file, never a part. The
    file gets the mode a plain ``open`` gives (0666 less the umask), not ``mkstemp``'s private 0600."""
    tmp = path.parent / f".{path.name}.{secrets.token_hex(8)}.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def read_json(path: Path) -> Any:
    """The JSON file at ``path``, or None if there is none."""
    return json.loads(path.read_text()) if path.is_file() else None


def write_curve_csv(path: Path, points: Sequence[CurvePoint]) -> None:
    """The evaluation curve as CSV: ``episodes,mean_hold_time_s,stderr_hold_time_s``, one row per point;
    an undefined standard error is an empty field."""
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(CSV_HEADER)
    for p in points:
        se = finite_or_none(p.stderr_hold_time_s)
        writer.writerow((p.episodes, repr(p.mean_hold_time_s), "" if se is None else repr(se)))
    write_atomic(path, text.getvalue().encode())


def read_curve_csv(path: Path) -> list[CurvePoint]:
    """A curve written by :func:`write_curve_csv`; ValueError if the header is not ours."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows or tuple(rows[0]) != CSV_HEADER:
        raise ValueError(f"{path}: not a learning-curve CSV (header {rows[0] if rows else None})")
    return [CurvePoint(int(e), float(m), finite_or_none(float(s)) if s else None) for e, m, s in rows[1:]]


def mean_curve(trials: Sequence[Sequence[CurvePoint]]) -> list[CurvePoint]:
    """Point by point over trials: the mean of the trials' mean hold times and its standard error
    (sample standard deviation / sqrt(trials)). Only points every trial has. One trial is its own curve,
    with the standard errors of its evaluations (:func:`stderr_over`)."""
    if not trials:
        return []
    if len(trials) == 1:
        return list(trials[0])
    n = min(len(t) for t in trials)
    out = []
    for i in range(n):
        values = [t[i].mean_hold_time_s for t in trials]
        episodes = {t[i].episodes for t in trials}
        if len(episodes) != 1:
            raise ValueError(f"trials disagree on the episodes of evaluation {i}: {sorted(episodes)}")
        mean = sum(values) / len(values)
        se = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1) / len(values))
        out.append(CurvePoint(episodes.pop(), mean, se))
    return out


def welch_p_value(a: Sequence[float], b: Sequence[float], alternative: str = "two-sided") -> float | None:
    """p-value of Welch's t-test of equal means (unequal variances; ``scipy.stats.ttest_ind`` with
    ``equal_var=False``), two-sided unless ``alternative`` says ``"greater"`` or ``"less"`` (of ``a``'s
    mean); None when it is undefined (fewer than two values in a sample, or both samples without spread)."""
    from scipy import stats

    if len(a) < 2 or len(b) < 2 or (min(a) == max(a) and min(b) == max(b)):
        return None
    return float(stats.ttest_ind(a, b, equal_var=False, alternative=alternative).pvalue)


def ratio_of_means(a: Sequence[float], b: Sequence[float]) -> tuple[float, float | None]:
    """mean(a) / mean(b) and its delta-method standard error over the two independent samples' means
    (None unless each sample has two values or more)."""
    ratio = float(np.mean(a) / np.mean(b))
    if len(a) < 2 or len(b) < 2:
        return ratio, None
    relative = [np.std(x, ddof=1) / math.sqrt(len(x)) / np.mean(x) for x in (a, b)]
    return ratio, ratio * math.hypot(*relative)


def stderr_over(trials: int) -> str:
    """What the standard errors of a mean curve over ``trials`` trials are over (:func:`mean_curve`)."""
    return OVER_TRIALS if trials > 1 else OVER_EPISODES


def stderr_basis(trials: int, eval_episodes: int) -> str:
    """The standard error's basis in words: ``s.e. over 20 trials`` or ``s.e. over 500 episodes of 1 trial``."""
    if stderr_over(trials) == OVER_TRIALS:
        return f"s.e. over {trials} trials"
    return f"s.e. over {eval_episodes} episode{'s' if eval_episodes > 1 else ''} of 1 trial"


def curve_summary(trials: Sequence[Sequence[CurvePoint]]) -> dict[str, Any]:
    """The over-trials part of a ``summary.json``: the mean curve, its last point and what its standard
    errors are over (``stderr_over``: "trials", or "episodes" with one trial)."""
    curve = mean_curve(trials)
    final = curve[-1] if curve else None
    return {"curve": [asdict(p) for p in curve],
            "final_mean_hold_time_s": None if final is None else final.mean_hold_time_s,
            "final_stderr_hold_time_s": None if final is None else final.stderr_hold_time_s,
            "stderr_over": stderr_over(len(trials))}


def draw_curve(ax: Any, label: str, points: Sequence[CurvePoint]) -> None:
    """One mean curve on matplotlib axes ``ax``, with its standard-error band wherever it is defined (a
    point without one interrupts the band)."""
    x = [p.episodes for p in points]
    y = [p.mean_hold_time_s for p in points]
    se = [finite_or_none(p.stderr_hold_time_s) for p in points]
    defined = [s is not None for s in se]
    half = [s if s is not None else 0.0 for s in se]
    (line,) = ax.plot(x, y, marker="o", markersize=3, label=label)
    ax.fill_between(x, [a - b for a, b in zip(y, half)], [a + b for a, b in zip(y, half)], where=defined,
                    color=line.get_color(), alpha=0.25, linewidth=0)


def draw_references(ax: Any, references: dict[str, float]) -> None:
    """Measured reference levels (e.g. the hand-coded and random keepers' hold times) as labelled dashed
    horizontal lines on ``ax``."""
    for (label, level), style in zip(references.items(), ("--", ":", "-.")):
        ax.axhline(level, color="0.25", linestyle=style, linewidth=1.2, label=f"{label}: {level:.2f} s")


def plot_curves(path: Path, curves: dict[str, Sequence[CurvePoint]], title: str,
                references: dict[str, float] | None = None) -> None:
    """A PNG of learning curves (hold time against training episodes), each with its standard-error
    band where it is defined, and the measured ``references`` levels as labelled lines; written
    atomically."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 4.5), dpi=100)
    ax = fig.add_subplot()
    for label, points in curves.items():
        draw_curve(ax, label, points)
    draw_references(ax, references or {})
    ax.set_xlabel("training episodes")
    ax.set_ylabel("mean hold time (s)")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best")
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    write_atomic(path, buffer.getvalue())


__all__ = ["CSV_HEADER", "OVER_EPISODES", "OVER_TRIALS", "CurvePoint", "curve_summary", "draw_curve", "draw_references",
           "mean_curve", "plot_curves", "ratio_of_means", "read_curve_csv", "read_json", "stderr_basis", "stderr_over",
           "welch_p_value", "write_atomic", "write_curve_csv"]
