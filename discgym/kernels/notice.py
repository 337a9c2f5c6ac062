"""The line a process logs when it has to compile discgym's kernels.

numba compiles a kernel the first time a process calls it with new argument types and
caches the result on disk (``cache=True``); a later process loads it. Compiling from an
empty cache takes tens of seconds, and without a word the first ``env.step`` looks hung. So the
first compile of a discgym kernel in a process logs, once, a WARNING on the ``discgym``
logger (shown on stderr by Python's default handler). The same event starts the compile
helper of the envs made before it (:mod:`.helper`).

First use is detected from numba's ``numba:compile`` event, which numba fires only when it
compiles (a function loaded from the cache fires none): nothing is logged when the cache
is warm, and the check costs nothing on the call path. Silence it with the logging
configuration (``logging.getLogger("discgym").setLevel(logging.ERROR)``) or with the
environment variable ``DISCGYM_COMPILE_NOTICE=0``. ``discgym compile`` warms the cache
ahead of time (docs/cli.md).
"""

from __future__ import annotations

import logging

from numba.core import event

from . import helper

LOGGER = logging.getLogger("discgym")
#: set to 0 (or "false", "no", "off") to silence the notice
ENV_VAR = "DISCGYM_COMPILE_NOTICE"
MESSAGE = ("compiling discgym's kernels for first use (tens of seconds from an empty cache; "
           "cached afterwards; `discgym compile` warms the cache ahead of time)")


class _FirstCompile(event.Listener):
    """Logs :data:`MESSAGE` at the start of the first compile of a discgym function."""

    def __init__(self):
        self.done = False

    def on_start(self, ev):
        f = getattr(ev.data.get("dispatcher"), "py_func", None)
        if f is None or not getattr(f, "__module__", "").startswith("discgym"):
            return
        helper.on_compile()
        if self.done:
            return
        # (stays registered: removing a listener while numba broadcasts to the list would
        # make it skip the next one)
        self.done = True
        if not helper.switched_off(ENV_VAR):
            LOGGER.warning(MESSAGE)

    def on_end(self, ev):
        pass


_LISTENER = _FirstCompile()
event.register("numba:compile", _LISTENER)


def rearm() -> None:
    """Log again at the next compile (for tests)."""
    _LISTENER.done = False
