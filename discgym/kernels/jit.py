"""``kernel``: the decorator of the kernels that compiled code calls, compiled without the
wrappers that only a call from Python needs.

With every function numba compiles a CPython wrapper (it unboxes each argument, a struct field
by field, and boxes the result) and a C wrapper. A kernel called only from other kernels never
runs either, yet both are generated, optimised and turned into machine code, and again at
every level that links the kernel in: most of a small kernel's compile time, and about a
fifth of a stepped env's first step. ``kernel`` is ``njit(cache=True)`` with numba's
``no_cpython_wrapper`` and ``no_cfunc_wrapper`` options; the functions Python calls (the
entry points a ``Simulation`` or an env calls) stay ``njit(cache=True)``.

Calling code without a CPython wrapper from Python would crash the interpreter, so a call
from Python (a test, a probe) goes to the kernel's *twin*: the same function compiled with
the wrappers, made on first use and cached under its own name (``<name>__py``), so that the
two versions never share a cache entry. The twin's own calls are the kernels', compiled
without wrappers. Never make a plain ``njit`` dispatcher of a kernel's ``py_func``: it would
share the kernel's cache entries and load code it cannot call (use :func:`python_twin`).
"""

from __future__ import annotations

import types

from numba.core import config
from numba.core.registry import CPUDispatcher

__all__ = ["kernel", "KernelDispatcher", "python_twin"]

#: What a kernel leaves out (numba's jit options).
_NO_WRAPPERS = {"no_cpython_wrapper": True, "no_cfunc_wrapper": True}


class KernelDispatcher(CPUDispatcher):
    """A dispatcher compiled without a Python entry; a call from Python runs its twin."""

    def __call__(self, *args, **kwargs):
        return python_twin(self)(*args, **kwargs)


def _make_twin(disp: KernelDispatcher) -> CPUDispatcher:
    f = disp.py_func
    g = types.FunctionType(f.__code__, f.__globals__, f.__name__ + "__py", f.__defaults__,
                           f.__closure__)
    g.__qualname__ = f.__qualname__ + "__py"  # (its own cache files)
    g.__module__, g.__doc__, g.__kwdefaults__ = f.__module__, f.__doc__, f.__kwdefaults__
    opts = {k: v for k, v in disp.targetoptions.items() if k not in _NO_WRAPPERS}
    twin = CPUDispatcher(py_func=g, locals=disp.locals, targetoptions=opts)
    twin.enable_caching()
    return twin


def python_twin(disp: KernelDispatcher) -> CPUDispatcher:
    """The dispatcher a call from Python runs (made on first use)."""
    if disp.__dict__.get("_discgym_twin") is None:
        disp._discgym_twin = _make_twin(disp)
    return disp._discgym_twin


def kernel(func=None, **options):
    """``@kernel`` or ``@kernel(parallel=True, ...)``: ``njit(cache=True, **options)``
    without the wrappers (module docstring)."""

    def wrap(f):
        if config.DISABLE_JIT:
            return f
        opts = {"nopython": True, "boundscheck": None, **options, **_NO_WRAPPERS}
        disp = KernelDispatcher(py_func=f, locals=opts.pop("locals", {}), targetoptions=opts)
        disp.enable_caching()
        return disp

    return wrap if func is None else wrap(func)
