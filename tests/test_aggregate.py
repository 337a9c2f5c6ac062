"""agents/aggregate.py: the learners across tasks on one scale. Synthetic evaluations with
known returns (no episode runs): the normalisation, the per-run scores, the stratified IQM,
the table's cells, the budgets beside the searches' and the refusals."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")
pytest.importorskip("tyro")
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "agents"))

import aggregate  # noqa: E402

from discgym.baselines import aggregate_iqm  # noqa: E402
from discgym.searched import SEARCHED  # noqa: E402


def _evaluation(env_id, rng, n=40, runs=None):
    """An evaluation.json of evaluate.py's shape: random near 0, searched near 2, a simple
    rule near 1.8, and learner runs ``{name: (variant, level, env_steps, wall)}``."""
    rows = {"random": rng.normal(0.0, 0.1, n), "searched": rng.normal(2.0, 0.1, n),
            "hand-written": rng.normal(1.8, 0.1, n), "best constant": rng.normal(1.5, 0.1, n)}
    pol = {k: {"label": k, "returns": v.tolist()} for k, v in rows.items()}
    for name, (kind, level, steps, wall) in (runs or {}).items():
        pol[name] = {"label": name, "returns": rng.normal(level, 0.1, n).tolist(),
                     "algo": kind.split(",")[0], "variant": kind,
                     "train": {"timesteps": steps, "env_steps": steps, "wall_seconds": wall}}
    first = [n for n, (k, *_) in (runs or {}).items() if k == "ppo"]
    if len(first) > 1:  # (evaluate.py's pooled row: never counted as a run)
        pol["ppo: mean of runs"] = {"label": "pooled", "pooled": first, "algo": "ppo",
                                    "returns": [0.0] * n}
    return {"env_id": env_id, "env_kwargs": {}, "eval_seeds": list(range(1000, 1000 + n)),
            "policies": pol}


@pytest.fixture()
def files(tmp_path):
    rng = np.random.default_rng(5)
    runs_f = {"ppo (a)": ("ppo", 1.9, 2_000_000, 600), "ppo (b)": ("ppo", 1.7, 2_000_000, 800),
              "ppo (c)": ("ppo, residual_searched", 2.05, 1_000_000, 300)}
    runs_j = {"ppo (a)": ("ppo", 1.0, 400_000, 120), "ppo (b)": ("ppo", 1.2, 400_000, 180)}
    paths = []
    for env_id, runs in (("DiscFlow-v0", runs_f), ("DiscJacket-v0", runs_j)):
        p = tmp_path / f"{env_id}.json"
        p.write_text(json.dumps(_evaluation(env_id, rng, runs=runs)))
        paths.append(p)
    ladder = {"env_id": "DiscFlow-v0", "policies": {
        "random": {"returns": [0.0, 0.2]}, "searched": {"returns": [1.0, 1.2]},
        "planner": {"returns": [1.1, 1.3]}, "oracle": {"returns": [1.5, 1.7]}}}
    lp = tmp_path / "ladder.json"
    lp.write_text(json.dumps(ladder))
    return paths, lp


def test_scores_and_the_stratified_iqm(files, tmp_path):
    paths, lp = files
    out = tmp_path / "agg"
    assert aggregate.main(["--evaluation", *map(str, paths), "--ladder", str(lp),
                           "--out", str(out)]) == 0
    res = json.loads((out / "aggregate.json").read_text())
    norm, agg = res["normalised"], res["aggregate"]
    ev = [json.loads(p.read_text()) for p in paths]
    # a learner: one score per run, its mean return mapped with the task's random/searched
    for e in ev:
        rows = e["policies"]
        lo, hi = np.mean(rows["random"]["returns"]), np.mean(rows["searched"]["returns"])
        want = [(np.mean(rows[k]["returns"]) - lo) / (hi - lo) for k in ("ppo (a)", "ppo (b)")]
        assert norm["policies"]["ppo"][e["env_id"]] == pytest.approx(want)
        seeds = (np.array(rows["hand-written"]["returns"]) - lo) / (hi - lo)
        assert norm["policies"]["hand-written"][e["env_id"]] == pytest.approx(seeds)
    # the pooled row is not a run; a variant on one task only is aggregated over that one
    assert len(norm["policies"]["ppo"]["DiscFlow-v0"]) == 2
    res_ = agg["ppo, residual_searched"]
    assert res_["tasks"] == ["DiscFlow-v0"] and res_["low"] is None  # (1 run: no interval)
    assert res_["value"] == pytest.approx(norm["policies"]["ppo, residual_searched"][
        "DiscFlow-v0"][0])
    want = aggregate_iqm([norm["policies"]["ppo"][t] for t in ("DiscFlow-v0", "DiscJacket-v0")])
    assert agg["ppo"]["value"] == pytest.approx(want.value)
    assert (agg["ppo"]["low"], agg["ppo"]["high"]) == pytest.approx((want.low, want.high))
    assert agg["ppo"]["low"] < agg["ppo"]["value"] < agg["ppo"]["high"]
    # the planner and the oracle on their ladder's scale: (1.1 - 0.1) / (1.1 - 0.1), ...
    assert norm["policies"]["planner"] == {"DiscFlow-v0": pytest.approx([1.0, 1.2])}
    assert norm["policies"]["oracle"]["DiscFlow-v0"] == pytest.approx([1.4, 1.6])
    # a controller is one run per task: the IQM of its task means, so searched 1, random 0
    assert agg["searched"]["value"] == pytest.approx(1.0)
    rule = [np.mean(norm["policies"]["hand-written"][t]) for t in ("DiscFlow-v0",
                                                                    "DiscJacket-v0")]
    assert agg["hand-written"]["value"] == pytest.approx(np.mean(rule))  # (IQM of two: mean)
    assert agg["hand-written"]["low"] < agg["hand-written"]["value"] < agg["hand-written"][
        "high"]
    md = (out / "aggregate.md").read_text()
    assert (out / "aggregate.png").stat().st_size > 10_000
    # the cells: the runs' mean (their range), the references on their tasks only
    f = norm["policies"]["ppo"]["DiscFlow-v0"]
    cell = f"{np.mean(f):.3f} ({min(f):.3f} - {max(f):.3f}, 2 runs)"
    assert "the planner and the oracle on their ladders' first seeds (DiscFlow-v0 2)" in md
    line = next(s for s in md.splitlines() if s.startswith("| PPO |"))
    assert cell in line and f"{agg['ppo']['value']:.3f} [" in line
    line = next(s for s in md.splitlines() if s.startswith("| PPO correcting the searched"))
    assert "(no interval: one run per task) (1 task)" in line and "(1 run)" in line
    assert line.endswith("|  |")
    # budgets: the searches' as recorded in discgym.searched, the runs' mean training
    b = SEARCHED["DiscJacket-v0"]["budget"]
    line = next(s for s in md.splitlines() if s.startswith("| searched controller: CMA"))
    assert f"{b['env_steps'] / 1e6:.2f} M, {b['wall_seconds'] / 60:.0f} min" in line
    line = next(s for s in md.splitlines() if s.startswith("| PPO: training"))
    assert "| 2.00 M, 12 min | 0.40 M, 2 min |" in line


def _refused(tmp_path, argv, flag):
    before = sorted(tmp_path.rglob("*"))
    r = subprocess.run([sys.executable, str(ROOT / "agents" / "aggregate.py"), *argv],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1 and flag in lines[0], r.stderr
    assert sorted(tmp_path.rglob("*")) == before


@pytest.mark.parametrize("case, flag", [
    ("none", "--evaluation: name at least one"),
    ("missing", "--evaluation: no file"),
    ("not json", "not readable JSON"),
    ("a ladder as evaluation", "has no random"),
    ("twice", "two evaluations of DiscFlow-v0"),
    ("other json", "not written by agents/evaluate.py"),
    ("out is a file", "--out"),
    ("no scale", "is not above random"),
    ("a row's seeds give no scale", "on the seeds of 'planner'"),
    ("unequal runs", "ppo: 2 on DiscFlow-v0, 1 on DiscKinetics-v0: give each task the same"),
    ("a ladder without its evaluation", "which no --evaluation has"),
    ("two ladders", "two ladders of DiscFlow-v0"),
    ("ladder of other arguments", "not one task"),
    ("older evaluation", "has no variant and its run folder is gone"),
])
def test_bad_arguments_are_refused_in_one_line(files, tmp_path, case, flag):
    paths, lp = files
    (tmp_path / "bad.json").write_text("{oops")
    (tmp_path / "other.json").write_text("[1, 2]")
    (tmp_path / "a_file").write_text("x")
    stripped = json.loads(lp.read_text())
    stripped["policies"] = {"planner": stripped["policies"]["planner"]}
    (tmp_path / "no_random.json").write_text(json.dumps(stripped))
    flat = json.loads(paths[0].read_text())
    flat["policies"]["searched"]["returns"] = flat["policies"]["random"]["returns"]
    (tmp_path / "flat.json").write_text(json.dumps(flat))
    lad = json.loads(lp.read_text())
    (tmp_path / "lad_kw.json").write_text(json.dumps(dict(lad, env_kwargs={"x": 1})))
    pol = dict(lad["policies"], random={"returns": [0.5, 0.0]},
               searched={"returns": [0.4, 1.2]}, planner={"returns": [1.0]})
    (tmp_path / "lad_row.json").write_text(json.dumps(dict(lad, policies=pol)))
    one = _evaluation("DiscKinetics-v0", np.random.default_rng(1),
                      runs={"ppo (a)": ("ppo", 1.0, 1, 1)})
    (tmp_path / "one_run.json").write_text(json.dumps(one))
    old = json.loads(paths[1].read_text())
    del old["policies"]["ppo (a)"]["variant"]
    old["policies"]["ppo (a)"]["run"] = str(tmp_path / "gone")
    (tmp_path / "old.json").write_text(json.dumps(old))
    argv = {"none": [], "missing": ["--evaluation", "nope.json"],
            "not json": ["--evaluation", "bad.json"],
            "a ladder as evaluation": ["--evaluation", "no_random.json"],
            "twice": ["--evaluation", str(paths[0]), str(paths[0])],
            "other json": ["--evaluation", "other.json"],
            "out is a file": ["--evaluation", str(paths[0]), "--out", "a_file"],
            "no scale": ["--evaluation", str(paths[1]), "flat.json"],
            "a row's seeds give no scale": ["--evaluation", str(paths[0]), "--ladder",
                                            "lad_row.json"],
            "unequal runs": ["--evaluation", str(paths[0]), "one_run.json"],
            "a ladder without its evaluation": ["--evaluation", str(paths[1]), "--ladder",
                                                str(lp)],
            "two ladders": ["--evaluation", str(paths[0]), "--ladder", str(lp), str(lp)],
            "ladder of other arguments": ["--evaluation", str(paths[0]), "--ladder",
                                          "lad_kw.json"],
            "older evaluation": ["--evaluation", "old.json"]}[case]
    _refused(tmp_path, argv, flag)


def test_an_older_evaluation_gets_its_variant_from_the_run_folder(files, tmp_path):
    """evaluation.json files written before evaluate.py recorded the variant: rebuilt from
    the run's args.json, so scratch and residual runs are never pooled."""
    paths, _ = files
    ev = json.loads(paths[0].read_text())
    for name, hp in (("ppo (a)", "hyperparams"), ("ppo (b)", "hyperparams"),
                     ("ppo (c)", "x/residual_searched")):
        run = tmp_path / name.replace(" ", "_")
        run.mkdir()
        (run / "args.json").write_text(json.dumps({"env_id": "DiscFlow-v0", "algo": "ppo",
                                                   "hyperparams": hp}))
        row = ev["policies"][name]
        del row["variant"]
        row["run"] = str(run)
    (tmp_path / "old.json").write_text(json.dumps(ev))
    out = tmp_path / "agg_old"
    assert aggregate.main(["--evaluation", str(tmp_path / "old.json"), "--out", str(out)]) == 0
    norm = json.loads((out / "aggregate.json").read_text())["normalised"]["policies"]
    assert len(norm["ppo"]["DiscFlow-v0"]) == 2
    assert len(norm["ppo, residual_searched"]["DiscFlow-v0"]) == 1
