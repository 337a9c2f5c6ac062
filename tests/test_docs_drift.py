"""The documentation cannot drift from the code: what the code knows is generated from it
(``docs/_scripts/gen_pages.py``: the task pages' tables, the scene tables) or tested against
it here. The numbers the task docstrings state (defaults, slot counts and bounds, reward
coefficients, episode length, the scene's geometry and activation energies), the built-in
scenes' descriptions, the command line's flags in ``docs/cli.md`` and the examples of the
guides are all checked against the live code."""

from __future__ import annotations

import argparse
import ast
import contextlib
import io
import json
import math
import re
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import discgym as dg
from discgym import cli
from discgym.bench import build_parser as bench_parser
from discgym.tasks import TASKS

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
sys.path.insert(0, str(DOCS / "_scripts"))
import gen_pages  # noqa: E402  (docs/_scripts)

IDS = list(TASKS)


def words(text: str) -> str:
    """``text`` on one line (docstrings wrap anywhere)."""
    return " ".join(text.split())


def numbers_equal(doc, code) -> bool:
    """A value written in a docstring against the code's: numbers compared as floats,
    sequences item by item (``[0.3, 6]`` is ``(0.3, 6.0)``)."""
    if isinstance(doc, (list, tuple)) and isinstance(code, (list, tuple)):
        return len(doc) == len(code) and all(numbers_equal(a, b) for a, b in zip(doc, code))
    if isinstance(doc, bool) or isinstance(code, bool):
        return doc is code
    if isinstance(doc, (int, float)) and isinstance(code, (int, float)):
        return math.isclose(float(doc), float(code), rel_tol=1e-9, abs_tol=0.0)
    return doc == code


@pytest.fixture(scope="module", params=IDS)
def task(request):
    env_id = request.param
    env_cls = TASKS[env_id][0]
    env = gym.make(env_id).unwrapped
    summary, sections = gen_pages.docstring_sections(env_cls)
    yield env_id, env_cls, env, summary, {k: words(v) for k, v in sections.items()}
    env.close()


# --------------------------------------------------------------------------------------------
# the task docstrings


def test_docstring_has_every_section_and_no_stray_line(task):
    env_id, env_cls, _, summary, sections = task
    # a line outside the docstring's indentation (an edit gone astray) breaks its dedent,
    # and with it every section's Markdown
    raw = (env_cls.__doc__ or "").splitlines()[1:]
    stray = [ln for ln in raw if ln.strip() and not ln.startswith("    ")]
    assert not stray, f"{env_id}: docstring lines outside its indentation: {stray}"
    assert summary.startswith(f"``{env_id}``") or env_cls is dg.env.DiscReactorEnv
    missing = [s for s in gen_pages.SECTION_ORDER if s not in sections]
    assert not missing, f"{env_id}: docstring lacks the sections {missing}"


#: ``name=value``, ``name`` = value, ``name`` (value), ``name``, value by default
_DEFAULT_FORMS = (
    r"``(\w+)=([^`]+)``",
    r"``(\w+)`` = (\[[^\]]*\]|-?[\d.]+(?:e-?\d+)?)",
    r"``(\w+)`` \((-?[\d.]+)\)",
    r"``(\w+)``, (-?[\d.]+) by default",
)


def stated_defaults(text: str, forms=_DEFAULT_FORMS) -> list[tuple[str, object]]:
    out = []
    for form in forms:
        for m in re.finditer(form, text):
            try:
                out.append((m.group(1), ast.literal_eval(m.group(2).strip())))
            except (ValueError, SyntaxError):
                out.append((m.group(1), m.group(2)))
    return out


def test_docstring_defaults_are_the_code(task):
    env_id, env_cls, _, summary, sections = task
    text = " ".join([summary, *sections.values()])
    # (DiscReactor-v0's docstring writes ``heating="jacket"`` for an option, not a default)
    forms = _DEFAULT_FORMS[1:] if env_cls is dg.env.DiscReactorEnv else _DEFAULT_FORMS
    stated = [(k, v) for k, v in stated_defaults(text, forms) if k in env_cls.defaults]
    wrong = [(k, v, env_cls.defaults[k]) for k, v in stated
             if not numbers_equal(v, env_cls.defaults[k])]
    assert not wrong, f"{env_id}: docstring defaults (argument, stated, code): {wrong}"
    if env_cls is not dg.env.DiscReactorEnv:
        # a task's Arguments section names every default it changes
        args = sections["Arguments"]
        changed = [k for k, v in env_cls.defaults.items()
                   if not gen_pages._same(v, dg.env.DEFAULTS[k])]
        unnamed = [k for k in changed if f"``{k}=" not in args]
        assert not unnamed, f"{env_id}: Arguments does not state the defaults of {unnamed}"


def _shape(text: str, head: str, env) -> int | None:
    """The size of the first ``Box(<head>, (N,), float32)`` in ``text``; N may be written
    in S (species) and F (feed species)."""
    m = re.search(rf"``Box\({re.escape(head)}, \(([^,]+),\), float32\)``", text)
    if m is None:
        return None
    S, F = env.config.n_species, len(env.config.feed)
    expr = re.sub(r"(\d)\s*([SF])", r"\1 * \2", m.group(1))
    return eval(expr, {"__builtins__": {}}, {"S": S, "F": F})  # noqa: S307


def test_docstring_spaces_are_the_code(task):
    env_id, _, env, _, sections = task
    obs, act = sections["Observation Space"], sections["Action Space"]
    n_act = _shape(act, "-1, 1", env)
    assert n_act == env.action_space.shape[0], f"{env_id}: Action Space states {n_act}"
    n_obs = _shape(obs, "low, high", env)
    assert n_obs == env.observation_space.shape[0], (
        f"{env_id}: Observation Space states {n_obs} slots (or no Box(low, high, (N,), "
        f"float32) at all), the env has {env.observation_space.shape[0]}")


def _slot_regex(pattern: str) -> re.Pattern:
    """A slot name as the docstrings write it (``outflow_<species>``,
    ``energy_<species>[a,b)``) as a regex over the env's slot names."""
    out = re.escape(pattern)
    out = re.sub(r"<[^>]+>", ".+?", out)
    out = out.replace(r"\[a,b\)", r"\[[^,]+,[^)]+\)")
    return re.compile(out + "$")


def test_docstring_slot_counts_and_bounds_are_the_code(task):
    env_id, _, env, _, sections = task
    obs = sections["Observation Space"]
    names = env.observation_names
    lo, hi = env.observation_space.low, env.observation_space.high
    blocks = gen_pages.observation_blocks(names)
    sizes = {n for _, _, n in blocks} | {len(names)}
    # every "N slots" is the size of a block (or of the whole observation) ...
    for m in re.finditer(r"(\d+) slots", obs):
        assert int(m.group(1)) in sizes, (
            f"{env_id}: '{obs[max(m.start() - 60, 0):m.end() + 30]}': {m.group(1)} slots; the "
            f"observation's blocks have {[(k, n) for k, _, n in blocks]}")
    # ... and "N slots, ``name``" the number of slots of that name
    for m in re.finditer(r"(\d+) slots, ``([^`]+)``", obs):
        rx = _slot_regex(m.group(2))
        count = sum(bool(rx.match(nm)) for nm in names)
        assert count == int(m.group(1)), f"{env_id}: {m.group(0)}: the env has {count}"
    # "``name``, in [low, high]" / "``name``, ..., in [low, high]": those slots' bounds
    for m in re.finditer(r"``([^`]+)``,? (?:[^`()]*?, )?in \[(-?[\d.]+), (-?[\d.]+)\]", obs):
        rx = _slot_regex(m.group(1))
        hit = [k for k, nm in enumerate(names) if rx.match(nm)]
        assert hit, f"{env_id}: {m.group(0)}: no slot of that name"
        for k in hit:
            assert (lo[k], hi[k]) == (float(m.group(2)), float(m.group(3))), (
                f"{env_id}: {m.group(0)}: {names[k]} has bounds [{lo[k]}, {hi[k]}]")
    # the first block is DiscReactor-v0's, "the 19 slots of ``DiscReactor-v0``"
    base = blocks[0]
    assert base[0] == "base"
    for m in re.finditer(r"(\d+) slots of ``DiscReactor-v0``|As ``DiscReactor-v0`` \((\d+) "
                         r"slots\)", obs):
        assert int(m.group(1) or m.group(2)) == base[2]


def test_docstring_rewards_are_the_code(task):
    env_id, env_cls, env, _, sections = task
    rewards, cfg = sections["Rewards"], env.config
    for pattern, value, name in ((r"(-?[\d.]+) \|heat energy\|", cfg.heat_cost, "heat_cost"),
                                 (r"(-?[\d.]+) x injected", cfg.feed_cost, "feed_cost")):
        stated = [float(x) for x in re.findall(pattern, rewards)]
        assert all(math.isclose(x, value) for x in stated), \
            f"{env_id}: Rewards states {name} {stated}, the code {value}"
        if value and not stated and env_cls is not dg.env.DiscReactorEnv:
            raise AssertionError(f"{env_id}: {name} is {value}, Rewards does not state it")
    if cfg.reward == "outflow":
        assert "C_out" in rewards, f"{env_id}: the reward is the product leaving (C_out)"
    else:
        assert "C_out" not in rewards
        assert "C_now - C_before" in rewards or "gain in C" in rewards
    # the generated page's terms come from the same config
    terms = gen_pages.reward_terms(env)
    assert [t[1] for t in terms[1:]] == [f"{cfg.heat_cost:g}", f"{cfg.feed_cost:g}"]


def test_reward_terms_are_the_steps_arithmetic(task):
    """The task page's reward table (gen_pages.reward_terms) against what a step returns."""
    env_id, _, env, _, _ = task
    (_, one, k_gain), (_, c_heat, k_heat), (_, c_feed, k_feed) = gen_pages.reward_terms(env)
    assert one == "1"
    env.reset(seed=3)
    rng = np.random.default_rng(3)
    for _ in range(3):
        _, reward, _, _, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        n_ref = info["n_ref"]
        injected = sum(v for k, v in info.items() if k.startswith("injected_"))
        assert math.isclose(reward, info[k_gain] - info[k_heat] - info[k_feed], abs_tol=1e-12)
        assert math.isclose(info[k_heat], float(c_heat) * abs(info["heat_energy"]) / n_ref,
                            rel_tol=1e-5, abs_tol=1e-12)
        assert math.isclose(info[k_feed], float(c_feed) * injected / n_ref, rel_tol=1e-5,
                            abs_tol=1e-12)


def test_docstring_episode_end_is_the_code(task):
    env_id, _, env, _, sections = task
    end, cfg = sections["Episode End"], env.config
    step_time = cfg.steps_per_action * cfg.scene.dt
    m = re.search(r"truncated after (\d+) steps \(([\d.]+) units of time\)", end)
    if m:
        assert int(m.group(1)) == cfg.episode_steps
        assert math.isclose(float(m.group(2)), cfg.episode_steps * step_time)
    else:  # DiscReactor-v0 names the arguments: "``episode_steps`` (100) steps"
        assert f"``episode_steps`` ({cfg.episode_steps})" in end, end
    assert gym.spec(env_id).max_episode_steps == cfg.episode_steps


_EQ = r"[A-Z]\w*(?: \+ [A-Z]\w*)? -> [A-Z]\w*(?: \+ [A-Z]\w*)?"


def check_scene_text(text: str, scene: dg.Scene, where: str, jitter: float = 0.0) -> int:
    """Check what ``text`` says of ``scene``: the reactions it writes out exist, their
    activation energies (``Ea 4``, ``activation energy 4``, ``(activation 8)``), the box's
    size, the sides that are thermal or outlets, formation energies. Returns the number of
    facts checked."""
    text = words(text)
    labels = {r.label(): r for r in scene.reactions}
    n = 0
    for eq in re.findall(_EQ, text):
        assert eq in labels, f"{where}: '{eq}' is not a reaction of the scene ({list(labels)})"
        n += 1
    for m in re.finditer(rf"({_EQ})(?:,| \()\s*(?:activated, )?(?:activation(?: energy)?|Ea) "
                         r"(-?[\d.]+)", text):
        r = labels[m.group(1)]
        assert float(m.group(2)) == r.activation_energy, \
            f"{where}: {m.group(0)}: the scene's activation energy is {r.activation_energy}"
        n += 1
    for m in re.finditer(rf"({_EQ}) in \[([\d.]+), ([\d.]+)\]", text):
        ea = labels[m.group(1)].activation_energy
        assert (float(m.group(2)), float(m.group(3))) == (ea * (1 - jitter), ea * (1 + jitter)), \
            f"{where}: {m.group(0)}: Ea {ea} x U[1 - {jitter}, 1 + {jitter}]"
        n += 1
    for m in re.finditer(r"(\d+(?:\.\d+)?) x (\d+(?:\.\d+)?) box", text):
        b = scene.bounds
        assert isinstance(b, dg.Box) and (b.width, b.height) == \
            (float(m.group(1)), float(m.group(2))), f"{where}: {m.group(0)}: bounds {b}"
        n += 1
    thermal = {w.side for w in scene.thermal_walls}
    outlets = {o.side for o in scene.outlets}
    for m in re.finditer(r"outlets? on the (\w+)(?: and (\w+))? walls?|whose (\w+) wall is an "
                         r"outlet", text):
        sides = {s for s in m.groups() if s}
        assert sides == outlets, f"{where}: {m.group(0)}: the scene's outlets are {outlets}"
        n += 1
    for m in re.finditer(r"thermal (\w+) wall|whose (\w+) wall is thermal", text):
        side = m.group(1) or m.group(2)
        assert {side} == thermal, f"{where}: {m.group(0)}: the thermal walls are {thermal}"
        n += 1
    if "circular" in text:
        assert isinstance(scene.bounds, dg.Circle), f"{where}: bounds {scene.bounds}"
        n += 1
    m = re.search(r"formation energies ((?:[A-Z]\w* -?[\d.]+(?:, )?)+)", text)
    if m:
        form = {s.name: s.formation_energy for s in scene.species}
        for name, value in re.findall(r"([A-Z]\w*) (-?[\d.]+)", m.group(1)):
            assert form[name] == float(value), f"{where}: formation energy of {name}"
            n += 1
    return n


def test_docstring_description_is_the_scene(task):
    env_id, env_cls, env, _, sections = task
    text = sections["Description"]
    n = check_scene_text(text, env.config.scene, f"{env_id} Description",
                         env_cls.defaults["activation_jitter"])
    m = re.search(r"built-in(?: ``(\w+)``)? scene(?: ``(\w+)``)?", text)
    if m:  # a task on a scene of its own describes it
        assert (m.group(1) or m.group(2)) == env.config.scene.name
        assert n >= 3, f"{env_id}: the Description states almost nothing checkable ({n})"


def test_every_task_has_its_page_and_gif():
    pages = gen_pages.pages()
    for env_id, (env_cls, _) in TASKS.items():
        page = pages[f"tasks/{env_id}.md"]
        env = gym.make(env_id).unwrapped
        for name in env.observation_names:  # the tables are the live env's
            assert f"`{name}`" in page
        for name, default, _ in gen_pages.arguments(env_cls):
            assert f"| `{name}` | `{default!r}` |" in page
        assert f"../img/tasks/{env_id}.gif" in page
        gif = gen_pages.GIF_DIR / f"{env_id}.gif"
        assert gif.is_file(), f"{gif} is missing: python docs/_scripts/make_gifs.py"
        data = gif.read_bytes()
        assert data[:6] in (b"GIF87a", b"GIF89a") and len(data) < 1_500_000
        env.close()
    assert set(TASKS) <= set(pages["tasks/index.md"].split("```{toctree}")[1].split())


# --------------------------------------------------------------------------------------------
# the scenes


@pytest.mark.parametrize("name", dg.scenes.names())
def test_scene_description_is_the_scene(name):
    scene = dg.scenes.load(name)
    assert scene.description and scene.name == name
    check_scene_text(scene.description, scene, f"scene {name!r} description")


def test_scene_keys_are_described_and_tabled():
    text = gen_pages.scene_keys()  # raises for a field Scene's docstring does not describe
    for f in dg.Scene.__dataclass_fields__:
        assert f"| `{f}` |" in text
    table = gen_pages.scenes_table()
    for name, desc in dg.scenes.describe().items():
        assert f"| `{name}` | {desc} |" in table


def _blocks(path: Path, lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", path.read_text(), flags=re.M | re.S)


def test_scene_guide_examples_run_and_agree(tmp_path, monkeypatch):
    guide = DOCS / "scenes.md"
    (py,), (toml,) = _blocks(guide, "python"), _blocks(guide, "toml")
    ns: dict = {}
    with contextlib.redirect_stdout(io.StringIO()) as out:
        exec(compile(py, str(guide), "exec"), ns)  # noqa: S102
    assert dg.Scene.from_toml_string(toml) == ns["scene"], \
        "docs/scenes.md: the TOML example is not the Python example's scene"
    shown = re.search(r"print\(sim\.counts\(\)\)  # (\{.*\})", py).group(1)
    assert out.getvalue().strip() == shown
    # the error it quotes, for a typo in the second species' mass
    error = re.search(r"\(`(species\[1\]\.masss: [^`]*)`", words(guide.read_text())).group(1)
    lines = toml.split("\n")
    k = [i for i, ln in enumerate(lines) if ln.startswith("mass =")][1]
    lines[k] = lines[k].replace("mass", "masss")
    (tmp_path / "my_reactor.toml").write_text("\n".join(lines))
    monkeypatch.chdir(tmp_path)
    with pytest.raises(dg.SceneError) as exc:
        dg.Scene.from_toml("my_reactor.toml")
    assert str(exc.value) == error


# --------------------------------------------------------------------------------------------
# the guides' examples


def test_quickstart_runs_and_its_commands_are_the_readmes():
    guide = DOCS / "quickstart.md"
    (py,) = _blocks(guide, "python")
    with contextlib.redirect_stdout(io.StringIO()) as out:
        exec(compile(py, str(guide), "exec"), {})  # noqa: S102
    assert re.fullmatch(r"return -?\d+\.\d{3}\n", out.getvalue())
    readme = (ROOT / "README.md").read_text()
    commands = [b for b in _blocks(guide, "bash") if "pytest" in b or "train_ppo" in b]
    assert len(commands) == 2
    for block in commands:
        assert block in readme, f"docs/quickstart.md's command is not the README's:\n{block}"


def test_the_first_command_without_rl_is_the_readmes_and_shows_the_chemistry(tmp_path,
                                                                              monkeypatch):
    guide = DOCS / "quickstart.md"
    (line,) = [ln for b in _blocks(guide, "console") for ln in b.splitlines()
               if ln.startswith("$ discgym run ")]
    words = line.split()[2:]
    readme = " ".join((ROOT / "README.md").read_text().split())
    assert f"`{' '.join(line.split()[1:])}`" in readme, line
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(io.StringIO()) as out, \
            contextlib.redirect_stderr(io.StringIO()):
        assert cli.main(words) in (0, None)
    text = out.getvalue()
    fired = int(re.search(r"^reactions fired +(\d+)$", text, flags=re.M).group(1))
    made = {m[0]: int(m[2]) for m in re.findall(r"^(\w+) +(\d+) +(\d+) +[-+]\d+$", text,
                                                flags=re.M)}
    # (the cold start shows nothing: 0 reactions in 40 time units, flat lines)
    assert fired >= 50 and made["C"] >= 20 and made["A"] < 120, text
    assert (tmp_path / "reactor.png").stat().st_size > 0


def test_api_reference_covers_the_public_names():
    api = "\n".join(p.read_text() for p in (DOCS / "api").glob("*.md"))
    modules = set(re.findall(r"\.\. automodule:: ([\w.]+)\n(?:   :[\w-]+:.*\n)*   :members:",
                             api))
    for mod, names in (("discgym", dg.__all__), ("discgym.tasks", dg.tasks.__all__)):
        for name in names:
            obj = getattr(sys.modules[mod], name)
            if mod in modules or isinstance(obj, type(sys)):
                continue
            assert re.search(rf"\.\. auto\w+:: {re.escape(mod)}\.{name}\b", api), \
                f"{mod}.{name} is not in docs/api/"
    for mod in ("discgym.controllers", "discgym.baselines", "discgym.oracle", "discgym.sb3",
                "discgym.scenes", "discgym.render"):
        assert mod in modules, f"docs/api/ has no automodule of {mod} with its members"


def _make_calls(text: str):
    """The ``gymnasium.make("<id>", k=v, ...)`` calls of a page's Python blocks."""
    for block in re.findall(r"^```python\n(.*?)^```", text, flags=re.M | re.S):
        for node in ast.walk(ast.parse(block)):
            if isinstance(node, ast.Call) and ast.unparse(node.func) in ("gymnasium.make",
                                                                        "gym.make"):
                yield node


def test_env_guide_signature_is_the_defaults():
    """docs/env.md writes out ``gymnasium.make("DiscReactor-v0", ...)`` with every default."""
    calls = [c for c in _make_calls((DOCS / "env.md").read_text()) if len(c.keywords) > 5]
    assert calls, "docs/env.md: no gymnasium.make call with the defaults"
    env_cls = dg.env.DiscReactorEnv
    want = {name: default for name, default, _ in gen_pages.arguments(env_cls)}
    for call in calls:
        shown = {k.arg: ast.literal_eval(k.value) for k in call.keywords}
        assert list(shown) == list(want), "docs/env.md: the arguments, in order"
        wrong = {k: (v, want[k]) for k, v in shown.items() if not numbers_equal(v, want[k])}
        assert not wrong, f"docs/env.md: defaults (shown, code): {wrong}"


def test_task_tables_are_the_code():
    """The tables of the README and docs/tasks.md: observation sizes, reward coefficients."""
    tasks = (DOCS / "tasks.md").read_text()
    readme = (ROOT / "README.md").read_text()
    for env_id in TASKS:
        env = gym.make(env_id).unwrapped
        row = re.search(rf"^\| `{env_id}` \|.*\| (\d+)(?::[^|]*)? \|$", tasks, flags=re.M)
        assert row, f"docs/tasks.md: no row of {env_id} in the table of tasks"
        assert int(row.group(1)) == env.observation_space.shape[0], f"docs/tasks.md {env_id}"
        row = re.search(rf"^\| `{env_id}` \|.*\|$", readme, flags=re.M)
        if row:
            for pattern, value in ((r"(\d[\d.]*) x heat", env.config.heat_cost),
                                   (r"(\d[\d.]*) x discs fed", env.config.feed_cost)):
                stated = [float(x) for x in re.findall(pattern, row.group(0))]
                assert all(x == value for x in stated), f"README {env_id}: {stated} {value}"
        env.close()


# --------------------------------------------------------------------------------------------
# the command line


def _flags(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                out.update(_flags(sub))
        for opt in action.option_strings:
            if opt not in ("-h", "--help"):
                out[opt] = action
    return out


def test_cli_doc_has_every_flag_and_no_other():
    doc = (DOCS / "cli.md").read_text()
    ours = _flags(cli.build_parser())
    passed_on = _flags(bench_parser())  # `discgym bench` passes the suite's options on
    flags = re.findall(r"(?<![\w-])(--[a-z][\w-]*|-[a-z])(?![\w-])", doc.replace("python -m", ""))
    documented = set(flags) - {"-h", "--help"}
    # (an option is documented by any of its names: `--time` for `-t`)
    undocumented = sorted({max(a.option_strings, key=len) for a in ours.values()
                           if not set(a.option_strings) & documented})
    assert not undocumented, f"docs/cli.md does not document {undocumented}"
    unknown = sorted(documented - set(ours) - set(passed_on))
    assert not unknown, f"docs/cli.md documents flags that do not exist: {unknown}"
    sub = next(a for a in cli.build_parser()._actions
               if isinstance(a, argparse._SubParsersAction))
    for command in sub.choices:
        assert f"discgym {command}" in doc, f"docs/cli.md does not show `discgym {command}`"
    # "`--frames` (100)": the defaults it states
    for flag, value in re.findall(r"`(--[\w-]+)` \((\d+(?:\.\d+)?)\)", doc):
        assert float(ours[flag].default) == float(value), f"docs/cli.md: {flag} ({value})"



# --------------------------------------------------------------------------------------------
# the measured ladders


def _ladder_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("ladder_script",
                                                  ROOT / "benchmarks" / "ladder.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_measured_ladders_are_the_code_and_the_pages_show_them():
    """docs/data/ladder_<task>.json: every task's ladder, measured with the searched
    controller the code ships and the planner's settings of the code; each task page's
    Baselines section shows it; docs/tasks.md's suite and aggregate tables are what
    ``ladder.py --table`` prints from those files."""
    from discgym.baselines import PLANNER_FUTURES, PLANNER_GATE
    from discgym.searched import SEARCHED

    ladder = _ladder_module()
    results = []
    for env_id in TASKS:
        res = json.loads((DOCS / "data" / f"ladder_{env_id}.json").read_text())
        assert res["env_id"] == env_id and list(res["policies"]) == list(ladder.LADDER)
        assert res["searched"]["params"] == SEARCHED[env_id]["params"], env_id
        pb = res["planner_budget"]
        assert (pb["futures_per_candidate"], pb["gate"]) == (PLANNER_FUTURES, PLANNER_GATE)
        assert res["env_kwargs"] == {} and len(res["eval_seeds"]) >= 20
        page = gen_pages.task_page(env_id)
        assert "## Baselines" in page and res["table"] in page
        results.append(res)
    text = (DOCS / "tasks.md").read_text()
    results.sort(key=lambda r: r["env_id"])  # (the order of ladder.py --table ladder_Disc*)
    assert ladder.summary_table(results) in text
    assert ladder.aggregate_table(results) in text
    variants = json.loads((DOCS / "data" / "ladder_variants_DiscReactor-v0.json").read_text())
    assert variants["variants_table"] in text
    assert variants["searched"]["params"] == SEARCHED["DiscReactor-v0"]["params"]


def test_the_learners_table_is_its_data():
    """docs/agents.md's table and budgets across the tasks are what agents/aggregate.py makes
    of docs/data/learners.json (every score it read), with the searches' budgets of the code;
    its planner and oracle are the shipped ladders' (normalised afresh here)."""
    pytest.importorskip("tyro")
    sys.path.insert(0, str(ROOT / "agents"))
    import aggregate

    data = json.loads((DOCS / "data" / "learners.json").read_text())
    norm = data["normalised"]
    assert norm["tasks"] and set(norm["tasks"]) == set(TASKS)
    text = (DOCS / "agents.md").read_text()
    assert aggregate.table(norm, aggregate.aggregate(norm)) in text
    assert aggregate.budget_table(norm) in text
    for env_id in TASKS:
        lad = json.loads((DOCS / "data" / f"ladder_{env_id}.json").read_text())
        for key in ("planner", "oracle"):
            assert norm["policies"][key][env_id] == pytest.approx(
                aggregate._scores(lad["policies"], key).tolist(), rel=0, abs=1e-12)
    assert (DOCS / "img" / "learners_across_tasks.png").stat().st_size > 10_000


def test_the_readme_quotes_the_learners_data():
    """The README's headline quotes each learner's, the planner's and the oracle's IQM over
    the tasks with its interval, as docs/data/learners.json gives them."""
    pytest.importorskip("tyro")
    sys.path.insert(0, str(ROOT / "agents"))
    import aggregate

    norm = json.loads((DOCS / "data" / "learners.json").read_text())["normalised"]
    agg = aggregate.aggregate(norm)
    readme = " ".join((ROOT / "README.md").read_text().split())
    for key in aggregate.learners(norm) + ["planner", "oracle"]:
        a = agg[key]
        quoted = f"{a['value']:.3f}" + ("" if a["low"] is None else  # (one run: no interval)
                                        f" [{a['low']:.3f}, {a['high']:.3f}]")
        assert quoted in readme, f"README: {aggregate.label(key)} should read {quoted}"
