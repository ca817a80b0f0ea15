"""Hold times of our players on rcssserver 19 (``keepaway player --rcss``), per keepers' Pass policy.

Plays ``--episodes`` episodes (default 200) per Pass policy (always hold, random, hand-coded; ``--policies``
for some) on the reference stack's rcssserver with the settings of ``benchmarks/reference_stack.py``
(keepaway.sh's, synchronous, CURRENT parameters, 3v2 on 20 m, hand-coded GetOpen and takers), our players
in the teams ``--ours`` names (both by default; the others are keepaway-0.6's), asking for protocol
``--version``. Prints per policy the number of episodes, the mean hold time ± its standard error and the
standard deviation, and what tells a player that falls behind or misreads: the cycles played per second,
the cycles rcssserver waited for a player in vain ("Someone missed a cycle", the shutdown's own one not
counted: ``reference_stack.stop_server_idle``), the lines our players logged at WARNING or above (a
skipped message, a refused command) and the share of each of our players' sees that came after the
``(think)`` of their cycle (``agents/rcss_client.py``, "Late sees"). Logs in ``--log-dir`` (default a
temporary directory).

    python benchmarks/rcss_players.py BUILD [--episodes 200] [--seed 7] [--policies hold,random,handcoded]
                                      [--ours keepers,takers] [--version 15] [--log-dir DIR]
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # the repository, before benchmarks/

from benchmarks.reference_stack import LOG_NAME, Cell, ReferenceStack, play_campaign  # noqa: E402
from keepaway.agents.rcss_client import DEFAULT_VERSION  # noqa: E402
from keepaway.runner.launch import interrupt_on_sigterm  # noqa: E402
from keepaway.server.episode_log import read_kwy  # noqa: E402

POLICIES = ("hold", "random", "handcoded")
TEAMS = ("keepers", "takers")
MISSED = "Someone missed a cycle"  # rcssserver's line for a cycle a player did not answer in time (stadium.cpp)
LOGGED = (" WARNING ", " ERROR ", "Traceback")
LATE_SEES = re.compile(r"(\d+) of its (\d+) sees came after")  # agents/rcss_client.py, "Late sees"


def measure(stack: ReferenceStack, policy: str, episodes: int, seed: int, ours: tuple[str, ...], version: int,
            log_dir: Path) -> str:
    """One campaign, as one line of figures (module docstring)."""
    started = time.monotonic()
    cell = Cell("rcssserver", *("ours" if team in ours else "cpp" for team in TEAMS))
    members = play_campaign(stack, cell, policy, episodes, seed, log_dir, version=version)
    elapsed = time.monotonic() - started
    kwy = read_kwy(log_dir / f"{LOG_NAME}.kwy")
    hold = [record.duration / 10 for record in kwy[:episodes]]
    mean = sum(hold) / len(hold)
    sd = math.sqrt(sum((h - mean) ** 2 for h in hold) / (len(hold) - 1))
    cycles = kwy[-1].end_cycle
    missed = (log_dir / "server.log").read_text(errors="replace").count(MISSED) - 1
    logs = {member.name: (log_dir / f"{member.name.replace(' ', '_')}.log").read_text() for member in members
            if member.name.split()[0] + "s" in ours}
    logged = sum(any(word in line for word in LOGGED) for log in logs.values() for line in log.splitlines())
    late = [f"{name} {100 * int(found[1]) / max(int(found[2]), 1):.0f} %" for name, log in logs.items()
            if (found := LATE_SEES.search(log))]
    return (f"{policy}: {len(hold)} episodes, {mean:.2f} ± {sd / math.sqrt(len(hold)):.2f} s (sd {sd:.2f}); "
            f"{cycles} cycles in {elapsed:.0f} s ({cycles / elapsed:.0f} a second), {missed} missed, "
            f"{logged} player lines at WARNING or above; late sees: {', '.join(late) or 'none'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", type=Path, help="the prefix tools/build-reference-stack.sh built into")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--seed", type=int, default=7, help="rcssserver's random_seed and our players' --seed")
    parser.add_argument("--policies", default=",".join(POLICIES))
    parser.add_argument("--ours", default=",".join(TEAMS), help="the teams that are our players (the others C++)")
    parser.add_argument("--version", type=int, default=DEFAULT_VERSION, help="our players' --rcss-version")
    parser.add_argument("--log-dir", type=Path, default=None)
    args = parser.parse_args()
    ours = tuple(team for team in args.ours.split(",") if team)
    if not set(ours) <= set(TEAMS) or not set(args.policies.split(",")) <= set(POLICIES) or args.episodes < 2:
        parser.error(f"--ours takes {', '.join(TEAMS)}; --policies {', '.join(POLICIES)}; --episodes at least 2")
    stack = ReferenceStack(args.build)
    interrupt_on_sigterm()
    with tempfile.TemporaryDirectory() as scratch:
        log_root = args.log_dir or Path(scratch)
        print(f"rcssserver {stack.server}, ours: {', '.join(ours) or 'none'}, protocol version {args.version}, "
              f"seed {args.seed}", flush=True)
        for policy in args.policies.split(","):
            log_dir = log_root / policy
            log_dir.mkdir(parents=True, exist_ok=True)
            print(measure(stack, policy, args.episodes, args.seed, ours, args.version, log_dir), flush=True)


if __name__ == "__main__":
    main()
