"""How the experiments' results read: Figure 3 as a figure (``figure3.png``) and as its final
evaluations (``figure3.csv``, ``figure3.json``, ``figure3.md``), Table 2 as two cross tables
(``table2.md``, ``table2.json``); docs/experiments.md describes each file.

A Table 2 entry is the mean over trials of the trials' mean hold times with its standard error; an entry
marked ``*`` differs from its column's best (Welch's t-test over trials, ``trainer.curves.welch_p_value``,
p < 0.05). The paper expects each column's best on the diagonal. With one trial a standard error over
trials does not exist: curves and finals carry the standard error over each evaluation's episodes
(``trainer.curves.mean_curve``, named by ``stderr_over``), Table 2's entries none (``null``, printed
``n/a``). Every JSON written here is strict JSON (``runner.report.dump_json``).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from keepaway.runner.report import dump_json, finite_or_none
from keepaway.trainer.configurations import POLICIES, SHORT, ConfigurationRun, ExperimentConfig, configuration_name
from keepaway.trainer.curves import (
    CurvePoint,
    draw_curve,
    draw_references,
    mean_curve,
    ratio_of_means,
    stderr_over,
    welch_p_value,
    write_atomic,
)
from keepaway.trainer.schedule import LEARNED, PASS
from keepaway.trainer.timing import Timing

SIGNIFICANCE = 0.05  # docs/players.md §8.3: Welch's t-test, p < 0.05
# Figure 3's measured reference levels: the configurations that learn nothing at the paper's two extremes.
REFERENCES = {("handcoded", "handcoded"): "hand-coded", ("random", "random"): "random"}
FINAL_HEADER = ("name", "pass", "getopen", "trials", "episodes", "final_mean_hold_time_s", "final_stderr_hold_time_s",
                "stderr_over")
# Figure 3's table: its columns as shares of the training (at 30,000 episodes: 0, 2,500, 5,000, 10,000,
# 20,000 and 30,000), each the nearest evaluation point.
TABLE_FRACTIONS = (0.0, 1 / 12, 1 / 6, 1 / 3, 2 / 3, 1.0)
LABELS = {("handcoded", "handcoded"): "hand-coded pair", ("random", "random"): "random pair",
          ("handcoded", LEARNED): "CEM GetOpen, hand-coded Pass", ("random", LEARNED): "CEM GetOpen, random Pass",
          (LEARNED, "handcoded"): "Sarsa Pass, hand-coded GetOpen", (LEARNED, "random"): "Sarsa Pass, random GetOpen",
          (LEARNED, LEARNED): "Algorithm 3"}


# -- Figure 3 ----------------------------------------------------------------------------------------
def plot_figure3(path: Path, runs: Sequence[ConfigurationRun]) -> None:
    """The paper's two-column layout as one PNG, written atomically: left, one panel per Pass policy with
    its three GetOpen curves; right, one panel per GetOpen policy with its three Pass curves. All panels
    share the axes, so heights compare across them, and every panel marks the :func:`reference_levels`
    (labelled once, below the panels)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11.0, 10.0), dpi=100, layout="constrained")
    axes = fig.subplots(len(POLICIES), 2, sharex=True, sharey=True)
    bases = sorted({r.stderr_basis() for r in runs})
    fig.suptitle(f"Keepaway 3v2: mean hold time (band: {'; '.join(bases)})")
    references = reference_levels(runs)
    for row, policy in enumerate(POLICIES):
        for column, (panel, grouped_by, other) in enumerate((("Pass", "pass_policy", "GO"),
                                                            ("GetOpen", "getopen_policy", "P"))):
            ax = axes[row, column]
            for run in runs:
                if getattr(run, grouped_by) == policy:
                    counterpart = run.getopen_policy if grouped_by == "pass_policy" else run.pass_policy
                    draw_curve(ax, f"{other}:{SHORT[counterpart]}", run.mean_curve())
            ax.set_title(f"{panel}: {SHORT[policy]}")
            ax.grid(True, alpha=0.3)
            ax.legend(loc="best", fontsize="small")
            draw_references(ax, references)  # after the panel's legend: the figure's legend names them once
            if row == len(POLICIES) - 1:
                ax.set_xlabel("training episodes")
            if column == 0:
                ax.set_ylabel("mean hold time (s)")
    if references:
        handles, labels = axes[0, 0].get_legend_handles_labels()
        fig.legend(handles[-len(references):], labels[-len(references):], loc="outside lower center",
                   ncols=len(references))
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    write_atomic(path, buffer.getvalue())


def reference_levels(runs: Sequence[ConfigurationRun]) -> dict[str, float]:
    """The levels of the hand-coded (P:HC-GO:HC) and random (P:R-GO:R) keepers (:data:`REFERENCES`) among
    ``runs``, by label, from their measured curves (:meth:`ConfigurationRun.reference_level`)."""
    measured = {(r.pass_policy, r.getopen_policy): r for r in runs}
    return {f"{configuration_name(*config)} ({label})": measured[config].reference_level()
            for config, label in REFERENCES.items() if config in measured}


def table_columns(episodes: Sequence[int]) -> list[int]:
    """The evaluation points (``episodes``, ascending) nearest to :data:`TABLE_FRACTIONS` of the last."""
    return sorted({min(episodes, key=lambda e: abs(e - f * episodes[-1])) for f in TABLE_FRACTIONS})


def format_estimate(value: float, se: float | None) -> str:
    se = finite_or_none(se)
    return f"{value:.2f}" if se is None else f"{value:.2f} +- {se:.2f}"


def ratio_text(a: Sequence[float], b: Sequence[float]) -> str:
    """mean(a) / mean(b) with its delta-method standard error over the two independent samples' means
    (``trainer.curves.ratio_of_means``) and Welch's p (each only with two or more values per sample)."""
    ratio, se = ratio_of_means(a, b)
    if se is None:
        return f"{ratio:.2f}"
    p = welch_p_value(a, b)
    return f"{ratio:.2f} +- {se:.2f}" + ("" if p is None else f" (p = {p:.2g})")


def figure3_markdown(runs: Sequence[ConfigurationRun]) -> str:
    """Figure 3 as a table (``figure3.md``): a row per configuration, the two reference pairs first; its
    trials, the mean curve +- its standard error at :func:`table_columns`, the last in bold, and the final
    evaluation beside the hand-coded pair's (:func:`ratio_text` over the trials' finals)."""
    first = [run for config in REFERENCES for run in runs if (run.pass_policy, run.getopen_policy) == config]
    ordered = first + [run for run in runs if run not in first]
    columns = table_columns([p.episodes for p in ordered[0].mean_curve()])
    hand = next((run for run in runs if (run.pass_policy, run.getopen_policy) == ("handcoded", "handcoded")), None)
    lines = ["| configuration | trials | " + " | ".join(f"{e:,}" for e in columns)
             + f" episodes | / P:HC-GO:HC at {columns[-1]:,} (Welch p) |", "|---" * (len(columns) + 3) + "|"]
    for run in ordered:
        curve = {p.episodes: p for p in run.mean_curve()}
        cells = [format_estimate(curve[e].mean_hold_time_s, curve[e].stderr_hold_time_s) for e in columns]
        cells[-1] = f"**{cells[-1]}**"
        finals = [trial[-1].mean_hold_time_s for trial in run.curves]
        versus = "-" if hand is None else "1" if run is hand else ratio_text(
            finals, [trial[-1].mean_hold_time_s for trial in hand.curves])
        label = LABELS.get((run.pass_policy, run.getopen_policy))
        name = f"{run.name} ({label})" if label else run.name
        lines.append(f"| {name} | {len(run.curves)} | {' | '.join(cells)} | {versus} |")
    return "\n".join(lines) + "\n"


def write_final_evaluations(out: Path, exp: ExperimentConfig, runs: Sequence[ConfigurationRun]) -> None:
    """``figure3.csv`` (one row per configuration: its last evaluation, mean over trials and standard
    error, and what that is over; an undefined one is an empty field), ``figure3.json`` (the same with
    the experiment's settings and every mean curve; ``null`` where undefined) and ``figure3.md``
    (:func:`figure3_markdown`)."""
    rows = []
    for run in runs:
        final = run.final()
        rows.append({"name": run.name, "pass": SHORT[run.pass_policy], "getopen": SHORT[run.getopen_policy],
                     "trials": len(run.curves), "episodes": final.episodes,
                     "final_mean_hold_time_s": final.mean_hold_time_s,
                     "final_stderr_hold_time_s": final.stderr_hold_time_s,
                     "stderr_over": stderr_over(len(run.curves))})
    text = io.StringIO()
    writer = csv.DictWriter(text, FINAL_HEADER, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    write_atomic(out / "figure3.csv", text.getvalue().encode())
    configurations = [{**row, "timing": asdict(run.timing), "curve": [asdict(p) for p in run.mean_curve()]}
                      for row, run in zip(rows, runs)]
    # the sums over the configurations (processes sharing the work with --only overlap in time) and the
    # most sittings any configuration took
    total = Timing(sum(r.timing.wall_s for r in runs), sum(r.timing.cpu_s for r in runs),
                   max((r.timing.sittings for r in runs), default=0))
    write_atomic(out / "figure3.json", dump_json({"experiment": asdict(exp), "timing": asdict(total),
                                                  "configurations": configurations}, indent=1).encode())
    write_atomic(out / "figure3.md", figure3_markdown(runs).encode())


# -- Table 2 ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Cell:
    """One entry of Table 2: the trials' mean hold times, whether it is its column's best, and the p-value
    of Welch's test against that best (None for the best itself and where the test is undefined)."""

    values: tuple[float, ...]
    best: bool
    p_value: float | None

    @property
    def mean(self) -> float:
        return self._over_trials().mean_hold_time_s

    @property
    def stderr(self) -> float | None:
        """Over trials; None with one trial (a cross-test keeps only each trial's mean)."""
        return self._over_trials().stderr_hold_time_s

    def _over_trials(self) -> CurvePoint:
        """Mean and standard error over trials, the statistic of a learning curve's point (trainer.curves)."""
        return mean_curve([[CurvePoint(0, v, None)] for v in self.values])[0]

    @property
    def significant(self) -> bool:
        """Differs from the column's best at p < 0.05."""
        return self.p_value is not None and self.p_value < SIGNIFICANCE

    def text(self) -> str:
        se = "n/a" if self.stderr is None else f"{self.stderr:.2f}"
        entry = f"{self.mean:.2f} +- {se}{'*' if self.significant else ''}"
        return f"**{entry}**" if self.best else entry


def table_cells(values: Sequence[Sequence[Sequence[float]]]) -> list[list[Cell]]:
    """Cells of a table from its values [row][column][trial]: each column's best is the highest mean,
    every entry tested against it."""
    rows, columns = len(values), len(values[0])
    cells: list[list[Cell | None]] = [[None] * columns for _ in range(rows)]
    for c in range(columns):
        column = [values[r][c] for r in range(rows)]
        best = max(range(rows), key=lambda r: sum(column[r]) / len(column[r]))
        for r in range(rows):
            p = None if r == best else welch_p_value(column[r], column[best])
            cells[r][c] = Cell(tuple(column[r]), r == best, p)
    return cells  # type: ignore[return-value]


@dataclass(frozen=True)
class CrossTable:
    """Table 2's half for one study: the policy learned with counterpart X (row) tested with Y (column)."""

    study: str
    cells: list[list[Cell]]

    @property
    def counterpart_prefix(self) -> str:
        return "GO" if self.study == PASS else "P"

    def best_on_diagonal(self) -> list[bool]:
        """Per column: is its best the policy trained with that very counterpart (the paper's expectation)?"""
        return [self.cells[c][c].best for c in range(len(POLICIES))]

    def markdown(self) -> str:
        learned = "Pass" if self.study == PASS else "GetOpen"
        other = "GetOpen" if self.study == PASS else "Pass"
        prefix = self.counterpart_prefix
        trials = len(self.cells[0][0].values)
        lines = [f"### {learned} learned with {other} X (rows), tested with {other} Y (columns)", "",
                 f"Mean hold time (s) +- standard error over {trials} trial{'s' if trials > 1 else ''}"
                 f"{' (n/a: one trial has none, and no test)' if trials == 1 else ''}; bold: the column's best; "
                 f"`*`: differs from it (Welch's t-test, p < {SIGNIFICANCE}).", "",
                 f"| {learned} trained with | " + " | ".join(f"tested with {prefix}:{SHORT[p]}" for p in POLICIES)
                 + " |",
                 "|---|" + "---:|" * len(POLICIES)]
        for policy, row in zip(POLICIES, self.cells):
            lines.append(f"| {prefix}:{SHORT[policy]} | " + " | ".join(cell.text() for cell in row) + " |")
        return "\n".join(lines) + "\n"

    def to_dict(self) -> dict[str, Any]:
        return {"study": self.study, "rows": [f"{self.counterpart_prefix}:{SHORT[p]}" for p in POLICIES],
                "columns": [f"{self.counterpart_prefix}:{SHORT[p]}" for p in POLICIES],
                "best_on_diagonal": self.best_on_diagonal(),
                "cells": [[{"mean_hold_time_s": c.mean, "stderr_hold_time_s": c.stderr, "trials": len(c.values),
                            "best": c.best, "p_value": c.p_value, "significant": c.significant,
                            "values": list(c.values)} for c in row] for row in self.cells]}


def write_table2(out: Path, exp: ExperimentConfig, tests_timing: Timing, tables: Sequence[CrossTable]) -> None:
    """``table2.json`` (the experiment's settings, what its tests cost and :meth:`CrossTable.to_dict` of
    each table) and ``table2.md`` (:meth:`CrossTable.markdown` of each)."""
    write_atomic(out / "table2.json", dump_json({"experiment": asdict(exp), "tests_timing": asdict(tests_timing),
                                                 "tables": [t.to_dict() for t in tables]}, indent=1).encode())
    write_atomic(out / "table2.md", "\n".join(t.markdown() for t in tables).encode())


__all__ = [
    "Cell",
    "CrossTable",
    "REFERENCES",
    "SIGNIFICANCE",
    "figure3_markdown",
    "plot_figure3",
    "ratio_text",
    "reference_levels",
    "table_cells",
    "table_columns",
    "write_final_evaluations",
    "write_table2",
]
