"""benchmarks/ladder.py on a tiny budget (2 seeds, 6-step episodes of 80 discs): it writes its
JSON (per-seed returns, table, the oracle's budget) and its plot, and refuses bad seeds; every
argument is checked before any work (one line, exit 2, nothing run or written) and the JSON is
renamed into place."""

import copy
import importlib.util
import json
import os
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
spec = importlib.util.spec_from_file_location("ladder", ROOT / "benchmarks" / "ladder.py")
ladder = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ladder)

TINY = ["--env-kwarg", "n_discs=80", "--env-kwarg", "episode_steps=6",
        "--env-kwarg", "max_episode_steps=6"]


def test_a_tiny_ladder_writes_its_json_table_and_plot(tmp_path, capsys):
    out = tmp_path / "{env}.json"
    png = tmp_path / "ladder.png"
    rc = ladder.main(["--env", "all", "--seeds", "2", "--search-seeds", "2", *TINY,
                      "--out", str(out), "--plot", "--plot-path", str(png)])
    assert rc == 0
    text = capsys.readouterr().out
    res = json.loads((tmp_path / "DiscReactor-v0.json").read_text())
    assert res["eval_seeds"] == [1000, 1001] and res["search_seeds"] == [0, 1]
    assert res["episode_steps"] == [6, 6]
    assert set(res["policies"]) == set(ladder.LADDER)
    for row in res["policies"].values():
        assert len(row["returns"]) == 2
        m = row["mean"]
        assert m["low"] <= m["value"] <= m["high"]
        assert m["value"] == pytest.approx(np.mean(row["returns"]))
    # the oracle never does worse than the controller it plans with (rollouts to the end)
    assert all(o >= h for o, h in zip(res["policies"]["oracle"]["returns"],
                                      res["policies"]["searched"]["returns"]))
    b = res["oracle_budget"]
    assert b["horizon"] == "episode end" and b["plan_mismatches"] == 0
    assert b["simulated_steps_per_episode"] > 6 and b["seconds_per_episode"] > 0
    assert len(res["best_constant"]["search_means"]) == 120
    assert res["table"] in text and "| random |" in res["table"]
    assert {"numpy", "scipy", "gymnasium", "numba"} <= set(res["versions"])
    assert res["date"] and res["machine"]
    assert png.stat().st_size > 1000


def test_the_searched_planner_and_oracle_rows(tmp_path, capsys):
    """The searched controller, the planner on it (fresh futures, candidates over every
    control) and the clairvoyant oracle on it, never below the searched controller; their
    budgets; the steps are the paired differences of consecutive rows."""
    out = tmp_path / "{env}.json"
    assert ladder.main(["--env", "DiscFlow-v0", "--seeds", "2", "--search-seeds", "1",
                        *TINY, "--out", str(out), "--planner-futures", "2"]) == 0
    res = json.loads((tmp_path / "DiscFlow-v0.json").read_text())
    r = {k: np.array(res["policies"][k]["returns"]) for k in ladder.LADDER}
    assert np.all(r["oracle"] >= r["searched"])
    pb, ob = res["planner_budget"], res["oracle_budget"]
    assert pb["futures_per_candidate"] == 2 and ob["futures_per_candidate"] == 1
    assert 1 < pb["candidates_per_replan"] <= 10 + 2 * 2 and pb["replans_per_episode"] == 2
    assert pb["rollouts_per_episode"] == pytest.approx(
        2 * pb["candidates_per_replan"] * pb["replans_per_episode"])
    assert "every control" in pb["candidate_rule"] and ob["plan_mismatches"] == 0
    for s, (lo, hi) in zip(res["ladder"], zip(ladder.LADDER[:-1], ladder.LADDER[1:])):
        assert s["step"] == f"{hi} - {lo}"
        assert s["difference"]["value"] == pytest.approx((r[hi] - r[lo]).mean())
    assert res["searched"]["command"].startswith("python benchmarks/search_controller.py")
    assert "| planner (rollout MPC on the searched controller, 2 fresh futures" in res["table"]
    with pytest.raises(SystemExit):
        ladder.main(["--planner-futures", "0", "--out", str(tmp_path / "x.json")])
    assert "--planner-futures" in capsys.readouterr().err


def test_overlapping_or_too_few_seeds_are_refused(tmp_path, capsys):
    with pytest.raises(SystemExit):
        ladder.main(["--seeds", "1", "--out", str(tmp_path / "x.json")])
    with pytest.raises(SystemExit):
        ladder.main(["--first-seed", "5", "--search-seeds", "10",
                     "--out", str(tmp_path / "x.json")])
    assert "--search-seeds" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        ladder.main(["--env", "NoSuchTask-v0"])


def test_the_aggregate_leaves_out_a_task_without_a_scale():
    """A task whose searched controller is not above random has no normalised scale: the
    aggregate leaves it out and says so (a tiny env's ladder, say); the rest are
    aggregated as before."""
    import copy

    files = sorted((ROOT / "docs" / "data").glob("ladder_Disc*-v0.json"))
    results = [json.loads(f.read_text()) for f in files]
    full = ladder.aggregate_table(results)
    bad = copy.deepcopy(results[0])
    bad["env_id"] = "Flat-v0"
    bad["policies"]["searched"]["returns"] = bad["policies"]["random"]["returns"]
    out = ladder.aggregate_table(results + [bad])
    assert out.startswith(full) and out.endswith("no scale): Flat-v0.")
    assert ladder.aggregate_table([bad]) == ("Left out (the searched controller not above "
                                             "random: no scale): Flat-v0.")


# ------------------------------------------------------------------ arguments, before any work

LADDER_JSON = ROOT / "docs" / "data" / "ladder_DiscReactor-v0.json"

#: (argv with TMP for the test's folder, the flag the one line names); TMP/folder, TMP/afile
#: (not JSON) and TMP/other.json (JSON, not a ladder's) exist.
REFUSED = {
    # the issue's
    "replan-every 0": (["--replan-every", "0"], "--replan-every"),
    "horizon 0": (["--horizon", "0"], "--horizon"),
    "first-seed -3": (["--first-seed", "-3"], "--first-seed"),
    "env-kwarg n_discs=-5": (["--env-kwarg", "n_discs=-5"], "--env-kwarg"),
    "env-kwarg unknown": (["--env-kwarg", "no_such_argument=1"], "--env-kwarg"),
    "out an existing folder": (["--out", "TMP/folder"], "--out"),
    # and the rest
    "replan-every -1": (["--replan-every", "-1"], "--replan-every"),
    "horizon -2": (["--horizon", "-2"], "--horizon"),
    "seeds 1": (["--seeds", "1"], "--seeds"),
    "seeds not an int": (["--seeds", "2.5"], "--seeds"),
    "seeds past numpy's": (["--first-seed", str(2**32 - 2), "--seeds", "3"], "--seeds"),
    "first-seed past numpy's": (["--first-seed", str(2**32)], "--first-seed"),
    "search-seeds 0": (["--search-seeds", "0"], "--search-seeds"),
    "search seeds meet the evaluation seeds": (["--first-seed", "5", "--search-seeds", "10"],
                                               "--search-seeds"),
    "planner-futures 0": (["--planner-futures", "0"], "--planner-futures"),
    "planner-gate nan": (["--planner-gate", "nan"], "--planner-gate"),
    "planner-gate inf": (["--planner-gate", "inf"], "--planner-gate"),
    "planner-gate without futures": (["--planner-futures", "1"], "--planner-gate"),
    "env unknown": (["--env", "NoSuchTask-v0"], "--env"),
    "env-kwarg without =": (["--env-kwarg", "n_discs"], "--env-kwarg"),
    "env-kwarg episode_steps=0": (["--env-kwarg", "episode_steps=0"], "--env-kwarg"),
    "env-kwarg max_episode_steps=-5": (["--env-kwarg", "max_episode_steps=-5"], "--env-kwarg"),
    "env-kwarg bad type": (["--env-kwarg", "n_discs=\"many\""], "--env-kwarg"),
    "env-kwarg on every task": (["--env", "all", "--env-kwarg", "n_discs=-5"], "--env-kwarg"),
    "out without {env} for several envs": (["--env", "all", "--out", "TMP/x.json"], "--out"),
    "out with other braces": (["--out", "TMP/{name}.json"], "--out"),
    "out under a file": (["--out", "TMP/afile/x.json"], "--out"),
    "out where nothing can be made": (["--out", "/proc/ladder-test/x.json"], "--out"),
    "plot-path an existing folder": (["--plot", "--plot-path", "TMP/folder"], "--plot-path"),
    "plot-path no image format": (["--plot", "--plot-path", "TMP/chart.xyz"], "--plot-path"),
    "plot-path under a file": (["--plot", "--plot-path", "TMP/afile/c.png"], "--plot-path"),
    "table missing": (["--table", "TMP/missing.json"], "--table"),
    "table a folder": (["--table", "TMP/folder"], "--table"),
    "table not JSON": (["--table", "TMP/afile"], "--table"),
    "table not a ladder's JSON": (["--table", str(LADDER_JSON), "TMP/other.json"], "--table"),
    "table then plot-path a folder": (["--table", str(LADDER_JSON), "--plot", "--plot-path",
                                       "TMP/folder"], "--plot-path"),
}


@pytest.mark.parametrize("argv, flag", REFUSED.values(), ids=REFUSED.keys())
def test_a_bad_argument_is_refused_before_any_work(argv, flag, tmp_path, monkeypatch, capsys):
    """One line ``ladder.py: error: --flag: ...``, exit 2, before the constant search (or the
    tables of --table): nothing run, printed or written."""
    if "/proc/" in " ".join(argv) and not Path("/proc").is_dir():
        pytest.skip("no /proc")
    (tmp_path / "folder").mkdir()
    (tmp_path / "afile").write_text("not JSON\n")
    (tmp_path / "other.json").write_text('{"env_id": "DiscReactor-v0"}\n')
    monkeypatch.chdir(tmp_path)
    work = []

    def spy(name):
        def called(*args, **kwargs):
            work.append(name)
            raise AssertionError(f"{name} ran: the arguments were not checked first")
        return called

    for name in ("run_task", "search_constant", "run_episodes", "run_variants", "plot"):
        monkeypatch.setattr(ladder, name, spy(name))
    before = sorted(tmp_path.rglob("*"))
    argv = [a.replace("TMP", str(tmp_path)) for a in argv]
    with pytest.raises(SystemExit) as e:
        ladder.main(["--out", str(tmp_path / "out" / "{env}.json"), *argv])
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert e.value.code == 2
    assert len(lines) == 1 and lines[0].startswith(f"ladder.py: error: {flag}: "), err
    assert not work and out == ""
    assert sorted(tmp_path.rglob("*")) == before


def _fake_run_task(calls):
    """run_task stand-in: a ladder of the docs for any env id, no episode run."""
    ref = json.loads(LADDER_JSON.read_text())

    def run_task(env_id, eval_seeds, search_seeds, env_kwargs, replan_every=None,
                 horizon=None, log=print, planner_futures=None, planner_gate=None):
        calls.append({"env_id": env_id, "eval_seeds": eval_seeds,
                      "search_seeds": search_seeds, "env_kwargs": dict(env_kwargs),
                      "replan_every": replan_every, "horizon": horizon,
                      "planner_futures": planner_futures, "planner_gate": planner_gate})
        res = copy.deepcopy(ref)
        for k in ("date", "machine", "versions", "command", "total_seconds", "table"):
            res.pop(k, None)
        return {**res, "env_id": env_id}

    return run_task


def test_good_arguments_pass_the_checks_and_each_json_is_renamed_into_place(
        tmp_path, monkeypatch, capsys):
    """Every check passes the arguments of a tiny ladder of every task (the env's own
    arguments and gymnasium.make's max_episode_steps), which reach run_task as given; each
    JSON is written to a temporary file in its folder and renamed over the old one."""
    calls, renames = [], []
    monkeypatch.setattr(ladder, "run_task", _fake_run_task(calls))
    real_replace = os.replace

    def replace(src, dst):
        renames.append((Path(src), Path(dst)))
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    folder = tmp_path / "new" / "folder"
    (tmp_path / "new").mkdir()
    old = tmp_path / "new" / "DiscFlow-v0.json"
    assert ladder.main(["--env", "all", "--seeds", "3", "--first-seed", "100",
                        "--search-seeds", "4", *TINY, "--replan-every", "2", "--horizon", "3",
                        "--planner-futures", "2", "--planner-gate", "-1",
                        "--out", str(folder / "{env}.json")]) == 0
    assert [c["env_id"] for c in calls] == list(ladder.TASK_BASELINES)
    for c in calls:
        assert c["eval_seeds"] == [100, 101, 102] and c["search_seeds"] == [0, 1, 2, 3]
        assert c["env_kwargs"] == {"n_discs": 80, "episode_steps": 6, "max_episode_steps": 6}
        assert (c["replan_every"], c["horizon"], c["planner_futures"], c["planner_gate"]) == (
            2, 3, 2, None)
    written = sorted(folder.iterdir())
    assert [p.name for p in written] == sorted(f"{e}.json" for e in ladder.TASK_BASELINES)
    assert sorted(dst for _, dst in renames) == written
    assert all(src.parent == dst.parent and src.name.startswith(".") for src, dst in renames)
    capsys.readouterr()
    # over an old file: renamed into place, no temporary file left
    old.write_text("old\n")
    assert ladder.main(["--env", "DiscFlow-v0", "--seeds", "2", "--search-seeds", "1",
                        "--out", str(old)]) == 0
    assert json.loads(old.read_text())["env_id"] == "DiscFlow-v0"
    assert sorted(p.name for p in old.parent.iterdir()) == ["DiscFlow-v0.json", "folder"]


def test_a_failed_write_leaves_the_old_json_whole(tmp_path, monkeypatch, capsys):
    """The JSON is whole or as it was: a write that fails (here the rename) leaves the old
    file and no temporary one."""
    monkeypatch.setattr(ladder, "run_task", _fake_run_task([]))

    def fail(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "replace", fail)
    out = tmp_path / "DiscReactor-v0.json"
    out.write_text("old\n")
    with pytest.raises(OSError):
        ladder.main(["--seeds", "2", "--search-seeds", "1", "--out", str(out)])
    assert out.read_text() == "old\n" and [p.name for p in tmp_path.iterdir()] == [out.name]
