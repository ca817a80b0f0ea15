"""How a run's numbers are shown: strict JSON, a hold time with its standard error, the summary table.

Shared by ``keepaway run`` and ``evaluate`` (``runner``) and the trainer's outputs (``trainer``). A value
that is undefined (no episodes, one episode, no measured time) is None: ``null`` in JSON, ``n/a`` in text,
never NaN.
"""

from __future__ import annotations

import json
import math
from typing import Any


def finite_or_none(value: float | None) -> float | None:
    """``value`` if it is a finite number, else None (what JSON and our CSV can hold)."""
    return value if value is not None and math.isfinite(value) else None


def format_hold(mean: float | None, stderr: float | None, basis: str) -> str:
    """A mean hold time with its standard error and what that is over (``basis``, e.g.
    ``trainer.curves.stderr_basis``): ``4.30 s +- 0.25 (s.e. over 20 trials)``; ``n/a`` for an undefined
    value."""
    m, se = finite_or_none(mean), finite_or_none(stderr)
    return f"{'n/a' if m is None else f'{m:.2f} s'} +- {'n/a' if se is None else f'{se:.2f}'} ({basis})"


def summary_table(summary: dict) -> str:
    """A short human-readable table of a run's summary (``runner.job.RunResult.summary``); an undefined
    value reads ``n/a``."""
    eps = summary["episodes"]
    n = len(eps)
    taken = sum(e["end"] == "taken" for e in eps)
    hold = format_hold(summary["mean_hold_time_s"], summary["stderr_hold_time_s"],
                       f"s.e. over {n} episode{'' if n == 1 else 's'}")
    rows = [
        ("mode", summary["mode"]),
        ("seed", str(summary["seed"])),
        ("episodes", str(n)),
        ("mean hold time", hold),
        ("ended by take", f"{taken} ({taken / n:.0%})" if n else "0"),
        ("ended out", f"{n - taken} ({(n - taken) / n:.0%})" if n else "0"),
        ("cycles / s", _rate(summary["cycles_per_s"], ",.0f")),
        ("episodes / s", _rate(summary["episodes_per_s"], ",.2f")),
    ]
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def _rate(value: float | None, spec: str) -> str:
    value = finite_or_none(value)
    return "n/a" if value is None else format(value, spec)


def dump_json(value: Any, indent: int | None = None) -> str:
    """``value`` as strict JSON (RFC 8259: no NaN or Infinity): every non-finite number becomes ``null``,
    so any JSON parser reads what the trainer prints and writes."""
    return json.dumps(_finite(value), indent=indent, allow_nan=False)


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return finite_or_none(value)
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


__all__ = ["dump_json", "finite_or_none", "format_hold", "summary_table"]
