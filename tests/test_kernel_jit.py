"""discgym.kernels.jit: kernels compiled without the wrappers only Python calls need, and a
call from Python that still works (it runs the kernel's twin, never wrapperless code); the
choice of the layer (linked only on a numba it was tested on, plain ``njit`` elsewhere) and
the plain layer's trajectories, which are the linked-only layer's."""

import ast
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from discgym.kernels import controls, jit
from discgym.kernels.jit import is_kernel, kernel, python_twin

ROOT = Path(__file__).resolve().parents[1]
linked_only = pytest.mark.skipif(
    jit.LAYER != jit.LINK_ONLY,
    reason=f"the plain kernel layer is in effect (numba {numba.__version__}, "
           f"{jit.ENV_VAR}={os.environ.get(jit.ENV_VAR, '')!r})")


def test_a_kernel_called_from_python_runs_its_twin():
    vel = np.ones((3, 2))
    controls.scale(vel, 2, 2.0)  # (without a CPython wrapper, this call would crash)
    assert vel.tolist() == [[2.0, 2.0], [2.0, 2.0], [1.0, 1.0]]
    twin = python_twin(controls.scale)
    assert type(twin) is CPUDispatcher and twin.signatures
    assert twin.targetoptions.get("no_cpython_wrapper") is None
    if jit.LAYER == jit.PLAIN:  # (the kernel is an ordinary njit function: its own twin)
        assert twin is controls.scale and twin.py_func.__qualname__ == "scale__plain"
        return
    # its own cache files: never the kernel's, whose entries have no wrapper
    assert twin.py_func.__qualname__ == "scale__py"
    assert controls.scale.targetoptions["no_cpython_wrapper"] is True


def test_options_pass_through_and_compiled_callers_get_the_kernel():
    @kernel(fastmath=False)
    def inner(x):
        return 2 * x

    assert is_kernel(inner) and inner.targetoptions["fastmath"] is False

    def outer(x):
        return inner(x) + 1

    outer.__globals__["inner"] = inner  # (a local function's globals are this module's)
    from numba import njit

    assert njit(outer)(3) == 7
    assert inner.signatures  # compiled for outer (linked only: without wrappers)
    assert inner(4) == 8 and python_twin(inner).signatures  # Python: the twin


def test_no_plain_dispatcher_shares_a_kernels_cache():
    """``njit(...)(f.py_func)`` of a kernel ``f`` would load the kernel's cached code, which
    has no entry from Python: the package makes none (a kernel's copy is ``kernel(...)``)."""
    import importlib

    for path in (ROOT / "discgym").rglob("*.py"):
        for name in re.findall(r"njit\([^)]*\)\((\w+)\.py_func\)", path.read_text()):
            mod = importlib.import_module(
                ".".join(path.relative_to(ROOT).with_suffix("").parts))
            assert not is_kernel(getattr(mod, name)), (path, name)


@pytest.mark.parametrize("version, setting, layer", [
    ("0.68.1", None, "link-only"), ("0.68.1", "", "link-only"), ("0.68.1", "auto", "link-only"),
    ("0.68.1", "plain", "plain"), ("0.68.1", " Plain ", "plain"),
    ("0.61.2", "", "plain"), ("0.59.1", "auto", "plain"), ("0.69.0", "", "plain"),
    ("0.61.2", "link-only", "link-only"),
])
def test_the_layer_is_linked_only_on_a_tested_numba_unless_told(monkeypatch, version,
                                                                  setting, layer):
    monkeypatch.setattr(jit, "TESTED_NUMBA", ("0.68.1",))
    monkeypatch.delenv(jit.ENV_VAR, raising=False)
    assert jit.choose_layer(version, setting) == layer
    if setting is not None:
        monkeypatch.setenv(jit.ENV_VAR, setting)
        assert jit.choose_layer(version) == layer


def test_an_unknown_layer_setting_warns_and_is_auto():
    with pytest.warns(RuntimeWarning, match="DISCGYM_KERNEL_LAYER"):
        assert jit.choose_layer("0.0.1", "fast") == jit.PLAIN


def test_the_numba_ci_installs_is_one_the_layer_was_tested_on():
    """CI's latest numba runs the linked-only layer (a new numba release runs the plain
    layer, correct and slower to compile, until tested and added to TESTED_NUMBA): the
    versions named are real releases, newest last."""
    versions = [tuple(int(p) for p in v.split(".")) for v in jit.TESTED_NUMBA]
    assert versions and versions == sorted(versions)
    if jit.LAYER == jit.PLAIN and os.environ.get(jit.ENV_VAR, "auto") in ("", "auto"):
        assert numba.__version__ not in jit.TESTED_NUMBA


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, anywhere in it (absolute names; relative ones as
    ``.name`` with one dot per level)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):  # (the names imported: numba.core.event)
            base = "." * node.level + (node.module + "." if node.module else "")
            out.update(base + a.name for a in node.names)
    return out


def test_numbas_internals_are_used_by_one_module_only():
    """Only kernels/linkonly.py imports numba's internals (``numba.core`` beyond its public
    event API) or llvmlite; jit.py imports it only on a tested numba."""
    users = []
    for path in sorted((ROOT / "discgym").rglob("*.py")):
        internal = [m for m in _imports(path)
                    if m.startswith("llvmlite") or (m.startswith("numba.core")
                                                    and m != "numba.core.event")]
        if internal:
            users.append(path.relative_to(ROOT).as_posix())
    assert users == ["discgym/kernels/linkonly.py"]


def test_the_kernel_layer_imports_nothing_above_it_and_jit_and_helper_no_cycle():
    kernels = ROOT / "discgym" / "kernels"
    graph = {}
    for path in sorted(kernels.glob("*.py")):
        mods = _imports(path)
        above = [m for m in mods if m.startswith("..") or (m.startswith("discgym")
                                                          and not m.startswith("discgym.kernels"))]
        assert not above, (path.name, above)
        graph[path.stem] = {m.lstrip(".").split(".")[0] for m in mods if m.startswith(".")
                            and not m.startswith("..")} | {
            m.split(".")[2] for m in mods if m.startswith("discgym.kernels.")}
    assert "helper" not in graph["jit"] and "helper" not in graph["linkonly"]
    assert "jit" not in graph["linkonly"] and "helper" not in graph["locks"]

    def reaches(a, b, seen=()):
        return any(n == b or (n not in seen and reaches(n, b, (*seen, n)))
                   for n in graph.get(a, ()))

    for a in graph:
        assert not reaches(a, a), f"an import cycle through kernels/{a}.py"


PLAIN_CHILD = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
import golden
import numpy as np
from discgym.kernels import controls, jit
assert jit.LAYER == "plain", jit.LAYER
vel = np.ones((2, 2))
controls.scale(vel, 1, 3.0)  # (a kernel called from Python: under the plain layer, itself)
assert vel.tolist() == [[3.0, 3.0], [1.0, 1.0]]
assert jit.python_twin(controls.scale) is controls.scale
golden.dg.scenes.names = lambda: ["reactor"]
print(json.dumps({**golden.scene_runs(("step",), (0,)), **golden.control_runs(("step",), (0,))}))
"""


@pytest.mark.slow
def test_the_plain_layer_gives_the_trajectories_of_the_linked_only_layer(tmp_path):
    """A fresh process on an empty cache with ``DISCGYM_KERNEL_LAYER=plain``: a small scene's
    golden fingerprints (tests/golden.py), as this process computes them with its layer,
    and as tests/golden.json recorded them where the platform is the one recorded."""
    sys.path.insert(0, str(ROOT / "tests"))
    import golden

    env = dict(os.environ, DISCGYM_KERNEL_LAYER="plain", NUMBA_CACHE_DIR=str(tmp_path),
               DISCGYM_COMPILE_NOTICE="0")
    out = subprocess.run([sys.executable, "-c", PLAIN_CHILD, str(ROOT / "tests")], env=env,
                         capture_output=True, text=True, timeout=1800)
    assert out.returncode == 0, out.stderr[-3000:]
    plain = json.loads(out.stdout.strip().splitlines()[-1])
    assert sorted(plain) == ["controls/reactor/step/seed0", "scene/reactor/step/seed0"]
    cached = sorted(p.name for p in tmp_path.rglob("*.nbi"))
    assert cached and any("__plain" in n for n in cached)
    assert not [n for n in cached if n.split(".")[1].split("-")[0].endswith("__py")], cached
    golden.dg.scenes.names, names = (lambda: ["reactor"]), golden.dg.scenes.names
    try:
        here = {**golden.scene_runs(("step",), (0,)), **golden.control_runs(("step",), (0,))}
    finally:
        golden.dg.scenes.names = names
    assert plain == here, jit.LAYER
    recorded = json.loads((ROOT / "tests" / "golden.json").read_text())
    if recorded["platform"] == golden.platform_key():
        assert plain == {k: recorded["fingerprints"][k] for k in plain}


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


@linked_only
def test_lean_meminfos_finds_what_numba_finds_from_less_ir(monkeypatch):
    """The reference counts a struct of arrays gets (kernels.linkonly, "Reference counts without
    dead code"): the same meminfos, in the same order, as numba's own method, which extracts
    every field of every array on the way."""
    import numba
    from numba.core import types
    from numba.core.runtime.context import NRTContext

    linkonly = pytest.importorskip("discgym.kernels.linkonly")  # (internals of a numba)
    LEAN_MEMINFOS, _lean_meminfos = linkonly.LEAN_MEMINFOS, linkonly._lean_meminfos
    numba_get_meminfos = linkonly.numba_get_meminfos
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
                    "kernels.linkonly replaces: review _lean_meminfos against it and update "
                    "_NUMBA_GET_MEMINFOS (numba's own method is in effect)")


@linked_only
def test_lean_meminfos_and_lock_callbacks_only_while_a_discgym_function_compiles():
    """numba's own method and llvmlite's lock callbacks (numba's ``numba:llvm_lock``
    events) are in place outside discgym's compiles: a function of another package is
    compiled as numba compiles it, and both are back after a discgym compile, failed or
    not."""
    from llvmlite.binding import ffi
    from numba import njit
    from numba.core import event
    from numba.core.runtime.context import NRTContext

    from discgym.kernels import linkonly

    assert linkonly._LLVM_LOCK is not None, "llvmlite's lock is not the one linkonly knows"
    callbacks = list(ffi.lib._lock._cblist)
    assert callbacks  # (numba registers its llvm_lock events)
    seen, lock_events = {}, []

    class Spy(event.Listener):  # (registered after linkonly's: sees what it put in place)
        def on_start(self, ev):
            seen[ev.data["dispatcher"].py_func.__module__] = (NRTContext.get_meminfos,
                                                             list(ffi.lib._lock._cblist))

        def on_end(self, ev):
            pass

    def probe(x):
        return x + 1

    def bad(x):
        return undefined_name + x  # noqa: F821

    with event.install_listener("numba:compile", Spy()), \
            event.install_recorder("numba:llvm_lock") as rec:
        for module in ("some_other_package", "discgym.kernels.probe"):
            probe.__module__ = module
            assert njit(probe)(1) == 2
            lock_events.append(len(rec.buffer))
        bad.__module__ = "discgym.kernels.probe"
        with pytest.raises(numba.core.errors.TypingError):
            njit(bad)(1)
    lean = linkonly._lean_meminfos if linkonly.LEAN_MEMINFOS else linkonly.numba_get_meminfos
    assert seen == {"some_other_package": (linkonly.numba_get_meminfos, callbacks),
                    "discgym.kernels.probe": (lean, [])}
    assert lock_events[0] > 0 and lock_events[1] == lock_events[0]  # (none from discgym's)
    assert NRTContext.get_meminfos is linkonly.numba_get_meminfos
    assert ffi.lib._lock._cblist == callbacks
