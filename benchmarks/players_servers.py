"""The players x servers table: the keepaway-0.6 C++ players and ours, on rcssserver 19 and on our server,
and mixed teams, each cell's behaviour statistics against the C++ players on rcssserver.

    python benchmarks/players_servers.py BUILD [--episodes 1000] [--seed 51] [--cells ...] [--log-dir DIR]
    python benchmarks/players_servers.py BUILD --logs DIR      # measure the logs an earlier --log-dir kept

``BUILD`` is the reference stack's build directory (tools/build-reference-stack.sh). A cell is a server and
whose players keep and take (``benchmarks.reference_stack.Cell``): ``ours,cpp,cpp`` is the C++ players on
our server through its rcssserver-protocol front, ``rcssserver,ours,ours`` ours on rcssserver through
``keepaway player --rcss``, ``ours,cpp,ours`` C++ keepers against our takers, and so on. Each cell plays
``--episodes`` episodes per keepers' Pass policy (always hold, random, hand-coded; hand-coded takers and
GetOpen), synchronous, CURRENT parameters, 3v2 on 20 m, server seed ``--seed``, its logs kept in
``--log-dir/CELL/POLICY``. Its statistics come from its game and episode logs by the side-by-side harness's
code (``trainer.behaviour``) and are judged against every stored campaign of the C++ players on rcssserver
(``tests/data/rcss-behaviour/stats_real.json``) with the tolerance rule of ``tests/test_behaviour.py``.
``--params classic`` plays the cells that can under CLASSIC parameters (on our server: by default the C++
players, and ours), each judged against the first cell of C++ players of the same invocation, since
there are no stored CLASSIC campaigns on rcssserver (rcssserver 19 cannot play them).
Prints one row per cell and policy: the episodes, the hold time with its standard error, and how many of
the 19 statistics are within tolerance, naming those that are not; then the C++ players' speed on
rcssserver and on our server, measured in the same invocation (``benchmarks/rcss_front.py``'s table,
``--speed-repeats`` runs of ``--speed-seconds``; 0 repeats: not measured).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from benchmarks.rcss_front import SETTINGS, speed_table  # noqa: E402
from benchmarks.reference_stack import KEEPERS, LOG_NAME, TAKERS, Cell, ReferenceStack, play_campaign  # noqa: E402
from keepaway.protocol.params import parameter_set  # noqa: E402
from keepaway.server.episode_log import read_kwy  # noqa: E402
from keepaway.server.game_log import read_rcg  # noqa: E402
from keepaway.trainer.behaviour import (  # noqa: E402
    REFERENCE_CAMPAIGNS,
    BehaviourStats,
    behaviour_statistics,
    game_log_episodes,
    judge,
    load_reference,
)

STORED = REPO / "tests" / "data" / "rcss-behaviour" / "stats_real.json"
DEFAULT_CELLS = ("ours,cpp,cpp", "rcssserver,ours,ours", "ours,cpp,ours", "ours,ours,cpp")
CLASSIC_CELLS = ("ours,cpp,cpp", "ours,ours,ours")
POLICIES = tuple(REFERENCE_CAMPAIGNS)


def cell_of(text: str, params: str = "current") -> Cell:
    server, keepers, takers = text.split(",")
    if server not in ("rcssserver", "ours") or not {keepers, takers} <= {"cpp", "ours"}:
        raise argparse.ArgumentTypeError(f"{text!r}: a cell is SERVER,KEEPERS,TAKERS of rcssserver|ours, cpp|ours")
    return Cell(server, keepers, takers, params)


def logged(where: Path, episodes: int, step_s: float) -> BehaviourStats:
    """The statistics of the first ``episodes`` whole episodes of the logs in ``where``."""
    kwy = where / f"{LOG_NAME}.kwy"
    recorded = game_log_episodes(read_rcg(where / f"{LOG_NAME}.rcg", kwy), read_kwy(kwy)[:episodes], KEEPERS, TAKERS)
    return behaviour_statistics(recorded, KEEPERS, step_s)


def row(cell: Cell, policy: str, stats: BehaviourStats, campaigns: list[BehaviourStats]) -> str:
    """A cell's line, judged against ``campaigns`` (none: the cell is the reference)."""
    hold = stats.hold_s
    head = f"| {cell.name} | {policy} | {stats.episodes} | {hold.value:.2f} ± {hold.se:.2f} | "
    if not campaigns:
        return head + "(the reference) | |"
    verdicts = judge(stats, campaigns)
    off = [v.statistic for v in verdicts if not v.within_tolerance]
    return head + f"{len(verdicts) - len(off)} / {len(verdicts)} | {', '.join(off) or '-'} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("build", type=Path, help="the reference stack's build directory")
    parser.add_argument("--episodes", type=int, default=1000, help="episodes per cell and Pass policy")
    parser.add_argument("--seed", type=int, default=51, help="the server's seed")
    parser.add_argument("--cells", nargs="+", help=f"default {' '.join(DEFAULT_CELLS)} (CLASSIC: "
                        f"{' '.join(CLASSIC_CELLS)})")
    parser.add_argument("--params", choices=("current", "classic"), default="current")
    parser.add_argument("--policies", nargs="+", choices=POLICIES, default=list(POLICIES))
    parser.add_argument("--log-dir", type=Path, help="keep the logs here, as DIR/SERVER_KEEPERS_TAKERS/POLICY")
    parser.add_argument("--logs", type=Path, metavar="DIR", help="measure the logs an earlier --log-dir kept")
    parser.add_argument("--speed-seconds", type=float, default=12.0, help="measured seconds per speed run")
    parser.add_argument("--speed-repeats", type=int, default=3, help="speed runs per server (0: none)")
    args = parser.parse_args()
    try:
        cells = [cell_of(c, args.params) for c in args.cells or (CLASSIC_CELLS if args.params == "classic"
                                                                 else DEFAULT_CELLS)]
    except (argparse.ArgumentTypeError, ValueError) as exc:
        parser.error(str(exc))
    if args.params == "classic" and not any(c.keepers == c.takers == "cpp" for c in cells):
        parser.error("CLASSIC cells are judged against a cell of C++ players: give one (ours,cpp,cpp)")
    stack = ReferenceStack(args.build)
    try:
        stack.check()
    except ValueError as exc:
        parser.error(str(exc))
    step_s = parameter_set(args.params).simulator_step_ms / 1000.0
    stored = load_reference(STORED)
    lines = ["| cell | keepers' Pass | episodes | hold time (s) | statistics within tolerance | beyond |",
             "|---|---|---:|---:|---:|---|"]
    classic = args.params == "classic"
    if classic:  # the C++ players' cell first: the others are judged against it
        cells.sort(key=lambda c: not c.keepers == c.takers == "cpp")
    references: dict[str, list[BehaviourStats]] = {}
    with tempfile.TemporaryDirectory(prefix="players-servers-") as scratch:
        root = args.logs or args.log_dir or Path(scratch)
        for cell in cells:
            for policy in args.policies:
                where = root / f"{cell.server}_{cell.keepers}_{cell.takers}{'_classic' if classic else ''}" / policy
                if args.logs is None:
                    where.mkdir(parents=True, exist_ok=True)
                    play_campaign(stack, cell, policy, args.episodes, args.seed, where)
                stats = logged(where, args.episodes, step_s)
                if classic and policy not in references:  # the reference: not judged against itself
                    references[policy] = [stats]
                    lines.append(row(cell, policy, stats, []))
                else:
                    reference = references[policy] if classic else [stored[c] for c in REFERENCE_CAMPAIGNS[policy]]
                    lines.append(row(cell, policy, stats, reference))
                print(lines[-1], file=sys.stderr)
    if classic:
        print(f"Against the C++ players on our server (the first rows), CLASSIC parameters; synchronous, 3v2 on "
              f"20 m, server seed {args.seed}\n")
    else:
        print(f"Against the {sum(map(len, REFERENCE_CAMPAIGNS.values()))} stored campaigns of the C++ players on "
              f"rcssserver; synchronous, CURRENT parameters, 3v2 on 20 m, server seed {args.seed}\n")
    print("\n".join(lines))
    if args.speed_repeats > 0:
        print()
        print("\n".join(speed_table(stack, "handcoded", args.speed_seconds, args.speed_repeats, SETTINGS[:2])))


if __name__ == "__main__":
    main()
