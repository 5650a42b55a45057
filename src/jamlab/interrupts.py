"""Ctrl-C for the command line, never delivered inside numba's runtime unpickling or inside
llvmlite's callbacks.

A compiled kernel that returns arrays calls back into Python for objects it needs to box them
(``numba.core.serialize._numba_unpickle``, a memo after the first return). Python's default
SIGINT handler raises ``KeyboardInterrupt`` at the next bytecode, which is often inside that
callback; at a kernel's first return in a process numba does not check the callback's failure
and hands back a tuple with a NULL in it, and unpacking it is a segmentation fault
(numba/numba#2324; seen with ``jamlab prepare --n 3000`` interrupted in its first FIRE run:
exit −11, no message, instead of ``jamlab: aborted`` and 130). The same holds for llvmlite's
ctypes callbacks (its object cache's ``_raw_object_cache_getbuffer``, called from C while numba
loads or compiles a kernel): an exception there is printed as "ignored", the C code goes on with
no buffer, and the process dies of a segmentation fault (seen in CI, 2026-12-07: ``prepare --n
3000`` interrupted 3.2 s after its start, while its kernels were being loaded).

:func:`install` replaces the default handler by :func:`handle_sigint`, which raises
``KeyboardInterrupt`` as before, except
- while ``_numba_unpickle`` is on the stack: there it raises it at the next line of the Python
  frame that called the kernel, once the kernel has returned;
- while an llvmlite frame is on the stack: there it raises it at the next line of the first
  frame outside llvmlite below it, once llvmlite's call has returned (numba's Python code,
  where an exception propagates as any other);
each by a one-shot trace function on that frame, so that the abort is as prompt as before. A
SIGINT that is ignored (a background job) stays ignored; another handler a caller installed is
kept.
"""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType

__all__ = ["handle_sigint", "install", "llvmlite_frame", "unpickling_frame"]


def unpickling_frame(frame: FrameType | None) -> FrameType | None:
    """The frame of numba's runtime unpickling among ``frame`` and its callers, or None."""
    while frame is not None:
        if (frame.f_code.co_name == "_numba_unpickle"
                and frame.f_globals.get("__name__") == "numba.core.serialize"):
            return frame
        frame = frame.f_back
    return None


def _in_llvmlite(frame: FrameType) -> bool:
    name = frame.f_globals.get("__name__")
    return isinstance(name, str) and (name == "llvmlite" or name.startswith("llvmlite."))


def llvmlite_frame(frame: FrameType | None) -> FrameType | None:
    """The innermost frame of llvmlite's code among ``frame`` and its callers, or None."""
    while frame is not None:
        if _in_llvmlite(frame):
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


def _deferred_to(frame: FrameType | None) -> FrameType | None:
    """The frame whose next line the interrupt waits for, or None to raise it now."""
    inner = unpickling_frame(frame)
    if inner is not None:
        return inner.f_back
    outer = llvmlite_frame(frame)
    while outer is not None and _in_llvmlite(outer):
        outer = outer.f_back
    return outer


def handle_sigint(signum: int, frame: FrameType | None) -> None:
    """The SIGINT handler: ``KeyboardInterrupt`` now, or, inside numba's unpickling, at the next
    line of the frame that called the kernel, and inside llvmlite at the next line of the first
    frame outside it."""
    target = _deferred_to(frame)
    if target is None:  # (also with nothing above the unsafe frames to raise in: as Python would)
        raise KeyboardInterrupt
    _raise_at_next_line(target)


def install() -> bool:
    """Use :func:`handle_sigint` for SIGINT in this process if it has Python's default handler and
    this is the main thread; whether it was installed."""
    if threading.current_thread() is not threading.main_thread():
        return False
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return False
    signal.signal(signal.SIGINT, handle_sigint)
    return True
