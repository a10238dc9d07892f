"""Ctrl-C and SIGTERM for the console script: prompt, and never leaving temporaries behind.

* :func:`signals_raise` makes SIGINT raise ``KeyboardInterrupt`` and SIGTERM raise
  :class:`Terminated`, so that the ``except``/``finally`` cleanup runs. The first of them also
  swallows every later SIGINT/SIGTERM: a second Ctrl-C cannot interrupt the cleanup
  of the first (the command is leaving anyway).
* :func:`in_worker` runs a long computation of the Rust core in a worker thread while the main
  thread waits in 0.2 s slices. Python runs signal handlers only in the main thread and only
  between bytecodes; while the main thread itself sits inside a Rust call the handler waits
  until the call returns (minutes for a big diagnosis). Waiting in short slices instead lets
  ``KeyboardInterrupt``/``Terminated`` reach the main thread at once; the cleanup then runs
  there, and :data:`cancel` is set so that the worker's progress callback stops the
  computation at its next call. A worker still running when the command ends is abandoned:
  ``main`` leaves with ``os._exit`` (the interpreter cannot finalize safely while a thread is
  inside native code and may call back into Python).
* :func:`signals_deferred` holds SIGINT/SIGTERM back around short critical file operations
  (reserving, committing, discarding outputs), so an interrupt never lands between creating a
  temporary and recording it.

Only plain flags and a C-level lock are used between the threads: an asynchronous exception
raised inside ``Thread.join``/``Event.wait`` can corrupt their Python-level state on
Python < 3.13 (bpo-45274: ``is_alive()`` then says False for a running thread).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from typing import Any, Callable, Dict, Iterator, List, TypeVar

from ._console_process import launched_as_console_script

__all__ = [
    "Terminated",
    "Cancelled",
    "cancel",
    "signals_raise",
    "signals_deferred",
    "in_worker",
    "worker_running",
    "flush_std_streams",
]

T = TypeVar("T")


class _Flag:
    """A boolean shared between threads (attribute access is atomic under the GIL)."""

    def __init__(self) -> None:
        self.value = False

    def set(self) -> None:
        self.value = True

    def clear(self) -> None:
        self.value = False

    def is_set(self) -> bool:
        return self.value


#: Set when the command was interrupted; progress callbacks raise :class:`Cancelled` then.
cancel = _Flag()

_unfinished: List[Dict[str, Any]] = []


class Terminated(BaseException):
    """SIGTERM received (a ``BaseException``, like ``KeyboardInterrupt``)."""


class Cancelled(Exception):
    """Raised by a progress callback to stop a computation whose result nobody will use."""


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


_SIGNALS = (signal.SIGINT, signal.SIGTERM)

#: Set by the first SIGINT/SIGTERM inside :func:`signals_raise`; later ones are swallowed.
_fired = _Flag()


def _on_sigint(signum: int, frame: Any) -> None:
    if not _fired.is_set():
        _fired.set()
        raise KeyboardInterrupt()


def _on_sigterm(signum: int, frame: Any) -> None:
    if not _fired.is_set():
        _fired.set()
        raise Terminated()


@contextlib.contextmanager
def signals_raise() -> Iterator[None]:
    """Within the block (main thread), SIGINT raises ``KeyboardInterrupt`` and SIGTERM
    :class:`Terminated` — once: later signals are swallowed by the same handlers (switching
    to ``SIG_IGN`` inside a handler races with a signal already pending and makes Python print
    "Signal 15 ignored due to race condition"). A signal the caller already ignores
    (``nohup``, a background job) stays ignored. After an interrupt our handlers stay in place
    when the block ends (the command is leaving); otherwise the previous ones are restored."""
    if not _in_main_thread():
        yield
        return
    _fired.clear()
    ours = {signal.SIGINT: _on_sigint, signal.SIGTERM: _on_sigterm}
    previous = {sig: signal.getsignal(sig) for sig in _SIGNALS}
    for sig in _SIGNALS:
        if previous[sig] is not signal.SIG_IGN:
            signal.signal(sig, ours[sig])
    try:
        yield
    finally:
        if not _fired.is_set():
            for sig in _SIGNALS:
                if signal.getsignal(sig) is ours[sig]:
                    signal.signal(sig, previous[sig])


@contextlib.contextmanager
def signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back for the duration of the block (POSIX, main thread)."""
    if not hasattr(signal, "pthread_sigmask") or not _in_main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, set(_SIGNALS))
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def in_worker(fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` in a worker thread; the calling (main) thread stays responsive
    to signals. Exceptions of ``fn`` are re-raised here."""
    value: T = in_workers(lambda: fn(*args, **kwargs))[0]
    return value


def in_workers(*calls: Callable[[], Any]) -> List[Any]:
    """Each of ``calls`` in its own worker thread, all at once (long Rust calls release the GIL
    and share the core's thread pool, which fills the gaps one leaves); their results in
    order. The calling (main) thread stays responsive to signals. Once all have finished, the
    exception of the first call that raised, in the order given, is re-raised: which error a
    command reports does not depend on which worker finished first."""
    if not _in_main_thread():
        return [call() for call in calls]
    boxes: List[Dict[str, Any]] = []
    for call in calls:
        box: Dict[str, Any] = {"finished": False, "done": threading.Lock()}
        box["done"].acquire()  # a C-level lock: held until the worker has finished

        def target(call: Callable[[], Any] = call, box: Dict[str, Any] = box) -> None:
            try:
                box["value"] = call()
            except BaseException as e:  # re-raised in the main thread
                box["error"] = e
            finally:
                box["finished"] = True
                box["done"].release()

        boxes.append(box)
        _unfinished.append(box)
        threading.Thread(target=target, name="robot-stiffness-worker", daemon=True).start()
    try:
        for box in boxes:
            while not box["done"].acquire(timeout=0.2):
                pass
    except BaseException:
        cancel.set()
        raise
    for box in boxes:
        _unfinished.remove(box)
    for box in boxes:
        if "error" in box:
            raise box["error"]
    return [box["value"] for box in boxes]


def worker_running() -> bool:
    """True when an abandoned worker has not finished."""
    return any(not box["finished"] for box in _unfinished)


def flush_std_streams() -> None:
    """Flush stdout and stderr, ignoring a closed pipe."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass


def _leave_while_starting(signum: int, frame: Any) -> None:
    # Nothing has been reserved or written yet: leave at once, without the traceback of a
    # KeyboardInterrupt raised inside an import (or inside rust-numpy's first import of numpy's
    # C-API capsule, which it turns into a panic).
    os.write(2, b"robot-stiffness: interrupted\n")
    os._exit(130 if signum == signal.SIGINT else 143)


def leave_quietly_while_starting() -> None:
    """When the process is the console script, SIGINT/SIGTERM that arrive while the package is
    still importing (before :func:`signals_raise` takes over) end it with 130/143 and one line,
    no traceback. A library import (``import robot_stiffness``) keeps Python's handlers; a
    signal the caller ignores stays ignored."""
    if not _in_main_thread() or not launched_as_console_script():
        return
    defaults = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}
    for sig, default in defaults.items():
        if signal.getsignal(sig) is default:
            signal.signal(sig, _leave_while_starting)
