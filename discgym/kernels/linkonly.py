"""The linked-only kernel layer: the one module of discgym that uses numba's internals.

:mod:`.jit` imports it only on a numba of :data:`.jit.TESTED_NUMBA` (or when
``DISCGYM_KERNEL_LAYER=link-only`` forces it); elsewhere the kernels are plain
``njit(cache=True)`` functions and nothing here is imported. It hooks numba's code
libraries (``numba.core.codegen.JITCodeLibrary``: ``_linking_libraries``, ``_reload_init``,
``_final_module``, ``_get_module_for_linking``, ...), its default compiler's
``_compile_core``, its function cache (``FunctionCache``, ``CompileResultCacheImpl``) and
``NRTContext.get_meminfos``; ``tests/test_kernel_jit.py`` and
``tests/test_compile_scope.py`` exercise them.

**Linked only.** numba compiles each function into an LLVM module of its own, links the
modules of its callees into it, optimises the whole at -O3 and generates machine code for
all of it. Down a call tree that work is done again at every level (``advance`` optimises
and emits the whole stepped integrator, then the env's step all of it once more), about
half of a stepped env's first compile. A kernel's module (:class:`LinkOnlyLibrary`) stops
after the cheap per-function passes and after linking its callees: no -O3 of its own, no
machine code. The entry point that calls it (an ``njit`` function) links the tree and
optimises and emits it once. Everything compiled while a kernel is being lowered (the
bodies and wrappers of a ``prange`` loop, numba's helpers) is linked only as well; numba's
overloads typed for a kernel (``np.empty``...) are compiled as numba compiles them. The
machine code of an entry point is the same computation (``tests/golden.py``'s
fingerprints are unchanged); LLVM sees each kernel once, unoptimised, instead of already
optimised. The cache keeps a kernel as its LLVM bitcode, ready to link; a process that
compiles a new entry point loads its kernels from there instead of compiling them again.
A kernel's version is compiled or loaded under a lock shared with other processes, and
saved under the lock of its function's cache index (:mod:`.locks`, :mod:`.helper`).

**Reference counts without dead code.** numba increments and decrements the reference
count of every array a value holds (``NRTContext.get_meminfos``) by walking the value's
whole data model: for each array of a struct it extracts all seven fields and every shape
and stride, of which only the meminfo is used. A kernel's state is a few structs of 6 to 20
arrays, so much of the IR numba writes was such dead ``extractvalue`` s (half the lines of
``step.advance``), which LLVM then parses and deletes. :func:`_lean_meminfos` walks
only the members that hold a meminfo: the same meminfos in the same order, so the same
code once LLVM has removed the dead instructions, from about 30 % less IR. It stands in
for numba's method only while numba compiles a discgym function (from the start of its
``numba:compile`` event to the end; numba holds its global compiler lock throughout, so no
other compile sees it), and only if numba's method is the one it was written against
(:data:`LEAN_MEMINFOS`).
"""

from __future__ import annotations

import contextlib
import hashlib
import inspect
from pathlib import Path

import llvmlite.binding as ll
import llvmlite.ir as llvmir
from llvmlite.binding import ffi
from numba.core import cgutils, event, sigutils
from numba.core.caching import CompileResultCacheImpl, FunctionCache
from numba.core.codegen import JITCodeLibrary
from numba.core.compiler import Compiler
from numba.core.compiler_lock import require_global_compiler_lock
from numba.core.registry import CPUDispatcher
from numba.core.runtime.context import NRTContext

from . import locks

#: The prefixes of numba's environment globals (one per compiled function) and of its CPython
#: wrappers' names.
_ENV_PREFIX, _PYTHON_ENTRY = "_ZN08NumbaEnv", "_ZN7cpython"


# -- reference counts ---------------------------------------------------------------------

def _lean_meminfos(self, builder, ty, val):
    """``NRTContext.get_meminfos`` without the dead code (module docstring): the
    ``(type, meminfo)`` of every array (or other reference-counted object) inside ``val``,
    depth first as numba lists them, extracting only the members that hold one."""
    dmm = self._context.data_model_manager
    model = dmm[ty]
    meminfos = []
    if model.has_nrt_meminfo():
        meminfos.append((ty, model.get_nrt_meminfo(builder, val)))
    for mty, getter in model.traverse(builder):
        holds = _HOLDS_MEMINFO.get(mty)
        if holds is None:
            holds = _HOLDS_MEMINFO[mty] = dmm[mty].contains_nrt_meminfo()
        if holds:
            meminfos.extend(_lean_meminfos(self, builder, mty, getter(val)))
    return meminfos


#: Whether a type holds a reference-counted object (``_lean_meminfos``'s memo).
_HOLDS_MEMINFO: dict = {}
#: The SHA-256 of the source of numba's ``get_meminfos`` that ``_lean_meminfos`` replaces:
#: any other version of numba keeps its own method.
_NUMBA_GET_MEMINFOS = "4681e04e53a8b20959da49edce6ec02e70c0a68d3839323d874bfaab1d2d1af1"


def _source_hash(f) -> str:
    try:
        return hashlib.sha256(inspect.getsource(f).encode()).hexdigest()
    except (OSError, TypeError):
        return ""


#: numba's own method (the tests compare the two).
numba_get_meminfos = NRTContext.__dict__["get_meminfos"]
#: Whether numba's reference counts are emitted by :func:`_lean_meminfos` while discgym's
#: functions compile.
LEAN_MEMINFOS = _source_hash(numba_get_meminfos) == _NUMBA_GET_MEMINFOS


class _LeanWhileCompiling(event.Listener):
    """From the start of the compile of a discgym function to its end (everything numba
    compiles on the way included): :func:`_lean_meminfos` in place of numba's method, and
    numba's callbacks of llvmlite's lock set aside (they broadcast a ``numba:llvm_lock``
    event to every compile's timer at each of the some 100,000 calls into LLVM of a first
    compile: about 2 % of its time, for a lock-time figure nothing reads). Both are put
    back afterwards."""

    def __init__(self):
        self.depth = 0
        self.callbacks = []

    def on_start(self, ev):
        if self.depth == 0:
            f = getattr(ev.data.get("dispatcher"), "py_func", None)
            if not getattr(f, "__module__", "").startswith("discgym"):
                return
            self.depth = 1  # (first: an interrupt below still finds on_end putting back)
            if LEAN_MEMINFOS:
                NRTContext.get_meminfos = _lean_meminfos
            if _LLVM_LOCK is not None:
                with _LLVM_LOCK._lock:  # (no call into LLVM between its callbacks meanwhile)
                    self.callbacks = [c for c in _LLVM_LOCK._cblist
                                      if getattr(c[0], "__module__", "").startswith("numba")]
                    for acquire, release in self.callbacks:
                        ffi.unregister_lock_callback(acquire, release)
            return
        self.depth += 1

    def on_end(self, ev):
        if self.depth == 0:
            return
        self.depth -= 1
        if self.depth == 0:
            try:
                if LEAN_MEMINFOS:
                    NRTContext.get_meminfos = numba_get_meminfos
            finally:
                if _LLVM_LOCK is not None:
                    callbacks, self.callbacks = self.callbacks, []
                    with _LLVM_LOCK._lock:
                        for cb in callbacks:
                            if cb not in _LLVM_LOCK._cblist:
                                ffi.register_lock_callback(*cb)


#: llvmlite's lock around its calls into LLVM, whose callbacks :class:`_LeanWhileCompiling`
#: sets aside (None if it is not the object this module knows: the callbacks then stay).
_LLVM_LOCK = getattr(ffi.lib, "_lock", None)
if not (isinstance(getattr(_LLVM_LOCK, "_cblist", None), list)
        and hasattr(getattr(_LLVM_LOCK, "_lock", None), "acquire")):
    _LLVM_LOCK = None

event.register("numba:compile", _LeanWhileCompiling())


# -- linked-only code libraries -----------------------------------------------------------

class LinkOnlyLibrary(JITCodeLibrary):
    """The code library of everything compiled for a kernel (module docstring): unless it
    has a CPython wrapper (a function Python may call), finalising it links the libraries
    it calls and stops, without -O3 or machine code."""

    #: The cache's name for a library kept as the bitcode of its module for linking.
    KIND = "discgym-link-only"
    #: Whether this library is linked only (decided when it is finalised).
    link_only = False
    #: Whether it is optimised (-O3) before it is linked (``kernel(optimise=True)``).
    optimise = False
    #: Whether its functions are inlined into their callers (``kernel(inline_code=True)``).
    inline_code = False

    def finalize(self):
        require_global_compiler_lock()
        self._raise_if_finalized()
        if any(fn.name.startswith(_PYTHON_ENTRY) and not fn.is_declaration
               for fn in self._final_module.functions):
            return super().finalize()  # (an njit function a kernel calls: Python may too)
        self.link_only = True
        seen = set()
        for library in self._linking_libraries:
            if library not in seen:
                seen.add(library)
                self._reload_init.update(library._reload_init)
                self._final_module.link_in(library._get_module_for_linking(), preserve=True)
        if self.optimise:
            self._optimize_final_module()
        self._finalize_dynamic_globals()
        self._define_environments()
        self._finalized = True

    def add_ir_module(self, ir_module):
        if self.inline_code:  # (LLVM's inliner, run by the entry points, then inlines them)
            for fn in ir_module.functions:
                if not fn.is_declaration and not fn.name.startswith(_PYTHON_ENTRY):
                    fn.attributes.add("alwaysinline")
        return super().add_ir_module(ir_module)

    def _define_environments(self):
        """Define in the engine the environment globals this module uses that it does not
        have yet, in a module of their own, so that numba can point each at its function's
        ``Environment`` now (``set_env``), as it does after compiling an ordinary function.
        The entry points linking this code then refer to those same globals."""
        engine = self._codegen._engine
        names = [gv.name for gv in self._final_module.global_variables
                 if gv.name.startswith(_ENV_PREFIX) and not engine.is_symbol_defined(gv.name)]
        if not names:
            return
        module = self._codegen._create_empty_module(f"{self.name}.environments")
        for name in names:
            gv = llvmir.GlobalVariable(module, cgutils.voidptr_t, name=name)
            gv.linkage = "common"
            gv.initializer = cgutils.get_null_value(gv.type.pointee)
        engine.add_module(ll.parse_assembly(str(module)))
        engine.finalize_object()

    def serialize_using_object_code(self):
        # (numba's cache asks every library for its object code; a linked-only one has none)
        self._ensure_finalized()
        if not self.link_only:
            return super().serialize_using_object_code()
        return self.name, self.KIND, self._get_module_for_linking().as_bitcode()

    @classmethod
    def _unserialize(cls, codegen, state):
        name, kind, data = state
        if kind != cls.KIND:  # (object code: an njit function, or a kernel cached before)
            with _libraries_of(codegen, JITCodeLibrary):
                return codegen.unserialize_library(state)
        self = cls(codegen, name)
        self._final_module = self._shared_module = ll.parse_bitcode(data)
        self.link_only = True
        self._finalize_dynamic_globals()
        self._define_environments()
        self._finalized = True
        return self


@contextlib.contextmanager
def _libraries_of(codegen, cls):
    """Within: the code libraries ``codegen`` creates are ``cls``'s (numba creates them
    through ``codegen._library_class``; the global compiler lock is held throughout)."""
    saved = codegen.__dict__.get("_library_class")
    codegen._library_class = cls
    try:
        yield
    finally:
        if saved is None:
            del codegen._library_class
        else:
            codegen._library_class = saved


class _KernelCompiler(Compiler):
    """numba's default compiler, everything compiled within (the kernel, the kernels and
    numba's overloads it calls, the bodies of its ``prange`` loops) in
    :class:`LinkOnlyLibrary` s."""

    def _compile_core(self):
        codegen = self.state.targetctx.codegen()
        with _libraries_of(codegen, LinkOnlyLibrary):
            if self.state.library is None:  # (the kernel's own library: numba's, made here)
                self.state.library = codegen.create_library(self.state.func_id.func_qualname)
                self.state.library.enable_object_caching()
                func = self.state.func_id.func
                self.state.library.optimise = getattr(func, "_discgym_optimise", False)
                self.state.library.inline_code = getattr(func, "_discgym_inline_code", False)
            return super()._compile_core()


class _KernelCacheImpl(CompileResultCacheImpl):
    def rebuild(self, target_context, payload):
        with _libraries_of(target_context.codegen(), LinkOnlyLibrary):
            return super().rebuild(target_context, payload)


def lock_folder(disp) -> Path | None:
    """The folder of ``disp``'s numba cache, where the locks of its kernels are kept; None
    without a cache."""
    path = getattr(getattr(disp, "_cache", None), "_cache_path", None)
    return None if path is None else Path(path)


def _index_lock(cache, sig=None) -> Path | None:
    """The lock of a function's cache index (``cache``: its numba cache), or of one of its
    versions (``sig``: the argument types); None without a cache."""
    index = getattr(getattr(cache, "_cache_file", None), "_index_name", None)
    if index is None:
        return None
    if sig is not None:
        digest = hashlib.sha256(repr(tuple(sig)).encode()).hexdigest()[:16]
        index = f"{index}.{digest}"
    return Path(cache._cache_path) / f"{index}{locks.SUFFIX}"


class _KernelCache(FunctionCache):
    """numba's function cache, storing and loading a kernel as a linked-only library; a
    version is saved under the lock of the function's index (numba rewrites a function's
    index at each save: two writers at once could lose an entry)."""

    _impl_class = _KernelCacheImpl

    def save_overload(self, sig, data):
        with locks.hold(_index_lock(self), f"saving {self._name}"):
            return super().save_overload(sig, data)


class KernelDispatcher(CPUDispatcher):
    """A dispatcher compiled without a Python entry and linked only; a call from Python
    runs its twin (:func:`.jit.python_twin`)."""

    #: ``disp -> dispatcher``: the twin a call from Python runs (set by :mod:`.jit`, which
    #: makes twins without numba's internals).
    twin_of = None

    def __call__(self, *args, **kwargs):
        return type(self).twin_of(self)(*args, **kwargs)

    def compile(self, sig):
        # (compiled or loaded under a lock shared with other processes: a process reaching
        # a version another is compiling waits for it, then loads it)
        args = tuple(sigutils.normalize_signature(sig)[0])
        if args in self.overloads:
            return super().compile(sig)
        f = self.py_func
        with locks.hold(_index_lock(getattr(self, "_cache", None), args),
                        f"compiling {f.__module__}.{f.__qualname__}{args}"):
            return super().compile(sig)

    def enable_caching(self):
        self._cache = _KernelCache(self.py_func)


def make_kernel(f, options: dict, optimise: bool, inline_code: bool = False
                ) -> KernelDispatcher:
    """The kernel of ``f`` (``options``: numba's jit options, without wrappers; ``optimise``,
    ``inline_code``: :func:`.jit.kernel`'s)."""
    f._discgym_optimise = bool(optimise)
    f._discgym_inline_code = bool(inline_code)
    disp = KernelDispatcher(py_func=f, locals=options.pop("locals", {}), targetoptions=options,
                            pipeline_class=_KernelCompiler)
    disp.enable_caching()
    return disp


def is_linked_only(cres) -> bool:
    """Whether a compile result (a dispatcher's overload) has no machine code of its own."""
    return isinstance(cres.library, LinkOnlyLibrary) and cres.library.link_only
