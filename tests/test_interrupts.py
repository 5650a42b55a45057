"""Ctrl-C never delivered inside numba's runtime unpickling (``jamlab.interrupts``): there numba
ignores the callback's failure and the process dies of a segmentation fault (numba/numba#2324)."""

import pickle
import signal
import sys
import threading

import pytest
from numba.core import serialize

from jamlab import interrupts

SEEN: list = []


class Probe:
    """Unpickled by numba's own callback, it runs the SIGINT handler where the signal would be
    processed: inside ``_numba_unpickle``."""

    def __reduce__(self):
        return (_rebuild, ())


def _rebuild():
    frame = sys._getframe()
    SEEN.append(interrupts.unpickling_frame(frame) is not None)
    try:
        interrupts.handle_sigint(signal.SIGINT, frame)  # as Python calls it at this bytecode
    except KeyboardInterrupt:
        SEEN.append("raised inside")
    return "rebuilt"


def test_inside_numbas_unpickling_the_interrupt_comes_at_the_callers_next_line():
    SEEN.clear()
    reached = []
    key = b"test-interrupts"
    data = pickle.dumps(Probe())
    before = sys.gettrace()
    try:
        with pytest.raises(KeyboardInterrupt):
            obj = serialize._numba_unpickle(id(data), data, key)  # the unpickling completes
            reached.append(obj)  # the next line of the caller: not run
        assert SEEN == [True] and reached == []
        assert sys.gettrace() is before  # the one-shot tracing is gone
    finally:
        serialize._unpickled_memo.pop((id(data), key), None)


def test_elsewhere_the_interrupt_is_immediate():
    assert interrupts.unpickling_frame(sys._getframe()) is None
    with pytest.raises(KeyboardInterrupt):
        interrupts.handle_sigint(signal.SIGINT, sys._getframe())


def test_install_keeps_an_ignored_or_foreign_handler_and_the_main_thread_only():
    previous = signal.getsignal(signal.SIGINT)
    try:
        for other in (signal.SIG_IGN, lambda s, f: None):
            signal.signal(signal.SIGINT, other)
            assert interrupts.install() is False and signal.getsignal(signal.SIGINT) is other
        signal.signal(signal.SIGINT, signal.default_int_handler)
        result = []
        worker = threading.Thread(target=lambda: result.append(interrupts.install()))
        worker.start()
        worker.join()
        assert result == [False] and signal.getsignal(signal.SIGINT) is signal.default_int_handler
        assert interrupts.install() is True
        assert signal.getsignal(signal.SIGINT) is interrupts.handle_sigint
    finally:
        signal.signal(signal.SIGINT, previous)


# Two functions as llvmlite's would be: a Python wrapper that calls into C, and the ctypes callback
# C calls back (here called directly: the frames and their modules are what the handler reads).
_FAKE_LLVMLITE = {"__name__": "llvmlite.binding.fake", "DONE": []}
exec(  # noqa: S102 (test scaffolding: functions whose module is llvmlite's)
    "def wrapper(hook):\n"
    "    out = callback(hook)\n"
    "    DONE.append('wrapper')\n"
    "    return out + ['wrapper returned']\n"
    "def callback(hook):\n"
    "    out = hook() + ['callback returned']\n"
    "    DONE.append('callback')\n"
    "    return out\n",
    _FAKE_LLVMLITE,
)


def test_inside_llvmlite_the_interrupt_comes_at_the_next_line_outside_it():
    """Ctrl-C while llvmlite's object-cache callback ran was ignored there and the process died
    (CI, 2026-12-07): the interrupt now waits until llvmlite's call has returned to the first
    frame outside it, and comes at that frame's next line."""
    assert interrupts.llvmlite_frame(sys._getframe()) is None

    def hook():  # numba's code, called by the callback
        frame = sys._getframe()
        assert interrupts.llvmlite_frame(frame).f_code.co_name == "callback"
        interrupts.handle_sigint(signal.SIGINT, frame)  # as Python calls it at this bytecode
        return ["hook returned"]

    reached = []
    before = sys.gettrace()
    _FAKE_LLVMLITE["DONE"].clear()
    with pytest.raises(KeyboardInterrupt):
        out = _FAKE_LLVMLITE["wrapper"](hook)  # every frame inside completes
        reached.append(out)  # the next line outside llvmlite: not run
    assert _FAKE_LLVMLITE["DONE"] == ["callback", "wrapper"]  # both ran to their ends
    assert reached == [] and sys.gettrace() is before
    # the same call without an interrupt returns through all three
    assert _FAKE_LLVMLITE["wrapper"](lambda: ["hook returned"]) == [
        "hook returned", "callback returned", "wrapper returned"]
