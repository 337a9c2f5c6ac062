"""benchmarks/ladder.py on a tiny budget (2 seeds, 6-step episodes of 80 discs): it writes its
JSON (per-seed returns, table, the oracle's budget) and its plot, and refuses bad seeds."""

import importlib.util
import json
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
    assert "search_seeds" in capsys.readouterr().err
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
