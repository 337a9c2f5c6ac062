"""discgym.kernels.jit: kernels compiled without the wrappers only Python calls need, and a
call from Python that still works (it runs the kernel's twin, never wrapperless code)."""

import re
from pathlib import Path

import numpy as np
import pytest
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


def _emit(get_meminfos, ty):
    """The meminfos ``get_meminfos`` finds in an argument of numba type ``ty`` of a new LLVM
    function, as (type, path of extractvalue indices from the argument), and how many
    instructions it wrote."""
    import llvmlite.ir as llvmir
    from numba.core.registry import cpu_target

    # (a context of its own: the global one caches its NRT context on first use, disabled,
    # and every function compiled afterwards would inherit that)
    ctx = cpu_target.target_context.subtarget(enable_nrt=True)
    module = llvmir.Module()
    fn = llvmir.Function(module, llvmir.FunctionType(llvmir.VoidType(),
                                                     [ctx.get_value_type(ty)]), "f")
    builder = llvmir.IRBuilder(fn.append_basic_block())
    found = []
    for mty, v in get_meminfos(ctx.nrt, builder, ty, fn.args[0]):
        path = []
        while isinstance(v, llvmir.instructions.ExtractValue):
            path[:0] = v.indices
            v = v.aggregate
        assert v is fn.args[0]
        found.append((mty, tuple(path)))
    return found, len(builder.block.instructions)


def test_lean_meminfos_finds_what_numba_finds_from_less_ir(monkeypatch):
    """The reference counts a struct of arrays gets (kernels.jit, "Reference counts without
    dead code"): the same meminfos, in the same order, as numba's own method, which extracts
    every field of every array on the way."""
    import numba
    from numba.core import types
    from numba.core.runtime.context import NRTContext

    from discgym.kernels.jit import LEAN_MEMINFOS, _lean_meminfos, numba_get_meminfos
    from discgym.kernels.structs import Discs

    discs = Discs(np.zeros((4, 2)), np.zeros((4, 2)), np.zeros(4, np.int32), np.zeros(4),
                  np.zeros(4, np.int64), np.zeros(1, np.int64))
    # (numba's method recurses through the class's: its own, for this test)
    monkeypatch.setattr(NRTContext, "get_meminfos", numba_get_meminfos)
    nested = types.Tuple([numba.typeof(discs), types.float64,
                          types.Tuple([types.int64, types.float64[:, :]])])
    for ty, arrays in ((numba.typeof(discs), 6), (nested, 7)):
        ours, n_ours = _emit(_lean_meminfos, ty)
        numbas, n_numbas = _emit(numba_get_meminfos, ty)
        assert ours == numbas and len(ours) == arrays
        assert all(isinstance(t, types.MemInfoPointer) for t, _ in ours)  # (an array's field 0)
        assert n_ours < n_numbas / 3, (n_ours, n_numbas)  # (Discs: 12 against 64)
    if not LEAN_MEMINFOS:
        pytest.skip(f"numba {numba.__version__}'s NRTContext.get_meminfos is not the one "
                    "kernels.jit replaces: review _lean_meminfos against it and update "
                    "_NUMBA_GET_MEMINFOS (numba's own method is in effect)")
