"""SIGINT and SIGTERM as exceptions, so that a run stops cleanly (temporary files removed,
a message that says what was written) and exits with 128 + the signal number."""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

__all__ = ["Interrupted", "catch_signals", "held_signals", "reraise_caught", "SIGNALS"]

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal (SIGINT or SIGTERM).

    Attributes
    ----------
    signum : int
        The signal number.
    name : str
        ``"SIGINT"`` or ``"SIGTERM"``.
    exit_code : int
        128 + ``signum`` (130 for SIGINT, 143 for SIGTERM).
    """

    def __init__(self, signum: int = signal.SIGINT):
        self.signum = int(signum)
        self.name = signal.Signals(self.signum).name
        self.exit_code = 128 + self.signum
        super().__init__(self.name)


#: the signals raised as :class:`Interrupted` since :func:`catch_signals` began
_caught: list[int] = []


def _raise(signum, frame):
    _caught.append(signum)
    raise Interrupted(signum)


def reraise_caught(error: BaseException) -> None:
    """Raise :class:`Interrupted` (from ``error``) when a signal was raised as one since
    :func:`catch_signals` began: ``error`` is then its consequence (code that caught the
    interrupt and failed on with an exception of its own, as a plotting library may), and
    the run was interrupted, not failed.  Nothing otherwise."""
    if _caught:
        raise Interrupted(_caught[0]) from error


@contextmanager
def catch_signals(restore: bool = True):
    """Inside, SIGINT and SIGTERM raise :class:`Interrupted` (in the main thread only);
    on exit the previous handlers are restored, or (``restore=False``, for a process that
    is about to end) the signals are ignored, so that a signal arriving after the run's
    outcome is decided cannot change its exit status."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _caught.clear()
    old = {s: signal.signal(s, _raise) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, (signal.SIG_DFL if h is None else h) if restore else signal.SIG_IGN)


@contextmanager
def held_signals():
    """Hold SIGINT and SIGTERM inside (a critical section such as swapping an output
    folder in): a signal that arrives meanwhile is recorded and raised again on exit,
    where the handler in force before (ours, Python's default or SIG_DFL) acts on it.

    Python runs signal handlers in the main thread whichever thread the signal hit, so
    the hold is a recording handler rather than a thread's signal mask; in other threads
    it does nothing."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending: list[int] = []

    def record(signum, frame):
        pending.append(signum)
    old = {s: signal.signal(s, record) for s in SIGNALS}
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, signal.SIG_DFL if h is None else h)
        if pending:
            signal.raise_signal(pending[0])
