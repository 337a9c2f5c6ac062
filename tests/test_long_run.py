"""Hard case 13: long runs of a dense reactive scene stay finite, inside, free of overlap and
honest about energy and mass.

By default a short version runs (2 * 10^4 steps, a few seconds). The long-run mode runs
10^6 steps (and a long random-action run of the environment); turn it on with

    DISCGYM_LONG=1 /work/venv/bin/python -m pytest -q tests/test_long_run.py

(measured: see docs/hard_cases.md).
"""

import math
import os

import numpy as np
import pytest

import discgym as dg

LONG = os.environ.get("DISCGYM_LONG", "") not in ("", "0")
long_only = pytest.mark.skipif(not LONG, reason="long-run mode: set DISCGYM_LONG=1")

CHECK_EVERY = 500  # steps between full checks (finite, inside, overlaps, energy, mass)
ENERGY_RTOL = 1e-9  # |energy_balance()| / |total energy| allowed at any check


def long_scene() -> dg.Scene:
    """A dense (packing ~0.55), living reactive scene in a 12 x 12 box: every reaction type
    runs in a cycle, so the chemistry never dies out.

    A + B -> C (E_a 0.5), C -> A + B (decomposition), C + A -> W + B (exchange, E_a 1,
    endothermic by 0.3), W -> C (transformation, exothermic) and B -> A (transformation).
    """
    a = dg.Species("A", 0.5, 1.0)
    b = dg.Species("B", 0.5, 1.0)
    c = dg.Species("C", 0.65, 2.0)
    w = dg.Species("W", 0.65, 2.0, formation_energy=0.3)
    return dg.Scene(
        bounds=dg.Box(12.0, 12.0), species=[a, b, c, w], dt=0.02,
        reactions=[dg.Combination("A", "B", "C", 0.5, 0.0),
                   dg.Decomposition("C", "A", "B", 0.2),
                   dg.Exchange("C", "A", "W", "B", 1.0),
                   dg.Transformation("W", "C", 0.2),
                   dg.Transformation("B", "A", 0.05)],
        counts={"A": 50, "B": 50}, temperature=1.0, name="long_run",
    )


def run_checked(sim: dg.Simulation, n_steps: int) -> dict:
    """Advance ``n_steps`` in chunks of CHECK_EVERY, checking after each chunk; returns the
    worst values seen."""
    mass0 = float(sim.masses.sum())
    worst = {"energy": 0.0}
    done = 0
    while done < n_steps:
        k = min(CHECK_EVERY, n_steps - done)
        sim.step(k)
        done += k
        assert np.isfinite(sim.positions).all() and np.isfinite(sim.velocities).all()
        assert np.isfinite(sim.internal_energy).all() and (sim.internal_energy >= 0).all()
        assert sim.outside(1e-12) == 0, f"a disc escaped by step {done}"
        assert sim.overlaps(1e-9) == 0, f"overlap at step {done}"
        assert float(sim.masses.sum()) == pytest.approx(mass0, rel=1e-12)
        rel = abs(sim.energy_balance()) / abs(sim.total_energy())
        worst["energy"] = max(worst["energy"], rel)
        assert rel <= ENERGY_RTOL, f"energy error {rel:.3g} at step {done}"
        assert sim.counters()["events_capped"] == 0
    return worst


def test_13_long_run_short_version():
    """Case 13 (default, short). 2 * 10^4 steps of the dense reactive scene: checked every
    500 steps: finite, no escape, no overlap (1e-9), mass exact to 1e-12, energy balance
    <= 1e-9 of the total (measured: ~5e-14), every reaction channel fired."""
    sim = dg.Simulation(long_scene(), seed=0)
    worst = run_checked(sim, 20_000)
    assert all(c > 0 for c in sim.reactions().values()), sim.reactions()
    print(f"\n2e4 steps: worst |energy balance| / |E| = {worst['energy']:.2e}; "
          f"{sim.counters()}")


@long_only
@pytest.mark.slow
def test_13_long_run_a_million_steps():
    """Case 13 (long mode). 10^6 steps of the dense reactive scene with the same checks every
    500 steps; the chemistry is still alive at the end."""
    sim = dg.Simulation(long_scene(), seed=1)
    worst = run_checked(sim, 1_000_000)
    assert all(c > 1000 for c in sim.reactions().values()), sim.reactions()
    print(f"\n1e6 steps: worst |energy balance| / |E| = {worst['energy']:.2e}; "
          f"reactions {sim.reactions()}; {sim.counters()}")


@long_only
@pytest.mark.slow
def test_13_long_run_under_random_controls():
    """Case 13 (long mode). 2 * 10^5 steps of the reactor scene (240 discs) while random
    controls act every 100 steps: heating/cooling by factors in [0, 4] (kept within
    kT in [0.05, 20]), injection of up to 10 discs (while there are fewer than 300),
    resizing the box between 22 and 36.
    Checked after every action: finite, inside, no overlap, energy balance <= 1e-9 of the
    energy that went through."""
    sim = dg.Simulation("reactor", seed=2)
    rng = np.random.default_rng(2)
    names = sim.scene.species_names
    through = abs(sim.total_energy())
    for _ in range(2000):
        u = rng.random()
        if u < 0.4 and sim.temperature() > 0:
            f = float(rng.choice([0.0, rng.uniform(0.25, 4.0)], p=[0.05, 0.95]))
            T = sim.temperature()
            f = min(max(f, 0.05 / T if f > 0 else 0.0), 20.0 / T)
            sim.scale_temperature(f)
        elif u < 0.7:
            if len(sim) < 300:
                sim.inject(names[int(rng.integers(len(names)))], int(rng.integers(0, 11)),
                           temperature=float(rng.uniform(0.0, 5.0)))
        else:
            w = float(rng.uniform(22.0, 36.0))
            try:
                sim.resize(dg.Box(w, w))
            except dg.PlacementError:
                pass
        if sim.temperature() == 0.0:
            sim.scale_temperature(0.0)
            sim.inject("A", 1, temperature=1.0)
        through = max(through, abs(sim.total_energy()), abs(sim.energy_input),
                      sim.dissipated_energy)
        sim.step(100)
        assert np.isfinite(sim.positions).all() and np.isfinite(sim.velocities).all()
        assert sim.outside(1e-12) == 0 and sim.overlaps(1e-9) == 0
        assert abs(sim.energy_balance()) <= 1e-9 * through
    assert math.isfinite(sim.total_energy())
