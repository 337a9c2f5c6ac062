"""The shared state: Simulations as handles on rows of one ReactorState.

A Simulation on a row of a state of several rows is the same reactor, bit for bit, as one
with a state of its own: its runs, controls, growth and clocks touch its row only.
"""

from __future__ import annotations

import numpy as np
import pytest

import discgym as dg
from discgym.state import ReactorState


def _state_for(scene, rows=3, capacity=8):
    sim = dg.Simulation(scene, seed=0)
    return ReactorState(rows, capacity, len(scene.species), len(sim.reactions()))


def _same(a, b):
    sa, sb = a.get_state(), b.get_state()
    for k, v in sa.items():
        if isinstance(v, np.ndarray):
            assert np.array_equal(v, sb[k]), k
        else:
            assert v == sb[k], k


@pytest.mark.parametrize("integrator", ["step", "event"])
def test_handles_on_rows_of_one_state_are_their_lone_simulations_bit_for_bit(integrator):
    scene = dg.scenes.load("reactor")
    st = _state_for(scene)
    rows = [dg.Simulation(scene, seed=s, integrator=integrator, row=(st, r))
            for r, s in ((0, 7), (2, 8))]
    lone = [dg.Simulation(scene, seed=s, integrator=integrator) for s in (7, 8)]
    assert st.capacity >= len(rows[0])  # (grown for the initial contents: every row)
    for a, b in zip(rows, lone):
        _same(a, b)
    # runs, controls, a growth of every row (200 more discs in row 0 only), clocks
    for sims in (rows, lone):
        sims[0].step(3)
        sims[1].advance(0.37)
        sims[0].inject("A", 200, temperature=0.8)
        sims[1].scale_temperature(1.3)
        sims[0].resize(dg.Box(33.0, 30.0))
        sims[1].step(2)
        sims[0].reset_counters()
        sims[0].advance(0.21)
    assert st.capacity >= len(rows[0]) > 400
    for a, b in zip(rows, lone):
        _same(a, b)
        assert a.time == b.time and a.pressure() == b.pressure()
        assert a.energy_balance() == b.energy_balance()
    assert st.rx.n[1] == 0 and (st.rx.species[1] == -1).all()  # the row between: untouched


def test_what_a_handle_changes_flags_its_row():
    scene = dg.scenes.load("reactor")
    st = _state_for(scene, rows=2)
    a = dg.Simulation(scene, seed=1, row=(st, 0))
    b = dg.Simulation(scene, seed=2, row=(st, 1))
    assert not st.touched.any()
    a.inject("B", 3)
    assert st.touched.tolist() == [True, False] and st.any_touched
    st.touched[:] = False
    b.resize(dg.Box(31.0, 30.0))
    b.set_state(b.get_state())
    b.step()
    assert st.touched.tolist() == [False, True]
    st.touched[:] = False
    a.scale_temperature(1.1)  # (what the envs need not re-check)
    assert not st.touched.any()


def test_a_row_of_another_scene_or_out_of_range_is_refused():
    scene = dg.scenes.load("reactor")
    st = _state_for(dg.scenes.load("ideal_gas"), rows=2)
    with pytest.raises(ValueError, match="row: expected \\(ReactorState, row index\\) of a "
                                         "state of 4 species"):
        dg.Simulation(scene, seed=0, row=(st, 0))
    st = _state_for(scene, rows=2)
    with pytest.raises(ValueError, match="row: expected"):
        dg.Simulation(scene, seed=0, row=(st, 2))


def test_a_handle_attached_to_a_row_continues_it():
    scene = dg.scenes.load("reactor")
    st = _state_for(scene, rows=2)
    a = dg.Simulation(scene, seed=4, row=(st, 1))
    a.step(2)
    twin = dg.Simulation.attach(scene, (st, 1))
    assert len(twin) == len(a) and twin.time == a.time
    twin.step(3)  # (the same row: a sees it)
    assert a.time == twin.time and np.array_equal(a.positions, twin.positions)
