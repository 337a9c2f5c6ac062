"""The stepped integrator's pair (Verlet) list (kernels.step, "the pair list").

The list must find exactly the overlapping pairs of small discs the per-substep scan finds,
whatever moved, grew, shrank, changed species or was renumbered since it was built; a call
of PAIR_MIN_STEPS or more steps takes it, a shorter call the scan, so a run stepped one step
at a time (the scan) and the same run in one call (the list) must agree bit for bit.
"""

import numpy as np
import pytest

import discgym as dg
from discgym.bench import bench_scene
from discgym.kernels import drift as DR
from discgym.kernels import pairlist as PL
from discgym.kernels import step as S
from discgym.kernels.celllist import build, cell_radius, make_grid
from discgym.kernels.structs import FLOAT, INDEX


# ------------------------------------------------------------------ the kernels, directly
class Scene2D:
    """Discs in a box, with the grid and scratch the broad phase reads."""

    def __init__(self, pos, species, sp_radius, side):
        self.pos = np.ascontiguousarray(pos, dtype=FLOAT)
        self.species = np.asarray(species, dtype=INDEX)
        self.sp_radius = np.asarray(sp_radius, dtype=FLOAT)
        self.n = len(self.species)
        self.bounds = np.array([0.0, 0.0, side, side], dtype=FLOAT)
        self.rcell = cell_radius(self.species, self.n, self.sp_radius)
        self.grid = make_grid(0, self.bounds, self.rcell, self.n)
        nstart = int(self.grid[4]) * int(self.grid[5]) + 2
        self.sc = S._carve(S._fit_work(S.empty_work(), self.n, nstart), self.n, nstart)
        self.big = bool(self.sp_radius.max() > self.rcell)

    def bin(self):
        build(self.n, self.pos, self.species, self.sp_radius, self.grid, self.sc.cell_start,
              self.sc.cell_items, self.sc.cell_of)

    def broad(self, pl, full=False):
        self.bin()
        pl = PL.pl_broad(self.n, self.pos, self.species, self.sp_radius, self.grid, self.sc,
                         pl, full, self.big)
        m = int(pl.count[1])
        found = {(min(i, j), max(i, j)) for i, j in zip(pl.ovi[:m], pl.ovj[:m])}
        assert len(found) == m, "a pair was found twice"
        return pl, found

    def brute(self):
        r = self.sp_radius[self.species]
        small = r <= self.rcell
        d2 = ((self.pos[:, None, :] - self.pos[None, :, :]) ** 2).sum(-1)
        R = r[:, None] + r[None, :]
        i, j = np.nonzero(np.triu(d2 < R * R, 1) & small[:, None] & small[None, :])
        return set(zip(i.tolist(), j.tolist()))

    def listed_invariant(self, pl):
        """Every small disc listed, within skin / 2 of its reference position, and every
        pair of them closer than the cut (by reference positions) in the list, once."""
        skin = PL.PAIR_SKIN * self.rcell
        small = self.sp_radius[self.species] <= self.rcell
        assert (pl.listed[:self.n][small] == 1).all()
        d = np.hypot(*(self.pos - pl.ref[:self.n]).T)
        assert (d[small] <= 0.5 * skin).all()
        p = int(pl.count[0])
        pairs = [(min(a, b), max(a, b)) for a, b in zip(pl.pi[:p], pl.pj[:p])]
        assert len(set(pairs)) == len(pairs), "a pair is listed twice"
        ref = pl.ref[:self.n]
        d2 = ((ref[:, None, :] - ref[None, :, :]) ** 2).sum(-1)
        cut = 2 * self.rcell + skin
        i, j = np.nonzero(np.triu(d2 < cut * cut, 1) & small[:, None] & small[None, :])
        assert set(zip(i.tolist(), j.tolist())) <= set(pairs)


def _gas(rng, n, side, radii=(1.0,), weights=None):
    species = rng.choice(len(radii), size=n, p=weights)
    pos = rng.uniform(0.0, side, size=(n, 2))
    return Scene2D(pos, species, radii, side)


@pytest.mark.parametrize("radii,weights", [((1.0,), None), ((1.0, 0.6), (0.7, 0.3)),
                                           ((1.0, 0.5, 4.0), (0.6, 0.38, 0.02))])
def test_the_list_finds_exactly_the_overlapping_pairs_as_discs_move(radii, weights):
    """Random moves, from far below skin / 2 to several skins (so some discs are refreshed
    and some not, every round), the big discs left to events.queue_initial."""
    rng = np.random.default_rng(1)
    g = _gas(rng, 400, 40.0, radii, weights)
    pl = PL.new_pairlist(g.n, PL.PAIR_CAP * g.n)
    pl, found = g.broad(pl, full=True)
    assert found == g.brute() and found
    g.listed_invariant(pl)
    refreshed = 0
    for step in range(30):
        scale = [0.02, 0.1, 0.4, 2.0][step % 4]
        g.pos += rng.normal(0.0, scale, size=g.pos.shape)
        np.clip(g.pos, 0.0, 40.0, out=g.pos)
        pl, found = g.broad(pl)
        assert found == g.brute()
        g.listed_invariant(pl)
        refreshed += int(PL.pl_stale(g.n, g.pos, g.species, g.sp_radius, g.rcell,
                                     0.5 * PL.PAIR_SKIN * g.rcell, g.big, pl))
    assert refreshed == 0  # (each broad phase leaves nothing to refresh at the same positions)


def test_a_disc_faster_than_half_the_skin_per_step_is_refreshed_and_its_contact_found():
    """Disc 0 jumps 0.9 skin per step onto disc 1 (listed far apart at first): each step it
    is beyond skin / 2 of where it was listed, so it is refreshed, and the overlap is found
    the step it happens."""
    skin = PL.PAIR_SKIN * 1.0
    pos = np.array([[5.0, 20.0], [5.0 + 6 * 0.9 * skin + 1.0, 20.0], [30.0, 30.0]])
    g = Scene2D(pos, [0, 0, 0], [1.0], 40.0)
    pl, found = g.broad(PL.new_pairlist(3, 8), full=True)
    assert found == set() and int(pl.count[0]) == 0  # (too far apart to be listed)
    for step in range(1, 7):
        g.pos[0, 0] += 0.9 * skin
        g.bin()
        m = PL.pl_stale(3, g.pos, g.species, g.sp_radius, g.rcell, 0.5 * skin, False, pl)
        assert m == 1 and pl.todo[0] == 0  # disc 0 alone is refreshed
        pl, found = g.broad(PL.pl_resize(pl, 3, pl.pi.shape[0]))
        gap = g.pos[1, 0] - g.pos[0, 0]
        assert found == ({(0, 1)} if gap < 2.0 else set()), (step, gap)
    assert found == {(0, 1)}


def test_a_full_list_grows_and_drops_no_pair():
    rng = np.random.default_rng(2)
    g = _gas(rng, 300, 18.0)  # dense: many pairs per disc
    # a list with room for one pair refuses the refresh (returns False) instead of dropping
    tiny = PL.new_pairlist(g.n, 1)
    g.bin()
    tiny.listed[:] = 0
    m = PL.pl_stale(g.n, g.pos, g.species, g.sp_radius, g.rcell, 0.5, False, tiny)
    skin = PL.PAIR_SKIN * g.rcell
    cut = 2 * g.rcell + skin
    assert not PL.pl_refresh(m, g.pos, g.species, g.sp_radius, tiny, g.grid, g.sc.cell_start,
                             g.sc.cell_items, cut, cut + 0.5 * skin)
    # the broad phase grows it (doubling) until every pair fits
    pl, found = g.broad(PL.new_pairlist(g.n, 1), full=True)
    assert pl.pi.shape[0] >= int(pl.count[0]) > 2 * g.n
    assert found == g.brute()
    g.listed_invariant(pl)
    g.pos += rng.normal(0.0, 0.5, size=g.pos.shape)
    pl, found = g.broad(pl)
    assert found == g.brute()


def test_removals_renumbering_and_species_changes_keep_the_list_exact():
    rng = np.random.default_rng(3)
    g = _gas(rng, 300, 30.0, (1.0, 0.5, 4.0), (0.6, 0.39, 0.01))
    pl, found = g.broad(PL.new_pairlist(g.n, 2 * g.n), full=True)
    assert found == g.brute()
    # a reaction makes small discs big and a big disc small, in place
    small = np.nonzero(g.species == 0)[0][:3]
    big = np.nonzero(g.species == 2)[0][:1]
    g.species[small] = 2
    g.species[big] = 0
    pl, found = g.broad(pl)
    assert found == g.brute()
    g.listed_invariant(pl)
    # discs removed (as _compact removes them): the list follows
    dead = rng.choice(g.n, size=40, replace=False)
    g.species[dead] = -1
    PL.pl_compact(g.n, g.species, pl, pl.todo)
    keep = g.species >= 0
    g2 = Scene2D(g.pos[keep], g.species[keep], g.sp_radius, 30.0)
    pl, found = g2.broad(pl)
    assert found == g2.brute()
    g2.listed_invariant(pl)
    # renumbered (as _reorder does): the list follows the permutation
    perm = rng.permutation(g2.n).astype(INDEX)
    PL.pl_permute(g2.n, perm, pl, np.empty(g2.n, dtype=INDEX), np.empty(2 * g2.n, dtype=FLOAT))
    g3 = Scene2D(g2.pos[perm], g2.species[perm], g2.sp_radius, 30.0)
    g3.pos += rng.normal(0.0, 0.3, size=g3.pos.shape)
    pl, found = g3.broad(pl)
    assert found == g3.brute()
    g3.listed_invariant(pl)


# -------------------------------------------------- the integrator: list and scan agree
def _same(a, b):
    assert len(a) == len(b)
    for x, y in ((a.positions, b.positions), (a.velocities, b.velocities),
                 (a.species, b.species), (a.ids, b.ids), (a.internal_energy, b.internal_energy)):
        assert np.array_equal(x, y)
    assert a.counters() == b.counters()


def _scan_vs_list(sim, steps):
    """``sim`` stepped one step per call (the scan) and in one call (the list)."""
    assert steps >= S.PAIR_MIN_STEPS > 1
    a = sim.copy()
    b = sim.copy()
    for _ in range(steps):
        a.step(1)
    b.step(steps)
    _same(a, b)
    return a


@pytest.mark.parametrize("name", dg.scenes.names())
def test_the_list_and_the_scan_give_the_same_trajectory_in_every_builtin_scene(name):
    """Reactions that remove, create and change discs, outlets, thermal walls, circles."""
    sim = dg.Simulation(name, seed=5)
    sim.step(2)
    _scan_vs_list(sim, S.PAIR_MIN_STEPS + 8)


def test_a_fast_disc_crossing_more_than_half_the_skin_per_step_misses_no_contact():
    """One disc at 60x the thermal speed (3 per step of 0.05: substeps, and several skins
    per step) through a gas: the list path equals the scan bit for bit, and no pair is left
    overlapping at the end of any call."""
    sim = dg.Simulation(bench_scene(600), seed=2)
    sim.step(1)
    v = sim.velocities.copy()
    v[0] = (60.0, 25.0)
    sim.set_state(dict(sim.get_state(), velocities=v))
    for _ in range(2):
        sim = _scan_vs_list(sim, S.PAIR_MIN_STEPS)
        p = sim.positions
        d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(-1) + np.eye(len(p)) * 1e9
        assert d2.min() >= 4.0 * (1.0 - 1e-9)
    # (the fast disc's steps were split into substeps, each moving it up to maxdisp; the
    # list refreshes it whenever it is skin / 2 from where it was listed, kernel test above)
    assert sim.counters()["substeps"] > 2 * 2 * S.PAIR_MIN_STEPS


def test_the_list_follows_the_reordering_in_memory():
    """From REORDER_MIN discs the discs are renumbered every REORDER_EVERY steps inside a
    call: the list is permuted with them."""
    sim = dg.Simulation(bench_scene(S.REORDER_MIN), seed=3)
    sim.threads = 1
    _scan_vs_list(sim, max(2 * S.REORDER_EVERY + 3, S.PAIR_MIN_STEPS))


def test_the_list_gives_the_same_trajectory_on_any_number_of_threads():
    """From PARALLEL_MIN discs a long call takes the list on one thread and, on two, the
    parallel scan and the event phase by clusters (kernels.clusters): one thread, two
    threads and the scan agree bit for bit."""
    sim = dg.Simulation(bench_scene(DR.PARALLEL_MIN + 1000), seed=4)
    one = sim.copy()
    one.threads = 1
    two = sim.copy()
    two.threads = 2
    one.step(S.PAIR_MIN_STEPS)
    two.step(S.PAIR_MIN_STEPS)
    _same(one, two)
    scan = sim.copy()
    scan.threads = 2
    for _ in range(S.PAIR_MIN_STEPS):
        scan.step(1)
    _same(one, scan)
