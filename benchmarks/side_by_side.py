"""Our players beside the reference stack (rcssserver 19.0.0 + keepaway-0.6): behaviour statistics per Pass policy.

Plays ``--episodes`` episodes (default 1,000) per Pass policy (always hold, random, hand-coded;
``--policies`` for some) with our players, 3v2 on 20 m, CURRENT parameters, hand-coded GetOpen and
takers, batched on one thread, and prints one table per statistic: ours, the reference's, the difference
in combined standard errors (where both have one) and in percent. Figures only, no verdict: the
tolerances live in ``tests/test_behaviour.py``. Definitions: ``trainer/behaviour.py``.

Without ``--reference`` the reference is the stored campaigns of each policy
(``tests/data/rcss-behaviour/stats_real.json``, ``trainer.behaviour.REFERENCE_CAMPAIGNS``), a row each.
With ``--reference BUILD`` (the directory ``../shared/tools/build-rcss.sh`` built) each policy is first
played live on the reference stack with the same settings, ``--episodes`` episodes with server seed
``--seed`` (``benchmarks/reference_stack.py``; logs in ``--log-dir`` or a temporary directory), its
statistics computed from its game log and episode log by the same code as ours
(``trainer.behaviour.game_log_episodes``), and printed as the reference. ``--save-reference TAG``
appends each such campaign to the stored file as a new campaign named after the policy and TAG
("hold", "rand" or "hand" + TAG, as the file's earlier campaigns; an existing name is refused).
``--reference-logs DIR`` measures the logs an earlier ``--log-dir DIR`` kept instead of playing again
(``DIR/<policy>/game.rcg`` and ``game.kwy``; ``--seed`` names the seed they were played with).

The first table weighs each statistic of ours against all the reference campaigns of its policy, as
``tests/test_behaviour.py`` does (``trainer.behaviour.judge``): within tolerance of one campaign, or
between the campaigns' lowest and highest value.

    python benchmarks/side_by_side.py [--episodes 1000] [--seed 7] [--batch 100] [--policies random]
    python benchmarks/side_by_side.py --reference /work/rcss-build/b --seed 31 [--save-reference 31]
    python benchmarks/side_by_side.py --reference-logs DIR --seed 31 --save-reference 31
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the repository, before benchmarks/

from keepaway.protocol.params import parameter_set  # noqa: E402
from keepaway.trainer.behaviour import (  # noqa: E402
    CURVE_CYCLES,
    REFERENCE_CAMPAIGNS,
    TOLERANCE_SE,
    TOLERANCE_SHARE,
    BehaviourStats,
    Estimate,
    behaviour_statistics,
    compare,
    game_log_episodes,
    judge,
    load_reference,
    measure_policy,
    reference_entry,
)
from keepaway.runner.launch import ArenaFailure, interrupt_on_sigterm  # noqa: E402
from benchmarks.reference_stack import (  # noqa: E402
    CPP_POLICY,
    KEEPERS,
    LOG_NAME,
    TAKERS,
    ReferenceStack,
    play_reference,
)
from keepaway.server.episode_log import read_kwy  # noqa: E402
from keepaway.server.game_log import read_rcg  # noqa: E402

REFERENCE = REPO / "tests" / "data" / "rcss-behaviour" / "stats_real.json"
# A policy's references: (label, statistics), one row each.
References = dict[str, list[tuple[str, BehaviourStats]]]


def estimate_text(e: Estimate) -> str:
    return f"{e.value:.3f}" if e.se is None else f"{e.value:.3f} +- {e.se:.3f}"


def optional_text(x: float | None, unit: str) -> str:
    return "-" if x is None else f"{x:+.1f}{unit}"


def scalar_tables(ours: dict[str, BehaviourStats], references: References) -> list[str]:
    """One markdown table per single-number statistic, a row per (our policy, reference campaign that has
    the statistic)."""
    rows: dict[str, list[str]] = {name: [] for stats in ours.values() for name in stats.scalars()}
    for policy in ours:
        for campaign, stats in references[policy]:
            for row in compare(ours[policy], stats):
                rows[row.statistic].append(
                    f"| {policy} (ref. {campaign}) | {estimate_text(row.ours)} | {estimate_text(row.reference)} | "
                    f"{row.difference:+.3f} | {optional_text(row.z, '')} | {optional_text(row.percent, ' %')} | "
                    f"{'' if row.within_tolerance else '**beyond**'} |")
    lines = []
    for name, table in rows.items():
        if table:
            lines += [f"\n### {name}\n",
                      "| policy | ours | reference | difference | in s.e. | in % | beyond tolerance |",
                      "|---|---|---|---|---|---|---|", *table]
    return lines


def verdict_table(ours: dict[str, BehaviourStats], references: References) -> list[str]:
    """One row per (policy, statistic): ours, the campaigns' range, and whether ours is within tolerance
    of the campaigns (``trainer.behaviour.judge``)."""
    lines = ["\n### Verdict: ours against every reference campaign of the policy\n",
             "| policy | statistic | ours | reference campaigns | within tolerance |", "|---|---|---|---|---|"]
    for policy, stats in ours.items():
        for v in judge(stats, [campaign for _, campaign in references[policy]]):
            low, high = v.reference_range
            span = f"{low:.3f}" if low == high else f"{low:.3f} - {high:.3f}"
            lines.append(f"| {policy} | {v.statistic} | {estimate_text(v.ours)} | {span} ({len(v.rows)}) | "
                         f"{'yes' if v.within_tolerance else '**no**'} |")
    return lines


def curve_tables(ours: dict[str, BehaviourStats], references: References) -> list[str]:
    """The taker-ball distance curves (m) for t = 0..29, ours beside the first reference campaign."""
    lines = []
    for policy, stats in ours.items():
        campaign, ref = references[policy][0]
        takers = [f"r{j + 1}" for j in range(len(stats.curve_takers))]
        head = " | ".join(f"{name} ours | {name} ref." for name in takers + ["nearer"])
        lines += [f"\n### taker-ball distance (m), {policy} (ref. {campaign})\n",
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


def campaign_name(policy: str, tag: str) -> str:
    """The stored file's name of a fresh campaign: the C++ policy's name and the tag ("rand31")."""
    return CPP_POLICY[policy] + tag


def stored_entries(path: Path, new_names: set[str]) -> list[dict]:
    """The stored reference file's entries; ValueError in one line if one of ``new_names`` is taken."""
    entries = json.loads(path.read_text())
    taken = sorted({entry["policy"] for entry in entries} & new_names)
    if taken:
        raise ValueError(f"{path.name} already has the campaign(s) {', '.join(taken)}: choose another tag")
    return entries


def save_campaigns(path: Path, campaigns: dict[str, dict]) -> None:
    """Append ``campaigns`` (name -> entry) to the stored reference file, keeping its entries and format."""
    entries = stored_entries(path, set(campaigns))
    path.write_text(json.dumps(entries + list(campaigns.values()), indent=1))


def play_live_reference(stack: ReferenceStack, policy: str, episodes: int, seed: int,
                        log_dir: Path | None, seconds_per_cycle: float) -> BehaviourStats:
    """``episodes`` episodes of ``policy`` on the reference stack, measured from its logs."""
    with tempfile.TemporaryDirectory(prefix="refstack-") as scratch:
        where = Path(scratch) if log_dir is None else log_dir / policy
        where.mkdir(parents=True, exist_ok=True)
        record, kwy = play_reference(stack, policy, episodes, seed, where)
        recorded = game_log_episodes(record, kwy, KEEPERS, TAKERS)
    return behaviour_statistics(recorded, KEEPERS, seconds_per_cycle)


def logged_reference(log_dir: Path, policy: str, episodes: int, seconds_per_cycle: float) -> BehaviourStats:
    """The statistics of the first ``episodes`` episodes of the reference stack's logs an earlier
    ``--log-dir`` kept for ``policy`` (the stack plays on a little beyond the episodes asked for)."""
    where = log_dir / policy
    kwy = where / f"{LOG_NAME}.kwy"
    recorded = game_log_episodes(read_rcg(where / f"{LOG_NAME}.rcg", kwy), read_kwy(kwy)[:episodes], KEEPERS, TAKERS)
    if len(recorded) < episodes:
        raise ValueError(f"{where} holds {len(recorded)} whole episodes, fewer than --episodes {episodes}")
    return behaviour_statistics(recorded, KEEPERS, seconds_per_cycle)


def measured_references(parser: argparse.ArgumentParser, args: argparse.Namespace, step_s: float) -> References:
    """Each policy of ``args`` played live on the reference stack, or measured from the logs
    ``--reference-logs`` names (and stored with ``--save-reference``); a bad build directory or a taken
    campaign name is refused before anything is played, a dead process, unreadable logs or Ctrl-C end the
    harness in one line with every process stopped."""
    stack = ReferenceStack(args.reference) if args.reference else None
    names = {policy: campaign_name(policy, args.save_reference or "") for policy in args.policies}
    try:
        if stack:
            stack.check()
        if args.save_reference:
            stored_entries(REFERENCE, set(names.values()))
    except ValueError as exc:
        parser.error(str(exc))
    references = {}
    for policy in args.policies:
        start = time.perf_counter()
        try:
            if stack:
                stats = play_live_reference(stack, policy, args.episodes, args.seed, args.log_dir, step_s)
            else:
                stats = logged_reference(args.reference_logs, policy, args.episodes, step_s)
        except (ArenaFailure, ValueError, OSError) as exc:
            sys.exit(f"side_by_side: {exc}")
        except KeyboardInterrupt:
            sys.exit("side_by_side: interrupted; the reference stack is stopped")
        references[policy] = [(f"{'live' if stack else 'logged'}, seed {args.seed}", stats)]
        print(f"{policy}: reference {'stack' if stack else 'logs'}, {stats.episodes} episodes in "
              f"{time.perf_counter() - start:.0f} s",
              file=sys.stderr)
    if args.save_reference:
        save_campaigns(REFERENCE, {names[p]: reference_entry(references[p][0][1], names[p], args.seed)
                                   for p in args.policies})
    return references


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=1000, help="episodes per Pass policy")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--batch", type=int, default=100, help="arenas played side by side")
    parser.add_argument("--policies", nargs="+", choices=list(REFERENCE_CAMPAIGNS), default=list(REFERENCE_CAMPAIGNS))
    parser.add_argument("--reference", type=Path, metavar="BUILD",
                        help="play the reference stack built in BUILD live (else: the stored campaigns)")
    parser.add_argument("--reference-logs", type=Path, metavar="DIR",
                        help="measure the reference logs an earlier --log-dir DIR kept (instead of --reference)")
    parser.add_argument("--log-dir", type=Path, help="keep the reference stack's logs here (per policy)")
    parser.add_argument("--save-reference", metavar="TAG",
                        help="store the live campaigns in stats_real.json as <policy>TAG")
    args = parser.parse_args()
    if args.reference and args.reference_logs:
        parser.error("--reference and --reference-logs are two sources of one reference: give one")
    if args.reference is None and args.log_dir:
        parser.error("--log-dir needs --reference")
    if args.reference is None and args.reference_logs is None and args.save_reference:
        parser.error("--save-reference needs --reference or --reference-logs")
    if args.episodes < 2:
        parser.error("--episodes must be at least 2")
    interrupt_on_sigterm()  # a terminated harness stops the reference stack as Ctrl-C does
    params = parameter_set("current")
    step_s = params.simulator_step_ms / 1000.0
    if args.reference is None and args.reference_logs is None:
        stored = load_reference(REFERENCE)
        references = {policy: [(c, stored[c]) for c in REFERENCE_CAMPAIGNS[policy]] for policy in args.policies}
    else:
        references = measured_references(parser, args, step_s)
    ours = {}
    for policy in args.policies:
        start = time.perf_counter()
        try:
            ours[policy] = measure_policy(params, policy, args.episodes, args.seed, args.batch)
        except RuntimeError as exc:  # a stuck episode (trainer.behaviour.record_batched)
            parser.exit(1, f"side_by_side.py: {policy}: {exc}\n")
        print(f"{policy}: {args.episodes} episodes in {time.perf_counter() - start:.0f} s", file=sys.stderr)
    source = "played live" if args.reference else "its logs" if args.reference_logs else "stored campaigns"
    print(f"# Side by side: our players ({args.episodes} episodes per policy, seed {args.seed}, batch "
          f"{args.batch}) and the reference stack ({source})\n")
    print("CURRENT parameters, 3v2 on 20 m, hand-coded GetOpen and takers. 'in s.e.': difference / "
          "sqrt(s.e. ours^2 + s.e. ref.^2). Beyond tolerance: more than "
          f"{TOLERANCE_SE:g} such s.e. and more than {100 * TOLERANCE_SHARE:g} % of the reference.")
    print("\n".join(verdict_table(ours, references) + scalar_tables(ours, references) + curve_tables(ours, references)))


if __name__ == "__main__":
    main()
