"""SpinPolicy's rules as arithmetic: what a wait teaches, what shrinks a spin, the duty cap
and asyncio's timeout, with times given, not measured."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from simbridge.endpoint.speed.spin_policy import BURST, SHORTEST, SpinPolicy

LIMIT = 0.05
A, B = 3, 4  # two file descriptors: the sim's socket and a ROS node's


def taught(window: float = 0.02) -> SpinPolicy:
    """Busy after work on A, with a spin of `window` learned for the wait after it."""
    policy = SpinPolicy(LIMIT, 0.5, now=0.0)
    policy.found((A,))
    policy.waited(A, window / 2, answered=True)
    assert policy.window(A) == window
    return policy


def test_an_answer_within_the_limit_teaches_twice_its_wait() -> None:
    policy = SpinPolicy(LIMIT, 0.5, now=0.0)
    assert policy.spin_after() is None  # idle: nothing to spin for
    assert policy.found((A,)) is True
    assert policy.spin_after() == A
    assert policy.found((B,)) is True  # data on another socket: an answer
    policy.waited(A, 0.01, answered=True)
    assert policy.window(A) == 0.02


def test_a_longer_answer_within_the_limit_grows_the_spin_to_the_limit() -> None:
    policy = taught(0.02)
    policy.waited(A, 0.04, answered=True)
    assert policy.window(A) == LIMIT  # twice 0.04, cut to the limit


def test_a_wait_past_the_limit_turns_the_spin_off() -> None:
    policy = taught()
    policy.waited(A, LIMIT * 1.01, answered=True)
    assert policy.window(A) == 0
    assert policy.spin_length(A, now=1.0, timeout=None) == 0


def test_a_stream_teaches_nothing() -> None:
    policy = SpinPolicy(LIMIT, 0.5, now=0.0)
    policy.found((A,))
    assert policy.found((A,)) is False  # the same socket again
    policy.waited(A, 0.001, answered=False)
    assert policy.window(A) == 0


def test_room_to_write_is_no_answer_and_keeps_the_last_reads() -> None:
    policy = SpinPolicy(LIMIT, 0.5, now=0.0)
    policy.found((A,))
    assert policy.found(()) is False
    assert policy.spin_after() == A


def test_events_on_several_sockets_leave_nothing_to_spin_for() -> None:
    policy = SpinPolicy(LIMIT, 0.5, now=0.0)
    assert policy.found((A, B)) is True
    assert policy.spin_after() is None


def test_idle_ends_the_busy_spell() -> None:
    policy = taught()
    policy.idle()
    assert policy.spin_after() is None


def test_a_spin_of_the_whole_window_that_finds_nothing_is_a_miss_and_halves_it() -> None:
    policy = taught(0.02)
    length = policy.spin_length(A, now=1.0, timeout=None)
    assert length == 0.02  # a second of quiet refilled the allowance up to BURST
    assert policy.spun(A, length, spent=length, answered=None) is True
    assert policy.window(A) == 0.01


def test_a_spin_that_finds_the_same_socket_again_halves_it() -> None:
    policy = taught(0.02)
    assert policy.spun(A, 0.02, spent=0.001, answered=False) is False
    assert policy.window(A) == 0.01


def test_a_spin_that_finds_an_answer_keeps_it() -> None:
    policy = taught(0.02)
    assert policy.spun(A, 0.02, spent=0.001, answered=True) is False
    assert policy.window(A) == 0.02


def test_a_spin_halved_below_the_shortest_is_off() -> None:
    policy = taught(SHORTEST * 1.5)
    policy.spun(A, SHORTEST * 1.5, spent=SHORTEST * 1.5, answered=None)
    assert policy.window(A) == 0


def test_a_spin_cut_to_asyncio_timeout_is_no_miss() -> None:
    policy = taught(0.02)
    length = policy.spin_length(A, now=1.0, timeout=0.002)
    assert length == 0.002
    assert policy.spun(A, length, spent=length, answered=None) is False
    assert policy.window(A) == 0.02


def test_forget_drops_what_was_learned() -> None:
    policy = taught()
    policy.forget(A)
    assert policy.window(A) == 0


@pytest.mark.parametrize("duty", [0.1, 0.5, 1.0])
@given(gaps=st.lists(st.floats(0, 0.1, allow_nan=False), min_size=1, max_size=50))
def test_spinning_never_takes_more_than_its_duty_share_plus_the_burst(
    duty: float, gaps: list[float]
) -> None:
    """Spins back to back, each spending all it was given, `gap` s apart: their total stays
    within duty x elapsed + BURST (the allowance saved up at the start)."""
    policy = SpinPolicy(LIMIT, duty, now=0.0)
    policy.found((A,))
    policy.waited(A, LIMIT / 2, answered=True)  # a window of the whole limit
    now = spent = 0.0
    for gap in gaps:
        now += gap
        length = policy.spin_length(A, now=now, timeout=None)
        assert length >= 0
        policy.spun(A, length, spent=length, answered=True)
        spent += length
        now += length
    assert spent <= duty * now + BURST + 1e-9
