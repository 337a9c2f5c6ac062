"""``kernel``: the decorator of the kernels that compiled code calls, over one of two layers.

**The linked-only layer** (:mod:`.linkonly`, on the numba versions of :data:`TESTED_NUMBA`):
a kernel is compiled without the CPython and C wrappers that only a call from Python needs
(numba's ``no_cpython_wrapper`` and ``no_cfunc_wrapper`` options), and its code is *linked
only*: optimised and turned into machine code once, inside each entry point (``njit``)
that calls it, instead of again at every level of the call tree. A second process may
compile part of a first compile (:mod:`.helper`). It rests on numba's internals, which
change between releases: that module is the only one of discgym to use them, and it is
imported only on a numba it was tested on.

**The plain layer** (any other numba): a kernel is ``njit(cache=True, **options)``, the
same computation (the same trajectories, ``tests/test_kernel_jit.py``), a slower first
compile and no compile helper. Its functions are compiled under a cache name of their own
(``<name>__plain``), so that the two layers never load each other's cache entries.

``DISCGYM_KERNEL_LAYER`` chooses: ``plain`` forces the plain layer on any numba;
``link-only`` forces the linked-only layer on a numba it was not tested on (to try a new
release: run the tests then); unset or ``auto``, the numba version decides. :data:`LAYER`
says which is in effect.

**A call from Python.** Calling code that has no CPython wrapper would crash the
interpreter (and a linked-only kernel has no machine code of its own), so under the
linked-only layer a call from Python (a test, a probe) goes to the kernel's *twin*: the
same function compiled as an ordinary ``njit`` function, made on first use and cached
under its own name (``<name>__py``), so that the two never share a cache entry. The twin's
own calls are the kernels'. Never make a plain ``njit`` dispatcher of a kernel's
``py_func``: it would share the kernel's cache entries and load code it cannot call (use
:func:`python_twin`, which under the plain layer is the kernel itself).
"""

from __future__ import annotations

import os
import types
import warnings

import numba
from numba import njit

__all__ = ["kernel", "python_twin", "is_kernel", "is_linked_only", "LAYER", "TESTED_NUMBA"]

#: The environment variable choosing the layer: ``plain``, ``link-only`` or ``auto``.
ENV_VAR = "DISCGYM_KERNEL_LAYER"
LINK_ONLY, PLAIN = "link-only", "plain"
#: The numba versions the linked-only layer was tested on (CI's latest; at the lowest numba
#: pyproject.toml allows, the layer's internals differ, and the plain layer runs).
TESTED_NUMBA = ("0.68.1",)

#: What a kernel leaves out under the linked-only layer (numba's jit options).
_NO_WRAPPERS = {"no_cpython_wrapper": True, "no_cfunc_wrapper": True}


def choose_layer(version: str = numba.__version__, setting: str | None = None) -> str:
    """The layer for numba ``version`` and the value of ``DISCGYM_KERNEL_LAYER``
    (``setting``; by default the environment's)."""
    if setting is None:
        setting = os.environ.get(ENV_VAR, "")
    setting = setting.strip().lower()
    if setting in (PLAIN, LINK_ONLY):
        return setting
    if setting not in ("", "auto"):
        warnings.warn(f"{ENV_VAR}={setting!r} is none of 'plain', 'link-only', 'auto': "
                      "taken as 'auto'", RuntimeWarning, stacklevel=2)
    return LINK_ONLY if version in TESTED_NUMBA else PLAIN


def _load_layer(layer: str):
    if layer != LINK_ONLY:
        return None
    try:
        from . import linkonly
    except (ImportError, AttributeError) as e:  # (forced onto a numba without those names)
        warnings.warn(f"discgym: the linked-only kernel layer does not load on numba "
                      f"{numba.__version__} ({e!r}): plain njit kernels instead",
                      RuntimeWarning, stacklevel=2)
        return None
    linkonly.KernelDispatcher.twin_of = staticmethod(python_twin)
    return linkonly


def _renamed(f, suffix: str):
    """A copy of the function ``f`` whose name ends with ``suffix`` (numba names a
    function's cache files after its qualified name)."""
    g = types.FunctionType(f.__code__, f.__globals__, f.__name__ + suffix, f.__defaults__,
                           f.__closure__)
    g.__qualname__ = f.__qualname__ + suffix
    g.__module__, g.__doc__, g.__kwdefaults__ = f.__module__, f.__doc__, f.__kwdefaults__
    return g


def python_twin(disp):
    """The dispatcher a call from Python runs: a linked-only kernel's twin (made on first
    use), or ``disp`` itself (a plain kernel, an ``njit`` function)."""
    if _layer is None or not isinstance(disp, _layer.KernelDispatcher):
        return disp
    twin = disp.__dict__.get("_discgym_twin")
    if twin is None:
        opts = {k: v for k, v in disp.targetoptions.items()
                if k not in _NO_WRAPPERS and k != "nopython"}
        twin = disp._discgym_twin = njit(cache=True, locals=disp.locals,
                                         **opts)(_renamed(disp.py_func, "__py"))
    return twin


def is_kernel(obj) -> bool:
    """Whether ``obj`` is a dispatcher made by :func:`kernel`."""
    if _layer is not None:
        return isinstance(obj, _layer.KernelDispatcher)
    return bool(getattr(obj, "_discgym_kernel", False))


def is_linked_only(cres) -> bool:
    """Whether a compile result (one of a dispatcher's ``overloads``) is linked only (no
    machine code of its own); always False under the plain layer."""
    return _layer is not None and _layer.is_linked_only(cres)


def lock_folder(disp):
    """The folder where the cross-process locks of ``disp``'s compiles are kept (its numba
    cache folder), or None: no cache, or the plain layer (no locks)."""
    return None if _layer is None else _layer.lock_folder(disp)


def kernel(func=None, *, optimise=False, inline_code=False, **options):
    """``@kernel`` or ``@kernel(parallel=True, ...)``: ``njit(cache=True, **options)``, under
    the linked-only layer without the wrappers and linked only (module docstring).
    ``optimise=True`` (linked-only layer): its module is optimised (-O3, with everything it
    calls) before entry points link it, still without machine code of its own: for a
    kernel that runs a large, hot tree of its own which the entry points calling it would
    otherwise optimise less well (the exact integrator's run, ``event_driven._simulate``:
    an env's step, one large function, ran it about 10 % slower as linked only).
    ``inline_code=True`` (linked-only layer): LLVM inlines its code into every function that
    calls it, when an entry point optimises the tree (LLVM's ``alwaysinline``; numba still
    types and lowers it once): for a small kernel called once per event with structs, whose
    every array a call would pass field by field (the event loop's handlers: as calls, a
    chunk of 140,000 discs' clusters ran 20-30 % slower)."""

    def wrap(f):
        if numba.config.DISABLE_JIT:
            return f
        if _layer is None:
            disp = njit(cache=True, **options)(_renamed(f, "__plain"))
            disp._discgym_kernel = True
            return disp
        opts = {"nopython": True, "boundscheck": None, **options, **_NO_WRAPPERS}
        return _layer.make_kernel(f, opts, optimise, inline_code)

    return wrap if func is None else wrap(func)


#: The layer in effect in this process: ``"link-only"`` or ``"plain"``.
LAYER = choose_layer()
_layer = _load_layer(LAYER)
if _layer is None:
    LAYER = PLAIN
