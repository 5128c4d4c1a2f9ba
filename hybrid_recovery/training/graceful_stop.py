"""Stopping a training run on Ctrl-C or ``kill`` at the end of an iteration, saved.

A first SIGINT or SIGTERM asks the run to stop: the iteration under way finishes, its
checkpoint is written as a periodic one (``model_<it>.pt`` and ``latest.pt``) and the
run ends with :class:`TrainingStopped` (the CLI prints its line and exits 130);
``--resume`` continues at the next iteration, nothing lost. A second signal stops at
once; the last periodic checkpoint stands.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

SIGNALS = (signal.SIGINT, signal.SIGTERM)
"""The signals that stop a run."""


class TrainingStopped(KeyboardInterrupt):
    """A run stopped by a signal at the end of an iteration, whose checkpoint is saved."""


class StopRequest:
    """Whether a stop was asked for, and by which signal (None: not asked)."""

    def __init__(self) -> None:
        self.signal: signal.Signals | None = None

    @property
    def asked(self) -> bool:
        return self.signal is not None


@contextmanager
def stop_on_signals(request: StopRequest) -> Iterator[None]:
    """While inside, a first :data:`SIGNALS` sets ``request`` (and says so on stderr), a
    second raises ``KeyboardInterrupt``; the earlier handlers are restored on leaving.
    Off the main thread, where Python takes no signal handlers, nothing changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum: int, frame: object) -> None:
        del frame
        name = signal.Signals(signum).name
        if request.asked:
            raise KeyboardInterrupt(f"{name} again: stopped at once; the last periodic "
                                    "checkpoint stands")
        request.signal = signal.Signals(signum)
        print(f"[hybrid-recovery] {name}: stopping at the end of this iteration, saved "
              f"(send it again to stop at once)", file=sys.stderr, flush=True)

    previous = {s: signal.getsignal(s) for s in SIGNALS}
    for s in SIGNALS:
        signal.signal(s, handler)
    try:
        yield
    finally:
        for s, old in previous.items():
            signal.signal(s, old)
