"""The task suite: reactor-control problems beyond ``DiscReactor-v0``.

Each task is a :class:`~discgym.env.DiscReactorEnv` (and a
:class:`~discgym.vector.DiscReactorVectorEnv`) with its own defaults: a scene, the arguments
that make its control problem, and its observation blocks. A task class's docstring is its
specification; ``docs/tasks.md`` has the same with the measured baselines. Every task is
registered on ``import discgym``, for ``gymnasium.make`` (also as ``"discgym:<id>"``) and
``gymnasium.make_vec`` (the native vector env: one compiled call for all reactors, bit for bit
the single env).

>>> import gymnasium as gym
>>> import discgym
>>> sorted(discgym.tasks.TASKS)  # doctest: +NORMALIZE_WHITESPACE
['DiscEconomic-v0', 'DiscFlow-v0', 'DiscJacket-v0', 'DiscKinetics-v0', 'DiscReactor-v0']
>>> gym.make("DiscKinetics-v0").observation_space.shape
(34,)
"""

from __future__ import annotations

import gymnasium as gym

from .config import DEFAULTS, ENV_ID
from .env import DiscReactorEnv
from .vector import DiscReactorVectorEnv

__all__ = [
    "TASKS",
    "DiscKineticsEnv",
    "DiscKineticsVectorEnv",
    "DiscEconomicEnv",
    "DiscEconomicVectorEnv",
    "DiscJacketEnv",
    "DiscJacketVectorEnv",
    "DiscFlowEnv",
    "DiscFlowVectorEnv",
    "register_tasks",
    "task_id",
]


class DiscKineticsEnv(DiscReactorEnv):
    """``DiscKinetics-v0``: the reactor of ``DiscReactor-v0`` with kinetics that change from
    episode to episode and are not revealed.

    ## Description
    The scene, controls and reward of ``DiscReactor-v0`` (A + B -> C, the product, competing
    with the side reaction C + A -> W + B), but each reset draws the activation energies, the
    reverse probability of A + B -> C and the formation energies from documented ranges:
    both activation energies x one factor U[0.5, 1.5] (A + B -> C in [2, 6], C + A -> W + B
    in [4, 12]), the reverse probability x 10 ** U[-0.5, 0.5] (0.063 to 0.63 per unit time),
    every formation energy + U[-0.3, 0.3]. The temperature window in which C is made faster
    than the side reaction destroys it moves with them, so no fixed setpoint is right for
    every episode: the policy must find the window from what it observes, as a chemist does
    from the reactions it sees fire.

    ## Action Space
    As ``DiscReactor-v0``: ``Box(-1, 1, (4,), float32)``: heat, wall, inject A, inject B.

    ## Observation Space
    ``Box(low, high, (34,), float32)``: the 19 slots of ``DiscReactor-v0``, then per species
    the share of its discs in 3 kinetic-energy bins with edges at the *nominal* activation
    energies ([0, 4), [4, 8), [8, inf): 12 slots, ``energy_<species>[a,b)``), then the
    reactions fired in the last step per channel, divided by the limiting reactant at reset
    (A + B -> C, C + A -> W + B, the reverse C -> A + B: 3 slots, ``reactions[<label>]``,
    in [0, 4]). Names in ``env.unwrapped.observation_names``.

    ## Rewards
    As ``DiscReactor-v0``: the gain in C per unit of limiting reactant; the return of an
    episode is the product yield.

    ## Starting State
    As ``DiscReactor-v0`` (counts x U[0.9, 1.1], kT 0.6 x U[0.6, 1.4]), and the kinetics
    drawn after them from the env's ``np_random`` (``ReactorConfig.draw_kinetics``).

    ## Episode End
    Never terminated; truncated after 100 steps (50 units of time).

    ## Arguments
    Those of ``DiscReactor-v0`` (the table of ``docs/env.md``), with the defaults
    ``activation_jitter=0.5``, ``reverse_jitter=0.5``, ``formation_jitter=0.3``,
    ``energy_bins=3``, ``observe_reactions=True``. ``activation_jitter`` in [0, 1) (a
    relative spread), ``reverse_jitter`` in [0, 3] (decades), ``formation_jitter`` >= 0 (an
    energy); ``energy_bins`` 0 or 2..32, ``spatial_grid`` 0..16, ``observe_reactions`` a bool.

    ## Version History
    - v0: first version.
    """

    defaults = dict(DEFAULTS, activation_jitter=0.5, reverse_jitter=0.5, formation_jitter=0.3,
                    energy_bins=3, observe_reactions=True)


class DiscEconomicEnv(DiscReactorEnv):
    """``DiscEconomic-v0``: the reactor of ``DiscReactor-v0`` run for profit: the product's
    value minus the heating energy and the reagents bought.

    ## Description
    The scene, controls and chemistry of ``DiscReactor-v0``; the reward charges every unit of
    energy the heat control puts in or takes out (``heat_cost`` = 0.08 per unit of energy)
    and every injected disc (``feed_cost`` = 0.3), both per unit of limiting reactant at
    reset, against 1 per disc of product C. Heating the cold reactor to the reaction window
    costs about a fifth of what its product is worth, and a fed disc pays only if it is
    turned into product: the trade-off between a fast, hot reactor and an economical one is
    the task.

    ## Action Space
    As ``DiscReactor-v0``: ``Box(-1, 1, (4,), float32)``.

    ## Observation Space
    ``Box(low, high, (35,), float32)``: the 19 slots of ``DiscReactor-v0``, plus the
    per-species kinetic-energy histogram with edges at the activation energies ([0, 2), [2, 4),
    [4, 8), [8, inf): 16 slots).

    ## Rewards
    ``(C_now - C_before) / n_ref - 0.08 |heat energy| / n_ref - 0.3 x injected / n_ref``: the
    return is the profit per unit of limiting reactant.

    ## Starting State
    As ``DiscReactor-v0``.

    ## Episode End
    Never terminated; truncated after 100 steps (50 units of time).

    ## Arguments
    Those of ``DiscReactor-v0`` with the defaults ``heat_cost=0.08``, ``feed_cost=0.3``,
    ``energy_bins=4``.

    ## Version History
    - v0: first version.
    """

    defaults = dict(DEFAULTS, heat_cost=0.08, feed_cost=0.3, energy_bins=4)


class DiscJacketEnv(DiscReactorEnv):
    """``DiscJacket-v0``: the reactor heated and cooled through its walls.

    ## Description
    The built-in scene ``jacket``: the chemistry of ``DiscReactor-v0`` (A + B -> C, activation
    energy 4, against C + A -> W + B, activation energy 8), with much more reaction heat
    (formation energies C -2.5, W -3.5), in a 30 x 30 box whose left wall is thermal: a disc
    that hits it leaves with a velocity drawn from the wall's temperature (the diffuse,
    flux-weighted Maxwell-Boltzmann rule, docs/physics.md). The agent sets this jacket's
    temperature instead of rescaling every velocity. Heat reaches the rest of the reactor only
    through collisions, so the reactor heats and cools with a lag and with a gradient: it pays
    to heat before the reaction needs it and to cool before the exotherm runs away.

    ## Action Space
    ``Box(-1, 1, (4,), float32)``: jacket (every thermal wall to ``t_min (t_max / t_min) **
    ((a + 1) / 2)``, log-uniform over ``temperature_range`` = [0.3, 6]; a NaN keeps the
    jacket as it is), wall, inject A, inject B (as in ``DiscReactor-v0``).

    ## Observation Space
    ``Box(low, high, (65,), float32)``: the 19 slots of ``DiscReactor-v0``, the jacket's
    temperature (``jacket_kT``, in [0, 6]), then a 3 x 3 spatial histogram: per species the
    share of its discs in each cell, and kT per cell (45 slots; ``spatial_grid=3``), where the
    gradient between the walls and the middle shows.

    ## Rewards
    As ``DiscReactor-v0``: the gain in C per unit of limiting reactant (``heat_cost``, 0 by
    default, charges the energy the walls exchange). ``info["heat_energy"]`` is the energy the
    thermal walls put in during the step (negative: taken out).

    ## Starting State
    As ``DiscReactor-v0``; the jacket starts at the scene's 0.6.

    ## Episode End
    Never terminated; truncated after 100 steps (50 units of time).

    ## Arguments
    Those of ``DiscReactor-v0`` with the defaults ``scene="jacket"``, ``heating="jacket"``,
    ``temperature_range=(0.3, 6.0)``, ``spatial_grid=3``.

    ## Version History
    - v0: first version.
    """

    defaults = dict(DEFAULTS, scene="jacket", heating="jacket", temperature_range=(0.3, 6.0),
                    spatial_grid=3)


class DiscFlowEnv(DiscReactorEnv):
    """``DiscFlow-v0``: a continuous stirred reactor, run for the product that leaves it.

    ## Description
    The built-in scene ``flow``: the chemistry of ``DiscReactor-v0`` (A + B -> C, activation
    energy 4, against C + A -> W + B, activation energy 8) in a 16 x 16 box whose right wall
    is an outlet: every disc that reaches it leaves (by two-dimensional effusion, a disc of
    the gas stays about 30 units of time at kT 1.5; a wider reactor keeps it longer). It
    starts with ~40 A and ~40 B, cold (kT ~0.6), and is fed A and B (up to 4 of each per step,
    400 of each per episode). The fed discs come in at an inlet temperature drawn per episode
    from U[0.3, 2.0], which changes, to another draw, at a random step in the middle third of
    the episode: a cold feed must be heated, and the heating costs. The reward is the product
    leaving per step, less the heating energy and the feed: the reactor must be hot and wide
    enough to convert what passes through, not so hot that the side reaction eats the product,
    and not heated or fed beyond what pays.

    ## Action Space
    As ``DiscReactor-v0``: ``Box(-1, 1, (4,), float32)``: heat, wall (the right wall, with
    the outlet on it), inject A, inject B.

    ## Observation Space
    ``Box(low, high, (24,), float32)``: the 19 slots of ``DiscReactor-v0`` (``yield``: C in
    the reactor / n_ref), the inlet temperature (``feed_kT``, in [0, 20]), then the discs of
    each species that left in the last step / n_ref (``outflow_<species>``, in [0, 4]).

    ## Rewards
    ``C_out / n_ref - 0.005 |heat energy| / n_ref - 0.02 x injected / n_ref`` per step, C_out
    the discs of C that left through the outlet during the step, n_ref the initial count of the
    limiting feed species (~40).

    ## Starting State
    As ``DiscReactor-v0`` with the scene's counts (A = B = 40) x U[0.9, 1.1]; then the inlet
    temperatures and the step of the change (``ReactorConfig.draw_feed``).

    ## Episode End
    Never terminated; truncated after 100 steps (50 units of time).

    ## Arguments
    Those of ``DiscReactor-v0`` with the defaults ``scene="flow"``, ``reward="outflow"``,
    ``observe_outflow=True``, ``inject_max=4``, ``feed_budget=400``,
    ``feed_temperature=(0.3, 2.0)``, ``heat_cost=0.005``, ``feed_cost=0.02``.

    ## Version History
    - v0: first version.
    """

    defaults = dict(DEFAULTS, scene="flow", reward="outflow", observe_outflow=True,
                    inject_max=4, feed_budget=400, feed_temperature=(0.3, 2.0),
                    heat_cost=0.005, feed_cost=0.02)


def _vector(env_cls: type, name: str) -> type:
    """The native vector env of a task: :class:`DiscReactorVectorEnv` with the task's
    defaults (its docstring is the task's)."""
    return type(name, (DiscReactorVectorEnv,), {
        "defaults": env_cls.defaults, "__module__": __name__,
        "__doc__": f"The native vector env of {env_cls.__name__} (see its docstring and "
                   f"DiscReactorVectorEnv's arguments)."})


DiscKineticsVectorEnv = _vector(DiscKineticsEnv, "DiscKineticsVectorEnv")
DiscEconomicVectorEnv = _vector(DiscEconomicEnv, "DiscEconomicVectorEnv")
DiscJacketVectorEnv = _vector(DiscJacketEnv, "DiscJacketVectorEnv")
DiscFlowVectorEnv = _vector(DiscFlowEnv, "DiscFlowVectorEnv")

#: ``{id: (env class, vector env class)}`` of every task, ``DiscReactor-v0`` included.
TASKS = {
    ENV_ID: (DiscReactorEnv, DiscReactorVectorEnv),
    "DiscKinetics-v0": (DiscKineticsEnv, DiscKineticsVectorEnv),
    "DiscEconomic-v0": (DiscEconomicEnv, DiscEconomicVectorEnv),
    "DiscJacket-v0": (DiscJacketEnv, DiscJacketVectorEnv),
    "DiscFlow-v0": (DiscFlowEnv, DiscFlowVectorEnv),
}


def task_id(env) -> str | None:
    """The task ``env`` is: its registered id (``env.spec``), or for an env or vector env
    of a task's own class built directly (no spec), that task's id; None otherwise (also
    for :class:`~discgym.env.DiscReactorEnv` and its vector env built directly: with
    keyword arguments they may be any task)."""
    if getattr(env, "spec", None) is not None:
        return env.spec.id
    u = getattr(env, "unwrapped", env)
    return next((k for k, classes in TASKS.items() if k != ENV_ID and type(u) in classes),
                None)


def register_tasks() -> None:
    """Register every task but ``DiscReactor-v0`` (:func:`discgym.env.register_envs` does
    that one); idempotent. Called by ``import discgym``."""
    for env_id, (env_cls, vec_cls) in TASKS.items():
        if env_id == ENV_ID or env_id in gym.registry:
            continue
        gym.register(id=env_id, entry_point=f"{__name__}:{env_cls.__name__}",
                     vector_entry_point=f"{__name__}:{vec_cls.__name__}",
                     max_episode_steps=env_cls.defaults["episode_steps"])
