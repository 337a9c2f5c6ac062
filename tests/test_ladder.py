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
                                      res["policies"]["hand-written"]["returns"]))
    b = res["oracle_budget"]
    assert b["horizon"] == "episode end" and b["plan_mismatches"] == 0
    assert b["simulated_steps_per_episode"] > 6 and b["seconds_per_episode"] > 0
    assert len(res["best_constant"]["search_means"]) == 120
    assert res["table"] in text and "| random |" in res["table"]
    assert {"numpy", "scipy", "gymnasium", "numba"} <= set(res["versions"])
    assert res["date"] and res["machine"]
    assert png.stat().st_size > 1000


def test_the_mpc_row_splits_the_oracles_margin(tmp_path, capsys):
    out = tmp_path / "{env}.json"
    assert ladder.main(["--env", "DiscReactor-v0", "--seeds", "2", "--search-seeds", "1",
                        *TINY, "--out", str(out), "--mpc"]) == 0
    res = json.loads((tmp_path / "DiscReactor-v0.json").read_text())
    mpc = np.array(res["policies"]["mpc"]["returns"])
    hw = np.array(res["policies"]["hand-written"]["returns"])
    orc = np.array(res["policies"]["oracle"]["returns"])
    assert res["mpc"]["minus_hand_written"]["value"] == pytest.approx((mpc - hw).mean())
    assert res["mpc"]["oracle_minus_mpc"]["value"] == pytest.approx((orc - mpc).mean())
    assert "| MPC - hand-written |" in res["table"] and "without foresight" in res["table"]


def test_overlapping_or_too_few_seeds_are_refused(tmp_path, capsys):
    with pytest.raises(SystemExit):
        ladder.main(["--seeds", "1", "--out", str(tmp_path / "x.json")])
    with pytest.raises(SystemExit):
        ladder.main(["--first-seed", "5", "--search-seeds", "10",
                     "--out", str(tmp_path / "x.json")])
    assert "search_seeds" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        ladder.main(["--env", "NoSuchTask-v0"])
