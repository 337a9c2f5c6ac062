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
    ladder = {"env_id": "DiscFlow-v0", "eval_seeds": [1000, 1001], "policies": {
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
    ("a ladder as evaluation", 'policies["random"] is missing'),
    ("twice", "two evaluations of DiscFlow-v0"),
    ("other json", "not written by agents/evaluate.py"),
    ("out is a file", "--out"),
    ("no scale", "is not above random"),
    ("a row's seeds give no scale", "on the seeds of 'oracle'"),
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
    row = json.loads(paths[0].read_text())  # (evaluate.py's oracle on the first seed only)
    row["policies"]["random"]["returns"][0] = 5.0
    row["policies"]["oracle"] = {"label": "oracle", "returns": [2.0], "seeds": [1000]}
    (tmp_path / "eval_row.json").write_text(json.dumps(row))
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
            "a row's seeds give no scale": ["--evaluation", "eval_row.json"],
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


def _edit(*keys, to=None, drop=False):
    """An edit of a file's JSON: the value at ``keys`` dropped, or replaced by ``to`` (a
    function of the old value, or the new value)."""
    def edit(d):
        *head, last = keys
        for k in head:
            d = d[k]
        if drop:
            del d[last]
        else:
            d[last] = to(d[last]) if callable(to) else to
    return edit


def _more(n, first=1000):
    """Extends a seed or return list by ``n`` items."""
    return lambda xs: xs + ([first + len(xs) + i for i in range(n)] if isinstance(xs[0], int)
                            else [xs[-1]] * n)


def _both(*edits):
    def edit(d):
        for e in edits:
            e(d)
    return edit


NAN, INF = float("nan"), float("inf")
A = ("policies", "ppo (a)")  # (a learner's run on DiscFlow-v0)
MALFORMED = [  # (case, the file edited: the evaluation or the ladder, its edit, the words)
    ("no eval_seeds", "evaluation", _edit("eval_seeds", drop=True),
     "eval_seeds is missing (not written by agents/evaluate.py)"),
    ("text returns", "evaluation", _edit(*A, "returns", to=lambda r: [str(x) for x in r]),
     'policies["ppo (a)"]["returns"] is not a non-empty list of finite numbers (item 0: "'),
    ("returns as one text", "evaluation", _edit(*A, "returns", to="1.9 1.8"),
     'policies["ppo (a)"]["returns"] is not a non-empty list of finite numbers ("1.9 1.8")'),
    ("policies as a list", "evaluation", _edit("policies", to=lambda p: list(p.values())),
     "policies is not an object ([{"),
    ("a NaN return", "evaluation", _edit(*A, "returns", to=lambda r: r[:3] + [NAN] + r[4:]),
     'policies["ppo (a)"]["returns"] is not a non-empty list of finite numbers (item 3: NaN)'),
    ("an infinite return", "evaluation", _edit("policies", "hand-written", "returns",
                                               to=lambda r: [INF] + r[1:]),
     'policies["hand-written"]["returns"] is not a non-empty list of finite numbers (item 0: '
     'Infinity)'),
    ("no returns", "evaluation", _edit("policies", "searched", "returns", to=[]),
     'policies["searched"]["returns"] is not a non-empty list of finite numbers ([])'),
    ("a row without returns", "evaluation", _edit("policies", "best constant", "returns",
                                                  drop=True),
     'policies["best constant"]["returns"] is missing'),
    ("a row as a list", "evaluation", _edit("policies", "hand-written", to=[1.7, 1.8]),
     'policies["hand-written"] is not an object ([1.7, 1.8])'),
    ("no searched row", "evaluation", _edit("policies", "searched", drop=True),
     'policies["searched"] is missing'),
    ("seeds as text", "evaluation", _edit("eval_seeds", to="1000-1039"),
     'eval_seeds is not a non-empty list of seeds (integers >= 0, each once) ("1000-1039")'),
    ("a fractional seed", "evaluation", _edit("eval_seeds", 2, to=1002.5),
     "eval_seeds is not a non-empty list of seeds (integers >= 0, each once) (item 2: 1002.5)"),
    ("a negative seed", "evaluation", _edit("eval_seeds", 0, to=-1),
     "eval_seeds is not a non-empty list of seeds (integers >= 0, each once) (item 0: -1)"),
    ("a repeated seed", "evaluation", _edit("eval_seeds", 5, to=1004),
     "eval_seeds is not a non-empty list of seeds (integers >= 0, each once) (1004 is there "
     "twice)"),
    ("env_id not text", "evaluation", _edit("env_id", to=7), "env_id is not a task's id (7)"),
    ("env_kwargs not an object", "evaluation", _edit("env_kwargs", to="dt=0.1"),
     'env_kwargs is not an object ("dt=0.1")'),
    ("variant not text", "evaluation", _edit(*A, "variant", to=["ppo"]),
     'policies["ppo (a)"]["variant"] is not a string (["ppo"])'),
    ("train as text", "evaluation", _edit(*A, "train", to="2M steps"),
     'policies["ppo (a)"]["train"] is not an object ("2M steps")'),
    ("training steps as text", "evaluation", _edit(*A, "train", "env_steps", to="2M"),
     'policies["ppo (a)"]["train"]["env_steps"] is not an integer >= 0 ("2M")'),
    ("no training wall time", "evaluation", _edit(*A, "train", "wall_seconds", drop=True),
     'policies["ppo (a)"]["train"]["wall_seconds"] is missing'),
    ("a row's seeds as text", "evaluation", _edit(*A, "seeds", to="all"),
     'policies["ppo (a)"]["seeds"] is not a non-empty list of seeds'),
    # the seeds: every scored row on the references' (random's, searched's), eval_seeds
    ("a learner on more seeds than the references", "evaluation",
     _both(_edit("eval_seeds", to=_more(10)), _edit(*A, "returns", to=_more(10))),
     'policies["ppo (a)"] is not on the seeds of the references random and searched it is '
     "normalised with (50 seeds against 40; the first difference, at position 40: 1040 "
     "against none)"),
    ("a learner with more returns than eval_seeds", "evaluation",
     _edit(*A, "returns", to=_more(1)),
     'policies["ppo (a)"]["returns"] holds 41 returns, eval_seeds 40 seeds'),
    ("a learner on other seeds", "evaluation",
     _edit(*A, "seeds", to=list(range(1100, 1140))),
     'policies["ppo (a)"] is not on the seeds of the references random and searched it is '
     "normalised with (40 seeds against 40; the first difference, at position 0: 1100 "
     "against 1000)"),
    ("a controller on fewer seeds", "evaluation",
     _edit("policies", "hand-written", "returns", to=lambda r: r[:-1]),
     'policies["hand-written"] is not on the seeds of the references random and searched it '
     "is normalised with (39 seeds against 40; the first difference, at position 39: none "
     "against 1039)"),
    ("the references on fewer seeds than eval_seeds", "evaluation",
     _edit("eval_seeds", to=_more(1)),
     "the references random and searched are not on eval_seeds (40 seeds against 41; the "
     "first difference, at position 40: none against 1040)"),
    ("a row's seeds fewer than its returns", "evaluation",
     _edit(*A, "seeds", to=list(range(1000, 1039))),
     'policies["ppo (a)"]["returns"] holds 40 returns, policies["ppo (a)"]["seeds"] 39 '
     "seeds"),
    ("an unscored row on later seeds", "evaluation",
     _edit("policies", "oracle", to={"returns": [2.0, 2.1], "seeds": [1005, 1006]}),
     'policies["oracle"] is not on the first eval_seeds (2 seeds against 40; the first '
     "difference, at position 0: 1005 against 1000)"),
    # a ladder: the same walk, its planner and oracle on its random's and searched's seeds
    ("a ladder without eval_seeds", "ladder", _edit("eval_seeds", drop=True),
     "eval_seeds is missing (not written by benchmarks/ladder.py)"),
    ("a ladder's text returns", "ladder", _edit("policies", "planner", "returns",
                                                to=["1.1", "1.3"]),
     'policies["planner"]["returns"] is not a non-empty list of finite numbers (item 0: '
     '"1.1")'),
    ("a ladder's NaN return", "ladder", _edit("policies", "searched", "returns",
                                              to=[NAN, 1.2]),
     'policies["searched"]["returns"] is not a non-empty list of finite numbers (item 0: '
     "NaN)"),
    ("a ladder's policies as a list", "ladder",
     _edit("policies", to=lambda p: list(p.values())), "policies is not an object"),
    ("a ladder's oracle on more seeds", "ladder",
     _both(_edit("eval_seeds", to=_more(1)),
           _edit("policies", "oracle", "returns", to=_more(1))),
     'policies["oracle"] is not on the seeds of the references random and searched it is '
     "normalised with (3 seeds against 2; the first difference, at position 2: 1002 "
     "against none)"),
    ("a ladder's planner on fewer seeds", "ladder",
     _edit("policies", "planner", "returns", to=[1.1]),
     'policies["planner"] is not on the seeds of the references random and searched it is '
     "normalised with (1 seed against 2; the first difference, at position 1: none "
     "against 1001)"),
]


@pytest.mark.parametrize("case, kind, edit, words", MALFORMED, ids=[c[0] for c in MALFORMED])
def test_a_malformed_file_is_refused_in_one_line(files, tmp_path, capsys, case, kind, edit,
                                                 words):
    """Each field aggregate.py reads, of the wrong kind or on other seeds: refused before
    anything is computed, in one line naming the flag, the file and the field; exit 2, no
    --out."""
    import argcheck

    paths, lp = files
    src = paths[0] if kind == "evaluation" else lp
    data = json.loads(src.read_text())
    edit(data)
    bad = tmp_path / f"bad_{kind}.json"
    bad.write_text(json.dumps(data))  # (NaN and Infinity as json.dumps writes them)
    out = tmp_path / "agg"
    given = {"evaluation": [str(paths[0])], "ladder": [str(lp)], kind: [str(bad)]}
    argv = ["--evaluation", *given["evaluation"], "--ladder", *given["ladder"],
            "--out", str(out)]
    with pytest.raises(SystemExit) as e:
        argcheck.run(lambda: aggregate.main(argv))
    err = capsys.readouterr().err
    assert e.value.code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert f"error: --{kind}: {bad}: {words}" in err, err
    assert ("not written by" in err) == ("not written by" in words), err
    assert not out.exists()


def test_the_issue_in_the_script(files, tmp_path):
    """The script itself: a learner on more seeds than its references, refused (it was
    aggregated silently), nothing written."""
    paths, _ = files
    data = json.loads(paths[0].read_text())
    _both(_edit("eval_seeds", to=_more(10)), _edit(*A, "returns", to=_more(10)))(data)
    (tmp_path / "more.json").write_text(json.dumps(data))
    _refused(tmp_path, ["--evaluation", "more.json", "--out", "agg"],
             '--evaluation: more.json: policies["ppo (a)"] is not on the seeds of the '
             "references random and searched")


def test_rows_it_does_not_score_may_be_on_the_first_seeds(files, tmp_path):
    """evaluate.py's planner and oracle on the first seeds (``--oracle-seeds``: the oracle's
    seeds recorded, the planner's implied) are legitimate, and not scored."""
    paths, _ = files
    data = json.loads(paths[0].read_text())
    data["policies"]["oracle"] = {"returns": [2.5] * 5, "seeds": data["eval_seeds"][:5]}
    data["policies"]["planner"] = {"returns": [2.2] * 5}
    (tmp_path / "prefix.json").write_text(json.dumps(data))
    out = tmp_path / "agg"
    assert aggregate.main(["--evaluation", str(tmp_path / "prefix.json"), "--out",
                           str(out)]) == 0
    norm = json.loads((out / "aggregate.json").read_text())["normalised"]["policies"]
    assert "oracle" not in norm and "planner" not in norm
