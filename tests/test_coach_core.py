"""The coach's logic without sockets (coach/core.py): decoded messages and a fake clock in, the messages to
send out. Every timeout is driven by the clock the test gives, so none of these tests waits."""

from __future__ import annotations

import numpy as np
import pytest

from keepaway.coach.core import HEARTBEAT_S, LOOK_INTERVAL_S, REPORT_TIMEOUT_S, SERVER, CoachCore
from keepaway.protocol import PROTOCOL_VERSION, ProtocolError, parameter_set
from keepaway.protocol import messages as m
from keepaway.protocol.advice import (
    PassSnapshotReport,
    PassTransitionsReport,
    PolicyAdvice,
    ReportRequest,
    SeedAdvice,
    decode_advice,
)
from keepaway.protocol.arena import EpisodesDone, RunEpisodes, StopArena
from keepaway.protocol.landmarks import to_wire as landmarks_to_wire

TRAINER = b"trainer-1"
OTHER = b"trainer-2"
STANDING = m.LookOk(cycle=7, paused=True, state={"ball": [0.0] * 4, "players": [], "play_mode": "play_on",
                                                  "episode": 1, "episode_start": 0, "take_count": 0})


def init_ok(cycle: int = 0, max_bytes: int = 1 << 20) -> m.CoachInitOk:
    return m.CoachInitOk(cycle=cycle, version=PROTOCOL_VERSION, params=parameter_set("classic").to_dict(),
                         landmarks=landmarks_to_wire(), play_mode="play_on",
                         config={"keepers": 3, "takers": 2, "max_message_bytes": max_bytes})


def joined_core(**kw) -> CoachCore:
    core = CoachCore(serves_arena=True, **kw)
    core.joined(init_ok())
    return core


def episode(n: int, start: int = 0, end: int = 10) -> m.EpisodeEnd:
    return m.EpisodeEnd(cycle=end, episode=n, start_cycle=start, end_cycle=end, end="taken")


def to_server(out) -> list:
    assert all(dest == SERVER for dest, _ in out), out
    return [msg for _, msg in out]


def control(out) -> list[str]:
    return [msg.action for msg in to_server(out) if isinstance(msg, m.EpisodeControl)]


def snapshot() -> PassSnapshotReport:
    """The snapshot of a keeper without a Sarsa learner."""
    return PassSnapshotReport(learner=False, episode=1, chunk=0, chunks=1, first=0, count=0)


def report(unum: int, payload) -> m.PlayerReport:
    return m.PlayerReport(cycle=20, side="l", unum=unum, payload=payload.to_wire())


def standing_run(core: CoachCore, now: float = 0.0, **request) -> list:
    """A request accepted and begun on a server that stands still at once; the messages of step 1."""
    first = core.from_trainer(TRAINER, RunEpisodes(**request), now)
    assert control(first) == ["pause"] and isinstance(to_server(first)[-1], m.Look)
    assert core.from_server(STANDING, now) == []
    return to_server(core.tick(now))


def test_a_run_pauses_delivers_advice_and_seed_restarts_and_answers_with_the_reports():
    core = joined_core()
    advice = PolicyAdvice(getopen_theta=np.full(91, 0.5), pass_policy="learned")
    begun = standing_run(core, episodes=2, seed=9, advice=(("keepers", advice),), reports=("snapshot",))
    assert [type(msg) for msg in begun] == [m.Advice, m.Advice, m.EpisodeControl, m.EpisodeControl,
                                            m.EpisodeControl]
    assert begun[0].target == "keepers" and decode_advice(begun[0].payload) == advice
    assert begun[1].target == "all" and decode_advice(begun[1].payload) == SeedAdvice(seed=9)
    assert [(c.action, c.episodes_left, c.seed) for c in begun[2:]] == [
        ("reset", None, 9), ("pause", 2, None), ("resume", None, None)]
    assert core.from_server(episode(1, 7, 30), 1.0) == []
    asked = to_server(core.from_server(episode(2, 30, 52), 2.0))
    assert [(a.target, decode_advice(a.payload)) for a in asked] == [("keepers", ReportRequest(what="snapshot"))]
    for unum in (1, 2):
        core.from_server(report(unum, snapshot()), 2.5)
    assert core.tick(2.5) == [(SERVER, m.Look())]  # the heartbeat: keeper 3 has not reported yet
    core.from_server(m.PlayerReport(cycle=52, side="r", unum=1, payload=snapshot().to_wire()), 2.6)  # a taker's
    assert core.tick(2.6) == []
    core.from_server(report(3, snapshot()), 2.7)
    ((dest, done),) = core.tick(2.7)
    assert dest == TRAINER and isinstance(done, EpisodesDone)
    assert [list(e) for e in done.episodes] == [[1, 7, 30, "taken"], [2, 30, 52, "taken"]]
    assert [(side, unum, r) for side, unum, r in done.reports][:2] == [("l", 1, snapshot()), ("l", 2, snapshot())]
    assert len(done.reports) == 4 and core.pending is None and core.deadline() is None
    assert core.episodes == [(1, 7, 30, "taken"), (2, 30, 52, "taken")]


def test_the_coach_looks_every_look_interval_until_the_server_stands_still():
    core = joined_core()
    out = core.from_trainer(TRAINER, RunEpisodes(episodes=1), 10.0)
    assert control(out) == ["pause"] and core.deadline() == pytest.approx(10.0 + LOOK_INTERVAL_S)
    assert core.tick(10.0 + LOOK_INTERVAL_S / 2) == []
    assert to_server(core.tick(10.0 + LOOK_INTERVAL_S)) == [m.Look()]  # the pause is sent once
    core.from_server(m.LookOk(cycle=8, paused=False, state=STANDING.state), 10.15)
    assert core.tick(10.15) == [] and core.pending.begun is False
    core.from_server(STANDING, 10.2)
    assert control(core.tick(10.2)) == ["reset", "pause", "resume"]
    assert core.deadline() == pytest.approx(10.0 + LOOK_INTERVAL_S + HEARTBEAT_S)  # a heartbeat after the last look


def test_a_keeper_that_never_reports_times_the_run_out_after_report_timeout():
    core = joined_core()
    standing_run(core, episodes=1, reports=("transitions", "snapshot"))
    core.from_server(episode(1), 100.0)
    for unum in (1, 2, 3):
        core.from_server(report(unum, snapshot()), 100.5)
    empty = PassTransitionsReport(learner=False, episode=1, chunk=0, chunks=1, first=0, count=0)
    for unum in (1, 3):
        core.from_server(report(unum, empty), 100.5)
    assert to_server(core.tick(100.5)) == [m.Look()]
    assert core.deadline() == pytest.approx(100.5 + HEARTBEAT_S)  # the heartbeat comes first
    while core.deadline() < 100.0 + REPORT_TIMEOUT_S:
        assert to_server(core.tick(core.deadline())) == [m.Look()]
    assert core.deadline() == pytest.approx(100.0 + REPORT_TIMEOUT_S)  # 159.5 + 1 s is later
    ((dest, error),) = [item for item in core.tick(core.deadline()) if item[0] != SERVER]
    assert dest == TRAINER and error.code == "reports_missing"
    assert error.message == f"after {REPORT_TIMEOUT_S:g} s still missing: keeper 2's transitions"
    assert core.pending is None


def test_reports_count_only_when_every_chunk_of_every_keeper_is_in():
    core = joined_core()
    standing_run(core, episodes=1, reports=("snapshot",))
    core.from_server(episode(1), 5.0)
    def chunk(i: int) -> PassSnapshotReport:
        return PassSnapshotReport(learner=True, episode=1, chunk=i, chunks=2, first=0, count=0,
                                  config={"table_size": 16}, table_size=16, hash_counts=np.zeros(3),
                                  index=np.zeros(0), check=np.zeros(0), value=np.zeros(0))

    for unum in (1, 2, 3):
        core.from_server(report(unum, chunk(0)), 5.0)
        core.from_server(report(unum, chunk(0)), 5.0)  # the same chunk twice counts once
    assert all(dest == SERVER for dest, _ in core.tick(5.0))
    for unum in (1, 2, 3):
        core.from_server(report(unum, chunk(1)), 5.1)
    ((dest, done),) = [item for item in core.tick(5.1) if item[0] != SERVER]
    assert isinstance(done, EpisodesDone) and len(done.reports) == 9


def test_a_report_that_is_not_one_is_logged_and_dropped(caplog):
    core = joined_core()
    standing_run(core, episodes=1, reports=("snapshot",))
    core.from_server(episode(1), 5.0)
    core.from_server(m.PlayerReport(cycle=9, side="l", unum=1, payload={"kind": "pass_snapshot", "chunk": 0}), 5.0)
    assert core.pending.reports == [] and "dropped a report of l 1: missing_field" in caplog.text


def test_busy_bad_and_oversized_requests_are_answered_at_once():
    core = joined_core()
    huge = PolicyAdvice(getopen_theta=np.zeros(1 << 17))  # a hear of just over 1 MiB, the server's limit here
    ((dest, error),) = core.from_trainer(TRAINER, RunEpisodes(episodes=1, advice=(("keepers", huge),)), 0.0)
    assert (dest, error.code) == (TRAINER, "too_large") and "1048576" in error.message
    assert core.pending is None
    ((dest, error),) = core.from_trainer(OTHER, ProtocolError("malformed", "not a msgpack value"), 0.0)
    assert (dest, error.code, error.message) == (OTHER, "malformed", "not a msgpack value")
    core.from_trainer(TRAINER, RunEpisodes(episodes=1), 0.0)
    ((dest, error),) = core.from_trainer(OTHER, RunEpisodes(episodes=1), 0.0)
    assert (dest, error.code) == (OTHER, "busy")


def test_an_idle_arena_is_paused_as_soon_as_the_coach_joins():
    assert control(CoachCore(serves_arena=True, idle=True).joined(init_ok())) == ["pause"]
    assert CoachCore(serves_arena=True).joined(init_ok()) == []
    assert CoachCore(idle=True).joined(init_ok()) == []  # no arena endpoint: nothing to wait for


def test_a_session_lost_before_the_run_begins_starts_it_over():
    core = joined_core()
    core.from_trainer(TRAINER, RunEpisodes(episodes=1), 0.0)
    lost = m.Error(cycle=0, code="not_initialised", message="send init first")
    (hello,) = to_server(core.from_server(lost, 0.1))
    assert isinstance(hello, m.CoachInit) and core.from_server(lost, 0.1) == []  # asked once until answered
    assert core.from_server(init_ok(cycle=3), 0.2) == []
    out = core.tick(0.3)
    assert control(out) == ["pause"]  # step 1 again


def test_a_session_lost_while_the_run_is_under_way_is_reported_and_a_stop_is_sent_again():
    core = joined_core()
    standing_run(core, episodes=3)
    core.from_server(m.Error(cycle=0, code="not_initialised", message="send init first"), 1.0)
    ((dest, lost),) = core.from_server(init_ok(cycle=40), 1.1)
    assert (dest, lost.code, lost.cycle) == (TRAINER, "session_lost", 40) and core.pending is None
    assert control(core.from_trainer(TRAINER, StopArena(), 2.0)) == ["stop"]
    core.from_server(m.Error(cycle=0, code="not_initialised", message="send init first"), 2.1)
    assert control(core.from_server(init_ok(cycle=41), 2.2)) == ["stop"]


def test_stop_after_and_shutdown_and_a_stopped_coach_answering_its_pending_run():
    core = CoachCore(stop_after=2)
    core.joined(init_ok())
    assert core.from_server(episode(1), 0.0) == []
    assert control(core.from_server(episode(2), 0.0)) == ["stop"]
    core.from_server(m.Shutdown(cycle=30, reason="done"), 0.0)
    assert core.stop_reason == "server shut down: done"
    serving = joined_core()
    serving.from_trainer(TRAINER, RunEpisodes(episodes=5), 0.0)
    serving.stop_reason = "received SIGTERM"
    ((dest, stopped),) = serving.stop()
    assert (dest, stopped.code, stopped.message) == (TRAINER, "arena_stopped", "received SIGTERM")
    assert serving.stop() == []


def test_episodes_beyond_the_run_and_between_runs_only_go_to_the_record():
    core = joined_core()
    assert core.from_server(episode(1), 0.0) == [] and core.deadline() is None
    standing_run(core, episodes=1)
    core.from_server(episode(2), 1.0)
    ((dest, done),) = [item for item in core.tick(1.0) if item[0] != SERVER]
    assert [e[0] for e in done.episodes] == [2]
    assert [e[0] for e in core.episodes] == [1, 2]
