"""``keepaway run``: play N episodes of one configuration in the distributed, embedded or batched mode.

All three modes yield the same thing, a stream of ended episodes, which this module turns into a
progress bar, a summary table, the logs and a machine-readable summary:
``{"mode", "seed", "episodes": [...], "mean_hold_time_s", "stderr_hold_time_s", "cycles_per_s",
"episodes_per_s"}``. The distributed mode's arena runs on this machine, or wherever a caller's
``elsewhere`` plays it (``runner.ray_backend.ray_run``: on a Ray node).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Generator, Iterator
from dataclasses import dataclass, replace
from itertools import islice
from pathlib import Path

import zmq

from keepaway.agents.player import sarsa_config
from keepaway.agents.policy_file import unpack_pass_arrays
from keepaway.protocol import MONITOR_EPISODE_TOPIC
from keepaway.protocol import messages as m
from keepaway.protocol.messages import decode_monitor
from keepaway.protocol.params import ServerParams
from keepaway.protocol.security import open_keys, secure_client
from keepaway.runner.batched import CHUNK_CYCLES, BatchedArenas
from keepaway.runner.embedded import ArenaSpec, embedded_episodes
from keepaway.runner.job import GREEDY, LEARN, LEARNED, EpisodeTable, RunResult
from keepaway.runner.kernels import ensure_compiled, kernel_sets
from keepaway.runner.launch import VIEW_RE, ArenaFailure, ArenaProcesses, keepaway_argv
from keepaway.server.arena import REFEREE_EPISODE_MESSAGE
from keepaway.server.episode_log import KWY_SUFFIX, EpisodeRecord, JsonlLog, KwyLog, read_jsonl, set_aside
from keepaway.server.game_log import PLAY_ON, RCG_SUFFIX, RcgLog, WorldShows
from keepaway.server.world import World


@dataclass(frozen=True)
class RunOptions:
    spec: ArenaSpec
    episodes: int
    mode: str = "distributed"
    batch: int = 1024
    realtime: bool = False
    out: Path = Path("out")
    policy_path: Path | None = None
    parameter_set: str = "classic"
    keys: Path | None = None  # distributed: a keys directory, CURVE on every connection (protocol.security)
    game_log: bool = True  # distributed, embedded: write keepaway.rcg (server/game_log.py)
    game_log_arenas: tuple[int, ...] = ()  # batched: the arenas whose keepaway-arena<B>.rcg is written
    view: bool = False  # distributed: a `keepaway view` of the arena's monitor, for as long as the run
    getopen_notes: str = "none"  # distributed, embedded: the keepers' notes (protocol.messages.GETOPEN_NOTE_MODES)


LOG_NAME = "keepaway"  # the run's logs: keepaway.kwy, keepaway.jsonl, keepaway.rcg in --out
JSONL_SUFFIX = ".jsonl"


def arena_game_log(out: Path, arena: int) -> Path:
    """The game log of arena ``arena`` of a batched run."""
    return out / f"{LOG_NAME}-arena{arena}{RCG_SUFFIX}"


def run_logs(opts: RunOptions) -> list[Path]:
    """The logs a run writes in ``opts.out`` (besides its processes' logs under ``processes/``)."""
    logs = [opts.out / f"{LOG_NAME}{KWY_SUFFIX}", opts.out / f"{LOG_NAME}{JSONL_SUFFIX}"]
    if opts.mode == "batched":
        return logs + [arena_game_log(opts.out, b) for b in opts.game_log_arenas]
    return logs + [opts.out / f"{LOG_NAME}{RCG_SUFFIX}"] if opts.game_log else logs


def set_aside_earlier(opts: RunOptions) -> str | None:
    """Set aside an earlier run's logs of the names this run writes, as every log is
    (``server.episode_log.set_aside``), before anything starts; one line naming their new names, None if
    there were none."""
    moved = [(path.name, aside.name) for path in run_logs(opts) if (aside := set_aside(path)) is not None]
    if not moved:
        return None
    return f"an earlier run's logs in {opts.out} set aside: " + ", ".join(f"{a} -> {b}" for a, b in moved)


def written_logs(opts: RunOptions) -> str:
    """One line naming where a run's logs are."""
    names = [path.name for path in run_logs(opts) if path.exists()]
    processes = opts.out / "processes"
    line = f"logs in {opts.out}: {', '.join(names) if names else 'none'}"
    return line + (f" (the processes' logs in {processes})" if processes.is_dir() else "")


class ShortHanded:
    """Which players the episodes are being played without, as the episodes' ``missed`` say: one line
    when a player starts missing cycles (it did not answer in time, or the server gave it up as hung or
    gone) and one when it plays whole episodes again, instead of one per short-handed episode (the logs
    mark each one)."""

    def __init__(self) -> None:
        self.missing: set[str] = set()

    def update(self, record: EpisodeRecord) -> list[str]:
        """The lines ``record`` calls for, in order of player name."""
        missed = dict(record.missed)
        lines = [f"{name} missed {missed[name]} of the {record.duration} cycles of episode {record.episode} "
                 "(late, hung or gone: see the server's log; such episodes are marked 'missed' in "
                 "keepaway.jsonl)" for name in sorted(missed.keys() - self.missing)]
        lines += [f"{name} played the whole of episode {record.episode} again"
                  for name in sorted(self.missing - missed.keys())]
        self.missing = set(missed)
        return lines


@dataclass
class RateWindow:
    """What a run's rates are measured over: from the first episode's end to the last's, so that start-up
    and compilation are left out. The progress bar shows the rate the summary reports, from the same
    window."""

    first_at: float | None = None
    first_cycle: int = 0
    last_at: float = 0.0
    last_cycle: int = 0  # the most arena-cycles any ended episode came with
    episodes: int = 0  # the episodes that ended in the window (after the first one's cycles)

    def add(self, cycles: int, now: float) -> None:
        """An episode ended, with ``cycles`` arena-cycles played so far, at ``now``."""
        if self.first_at is None:
            self.first_at, self.first_cycle = now, cycles
        if cycles > self.last_cycle:
            self.last_at, self.last_cycle = now, cycles
        if cycles > self.first_cycle:
            self.episodes += 1

    @property
    def elapsed_s(self) -> float:
        """The window's wall time; 0 until episodes have ended at two different times."""
        return self.last_at - self.first_at if self.first_at is not None and self.last_at > self.first_at else 0.0


BAR_FORMAT = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}<{remaining}{postfix}]"  # the rate is in the postfix


# An ended episode as run() takes it: the record, the arena-cycles played so far, and when it was seen
# ended (time.perf_counter of the machine that played it: the rates need no clock shared with this one).
Ended = tuple[EpisodeRecord, int, float]
# Plays a distributed run's arena somewhere else (``runner.ray_backend.ray_run``): the options and a
# one-line announcer in, the ended episodes out; it raises ArenaFailure in one line if a process of the
# arena dies, and leaves the arena's logs in ``opts.out`` when it ends or is closed.
Elsewhere = Callable[["RunOptions", Callable[[str], None] | None], Iterator[Ended]]


# -- modes ------------------------------------------------------------------------------------------
def distributed_episodes(opts: RunOptions, processes: ArenaProcesses, viewer: ArenaProcesses | None = None,
                         announce: Callable[[str], None] | None = None) -> Iterator[tuple[EpisodeRecord, int]]:
    """Start server, coach and players as processes; yield episodes as the monitor port reports them.
    With ``viewer``, start a ``keepaway view`` of the arena there and ``announce`` its URL.

    Raises ArenaFailure naming the process if any of them dies before the run has finished (a clean
    exit once every episode is in the server's log is not a death, however slowly the rest stop).
    """
    spec = opts.spec
    server_args = ["--seed", str(spec.seed), "--keepers", str(spec.keepers), "--takers", str(spec.takers),
                   "--field-size", str(spec.params.keepaway_length), "--episodes", str(opts.episodes),
                   "--params", opts.parameter_set, "--log-dir", str(opts.out), "--kwy-name", LOG_NAME]
    if opts.realtime:
        server_args += ["--mode", "realtime"]
    if not opts.game_log:
        server_args += ["--no-game-log"]
    if opts.getopen_notes != "none":
        server_args += ["--getopen-notes", opts.getopen_notes]
    player_args = ["--seed", str(spec.seed), "--pass", spec.pass_policy, "--getopen", spec.getopen_policy]
    if opts.policy_path is not None:
        player_args += ["--policy", str(opts.policy_path)]
    endpoints = processes.start_arena(server_args, player_args, spec.keepers, spec.takers, keys=opts.keys)
    server = processes.member("server")
    if viewer is not None:
        keys = ["--keys", str(opts.keys)] if opts.keys is not None else []
        member = viewer.start("viewer", keepaway_argv("view", "--server", endpoints.monitor, "--port", "0",
                                                      "--field-size", str(spec.params.keepaway_length), *keys),
                              capture_stdout=True)
        url = viewer.announced(member, VIEW_RE, 60.0).group(1)
        if announce is not None:
            announce(f"watch the arena at {url}")

    def finished() -> bool:
        return len(logged_episodes(opts.out)) >= opts.episodes

    ctx = zmq.Context.instance()
    monitor = ctx.socket(zmq.SUB)
    monitor.setsockopt(zmq.LINGER, 0)
    monitor.setsockopt(zmq.SUBSCRIBE, MONITOR_EPISODE_TOPIC)
    secure_client(monitor, open_keys(opts.keys))
    monitor.connect(endpoints.monitor)
    try:
        yielded: set[int] = set()
        while server.proc.poll() is None:
            if monitor.poll(200):
                end = decode_monitor(*monitor.recv_multipart())
                assert isinstance(end, m.EpisodeEnd)
                yielded.add(end.episode)
                yield EpisodeRecord(end.episode, end.start_cycle, end.end_cycle, end.end,
                                    missed=end.missed), end.end_cycle
            dead = processes.first_death(finished)
            if dead is not None:
                raise ArenaFailure(dead.describe_exit())
        dead = processes.first_death(finished)
        if dead is not None:
            raise ArenaFailure(dead.describe_exit())
        # the server's log is the record; the monitor (PUB/SUB) only drives the progress bar and may
        # have missed events published before the subscription took effect
        records = logged_episodes(opts.out)
        if len(records) < opts.episodes:
            raise ArenaFailure(f"the server ended after {len(records)} of {opts.episodes} episodes "
                               f"({server.describe_exit()})")
        for record in records:
            if record.episode not in yielded:
                yield record, record.end_cycle
        unclean = processes.wait_all(timeout_s=60.0)
        if unclean:
            raise ArenaFailure("; ".join(mem.describe_exit() for mem in unclean))
    finally:
        monitor.close(linger=0)


def logged_episodes(out: Path) -> list[EpisodeRecord]:
    """The episodes in the server's JSON-lines log in ``out`` so far (none if it has no log yet)."""
    try:
        return read_jsonl(out / f"{LOG_NAME}{JSONL_SUFFIX}")[1]
    except (OSError, ValueError):
        return []


def batched_episodes(opts: RunOptions) -> Iterator[tuple[EpisodeRecord, int]]:
    """Step ``opts.batch`` arenas in one process; yield episodes in the order they end, numbered from 1,
    each chunk's as soon as it is played, with the arena-cycles simulated so far (the first chunk's
    include the kernels' compilation, so rates are measured from its end)."""
    spec = opts.spec
    theta = spec.policy.getopen_net if spec.policy is not None else None
    # learned Pass from a policy file plays its weights greedily, as the players of the other modes do
    # (agents.player.sarsa_pass_factory), with the tile coding they were learned with
    loaded = spec.pass_policy == LEARNED and spec.policy is not None and bool(spec.policy.pass_arrays)
    arenas = BatchedArenas(spec.params, opts.batch, spec.seed, keepers=spec.keepers, takers=spec.takers,
                           pass_policy=spec.pass_policy, getopen_policy=spec.getopen_policy,
                           getopen_theta=theta, sarsa=sarsa_config(spec.policy) if loaded else None,
                           pass_mode=GREEDY if loaded else LEARN)
    if loaded:
        arenas.load_pass_arrays(unpack_pass_arrays(spec.policy.pass_arrays, spec.keepers))
    logs = BatchedGameLogs(arenas.world, spec.params, opts.out, opts.game_log_arenas)
    ended = cycles = 0
    try:
        # the logs need every cycle of their arenas: chunks of one cycle (slower, the same games)
        for chunk in arenas.chunks(total_episodes=opts.episodes, cycles_per_chunk=1 if logs.logs else CHUNK_CYCLES):
            cycles += chunk.cycles
            logs.step(chunk)
            for record in chunk.records(spec.params.simulator_step_ms):
                ended += 1
                yield replace(record, episode=ended), cycles
    finally:
        logs.close()


class BatchedGameLogs:
    """The game logs of chosen arenas of a batched run (``<out>/keepaway-arena<B>.rcg``), as the server
    writes its own: the kick-off, then a show after every cycle, the referee's episode message before
    the show of an episode's end (``server.game_log``). The arenas are at their kick-off when this opens."""

    def __init__(self, world: World, params: ServerParams, out: Path, arenas: tuple[int, ...]) -> None:
        self.world = world
        self.shows = WorldShows(world, params.visible_angle)
        self.logs = {b: RcgLog(arena_game_log(out, b), params) for b in arenas}
        for b, log in self.logs.items():
            log.start_game(self.shows.table(b), (PLAY_ON,))

    def step(self, chunk: EpisodeTable) -> None:
        """After a chunk of one cycle: the show of every logged arena that played it."""
        ended = set(chunk.arena.tolist())
        for b, log in self.logs.items():
            if self.world.time[b] > log.last_cycle:
                log.cycle(self.shows.table(b), (REFEREE_EPISODE_MESSAGE,) if b in ended else ())

    def close(self) -> None:
        for log in self.logs.values():
            log.close()


def timed(stream: Generator[tuple[EpisodeRecord, int], None, None]) -> Iterator[Ended]:
    """``stream``'s episodes with the time each came here (closing this closes ``stream``)."""
    try:
        for record, cycles in stream:
            yield record, cycles, time.perf_counter()
    finally:
        stream.close()


class RunStopped(Exception):
    """A run that stopped before its last episode: a process died (``cause`` is the ArenaFailure) or it
    was interrupted (KeyboardInterrupt). ``result`` holds the episodes that did finish."""

    def __init__(self, result: RunResult, cause: BaseException) -> None:
        super().__init__(str(cause))
        self.result = result
        self.cause = cause


def run(opts: RunOptions, progress: bool = True, announce: Callable[[str], None] | None = None,
        elsewhere: Elsewhere | None = None) -> RunResult:
    """Play ``opts.episodes`` episodes in ``opts.mode``; write the logs; return the result. With
    ``elsewhere`` (distributed mode only), the arena is played where it places it, which also compiles
    the kernels there and brings the logs back into ``opts.out``.

    The kernels are compiled first, once (``announce`` is told so in one line). Raises RunStopped, with
    the result of the episodes that finished, if a process dies or the run is interrupted.
    """
    from tqdm import tqdm

    def said(line: str) -> None:  # ``announce``, a line above the progress bar, not through it
        if announce is not None:
            with tqdm.external_write_mode():
                announce(line)

    if elsewhere is not None and opts.mode != "distributed":
        raise ValueError(f"only the distributed mode's arena can be played elsewhere, not the {opts.mode} mode's")
    spec = opts.spec
    opts.out.mkdir(parents=True, exist_ok=True)
    aside = set_aside_earlier(opts)
    if aside is not None:
        said(aside)
    if elsewhere is None:
        ensure_compiled(kernel_sets(opts.mode), announce, log_dir=opts.out / "processes")
    records: list[EpisodeRecord] = []
    window = RateWindow()  # over the stream's cycle counts (all arenas' in batched mode) and times
    held_s = 0.0  # the records' hold times, summed as they come (the bar's running mean)
    bar = tqdm(total=opts.episodes, unit="ep", disable=not progress, dynamic_ncols=True, bar_format=BAR_FORMAT)
    short_handed = ShortHanded()
    start = time.perf_counter()
    processes = (ArenaProcesses(opts.out / "processes", batch_scheduled=not opts.realtime)
                 if opts.mode == "distributed" and elsewhere is None else None)
    viewer = ArenaProcesses(opts.out / "processes") if opts.view else None  # not one of the arena's
    stopped: BaseException | None = None
    stream: Iterator[Ended] | None = None
    try:
        if elsewhere is not None:
            stream = elsewhere(opts, said)
        elif opts.mode == "distributed":
            assert processes is not None
            processes.__enter__()
            stream = timed(distributed_episodes(opts, processes, viewer, said))
        elif opts.mode == "embedded":
            stream = timed(embedded_episodes(spec, opts.out / f"{LOG_NAME}{RCG_SUFFIX}" if opts.game_log else None,
                                             opts.getopen_notes))
        else:
            stream = timed(batched_episodes(opts))
        # the distributed stream ends by itself (and then checks every process's exit); the others
        # are cut at the wanted number of episodes
        for record, cycles, now in stream if opts.mode == "distributed" else islice(stream, opts.episodes):
            records.append(record)
            window.add(cycles, now)
            held_s += record.hold_time_s
            for line in short_handed.update(record):
                said(line)
            rate = f"{window.episodes / window.elapsed_s:,.2f} ep/s, " if window.elapsed_s > 0 else ""
            bar.set_postfix_str(f"{rate}mean hold {held_s / len(records):.2f} s", refresh=False)
            bar.update(1)
    except (ArenaFailure, KeyboardInterrupt) as exc:
        stopped = exc
    finally:
        bar.close()
        if stream is not None:
            stream.close()  # closes the game logs of the in-process modes; brings an arena's from elsewhere
        for group in (processes, viewer):
            if group is not None:
                group.stop()
    if opts.mode == "distributed":
        # the server's log is the record (flushed per episode, also when the server was killed)
        records = logged_episodes(opts.out) or records
    records.sort(key=lambda r: r.episode)
    if len(records) > 1 and window.elapsed_s > 0:
        elapsed, cycles, n_rate = window.elapsed_s, window.last_cycle - window.first_cycle, window.episodes
    else:
        elapsed, cycles, n_rate = time.perf_counter() - start, window.last_cycle, len(records)
    if opts.mode != "distributed":  # the distributed server writes its own logs
        _write_logs(opts, records)
    result = RunResult(opts.mode, spec.seed, records, elapsed, cycles, n_rate)
    said(written_logs(opts))
    if stopped is not None:
        raise RunStopped(result, stopped)
    return result


def _write_logs(opts: RunOptions, records: list[EpisodeRecord]) -> None:
    spec = opts.spec
    p = spec.params
    config = {"mode": opts.mode, "keepers": spec.keepers, "takers": spec.takers, "pass": spec.pass_policy,
              "getopen": spec.getopen_policy, "episodes": opts.episodes, "batch": opts.batch}
    with KwyLog(opts.out, spec.keepers, spec.takers, p.keepaway_length, p.keepaway_width,
                fixed_name=LOG_NAME) as kwy:
        jsonl = JsonlLog(opts.out / f"{LOG_NAME}{JSONL_SUFFIX}", seed=spec.seed, config=config, params=p.to_dict())
        for record in records:
            kwy.write(record)
            jsonl.write(record)
        jsonl.close()


__all__ = ["Elsewhere", "Ended", "RateWindow", "RunOptions", "RunStopped", "ShortHanded", "distributed_episodes",
           "logged_episodes", "run", "timed"]
