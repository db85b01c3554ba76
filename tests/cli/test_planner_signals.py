"""`simbridge planner`'s signal handling: a SIGINT or SIGTERM that Python handles while the
main thread is inside `stop.wait()`, holding the event's lock, still stops the planner.

The check runs in a child process: were the handler to set the event itself, it would wait
for that lock forever, and only a process can be given up on."""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap

import pytest

CHECK = textwrap.dedent(
    """
    import signal, sys
    from simbridge.cli.planner import _stop_on_signals

    sig = signal.Signals[sys.argv[1]]
    with _stop_on_signals() as stop:
        handler = signal.getsignal(sig)
        with stop._cond:  # where Event.wait holds it when a handler runs between bytecodes
            handler(sig, None)
        print("stopped" if stop.wait(10) else "not stopped")
    print("restored" if signal.getsignal(sig) is not handler else "not restored")
    """
)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_handled_inside_stop_wait_sets_stop(sig: signal.Signals) -> None:
    try:
        done = subprocess.run(
            [sys.executable, "-c", CHECK, sig.name],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{sig.name} handled inside stop.wait() deadlocked the planner's main thread")
    assert done.stdout.split() == ["stopped", "restored"], done.stderr
