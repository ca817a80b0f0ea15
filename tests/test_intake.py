"""Per-peer budgets of the server's input (server/intake.py), without sockets."""

from __future__ import annotations

from keepaway.server.intake import BACKLOG, Intake


def frames(n: int) -> list[bytes]:
    return [b"id", str(n).encode()]


def test_an_unseated_peer_beyond_its_budget_is_dropped_and_counted_without_holding_back_others():
    intake = Intake(seated=3, unseated=1)
    admitted = [intake.admit(b"flood", False, frames(i)) for i in range(10)]
    assert admitted == [True] + [False] * 9
    assert all(intake.admit(b"keeper", True, frames(i)) for i in range(3))  # not held back by the flood
    assert intake.close_window(seated=False) == {b"flood": 9}
    assert intake.close_window(seated=False) == {}


def test_a_seated_peer_beyond_its_budget_waits_in_order_for_the_next_windows():
    intake = Intake(seated=2, unseated=1)
    served = [n for n in range(7) if intake.admit(b"keeper", True, frames(n))]
    assert served == [0, 1] and intake.spent(b"keeper")  # a synchronous server does not wait for it
    assert intake.due() == []  # nothing more in this window
    assert intake.close_window(seated=True) == {}  # nothing dropped: it all waits
    assert not intake.admit(b"keeper", True, frames(7))  # behind what waits, even within the budget
    assert intake.due() == [frames(2), frames(3)]
    intake.close_window(seated=True)
    assert intake.due() == [frames(4), frames(5)]
    intake.close_window(seated=True)
    assert intake.due() == [frames(6), frames(7)]
    intake.close_window(seated=True)
    assert not intake.spent(b"keeper") and intake.admit(b"keeper", True, frames(8))  # served at once again


def test_a_seated_peer_that_floods_fills_its_backlog_and_the_rest_is_dropped_and_counted():
    intake = Intake(seated=2, unseated=1)
    served = sum(intake.admit(b"flood", True, frames(n)) for n in range(2 + BACKLOG + 10))
    assert served == 2
    assert intake.close_window(seated=True) == {b"flood": 10}
    assert len(intake.due()) == 2  # the oldest waiting ones, in order
    assert intake.close_window(seated=True) == {}


def test_the_seated_and_unseated_windows_end_separately():
    intake = Intake(seated=2, unseated=2)
    for n in range(3):
        intake.admit(b"u", False, frames(n))
    assert intake.close_window(seated=True) == {}  # a cycle ends: the unseated window goes on
    assert not intake.admit(b"u", False, frames(3))
    assert intake.close_window(seated=False) == {b"u": 2}
    assert intake.admit(b"u", False, frames(4))


def test_without_a_seated_budget_nothing_of_a_seated_peer_waits():
    intake = Intake(seated=None, unseated=1)  # the coach port: the coach is trusted
    assert all(intake.admit(b"coach", True, frames(n)) for n in range(10_000))
    assert not intake.spent(b"coach") and intake.due() == []
    assert intake.close_window(seated=True) == {}
