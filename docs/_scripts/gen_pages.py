"""Generate the documentation pages that the code knows: one page per task (``docs/tasks/``)
and the table of built-in scenes (``docs/_generated/scenes.md``).

Run by ``docs/conf.py`` when a build starts (or by hand: ``python docs/_scripts/gen_pages.py``).
A task page is the task class's docstring (its Gymnasium-style sections: Description, Action
Space, Observation Space, Rewards, Starting State, Episode End, Arguments, Version History)
followed, in the matching sections, by tables read from a live env: the action slots, the
observation slots with their bounds, the reward terms with their coefficients and every
constructor argument with its default. ``tests/test_docs_drift.py`` checks the docstrings'
numbers against the same code. Only files whose text changed are written, so that Sphinx
rereads only what changed.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import re
from pathlib import Path

import gymnasium as gym

from discgym import Box, Circle, Outlet, Scene, Species, ThermalWall, controllers, scenes
from discgym.env import DEFAULTS, ENV_ID
from discgym.scene import _REACTION_FIELDS, REACTION_TYPES
from discgym.tasks import TASKS

DOCS = Path(__file__).resolve().parent.parent
#: Where make_gifs.py writes each task's episode and the pages look for it.
GIF_DIR = DOCS / "img" / "tasks"
#: The measured ladders (benchmarks/ladder.py's JSON) the task pages show.
DATA_DIR = DOCS / "data"

SECTION_ORDER = ("Description", "Action Space", "Observation Space", "Rewards",
                 "Starting State", "Episode End", "Arguments", "Version History")

# --------------------------------------------------------------------------------------------
# reading the docstrings


def docstring_sections(cls: type) -> tuple[str, dict[str, str]]:
    """``(summary, {section: text})`` of a task class's docstring: the text before the first
    ``## Heading`` and the text under each heading (dedented, stripped)."""
    doc = inspect.cleandoc(cls.__doc__ or "")
    parts = re.split(r"^## (.+)$", doc, flags=re.M)
    summary, out = parts[0].strip(), {}
    for title, body in zip(parts[1::2], parts[2::2]):
        out[title.strip()] = body.strip()
    return summary, out


_CODE = re.compile(r"(``.+?``)", re.S)


def escape_bars(text: str) -> str:
    """``|x|`` (an absolute value) outside literals, escaped for reStructuredText (where it
    would be a substitution reference)."""
    parts = _CODE.split(text)
    return "".join(p if k % 2 else p.replace("|", r"\|") for k, p in enumerate(parts))


_ROLE = re.compile(r":(?:py:)?(class|meth|func|data|attr|mod|obj|exc):`([^`]+)`")


def to_myst(text: str) -> str:
    """A docstring's reStructuredText roles (``:class:`X```) as MyST roles (``{class}`X```);
    the rest of the docstrings is already Markdown-compatible."""
    return _ROLE.sub(lambda m: f"{{py:{m.group(1)}}}`{m.group(2)}`", text)


# --------------------------------------------------------------------------------------------
# what a live env says

#: The observation's blocks, in order: (key, pattern of its slot names, what adds it).
BLOCKS = (
    ("base", r"(fraction|kT|internal|feed_left)_|(energy_per_disc|discs|yield|size|time_left)$",
     "DiscReactor-v0's slots (3 S + 5 + F)"),
    ("jacket_kT", r"jacket_kT$", '`heating="jacket"`: the thermal walls\' kT'),
    ("feed_kT", r"feed_kT$", "`feed_temperature`: the inlet kT"),
    ("outflow", r"outflow_", "`observe_outflow=True`: discs of each species that left"),
    ("energy", r"energy_.+\[", "`energy_bins`: kinetic-energy histogram per species"),
    ("grid", r"cell_", "`spatial_grid`: per species share per cell, then kT per cell"),
    ("reactions", r"reactions\[", "`observe_reactions=True`: reactions per channel"),
)


def block_of(name: str) -> str:
    """The observation block a slot name belongs to (a key of :data:`BLOCKS`)."""
    for key, pattern, _ in BLOCKS:
        if re.match(pattern, name):
            return key
    raise ValueError(f"observation slot {name!r} belongs to no known block: add it to "
                     f"docs/_scripts/gen_pages.py BLOCKS")


def observation_blocks(names) -> list[tuple[str, int, int]]:
    """``[(block key, first slot, slot count)]`` of an observation's slot names, in order
    (a block's slots are contiguous)."""
    out: list[tuple[str, int, int]] = []
    for k, nm in enumerate(names):
        key = block_of(nm)
        if out and out[-1][0] == key:
            out[-1] = (key, out[-1][1], out[-1][2] + 1)
        else:
            if any(b[0] == key for b in out):
                raise ValueError(f"observation block {key!r} is not contiguous at {nm!r}")
            out.append((key, k, 1))
    return out


def make(env_id: str) -> gym.Env:
    """The task's env, unwrapped (constructing it compiles nothing)."""
    return gym.make(env_id).unwrapped


#: The reward's first term per ``reward`` argument (config.REWARDS), in words.
GAIN = {
    "product": "({p} now - {p} before) / n_ref: the product {p} made during the step",
    "outflow": "{p} that left through the outlets during the step / n_ref",
}


def reward_terms(env) -> list[tuple[str, str, str]]:
    """``[(term, coefficient, info key)]`` of the env's per-step reward (its step's
    arithmetic: gain - heat cost - feed cost)."""
    cfg = env.config
    product = cfg.species_names[cfg.product]
    return [
        ("+ " + GAIN[cfg.reward].format(p=product), "1", "reward_product"),
        ("- heat_cost x |heat energy| / n_ref: the energy the heat action (or the jacket) put "
         "in or took out",
         f"{cfg.heat_cost:g}", "cost_heat"),
        ("- feed_cost x discs injected / n_ref", f"{cfg.feed_cost:g}", "cost_feed"),
    ]


def action_meaning(env, name: str) -> str:
    cfg = env.config
    if name == "heat":
        if cfg.heating == "jacket":
            return (f"every thermal wall's kT to t_min (t_max / t_min) ** ((a + 1) / 2), "
                    f"[t_min, t_max] = [{cfg.t_min:g}, {cfg.t_max:g}]")
        return (f"kinetic energy x heat_rate ** a (heat_rate {cfg.heat_rate:g}), kT kept in "
                f"[{cfg.t_min:g}, {cfg.t_max:g}]")
    if name == "wall":
        return (f"target width size_min + (a + 1) / 2 (size_max - size_min) of the scene's, "
                f"[{cfg.size_min:g}, {cfg.size_max:g}], at most {cfg.wall_speed:g} per step")
    species = name.removeprefix("inject_")
    budget = dict(zip((cfg.species_names[f] for f in cfg.feed), cfg.feed_budget))[species]
    return (f"round(a x {cfg.inject_max}) discs of {species} for a > 0, "
            f"{int(budget)} per episode")


def arguments(cls: type) -> list[tuple[str, object, object]]:
    """``[(argument, the task's default, DiscReactor-v0's default)]``: every keyword the
    constructor takes (the task's ``defaults``, then ``render_mode`` and ``render_size``)."""
    rows = [(k, v, DEFAULTS[k]) for k, v in cls.defaults.items()]
    sig = inspect.signature(cls._construct)
    for p in sig.parameters.values():
        if p.kind is p.KEYWORD_ONLY or (p.kind is p.POSITIONAL_OR_KEYWORD and p.name != "self"):
            rows.append((p.name, p.default, p.default))
    return rows


def controller_name(env_id: str) -> str:
    env = gym.make(env_id)
    c = controllers.controller_for(env)
    env.close()
    return type(c).__name__


# --------------------------------------------------------------------------------------------
# the pages


def _num(x: float) -> str:
    return f"{float(x):g}"


def _table(header: tuple, rows) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        out.append("| " + " | ".join(str(c).replace("|", r"\|") for c in r) + " |")
    return "\n".join(out)


def task_page(env_id: str) -> str:
    env_cls, vec_cls = TASKS[env_id]
    env = make(env_id)
    cfg = env.config
    summary, sections = docstring_sections(env_cls)
    spec = gym.spec(env_id)
    obs, act = env.observation_space, env.action_space
    mod = env_cls.__module__
    lines = [
        f"# {env_id}",
        "",
        "<!-- generated by docs/_scripts/gen_pages.py from the code: edit the task class's "
        "docstring instead -->",
        "",
        f"```{{py:currentmodule}} {mod}",
        "```",
        "",
        f"```{{figure}} ../img/tasks/{env_id}.gif",
        f":alt: one episode of {env_id} under its hand-written controller",
        ":width: 480px",
        "",
        f"One episode (seed 0) under the hand-written controller "
        f"({{py:obj}}`~discgym.controllers.{controller_name(env_id)}`): the reactor, and its "
        f"species counts step by step (`docs/_scripts/make_gifs.py`).",
        "```",
        "",
        to_myst(summary),
        "",
        _table(("", ""), [
            ("make", f'`gymnasium.make("{env_id}")`, `gymnasium.make_vec("{env_id}", 16)`'),
            ("class", f"{{py:class}}`{mod}.{env_cls.__name__}`"),
            ("vector env", f"{{py:class}}`{vec_cls.__module__}.{vec_cls.__name__}`"),
            ("scene", f"`{cfg.scene.name}`: {cfg.scene.description}"),
            ("action space", f"`Box(-1, 1, {act.shape}, {act.dtype})`: "
                             + ", ".join(f"`{a}`" for a in env.action_names)),
            ("observation space", f"`Box(low, high, {obs.shape}, {obs.dtype})`"),
            ("episode", f"{cfg.episode_steps} steps of {_num(cfg.steps_per_action * cfg.scene.dt)}"
                        f" time units (`max_episode_steps={spec.max_episode_steps}`)"),
        ]),
        "",
    ]
    extra = {
        "Action Space": _action_table(env),
        "Observation Space": _observation_tables(env),
        "Rewards": _reward_table(env),
        "Arguments": _argument_table(env_cls),
    }
    titles = [t for t in SECTION_ORDER if t in sections] + \
        [t for t in sections if t not in SECTION_ORDER]
    for title in titles:
        lines += [f"## {title}", "", to_myst(sections[title]), ""]
        if title in extra:
            lines += [extra.pop(title), ""]
    for title, text in extra.items():  # (a section the docstring lacks: the tables anyway)
        lines += [f"## {title}", "", text, ""]
    lines += [baselines_section(env_id)]
    env.close()
    return "\n".join(lines).rstrip() + "\n"


def ladder_data(env_id: str) -> dict | None:
    """The task's measured ladder (``docs/data/ladder_<env>.json``, written by
    ``benchmarks/ladder.py``), or None."""
    path = DATA_DIR / f"ladder_{env_id}.json"
    return json.loads(path.read_text()) if path.exists() else None


def baselines_section(env_id: str) -> str:
    """The task page's "Baselines" section: its ladder as measured (the table the ladder
    script wrote into its JSON, with the run's command, date and machine) and the searched
    controller's parameters."""
    res = ladder_data(env_id)
    if res is None:
        return "## Baselines\n\nNot measured yet (`python benchmarks/ladder.py --env " \
               f"{env_id}`).\n"
    cmd = re.sub(r"--out \S+", f"--out docs/data/ladder_{env_id}.json", res["command"])
    pb, ob = res["planner_budget"], res["oracle_budget"]
    seeds = res["eval_seeds"]
    sp = res["searched"]
    lines = [
        "## Baselines", "",
        f"`{cmd}` ({res['date']}; {res['machine']}; {res['total_seconds']:.0f} s in all). "
        f"One episode per evaluation seed {seeds[0]}-{seeds[-1]}; the constant searched on "
        f"seeds {res['search_seeds'][0]}-{res['search_seeds'][-1]}; mean and IQM with 95% BCa "
        "bootstrap intervals, each step of the ladder by its paired difference "
        "([the ladder](../tasks.md#tasks-and-their-baseline-ladders)):", "",
        res["table"], "",
        f"The planner: {pb['candidates_per_replan']:.1f} candidate first actions per re-plan, "
        f"each on {pb['futures_per_candidate']} fresh random futures, every "
        f"{pb['replan_every']} steps, rollouts to the {pb['horizon']}, "
        + (f"a candidate taken only {pb['gate']:g} standard errors clear of the searched "
           f"controller's action ({pb['gated_per_replan']:.1f} turned down per re-plan); "
           if pb.get("gate") is not None else "")
        + f"{pb['simulated_steps_per_episode']:,.0f} simulated env steps per episode. The "
        f"oracle: the same candidates on exact copies, {ob['simulated_steps_per_episode']:,.0f}"
        " simulated env steps per episode. Wall times are of this run (the machine may have "
        "run other jobs beside it).", "",
        f"The searched controller ({{py:func}}`discgym.searched.searched`), found by "
        f"`{sp['command']}`:", "",
        _table(("parameter", "value"), [(f"`{k}`", f"{v:.4g}") for k, v in sp["params"].items()]),
        "",
    ]
    return "\n".join(lines)


def _action_table(env) -> str:
    rows = [(k, f"`{nm}`", "[-1, 1]", action_meaning(env, nm))
            for k, nm in enumerate(env.action_names)]
    return "The action slots (`env.unwrapped.action_names`):\n\n" + \
        _table(("index", "name", "range", "effect of a"), rows)


def _observation_tables(env) -> str:
    names = env.observation_names
    lo, hi = env.observation_space.low, env.observation_space.high
    what = {key: text for key, _, text in BLOCKS}
    blocks = observation_blocks(names)
    btab = _table(("slots", "count", "block"), [
        (f"{s}-{s + n - 1}" if n > 1 else f"{s}", n, what[key]) for key, s, n in blocks])
    stab = _table(("index", "name", "low", "high"), [
        (k, f"`{nm}`", _num(lo[k]), _num(hi[k])) for k, nm in enumerate(names)])
    return (f"The {len(names)} slots by block (S = {env.config.n_species} species, "
            f"F = {len(env.config.feed)} feed species):\n\n{btab}\n\n"
            f"Every slot (`env.unwrapped.observation_names`, bounds of "
            f"`env.observation_space`, float32):\n\n{stab}")


def _reward_table(env) -> str:
    n_ref = "n_ref: the initial count of the limiting feed species"
    rows = [(t, c, f"`info[\"{k}\"]`") for t, c, k in reward_terms(env)]
    return (f"The reward of a step is the sum of these terms ({n_ref}):\n\n"
            + _table(("term", "coefficient", "in info"), rows))


def _argument_table(env_cls: type) -> str:
    def show(v):
        return f"`{v!r}`"

    rows = [(f"`{k}`", show(v), "" if _same(v, base) else show(base))
            for k, v, base in arguments(env_cls)]
    return ("Every keyword argument and its default (`gymnasium.make(id, **kwargs)` passes "
            "them on):\n\n" + _table(("argument", "default", f"{ENV_ID}'s, if different"), rows))


def _same(a, b) -> bool:
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    return type(a) is type(b) and a == b


def tasks_index() -> str:
    rows = []
    for env_id, (env_cls, _) in TASKS.items():
        env = make(env_id)
        first = docstring_sections(env_cls)[0].split("\n\n")[0]
        summary = first.split("``: ", 1)[-1].strip()
        rows.append((f"[{env_id}]({env_id}.md)", to_myst(" ".join(summary.split())),
                     env.action_space.shape[0], env.observation_space.shape[0]))
        env.close()
    toc = "\n".join(TASKS)
    return (
        "# Task reference\n\n"
        "<!-- generated by docs/_scripts/gen_pages.py -->\n\n"
        "One page per registered task, generated from its class and a live env: the "
        "specification (the class docstring) with tables of its actions, observation slots, "
        "reward terms and arguments. The suite and its baselines: [the task suite](../tasks.md)."
        "\n\n" + _table(("task", "", "actions", "observation"), rows) + "\n\n"
        f"```{{toctree}}\n:hidden:\n\n{toc}\n```\n")


def scenes_table() -> str:
    rows = []
    for name in scenes.names():
        sc = scenes.load(name)
        walls = [f"thermal {w.side}" for w in sc.thermal_walls] + \
            [f"outlet {o.side} [{_num(o.start)}, {_num(o.end)}]" for o in sc.outlets]
        rows.append((f"`{name}`", sc.description, repr(sc.bounds),
                     ", ".join(s.name for s in sc.species),
                     "; ".join(r.label() for r in sc.reactions) or "none",
                     ", ".join(walls) or "elastic",
                     ", ".join(f"{k} {v}" for k, v in sc.counts.items())))
    return ("<!-- generated by docs/_scripts/gen_pages.py from discgym/scenes/*.toml -->\n\n"
            + _table(("scene", "description", "bounds", "species", "reactions", "walls",
                      "counts"), rows) + "\n")


def scene_arguments() -> dict[str, str]:
    """``{field: description}`` of :class:`discgym.Scene`'s docstring section Arguments
    (``name, description: ...`` describes both)."""
    doc = inspect.cleandoc(Scene.__doc__ or "")
    body = doc.split("Arguments:", 1)[1]
    out: dict[str, str] = {}
    key = None
    for line in body.splitlines():
        m = re.match(r"    ([a-z_, ]+): (.*)$", line)
        if m:
            key = [k.strip() for k in m.group(1).split(",")]
            for k in key:
                out[k] = m.group(2).strip()
        elif line.startswith("        ") and key:
            for k in key:
                out[k] += " " + line.strip()
        elif line.strip():
            key = None
    return out


def _default(f) -> str:
    if f.default is not dataclasses.MISSING:
        return f"`{_toml_text(f.default)}`"
    if f.default_factory is not dataclasses.MISSING:
        return f"`{_toml_text(f.default_factory())}`"
    return "required"


def _toml_text(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_toml_text(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{}" if not v else repr(v)
    return repr(v)


#: The TOML tables of a scene file and the class each builds.
TABLES = (("[bounds] shape = \"box\"", Box), ("[bounds] shape = \"circle\"", Circle),
          ("[[species]]", Species), ("[[thermal_walls]]", ThermalWall), ("[[outlets]]", Outlet))


def scene_keys() -> str:
    """The keys of a scene file, from :class:`discgym.Scene`'s fields and docstring and the
    dataclasses of its parts."""
    described = scene_arguments()
    top = []
    for f in dataclasses.fields(Scene):
        if f.name not in described:
            raise ValueError(f"Scene.{f.name} is not described in Scene's docstring "
                             "(section Arguments)")
        top.append((f"`{f.name}`", _default(f), to_myst(described[f.name])))
    parts = []
    for table, cls in TABLES:
        keys = ", ".join(f"`{f.name}` ({_default(f)})" for f in dataclasses.fields(cls))
        parts.append((f"`{table}`", keys, to_myst(" ".join(
            inspect.cleandoc(cls.__doc__ or "").split("\n\n")[0].split()))))
    for kind, cls in REACTION_TYPES.items():
        fields = {f.name: f for f in dataclasses.fields(cls)}
        rnames, pnames, params = _REACTION_FIELDS[kind]
        keys = [f"`reactants` ({len(rnames)} name{'s' * (len(rnames) > 1)})",
                f"`products` ({len(pnames)} name{'s' * (len(pnames) > 1)})"]
        keys += [f"`{p}` ({_default(fields[p])})" for p in params]
        parts.append((f'`[[reactions]] type = "{kind}"`', ", ".join(keys), to_myst(" ".join(
            inspect.cleandoc(cls.__doc__ or "").split("\n\n")[0].split()))))
    parts.append(("`[counts]`", "`<species> = <count>`, ...", "the default initial "
                  "population (`counts`)"))
    return ("<!-- generated by docs/_scripts/gen_pages.py from discgym/scene.py -->\n\n"
            "The top-level keys (the fields of {py:class}`discgym.Scene`):\n\n"
            + _table(("key", "default", ""), top) + "\n\nThe tables:\n\n"
            + _table(("table", "keys (default)", ""), parts) + "\n")


def pages() -> dict[str, str]:
    """``{path relative to docs/: text}`` of every generated page."""
    out = {f"tasks/{env_id}.md": task_page(env_id) for env_id in TASKS}
    out["tasks/index.md"] = tasks_index()
    out["_generated/scenes.md"] = scenes_table()
    out["_generated/scene_keys.md"] = scene_keys()
    return out


def write_all(docs: Path = DOCS) -> list[Path]:
    """Write the generated pages under ``docs``; returns those whose text changed."""
    changed = []
    for rel, text in pages().items():
        path = docs / rel
        if path.exists() and path.read_text() == text:
            continue
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        changed.append(path)
    return changed


if __name__ == "__main__":
    for p in write_all():
        print(f"wrote {p}")
