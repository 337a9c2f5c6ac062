"""Trajectories bit for bit: every built-in scene with both integrators, driven through the
controls, and env episodes (single and vector env, random and heuristic actions) hash to the
fingerprints recorded in ``tests/golden.json`` (see ``tests/golden.py``).

Float bits hold on the CPU model and library versions they were recorded with, so the test
runs only on the platform the file was recorded on, or one on which ``python tests/golden.py
--check tests/golden.json --confirm`` found every fingerprint identical (the file's
``also_on``), and skips elsewhere, saying why. A change
meant to alter trajectories re-records the file (``python tests/golden.py --write
tests/golden.json``) and says so in its commit; a refactoring must leave it untouched.
"""

import functools
import json
from pathlib import Path

import golden
import pytest

RECORDED = json.loads((Path(__file__).parent / "golden.json").read_text())


def _platform_or_skip():
    here = golden.platform_key()
    if here not in golden.verified_platforms(RECORDED):
        pytest.skip(f"golden.json holds for {golden.verified_platforms(RECORDED)}, this is "
                    f"{here}")


@functools.cache
def _runs(group):
    if group in ("env", "envinfo"):  # (one set of episodes gives both)
        return _env_runs()
    return {"scene": golden.scene_runs, "controls": golden.control_runs,
            "large": golden.large_runs}[group]()


@functools.cache
def _env_runs():
    return golden.env_runs()


@pytest.mark.slow
@pytest.mark.parametrize("group", ["scene", "controls", "env", "envinfo", "large"])
def test_trajectories_match_the_recorded_fingerprints(group):
    _platform_or_skip()
    runs = _runs(group)
    runs = {k: v for k, v in runs.items() if k.startswith(group + "/")}
    want = {k: v for k, v in RECORDED["fingerprints"].items() if k.startswith(group + "/")}
    assert want, f"no {group} fingerprints recorded"
    changed = sorted(k for k in want.keys() | runs.keys() if want.get(k) != runs.get(k))
    assert not changed, f"{len(changed)} of {len(want)} trajectories changed: {changed[:8]}"


def test_a_changed_trajectory_changes_its_fingerprint():
    """The hash sees the last bit of a position (so the test above can fail)."""
    import numpy as np

    import discgym as dg

    sim = dg.Simulation("ideal_gas", seed=0)
    sim.step(2)
    a = golden.simulation_fingerprint(sim)
    st = sim.get_state()
    st["positions"][0, 0] = np.nextafter(st["positions"][0, 0], np.inf)
    sim.set_state(st)
    assert golden.simulation_fingerprint(sim) != a
