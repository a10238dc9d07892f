"""Ctrl-C and SIGTERM for the console script: prompt, and never leaving temporaries behind.

* :func:`sigterm_raises` turns SIGTERM into the exception :class:`Terminated` (like SIGINT is
  turned into ``KeyboardInterrupt``) so that the ``except``/``finally`` cleanup runs.
* :func:`in_worker` runs a long computation of the Rust core in a worker thread while the main
  thread waits in ``join(timeout=0.2)``. Python runs signal handlers only in the main thread and
  only between bytecodes; while the main thread itself sits inside a Rust call the handler
  waits until the call returns (minutes for a big diagnosis). Waiting in short joins instead
  lets ``KeyboardInterrupt``/``Terminated`` reach the main thread at once; the cleanup then
  runs there, and :data:`cancel` is set so that the worker's progress callback stops the
  computation at its next call. A worker still running when the command ends is abandoned:
  :func:`worker_running` tells ``main`` to leave with ``os._exit`` (the interpreter cannot
  finalize while a thread is inside native code).
* :func:`signals_deferred` holds SIGINT/SIGTERM back around short critical file operations
  (reserving, committing, discarding outputs), so an interrupt never lands between creating a
  temporary and recording it.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
from typing import Any, Callable, Dict, Iterator, List, TypeVar

__all__ = [
    "Terminated",
    "Cancelled",
    "cancel",
    "sigterm_raises",
    "signals_deferred",
    "in_worker",
    "worker_running",
    "flush_std_streams",
    "ignore_signals",
]

T = TypeVar("T")

#: Set when the command was interrupted; progress callbacks raise :class:`Cancelled` then.
cancel = threading.Event()

_workers: List[threading.Thread] = []


class Terminated(BaseException):
    """SIGTERM received (a ``BaseException``, like ``KeyboardInterrupt``)."""


class Cancelled(Exception):
    """Raised by a progress callback to stop a computation whose result nobody will use."""


def _on_sigterm(signum: int, frame: Any) -> None:
    raise Terminated()


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def sigterm_raises() -> Iterator[None]:
    """Within the block, SIGTERM raises :class:`Terminated` in the main thread."""
    if not _in_main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


_SIGNALS = {signal.SIGINT, signal.SIGTERM}


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back for the duration of the block (POSIX, main thread)."""
    if not hasattr(signal, "pthread_sigmask") or not _in_main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def ignore_signals() -> None:
    """Ignore SIGINT and SIGTERM from now on (the command is already leaving)."""
    if _in_main_thread():
        for sig in _SIGNALS:
            signal.signal(sig, signal.SIG_IGN)


def in_worker(fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` in a worker thread; the calling (main) thread stays responsive
    to signals. Exceptions of ``fn`` are re-raised here."""
    if not _in_main_thread():
        return fn(*args, **kwargs)
    box: Dict[str, Any] = {}

    def target() -> None:
        try:
            box["value"] = fn(*args, **kwargs)
        except BaseException as e:  # re-raised in the main thread
            box["error"] = e

    worker = threading.Thread(target=target, name="robot-stiffness-worker", daemon=True)
    _workers.append(worker)
    worker.start()
    try:
        while worker.is_alive():
            worker.join(0.2)
    except BaseException:
        cancel.set()
        raise
    _workers.remove(worker)
    if "error" in box:
        raise box["error"]
    return box["value"]  # type: ignore[no-any-return]


def worker_running() -> bool:
    """True when an abandoned worker is still computing."""
    return any(w.is_alive() for w in _workers)


def flush_std_streams() -> None:
    """Flush stdout and stderr, ignoring a closed pipe."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
