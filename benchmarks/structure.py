#!/usr/bin/env python
"""The code-structure targets of the kernel layer (``discgym/kernels/``) and of the package
(``discgym/``): each metric measured from the source, its target, PASS or FAIL.

    python benchmarks/structure.py                   # both scopes
    python benchmarks/structure.py --scope kernels   # the kernels (or: --scope package)
    python benchmarks/structure.py --check all       # exit 1 if a target fails, naming it
    python benchmarks/structure.py --json out/structure.json --root OTHER_CHECKOUT

It reads the files with ``ast`` and ``tokenize`` and never imports discgym (nor numba), so it
runs in any plain venv, in about a second. The targets and the table of event rules
(``RULES``) are the constants at the top.

Duplicated blocks follow the exact rows of the tool library's ``duplicates`` command: blank
lines, comments, docstrings, lone punctuation and imports are passed over, white space is
folded, and a block is a maximal run of 6 or more such lines standing to the letter at two
places (``a.py:10-24 ~ b.py:40-54``). Where the two differ: here a trailing comment is passed
over too, and so is every line of a multi-line import or docstring (``duplicates`` drops whole
comment lines and only the first line of an import or docstring); ``duplicates`` drops a run
that stands in more than 8 places, and lists file pairs where this lists each block.
"""

from __future__ import annotations

import argparse
import ast
import io
import json
import re
import sys
import tokenize
from collections import defaultdict
from dataclasses import asdict, dataclass, field
from itertools import combinations
from pathlib import Path

# ------------------------------------------------------------------ targets (edit here)
MAX_MODULE_LINES = 800
LONG_MODULES_ALLOWED = ("scene.py",)  # package scope; paths below discgym/
MAX_FUNCTION_LINES = 120
MAX_KERNEL_PARAMS, WIDE_PARAMS, MAX_WIDE_KERNELS = 14, 12, 10
SIMULATION = ("simulation.py", "Simulation")
MAX_SIMULATION_METHODS, MAX_SIMULATION_LINES = 45, 700
DUPLICATE_LINES = 6
MAX_DUPLICATES = {"kernels": 0, "package": 2}
#: A kernel is a function decorated with one of these (bare, called, or as ``numba.njit``).
KERNEL_DECORATORS = {"kernel", "njit", "register_jitable"}
#: The one module that may use numba's private names, and numba's packages.
NUMBA_GATE, GATED_PACKAGES = "kernels/jit.py", ("numba", "llvmlite")
#: Each event rule, written once and called by both integrators: rule -> function name.
#: (The names of the refactor under way in kernels/rules.py: edit them when they change.)
#: The modules of each integrator's event handling (path prefixes under discgym/).
STEPPED, EXACT = ("kernels/events.py",), ("kernels/event_",)
#: Each event rule: its function, and the integrators that must call it. The stepped
#: integrator's tests of a popped event serve its one event loop (serial and by clusters);
#: the exact integrator, one event per disc, has tests of its own (kernels/rules.py).
RULES = {
    "stale event check": ("stale", (STEPPED,)),
    "round-off guard": ("grazing", (STEPPED,)),
    "partner rule": ("rebound", (STEPPED,)),
    "TC repeats": ("tc_restitution", (STEPPED, EXACT)),
    "outlet booking": ("book_outflow", (STEPPED, EXACT)),
    "thermal-wall heat": ("book_thermal", (STEPPED, EXACT)),
}
#: Underscored names that are public API (namedtuple's), not private.
# (documented public names: namedtuple's methods, os._exit)
PUBLIC_UNDERSCORED = {"_fields", "_field_defaults", "_replace", "_asdict", "_make", "_exit"}
PACKAGE, KERNELS = "discgym", "discgym.kernels"
FUNCTION = ast.FunctionDef | ast.AsyncFunctionDef


@dataclass
class Module:
    rel: str  # path below discgym/, e.g. "kernels/step.py"
    name: str  # dotted, e.g. "discgym.kernels.step"
    package: str  # where its relative imports start
    lines: list[str]
    tree: ast.Module
    nodes: list[ast.AST]  # (each walk of the tree done once, for every metric)
    funcs: list[tuple[str, ast.FunctionDef]]
    imports: list[tuple[ast.Import | ast.ImportFrom, str]]
    code: list[tuple[int, str]]


@dataclass
class Metric:
    name: str
    value: str
    target: str
    ok: bool | None  # None: information, no target
    details: list[str] = field(default_factory=list)


def load(package_dir: Path) -> list[Module]:
    mods = []
    for path in sorted(package_dir.rglob("*.py")):
        if "__pycache__" in path.parts:
            continue
        with tokenize.open(path) as f:  # (in the encoding its cookie declares)
            text = f.read()
        rel = path.relative_to(package_dir).as_posix()
        name = ".".join([PACKAGE, *rel[:-3].split("/")]).removesuffix(".__init__")
        package = name if rel.endswith("__init__.py") else name.rpartition(".")[0]
        lines = text.split("\n")  # (not splitlines: ast counts lines at \n only)
        lines = lines[:-1] if lines[-1] == "" else lines
        try:
            tree = ast.parse(text, rel)
        except SyntaxError as e:  # (a file half-way through an edit: say which, measure none)
            raise SystemExit(f"{PACKAGE}/{rel}:{e.lineno}: cannot parse: {e.msg}") from None
        nodes = list(ast.walk(tree))
        mods.append(Module(rel, name, package, lines, tree, nodes, functions(tree),
                           imports(tree), code_lines(lines, nodes)))
    return mods


# ------------------------------------------------------------------ reading the trees
def statements(node: ast.AST) -> list[ast.AST]:
    """The children that may hold statements: functions, classes and imports stand only in
    these, so a walk need not enter expressions."""
    return [c for c in ast.iter_child_nodes(node)
            if isinstance(c, ast.stmt | ast.excepthandler | ast.match_case)]


def functions(tree: ast.Module) -> list[tuple[str, ast.FunctionDef]]:
    """(qualified name, node) of every function and method, nested ones too."""
    out, stack = [], [(tree, "")]
    while stack:
        node, prefix = stack.pop()
        for child in statements(node):
            if isinstance(child, FUNCTION):
                out.append((prefix + child.name, child))
            named = isinstance(child, FUNCTION | ast.ClassDef)
            stack.append((child, f"{prefix}{child.name}." if named else prefix))
    return out


def imports(tree: ast.Module) -> list[tuple[ast.Import | ast.ImportFrom, str]]:
    """(import statement, where: "module", "function" or "typing") of a module; "typing":
    under ``if TYPE_CHECKING:``, which never runs (so closes no cycle)."""
    out, stack = [], [(tree, "module")]
    while stack:
        node, where = stack.pop()
        if isinstance(node, ast.Import | ast.ImportFrom):
            out.append((node, where))
        elif isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            stack += [(c, "typing") for c in node.body] + [(c, where) for c in node.orelse]
        else:
            inner = "function" if isinstance(node, FUNCTION) and where == "module" else where
            stack += [(c, inner) for c in statements(node)]
    return out


def code_lines(lines: list[str], nodes: list[ast.AST]) -> list[tuple[int, str]]:
    """(line number, text) of the lines that count for duplicates, white space folded."""
    skip = set()
    for node in nodes:
        bare_string = isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) \
            and isinstance(node.value.value, str)  # a docstring, or a string as a comment
        if bare_string or isinstance(node, ast.Import | ast.ImportFrom):
            skip.update(range(node.lineno, node.end_lineno + 1))
    code = list(lines)
    for tok in tokenize.generate_tokens(io.StringIO("\n".join(code) + "\n").readline):
        if tok.type == tokenize.COMMENT:  # (tokenize knows a '#' in a string is none)
            code[tok.start[0] - 1] = code[tok.start[0] - 1][:tok.start[1]]
    folded = ((i, " ".join(line.split())) for i, line in enumerate(code, 1) if i not in skip)
    return [(i, s) for i, s in folded if len(s) >= 3 and not re.fullmatch(r"[{}()\[\];,:.]*",
                                                                           s.replace(" ", ""))]


def span(node: ast.AST) -> int:
    return node.end_lineno - node.lineno + 1


def is_kernel(fn: ast.FunctionDef) -> bool:
    names = [d.func if isinstance(d, ast.Call) else d for d in fn.decorator_list]
    return any(getattr(d, "id", getattr(d, "attr", None)) in KERNEL_DECORATORS for d in names)


def n_params(fn: ast.FunctionDef) -> int:
    a = fn.args
    return len(a.posonlyargs) + len(a.args) + len(a.kwonlyargs) + bool(a.vararg) + bool(a.kwarg)


def ranked(mods: list[Module], measure, kernels_only: bool) -> list[tuple[int, str]]:
    """(measure, "file:line name") of the functions, largest first."""
    found = sorted((-measure(f), m.rel, f.lineno, q) for m in mods for q, f in m.funcs
                   if is_kernel(f) or not kernels_only)
    return [(-n, f"{rel}:{line} {q}") for n, rel, line, q in found]


def private(name: str) -> bool:
    dunder = name.startswith("__") and name.endswith("__")
    return name.startswith("_") and not dunder and name not in PUBLIC_UNDERSCORED


def source_of(mod: Module, node: ast.ImportFrom) -> str:
    """The absolute name of the module a ``from ... import`` reads from."""
    if not node.level:
        return node.module or ""
    parts = mod.package.split(".")
    return ".".join(parts[:len(parts) - node.level + 1] + [node.module or ""]).rstrip(".")


def dotted(node: ast.AST) -> str | None:
    if isinstance(node, ast.Attribute) and (base := dotted(node.value)):
        return f"{base}.{node.attr}"
    return node.id if isinstance(node, ast.Name) else None


def import_graph(mods: list[Module], known: set[str], with_functions: bool):
    """importer -> the discgym modules it loads: ``from p import x`` loads ``p.x`` where that
    is a module, else ``p`` (for its names)."""
    graph = defaultdict(set)
    for m in mods:
        for node, where in m.imports:
            if where == "typing" or (where == "function" and not with_functions):
                continue
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                src = source_of(m, node)
                names = [f"{src}.{a.name}" if f"{src}.{a.name}" in known else src
                         for a in node.names]
            for n in names:
                while n and n not in known:  # (``import discgym.x.y``, y not a module)
                    n = n.rpartition(".")[0]
                if n and n != m.name:
                    graph[m.name].add(n)
    return graph


def cycles(graph: dict[str, set[str]]) -> dict[frozenset, str]:
    """Each group of modules that reach each other through imports -> a shortest loop
    through its first module (and the group's size, if the loop leaves some out)."""
    reach = {}
    for v in list(graph):
        seen, todo = set(), [v]
        while todo:
            new = graph.get(todo.pop(), set()) - seen
            seen |= new
            todo += new
        reach[v] = seen
    groups = {frozenset(w for w in reach[v] if v in reach.get(w, ())) for v in reach
              if v in reach[v]}
    loops = {}
    for group in sorted(groups, key=min):
        start = min(group)
        paths, queue = {start: [start]}, [start]
        for v in queue:  # breadth first
            for w in sorted(graph[v] & group - paths.keys()):
                paths[w] = paths[v] + [w]
                queue.append(w)
        loop = next(paths[v] + [start] for v in queue if start in graph[v])
        more = f" (of a group of {len(group)} modules)" if len(group) > len(loop) - 1 else ""
        loops[group] = " -> ".join(n.removeprefix(f"{PACKAGE}.") for n in loop) + more
    return loops


# ------------------------------------------------------------------ metrics
def module_lines(mods: list[Module], allowed=()) -> Metric:
    sizes = sorted(((len(m.lines), m.rel) for m in mods if m.rel not in allowed), reverse=True)
    n, rel = sizes[0] if sizes else (0, "-")
    note = f"; {', '.join(allowed)} exempt" if allowed else ""
    over = [f"{r} {k}" for k, r in sizes if k > MAX_MODULE_LINES]
    return Metric(f"lines per module (max{note})", f"{n} {rel}", f"<= {MAX_MODULE_LINES}",
                  not over, over)


def longest_function(mods: list[Module], kernels_only: bool) -> Metric:
    found = ranked(mods, span, kernels_only)
    n, where = found[0] if found else (0, "-")
    over = [f"{w} {k}" for k, w in found if k > MAX_FUNCTION_LINES]
    return Metric(f"longest {'kernel' if kernels_only else 'function'} (lines)", f"{n} {where}",
                  f"<= {MAX_FUNCTION_LINES}", not over, over)


def widest_kernel(mods: list[Module]) -> Metric:
    found = ranked(mods, n_params, kernels_only=True)
    n, where = found[0] if found else (0, "-")
    over = [f"{w} {k}" for k, w in found if k > MAX_KERNEL_PARAMS]
    return Metric("widest kernel (parameters)", f"{n} {where}", f"<= {MAX_KERNEL_PARAMS}",
                  not over, over)


def wide_kernels(mods: list[Module]) -> Metric:
    wide = [f"{w} {k}" for k, w in ranked(mods, n_params, True) if k >= WIDE_PARAMS]
    return Metric(f"kernels of {WIDE_PARAMS}+ parameters", str(len(wide)),
                  f"<= {MAX_WIDE_KERNELS}", len(wide) <= MAX_WIDE_KERNELS, wide)


def rules_written_once(mods: list[Module]) -> Metric:
    """Each RULES function defined once in the scope and called (by its name, an alias or
    ``module.name``) from a module of each integrator it names."""
    defined, callers = defaultdict(list), defaultdict(set)
    for m in mods:
        alias = {a.asname: a.name for n in m.nodes if isinstance(n, ast.ImportFrom)
                 for a in n.names if a.asname}
        for _, f in m.funcs:
            defined[f.name].append(m.rel)
        for node in m.nodes:
            if isinstance(node, ast.Call):
                name = getattr(node.func, "id", getattr(node.func, "attr", None))
                callers[alias.get(name, name)].add(m.rel)
    details = []
    for rule, (fn, groups) in RULES.items():
        where, others = defined[fn], sorted(callers[fn] - set(defined[fn]))
        if len(where) != 1:
            how = f"defined {len(where)} times ({', '.join(where)})" if where else "not defined"
            details.append(f"FAIL {rule}: {fn} {how}")
        else:
            ok = all(any(o.startswith(g) for o in others for g in group) for group in groups)
            details.append(f"{'ok  ' if ok else 'FAIL'} {rule}: {fn} in "
                           f"{where[0]}, called from {', '.join(others) or 'no other module'}")
    held = sum(d.startswith("ok") for d in details)
    return Metric("event rules written once, called by both integrators", f"{held} of "
                  f"{len(RULES)}", f"{len(RULES)} of {len(RULES)}", held == len(RULES), details)


def private_crossings(mods: list[Module], known: set[str]) -> Metric:
    """``from m import _x``, ``import m._x`` or ``m._x`` with ``m`` a name an import binds to
    a module (``obj._x`` on any other object is that object's business)."""
    found = []
    for m in mods:
        def exempt(module: str, m=m) -> bool:  # numba's internals, in their one module
            return m.rel == NUMBA_GATE and module.split(".")[0] in GATED_PACKAGES

        bound, modules = {}, set(known)  # name -> the module it is; all names of modules
        for node, _ in m.imports:
            if isinstance(node, ast.Import):
                for a in node.names:
                    parts = a.name.split(".")
                    modules.update(".".join(parts[:k]) for k in range(1, len(parts) + 1))
                    bound[a.asname or parts[0]] = a.name if a.asname else parts[0]
                    if any(map(private, parts)) and not exempt(a.name):
                        found.append(f"{m.rel}:{node.lineno} import {a.name}")
                continue
            src = source_of(m, node)
            bound |= {a.asname or a.name: f"{src}.{a.name}" for a in node.names
                      if f"{src}.{a.name}" in known}
            names = [a.name for a in node.names if private(a.name)]
            if (names or any(map(private, src.split(".")))) and not exempt(src):
                shown = ", ".join(names or [a.name for a in node.names])
                found.append(f"{m.rel}:{node.lineno} from {'.' * node.level}{node.module or ''}"
                             f" import {shown}")
        for node in m.nodes:
            if isinstance(node, ast.Attribute) and private(node.attr) \
                    and (name := dotted(node.value)) and name.split(".")[0] in bound:
                root, _, rest = name.partition(".")
                module = bound[root] + (f".{rest}" if rest else "")
                if module in modules and not exempt(module):
                    found.append(f"{m.rel}:{node.lineno} {name}.{node.attr}")
    return Metric("private names crossing a module boundary", str(len(found)), "0",
                  not found, found)


def duplicate_blocks(mods: list[Module], most: int) -> Metric:
    rows = {m.rel: m.code for m in mods}
    places = defaultdict(list)  # DUPLICATE_LINES counted lines -> (file, index of the first)
    for rel, rs in rows.items():
        for i in range(len(rs) - DUPLICATE_LINES + 1):
            places[tuple(s for _, s in rs[i:i + DUPLICATE_LINES])].append((rel, i))
    pairs = {(fa, i, fb, j) for spots in places.values()
             for (fa, i), (fb, j) in combinations(sorted(spots), 2)
             if fa != fb or j >= i + DUPLICATE_LINES}  # (not a block overlapping itself)
    blocks = []
    for fa, i, fb, j in pairs:
        if (fa, i - 1, fb, j - 1) in pairs:
            continue  # inside a longer run
        n = 1  # windows in the run
        while (fa, i + n, fb, j + n) in pairs:
            n += 1
        k, a, b = n + DUPLICATE_LINES - 2, rows[fa], rows[fb]  # (k: its last line's offset)
        blocks.append((-k, f"{fa}:{a[i][0]}-{a[i + k][0]} ~ {fb}:{b[j][0]}-{b[j + k][0]}"))
    return Metric(f"duplicated blocks of {DUPLICATE_LINES}+ lines", str(len(blocks)),
                  f"<= {most}", len(blocks) <= most,
                  [f"{w} ({1 - k} lines)" for k, w in sorted(blocks)])


def upward_imports(mods: list[Module]) -> Metric:
    """Imports of ``discgym`` or ``discgym.<not kernels>`` in the kernel layer, at module
    level or in a function (``from .. import x`` reads from ``discgym``)."""
    found = []
    for m in mods:
        for node, _ in m.imports:
            targets = [a.name for a in node.names] if isinstance(node, ast.Import) \
                else [source_of(m, node)]
            if any(t.split(".")[0] == PACKAGE and not f"{t}.".startswith(f"{KERNELS}.")
                   for t in targets):
                found.append(f"{m.rel}:{node.lineno} {ast.unparse(node)}")
    return Metric("imports of the package above the kernels", str(len(found)), "0",
                  not found, sorted(found))


def simulation_size(mods: list[Module]) -> Metric:
    rel, name = SIMULATION  # (looked for elsewhere in the package if it moves)
    found = sorted([((m.rel != rel, m.rel), n) for m in mods for n in m.tree.body
                    if isinstance(n, ast.ClassDef) and n.name == name], key=lambda c: c[0])
    what, target = f"class {name}: methods, lines", \
        f"<= {MAX_SIMULATION_METHODS}, {MAX_SIMULATION_LINES}"
    if not found:
        return Metric(what, "not found", target, False, [f"no class {name} in {PACKAGE}/"])
    (_, where), cls = found[0]
    methods = sum(isinstance(n, FUNCTION) for n in cls.body)
    ok = methods <= MAX_SIMULATION_METHODS and span(cls) <= MAX_SIMULATION_LINES
    return Metric(what, f"{methods}, {span(cls)} {where}:{cls.lineno}", target, ok)


def import_cycles(mods: list[Module], known: set[str]) -> Metric:
    loops = cycles(import_graph(mods, known, with_functions=False))
    return Metric("import cycles (module level)", str(len(loops)), "0", not loops,
                  list(loops.values()))


def function_import_cycles(mods: list[Module], known: set[str]) -> Metric:
    """Cycles closed by an import inside a function: they run, but still tie the modules."""
    top = cycles(import_graph(mods, known, with_functions=False))
    loops = [s for g, s in cycles(import_graph(mods, known, True)).items() if g not in top]
    return Metric("  + cycles through function-level imports", str(len(loops)), "-", None,
                  loops)


# ------------------------------------------------------------------ scopes and output
def kernels_scope(mods: list[Module], known: set[str]) -> list[Metric]:
    ks = [m for m in mods if f"{m.name}.".startswith(f"{KERNELS}.")]
    return [module_lines(ks), longest_function(ks, kernels_only=True), widest_kernel(ks),
            wide_kernels(ks), rules_written_once(ks), private_crossings(ks, known),
            duplicate_blocks(ks, MAX_DUPLICATES["kernels"]), upward_imports(ks)]


def package_scope(mods: list[Module], known: set[str]) -> list[Metric]:
    return [module_lines(mods, LONG_MODULES_ALLOWED), longest_function(mods, False),
            simulation_size(mods), private_crossings(mods, known), import_cycles(mods, known),
            function_import_cycles(mods, known), duplicate_blocks(mods, MAX_DUPLICATES["package"])]


SCOPES = {"kernels": ("discgym/kernels/", kernels_scope),
          "package": ("discgym/", package_scope)}


def show(scope: str, metrics: list[Metric], most: int) -> str:
    out = [f"{scope}: {SCOPES[scope][0]}", f"  {'metric':<53} {'value':<42} {'target':<9} result"]
    for m in metrics:
        result = "info" if m.ok is None else "PASS" if m.ok else "FAIL"
        out.append(f"  {m.name:<53} {m.value:<42} {m.target:<9} {result}")
        shown = m.details if most < 0 else m.details[:most]
        out += [f"      {d}" for d in shown]
        if len(m.details) > len(shown):
            out.append(f"      (+{len(m.details) - len(shown)} more: --details -1 shows all)")
    return "\n".join(out)


class Parser(argparse.ArgumentParser):
    def error(self, message):  # refused in one line, exit 2, before anything is read
        self.exit(2, f"{self.prog}: error: {message} (--help for usage)\n")


def main(argv=None) -> int:
    p = Parser(description="Print the code-structure targets of the kernel layer and the "
                            "package.")
    p.add_argument("--scope", choices=sorted(SCOPES), help="one scope (default: both)")
    p.add_argument("--check", choices=[*sorted(SCOPES), "all"],
                   help="exit 1 if a target of this scope fails (prints that scope)")
    p.add_argument("--json", type=Path, metavar="PATH", help="also write the metrics as JSON")
    p.add_argument("--root", type=Path, help="the checkout to read (default: this script's)")
    p.add_argument("--details", type=int, default=12, metavar="N",
                   help="detail lines shown per metric (-1: all; default 12)")
    args = p.parse_args(argv)
    if args.scope and args.check not in (None, "all", args.scope):
        p.error(f"--scope {args.scope} and --check {args.check} name different scopes")
    root = (args.root or Path(__file__).resolve().parent.parent).resolve()
    if not (root / PACKAGE).is_dir():
        p.error(f"--root {root}: no {PACKAGE}/ package in it")
    check = args.check and (sorted(SCOPES) if args.check == "all" else [args.check])
    scopes = check or ([args.scope] if args.scope else list(SCOPES))

    mods = load(root / PACKAGE)
    known = {m.name for m in mods}
    results = {s: SCOPES[s][1](mods, known) for s in scopes}
    print(f"structure of {root / PACKAGE} ({len(mods)} modules)\n")
    print("\n\n".join(show(s, ms, args.details) for s, ms in results.items()))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"root": str(root), "scopes": {
            s: {"passed": all(m.ok is not False for m in ms), "metrics": [asdict(m) for m in ms]}
            for s, ms in results.items()}}, indent=1) + "\n")
    if not check:
        return 0
    failed = [f"{s}: {m.name}" for s in check for m in results[s] if m.ok is False]
    print("\ncheck " + (f"FAILED, {len(failed)} target(s): " + "; ".join(failed) if failed
                        else f"passed: every target of {' and '.join(check)} holds"))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
