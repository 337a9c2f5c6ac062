"""discgym.kernels.jit: kernels compiled without the wrappers only Python calls need, and a
call from Python that still works (it runs the kernel's twin, never wrapperless code)."""

import re
from pathlib import Path

import numpy as np
from numba.core.registry import CPUDispatcher

from discgym.kernels import controls
from discgym.kernels.jit import KernelDispatcher, kernel, python_twin

ROOT = Path(__file__).resolve().parents[1]


def test_a_kernel_called_from_python_runs_its_twin():
    vel = np.ones((3, 2))
    controls.scale(vel, 2, 2.0)  # (without a CPython wrapper, this call would crash)
    assert vel.tolist() == [[2.0, 2.0], [2.0, 2.0], [1.0, 1.0]]
    twin = python_twin(controls.scale)
    assert type(twin) is CPUDispatcher and twin.signatures
    assert twin.targetoptions.get("no_cpython_wrapper") is None
    # its own cache files: never the kernel's, whose entries have no wrapper
    assert twin.py_func.__qualname__ == "scale__py"
    assert controls.scale.targetoptions["no_cpython_wrapper"] is True


def test_options_pass_through_and_compiled_callers_get_the_kernel():
    @kernel(fastmath=False)
    def inner(x):
        return 2 * x

    assert isinstance(inner, KernelDispatcher) and inner.targetoptions["fastmath"] is False

    def outer(x):
        return inner(x) + 1

    outer.__globals__["inner"] = inner  # (a local function's globals are this module's)
    from numba import njit

    assert njit(outer)(3) == 7
    assert inner.signatures  # compiled for outer, without wrappers
    assert inner(4) == 8 and python_twin(inner).signatures  # Python: the twin


def test_no_plain_dispatcher_shares_a_kernels_cache():
    """``njit(...)(f.py_func)`` of a kernel ``f`` would load the kernel's cached code, which
    has no entry from Python: the package makes none (a kernel's copy is ``kernel(...)``)."""
    import importlib

    for path in (ROOT / "discgym").rglob("*.py"):
        for name in re.findall(r"njit\([^)]*\)\((\w+)\.py_func\)", path.read_text()):
            mod = importlib.import_module(
                ".".join(path.relative_to(ROOT).with_suffix("").parts))
            assert not isinstance(getattr(mod, name), KernelDispatcher), (path, name)
