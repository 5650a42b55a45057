"""Ctrl-C for the command line, never delivered inside numba's runtime unpickling.

A compiled kernel that returns arrays calls back into Python for objects it needs to box them
(``numba.core.serialize._numba_unpickle``, a memo after the first return). Python's default
SIGINT handler raises ``KeyboardInterrupt`` at the next bytecode, which is often inside that
callback; at a kernel's first return in a process numba does not check the callback's failure
and hands back a tuple with a NULL in it, and unpacking it is a segmentation fault
(numba/numba#2324; seen with ``jamlab prepare --n 3000`` interrupted in its first FIRE run:
exit −11, no message, instead of ``jamlab: aborted`` and 130).

:func:`install` replaces the default handler by :func:`handle_sigint`, which raises
``KeyboardInterrupt`` as before, except while ``_numba_unpickle`` is on the stack: there it
raises it at the next line of the Python frame that called the kernel, once the kernel has
returned (a one-shot trace function on that frame), so that the abort is as prompt as before. A
SIGINT that is ignored (a background job) stays ignored; another handler a caller installed is
kept.
"""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType

__all__ = ["handle_sigint", "install", "unpickling_frame"]


def unpickling_frame(frame: FrameType | None) -> FrameType | None:
    """The frame of numba's runtime unpickling among ``frame`` and its callers, or None."""
    while frame is not None:
        if (frame.f_code.co_name == "_numba_unpickle"
                and frame.f_globals.get("__name__") == "numba.core.serialize"):
            return frame
        frame = frame.f_back
    return None


def _raise_at_next_line(frame: FrameType) -> None:
    """``KeyboardInterrupt`` at the next line (or return) of ``frame``; no other frame traced (a
    trace function already set, e.g. a debugger's, is put back first)."""
    previous = sys.gettrace()

    def local(f: FrameType, event: str, arg: object) -> object:
        if event in ("line", "return"):
            f.f_trace = None
            sys.settrace(previous)
            raise KeyboardInterrupt
        return local

    frame.f_trace = local
    sys.settrace(lambda f, event, arg: None)  # tracing on, for ``frame`` alone


def handle_sigint(signum: int, frame: FrameType | None) -> None:
    """The SIGINT handler: ``KeyboardInterrupt`` now, or, inside numba's unpickling, at the next
    line of the frame that called the kernel."""
    inner = unpickling_frame(frame)
    if inner is None or inner.f_back is None:  # (nothing above it to raise in: as Python would)
        raise KeyboardInterrupt
    _raise_at_next_line(inner.f_back)


def install() -> bool:
    """Use :func:`handle_sigint` for SIGINT in this process if it has Python's default handler and
    this is the main thread; whether it was installed."""
    if threading.current_thread() is not threading.main_thread():
        return False
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return False
    signal.signal(signal.SIGINT, handle_sigint)
    return True
