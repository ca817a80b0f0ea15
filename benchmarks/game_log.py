"""What the game log (.rcg, server/game_log.py) costs ``keepaway run``: the formatting of one show (the
world's state to a show, the show to its text line), and the speed of whole runs with and without it
(``--no-game-log`` is the baseline), embedded and distributed, interleaved so that both see the same load.

Run: ``python benchmarks/game_log.py [--episodes N] [--repeats R]``. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from keepaway.protocol.params import parameter_set  # noqa: E402
from keepaway.runner.embedded import ArenaSpec, EmbeddedGame  # noqa: E402
from keepaway.runner.run import RunOptions, run  # noqa: E402
from keepaway.server.game_log import WorldShows, show_line  # noqa: E402


def formatting_us(cycles: int = 2000) -> tuple[float, float]:
    """Microseconds per show: building it from a playing arena's world, and writing its line."""
    game = EmbeddedGame(ArenaSpec(parameter_set("classic")))
    for _ in range(50):
        game.cycle()
    shows = WorldShows(game.arena.world, game.arena.params.visible_angle)
    start = time.perf_counter()
    for _ in range(cycles):
        show = shows.table(0)
    built = time.perf_counter()
    for _ in range(cycles):
        show_line(show)
    done = time.perf_counter()
    return (built - start) / cycles * 1e6, (done - built) / cycles * 1e6


def cycles_per_s(mode: str, episodes: int, game_log: bool) -> float:
    spec = ArenaSpec(parameter_set("classic"), seed=0)
    with tempfile.TemporaryDirectory() as out:
        return run(RunOptions(spec, episodes, mode, out=Path(out), game_log=game_log), progress=False).summary()[
            "cycles_per_s"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=3)
    opts = parser.parse_args()
    build, line = formatting_us()
    print(f"one show: {build:.0f} us from the world, {line:.0f} us to its line ({build + line:.0f} us a cycle)")
    for mode in ("embedded", "distributed"):
        rates: dict[bool, list[float]] = {False: [], True: []}
        for _ in range(opts.repeats):
            for game_log in (False, True):
                rates[game_log].append(cycles_per_s(mode, opts.episodes, game_log))
        off, on = (statistics.median(rates[k]) for k in (False, True))
        print(f"{mode:<12} --no-game-log (baseline) {off:7.0f} cycles/s   game log {on:7.0f} cycles/s "
              f"({on / off:.2f} of the baseline; medians of {opts.repeats})")


if __name__ == "__main__":
    main()
