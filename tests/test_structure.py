"""benchmarks/structure.py: every metric of the kernel layer and the package finds its
violation in a tiny synthetic package and passes on the clean one; the script runs on this
checkout."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "structure.py"
_spec = importlib.util.spec_from_file_location("discgym_structure", SCRIPT)
structure = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = structure  # (dataclasses look their module up)
_spec.loader.exec_module(structure)

RULES = [fn for fn, _callers in structure.RULES.values()]


def lines(prefix: str, n: int) -> str:
    """n distinct lines of code."""
    return "".join(f"{prefix}_{k} = {k}\n" for k in range(n))


def function(name: str, n_lines: int, n_params: int = 1, deco: str = "@kernel",
             indent: str = "") -> str:
    """A function of n_lines lines from its def to its last line, under ``deco``."""
    params = ", ".join(f"p{k}" for k in range(n_params))
    body = [f"    {name}_{k} = p0 + {k}" for k in range(n_lines - 2)] + ["    return p0"]
    return "".join(f"{indent}{ln}\n" for ln in [deco, f"def {name}({params}):", *body] if ln)


def simulation(n_methods: int) -> str:
    return "from .kernels import step\n\n\nclass Simulation:\n" + "".join(
        f"    def m{k}(self):\n        return step.advance(self._x{k})\n" for k in range(n_methods))


# A package that meets every target: the rules once in kernels/rules.py and called by both
# integrators (by name, by alias, as module.name), numba's privates in the gate module only.
CLEAN = {
    "discgym/__init__.py": '"""The package."""\n\nfrom .simulation import Simulation\n'
                           "__version__ = '1'\n",
    "discgym/simulation.py": simulation(3),
    "discgym/scene.py": lines("scene", 20),
    "discgym/kernels/__init__.py": "from . import jit  # noqa\n",
    "discgym/kernels/jit.py": "import numba.core.codegen as cg\nfrom numba.core import _private\n"
                              "from . import structs\n\n\ndef kernel(f):\n"
                              "    return cg._library_class, _private, structs.Consts._fields\n",
    "discgym/kernels/structs.py": "from typing import NamedTuple\n\n\nclass Consts(NamedTuple):"
                                  "\n    dt: float\n",
    "discgym/kernels/rules.py": "from numba import njit\n\n\n" + "".join(
        function(r, 3, 2, "@njit(cache=True, inline='always')") for r in RULES),
    "discgym/kernels/events.py": "import discgym.kernels.rules as rules\nfrom .jit import kernel\n"
                               f"from .rules import {RULES[0]} as _first\n\n\n@kernel\n"
                               "def advance(p0):\n    obj = p0\n    obj._state = 1\n"
                               f"    _first(p0, 1)\n" + "".join(
                                   f"    rules.{r}(p0, 1)\n" for r in RULES[1:]),
    "discgym/kernels/event_driven.py": f"from .rules import {', '.join(RULES)}\n\n\n"
                                       "class Loop:\n    def run(self, p0):\n"
                                       "        self._n = 0\n" + "".join(
                                           f"        {r}(p0, 2)\n" for r in RULES),
}

# Six code lines; the copy differs only in white space, comments, a docstring between them
# and its indentation (all passed over), so it is the same block.
BLOCK = ("total = 0\nfor k in range(n):\n    total += k * k\n    if total > limit:\n"
         "        break\nprint(total)\n")
BLOCK_COPY = ('def again(n, limit):\n    total  =  0  # restart\n    # the loop\n'
              '    for k in range(n):\n        total += k * k\n        """a note"""\n'
              "\n        if total > limit:\n            break\n    print(total)\n")


def build(root: Path, files: dict[str, str | None]) -> Path:
    """CLEAN with ``files`` laid over it (None removes a file)."""
    for rel, text in {**CLEAN, **files}.items():
        if text is not None:
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            (root / rel).write_text(text)
    return root


def measure(root: Path) -> dict[tuple[str, str], object]:
    mods = structure.load(root / "discgym")
    known = {m.name for m in mods}
    return {(scope, m.name): m for scope, (_, run) in structure.SCOPES.items()
            for m in run(mods, known)}


def metric(found: dict, scope: str, prefix: str):
    [m] = [m for (s, name), m in found.items() if s == scope and name.startswith(prefix)]
    return m


def test_the_clean_package_meets_every_target(tmp_path):
    found = measure(build(tmp_path, {}))
    failed = {k: m.details for k, m in found.items() if m.ok is False}
    assert not failed
    assert metric(found, "kernels", "event rules").value == f"{len(RULES)} of {len(RULES)}"


# (scope, metric, files laid over CLEAN, a detail the metric must print)
VIOLATIONS = {
    "long kernels module": ("kernels", "lines per module", {
        "discgym/kernels/big.py": lines("big", 801)}, "kernels/big.py 801"),
    "long module": ("package", "lines per module", {"discgym/env.py": lines("e", 801)},
                    "env.py 801"),
    "long kernel": ("kernels", "longest kernel", {
        "discgym/kernels/big.py": "from numba import njit\n\n\n" + function("f", 121, 1, "@njit")},
        "kernels/big.py:5 f 121"),
    "long method": ("package", "longest function", {
        "discgym/env.py": "class Env:\n" + function("step", 121, 1, "", "    ")},
        "env.py:2 Env.step 121"),
    "wide kernel": ("kernels", "widest kernel", {
        "discgym/kernels/big.py": function("f", 3, 15)}, "kernels/big.py:2 f 15"),
    "11 kernels of 12": ("kernels", "kernels of 12+", {
        "discgym/kernels/big.py": "".join(function(f"f{k}", 3, 12) for k in range(11))},
        "kernels/big.py:2 f0 12"),
    "rule not defined": ("kernels", "event rules", {
        "discgym/kernels/rules.py": "".join(function(r, 3, 2) for r in RULES[1:])},
        f"{RULES[0]} not defined"),
    "rule written twice": ("kernels", "event rules", {
        "discgym/kernels/clusters.py": function(RULES[1], 3, 2)},
        f"{RULES[1]} defined 2 times (kernels/clusters.py, kernels/rules.py)"),
    "rule used by one integrator": ("kernels", "event rules", {
        "discgym/kernels/event_driven.py": f"from .rules import {RULES[2]}\n"},
        f"{RULES[-1]} in kernels/rules.py, called from kernels/events.py"),
    "private from-import": ("kernels", "private names", {
        "discgym/kernels/walls.py": "from .events import advance, _helper\n"},
        "kernels/walls.py:1 from .events import _helper"),
    "private module attribute": ("kernels", "private names", {
        "discgym/kernels/walls.py": "from . import events\n\n\ndef f():\n    return events._x\n"},
        "kernels/walls.py:5 events._x"),
    "private of an imported module": ("package", "private names", {
        "discgym/env.py": "import discgym.kernels.step as s\nY = s._helper\n"},
        "env.py:2 s._helper"),
    "numba privates outside the gate": ("kernels", "private names", {
        "discgym/kernels/walls.py": "from numba.core import _private\n"},
        "kernels/walls.py:1 from numba.core import _private"),
    "private across the package": ("package", "private names", {
        "discgym/env.py": "from .simulation import Simulation, _as_scene\n"},
        "env.py:1 from .simulation import _as_scene"),
    "duplicate in kernels": ("kernels", "duplicated blocks", {
        "discgym/kernels/a.py": "n, limit = 3, 9\n" + BLOCK,
        "discgym/kernels/b.py": BLOCK_COPY}, "kernels/a.py:2-7 ~ kernels/b.py:2-10"),
    "3 duplicates in the package": ("package", "duplicated blocks", {
        "discgym/a.py": "n, limit = 3, 9\n" + BLOCK, "discgym/b.py": BLOCK_COPY,
        "discgym/c.py": "import sys\n" + BLOCK}, "a.py:2-7 ~ c.py:2-7"),
    "upward imports": ("kernels", "imports of the package above", {
        "discgym/kernels/walls.py": "from .. import scene\nfrom discgym.env import X\n\n\n"
                                    "def f():\n    import discgym\n    return discgym\n"},
        "kernels/walls.py:6 import discgym"),
    "Simulation of 46 methods": ("package", "class Simulation", {
        "discgym/simulation.py": simulation(46)}, None),
    "Simulation of 701 lines": ("package", "class Simulation", {
        "discgym/simulation.py": "class Simulation:\n" + "".join(
            f"    a{k} = {k}\n" for k in range(700))}, None),
    "import cycle": ("package", "import cycles", {
        "discgym/a.py": "from . import b\nX = 1\n", "discgym/b.py": "from .a import X\n"},
        "a -> b -> a"),
    "cycle through the package": ("package", "import cycles", {
        "discgym/kernels/step.py": "from .. import Simulation\n"},
        "discgym -> simulation -> kernels.step -> discgym"),
}


@pytest.mark.parametrize("case", VIOLATIONS)
def test_each_metric_finds_its_violation(tmp_path, case):
    scope, prefix, files, detail = VIOLATIONS[case]
    found = measure(build(tmp_path, files))
    m = metric(found, scope, prefix)
    assert m.ok is False, m
    assert detail is None or any(detail in d for d in m.details), m.details
    assert [name for (s, name), x in found.items() if x.ok is False and s == scope] == [m.name]


def test_every_target_can_fail(tmp_path):
    found = measure(build(tmp_path, {}))
    covered = {(scope, prefix) for scope, prefix, _, _ in VIOLATIONS.values()}
    for (scope, name), m in found.items():
        if m.ok is not None:
            assert any(s == scope and name.startswith(p) for s, p in covered), name


@pytest.mark.parametrize("files, scope, prefix", [
    ({"discgym/kernels/big.py": lines("big", 800)}, "kernels", "lines per module"),
    ({"discgym/scene.py": lines("scene", 900)}, "package", "lines per module"),
    ({"discgym/kernels/big.py": function("f", 120)}, "kernels", "longest kernel"),
    ({"discgym/kernels/big.py": function("f", 121, 1, "")}, "kernels", "longest kernel"),
    ({"discgym/kernels/big.py": function("f", 3, 14)}, "kernels", "widest kernel"),
    ({"discgym/kernels/big.py": function("f", 3, 15, "@other")}, "kernels", "widest kernel"),
    ({"discgym/kernels/big.py": "".join(function(f"f{k}", 3, 12) for k in range(10))},
     "kernels", "kernels of 12+"),
    ({"discgym/simulation.py": simulation(45)}, "package", "class Simulation"),
    ({"discgym/a.py": "n, limit = 3, 9\n" + BLOCK[:-13], "discgym/b.py": BLOCK_COPY},
     "package", "duplicated blocks"),
    ({"discgym/a.py": "from .scene import (\n" + "".join(f"    scene_{k},\n" for k in range(8))
      + ")\n", "discgym/b.py": "from .scene import (\n" + "".join(
          f"    scene_{k},\n" for k in range(8)) + ")\n"}, "package", "duplicated blocks"),
    ({"discgym/a.py": "n, limit = 3, 9\n" + BLOCK, "discgym/b.py": BLOCK_COPY},
     "package", "duplicated blocks"),
    ({"discgym/kernels/c.py": "from discgym.kernels import rules\nimport discgym.kernels.jit\n"},
     "kernels", "imports of the package above"),
    ({"discgym/a.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from . import b\n",
      "discgym/b.py": "from . import a\n"}, "package", "import cycles"),
])
def test_just_within_a_target_passes(tmp_path, files, scope, prefix):
    found = measure(build(tmp_path, files))
    assert metric(found, scope, prefix).ok, metric(found, scope, prefix)


@pytest.mark.parametrize("deco", ["@kernel", "@kernel(parallel=True)", "@njit",
                                  "@njit(cache=True)", "@numba.njit", "@register_jitable"])
def test_every_kernel_decorator_makes_a_kernel(tmp_path, deco):
    found = measure(build(tmp_path, {"discgym/kernels/big.py": function("f", 3, 15, deco)}))
    assert metric(found, "kernels", "widest kernel").value == "15 kernels/big.py:2 f"


def test_a_cycle_through_a_function_is_information(tmp_path):
    found = measure(build(tmp_path, {"discgym/a.py": "from . import b\nX = 1\n",
                                     "discgym/b.py": "def f():\n    from .a import X\n"}))
    assert metric(found, "package", "import cycles").ok
    info = metric(found, "package", "  + cycles through function")
    assert info.ok is None and info.details == ["a -> b -> a"]


def test_check_exits_1_naming_the_failed_target_and_json_has_every_metric(tmp_path, capsys):
    root = build(tmp_path / "tree", {})
    assert structure.main(["--root", str(root), "--check", "all"]) == 0
    assert "check passed" in capsys.readouterr().out
    build(root, {"discgym/kernels/big.py": function("f", 3, 15)})
    out = tmp_path / "out" / "s.json"
    assert structure.main(["--root", str(root), "--check", "kernels", "--json", str(out)]) == 1
    text = capsys.readouterr().out
    assert "package:" not in text and "check FAILED, 1 target(s): kernels: widest" in text
    assert structure.main(["--root", str(root), "--check", "package"]) == 0
    data = json.loads(out.read_text())
    assert data["scopes"]["kernels"]["passed"] is False
    assert len(data["scopes"]["kernels"]["metrics"]) == 8


@pytest.mark.parametrize("argv", [["--scope", "all"], ["--check", "nope"], ["--root"],
                                  ["--scope", "kernels", "--check", "package"],
                                  ["--root", "/nonexistent/checkout"], ["--details", "x"]])
def test_bad_arguments_are_refused_in_one_line(argv, capsys):
    with pytest.raises(SystemExit) as e:
        structure.main(argv)
    out, err = capsys.readouterr()
    assert e.value.code == 2 and out == "" and len(err.splitlines()) == 1, err


def test_the_script_runs_on_this_checkout_without_importing_discgym():
    """(``-I -S``: the standard library only, no site-packages, so no discgym, no numba.)"""
    res = subprocess.run([sys.executable, "-I", "-S", str(SCRIPT), "--details", "2"],
                         capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    assert "kernels: discgym/kernels/\n" in res.stdout
    assert "package: discgym/\n" in res.stdout
    results = [ln.split()[-1] for ln in res.stdout.splitlines() if ln.strip()]
    assert sum(r in ("PASS", "FAIL") for r in results) == 8 + 6, res.stdout


def test_a_file_that_does_not_parse_is_named(tmp_path):
    root = build(tmp_path, {"discgym/kernels/half.py": "def f(:\n"})
    with pytest.raises(SystemExit, match="discgym/kernels/half.py:1: cannot parse"):
        structure.main(["--root", str(root)])
