"""Our players beside the reference stack (rcssserver 19.0.0 + keepaway-0.6): behaviour statistics per Pass policy.

Plays ``--episodes`` episodes (default 1,000) per Pass policy (always hold, random, hand-coded) with our
players, 3v2 on 20 m, CURRENT parameters, hand-coded GetOpen and takers, batched on one thread, and prints
one table per statistic: ours, the reference's (``tests/data/rcss-behaviour/stats_real.json``), the
difference in combined standard errors (where both have one) and in percent. The hand-coded Pass has two
reference campaigns ("hand", "hand14"); each gets its row. Figures only, no verdict: the tolerances live
in ``tests/test_behaviour.py``. Definitions: ``trainer/behaviour.py``.

    python benchmarks/side_by_side.py [--episodes 1000] [--seed 7] [--batch 100]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the repository, before benchmarks/

from protocol.params import parameter_set  # noqa: E402
from trainer.behaviour import (  # noqa: E402
    CURVE_CYCLES,
    REFERENCE_CAMPAIGNS,
    TOLERANCE_SE,
    TOLERANCE_SHARE,
    BehaviourStats,
    Estimate,
    compare,
    load_reference,
    measure_policy,
)

REFERENCE = REPO / "tests" / "data" / "rcss-behaviour" / "stats_real.json"


def estimate_text(e: Estimate) -> str:
    return f"{e.value:.3f}" if e.se is None else f"{e.value:.3f} +- {e.se:.3f}"


def optional_text(x: float | None, unit: str) -> str:
    return "-" if x is None else f"{x:+.1f}{unit}"


def scalar_tables(ours: dict[str, BehaviourStats], reference: dict[str, BehaviourStats]) -> list[str]:
    """One markdown table per single-number statistic, a row per (our policy, reference campaign)."""
    pairs = [(policy, campaign, compare(ours[policy], reference[campaign]))
             for policy in ours for campaign in REFERENCE_CAMPAIGNS[policy]]
    lines = []
    for i, name in enumerate(row.statistic for row in pairs[0][2]):
        lines += [f"\n### {name}\n", "| policy | ours | reference | difference | in s.e. | in % | beyond tolerance |",
                  "|---|---|---|---|---|---|---|"]
        for policy, campaign, rows in pairs:
            row = rows[i]
            lines.append(f"| {policy} (ref. {campaign}) | {estimate_text(row.ours)} | "
                         f"{estimate_text(row.reference)} | {row.difference:+.3f} | "
                         f"{optional_text(row.z, '')} | {optional_text(row.percent, ' %')} | "
                         f"{'' if row.within_tolerance else '**beyond**'} |")
    return lines


def curve_tables(ours: dict[str, BehaviourStats], reference: dict[str, BehaviourStats]) -> list[str]:
    """The taker-ball distance curves (m) for t = 0..29, ours beside the first reference campaign."""
    lines = []
    for policy, stats in ours.items():
        ref = reference[REFERENCE_CAMPAIGNS[policy][0]]
        takers = [f"r{j + 1}" for j in range(len(stats.curve_takers))]
        head = " | ".join(f"{name} ours | {name} ref." for name in takers + ["nearer"])
        lines += [f"\n### taker-ball distance (m), {policy} (ref. {REFERENCE_CAMPAIGNS[policy][0]})\n",
                  f"| t | {head} | nearer in % | running ours | running ref. |",
                  "|---|" + "---|" * (2 * len(takers) + 5)]
        for t in range(CURVE_CYCLES):
            ours_t = [*stats.curve_takers[:, t], stats.curve_nearer[t]]
            ref_t = [*ref.curve_takers[:, t], ref.curve_nearer[t]]
            cells = " | ".join(f"{a:.2f} | {b:.2f}" for a, b in zip(ours_t, ref_t))
            percent = 100.0 * (ours_t[-1] - ref_t[-1]) / ref_t[-1]
            lines.append(f"| {t} | {cells} | {percent:+.1f} % | {stats.curve_running[t]} | "
                         f"{ref.curve_running[t]} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000, help="episodes per Pass policy")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--batch", type=int, default=100, help="arenas played side by side")
    args = parser.parse_args()
    params = parameter_set("current")
    reference = load_reference(REFERENCE)
    ours = {}
    for policy in REFERENCE_CAMPAIGNS:
        start = time.perf_counter()
        ours[policy] = measure_policy(params, policy, args.episodes, args.seed, args.batch)
        print(f"{policy}: {args.episodes} episodes in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    print(f"# Side by side: our players ({args.episodes} episodes per policy, seed {args.seed}, batch "
          f"{args.batch}) and the reference stack\n")
    print("CURRENT parameters, 3v2 on 20 m, hand-coded GetOpen and takers. 'in s.e.': difference / "
          "sqrt(s.e. ours^2 + s.e. ref.^2). Beyond tolerance: more than "
          f"{TOLERANCE_SE:g} such s.e. and more than {100 * TOLERANCE_SHARE:g} % of the reference.")
    print("\n".join(scalar_tables(ours, reference) + curve_tables(ours, reference)))


if __name__ == "__main__":
    main()
