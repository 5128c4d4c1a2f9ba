"""The CLI's one error mechanism: ``error: <message>`` and exit 2, Ctrl-C one line and 130.

Every subcommand raises; :func:`report_errors` turns what reaches the top into one line
on stderr. The traceback is printed only with ``--debug``.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
import traceback
from collections.abc import Callable, Iterator

EXIT_ERROR = 2
"""Exit status of a refused input or a failed command (as argparse's usage errors)."""
EXIT_INTERRUPTED = 130
"""Exit status after Ctrl-C (128 + SIGINT)."""


_EXPECTED = (ValueError, KeyError, OSError, RuntimeError)
"""Errors whose message is the whole story (refused inputs, missing or damaged files,
faults); any other exception is a bug and is named with its type and a hint."""


class UsageError(ValueError):
    """A command-line input that is refused before any work is done; the message says why."""


@contextlib.contextmanager
def sigterm_as_interrupt() -> Iterator[None]:
    """While inside, SIGTERM (``kill``) raises ``KeyboardInterrupt`` in this process, as
    Ctrl-C does: one line, exit :data:`EXIT_INTERRUPTED`, finished work kept. A process
    forked meanwhile (an evaluation worker) ends at once and silently on SIGTERM, as with
    no handler. Off the main thread, where Python takes no signal handlers, nothing
    changes; the earlier handler is restored on leaving."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    owner = os.getpid()

    def handler(signum: int, frame: object) -> None:
        del frame
        if os.getpid() != owner:  # a forked worker: the default, end without a word
            signal.signal(signum, signal.SIG_DFL)
            os.kill(os.getpid(), signum)
            return
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def error_message(err: BaseException) -> str:
    """The one-line text of an error: its message, or its type where it has none.

    ``KeyError`` quotes its message (``repr``); the quotes are dropped here.
    """
    if isinstance(err, KeyError) and len(err.args) == 1 and isinstance(err.args[0], str):
        text = err.args[0]
    else:
        text = str(err)
    return text or type(err).__name__


def report_errors(run: Callable[[], int], debug: bool) -> int:
    """Runs ``run`` and returns its exit status; an exception becomes ``error: <message>``
    (exit :data:`EXIT_ERROR`), Ctrl-C one line (exit :data:`EXIT_INTERRUPTED`).

    Args:
        run: The subcommand, returning its exit status.
        debug: Print the traceback too (``--debug``).
    """
    try:
        return run()
    except KeyboardInterrupt as err:
        if debug:
            traceback.print_exc()
        print(error_message(err) if str(err) else "interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except SystemExit as err:  # a library's own exit with a message
        if isinstance(err.code, int) or err.code is None:
            raise
        if debug:
            traceback.print_exc()
        print(f"error: {err.code}", file=sys.stderr)
        return EXIT_ERROR
    except Exception as err:  # noqa: BLE001 - the top of the program: one line, no traceback
        if debug:
            traceback.print_exc()
        if isinstance(err, _EXPECTED):
            print(f"error: {error_message(err)}", file=sys.stderr)
        else:
            print(f"error: {type(err).__name__}: {error_message(err)} (a bug: run with --debug "
                  "for the traceback and report it)", file=sys.stderr)
        return EXIT_ERROR
