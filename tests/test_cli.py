"""The discgym command line, driven as a user would: ``python -m discgym ...`` in a subprocess.

Each subprocess pays for loading numba's cache (~1-2 s), so the subprocess runs are few and
shared (one full run feeds several checks); error messages and option handling that need no
simulation are checked in-process through ``discgym.cli.main(argv)``.
"""

from __future__ import annotations

import csv
import importlib.util
import math
import pickle
import signal
import subprocess
import sys
import time
import tomllib

import numpy as np
import pytest

import discgym as dg
from discgym import cli

TIMEOUT = 900  # generous: a stale numba cache recompiles the kernels (~1-2 min)
RUN = [sys.executable, "-m", "discgym"]


def discgym(*args, cwd, check=True):
    """Run ``python -m discgym ARGS`` in ``cwd``; returns the CompletedProcess."""
    res = subprocess.run(RUN + [str(a) for a in args], cwd=cwd, capture_output=True, text=True,
                         timeout=TIMEOUT)
    if check:
        assert res.returncode == 0, f"exit {res.returncode}\n{res.stdout}\n{res.stderr}"
    assert "Traceback" not in res.stderr, res.stderr
    return res


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    cols = {name: [float(r[k]) for r in body] for k, name in enumerate(header)}
    return header, cols


def image_colours(path) -> int:
    from PIL import Image

    with Image.open(path) as im:
        im.load()
        return len(im.convert("RGB").getcolors(maxcolors=1 << 20) or [])


# --------------------------------------------------------------------------------------------
# scenes, show, help


def test_scenes_lists_every_builtin_with_its_description(tmp_path):
    res = discgym("scenes", cwd=tmp_path)
    lines = res.stdout.splitlines()
    for name, desc in dg.scenes.describe().items():
        assert any(line.startswith(name + " ") and desc in line for line in lines), name


@pytest.mark.parametrize("command", [[], ["scenes"], ["show"], ["run"], ["bench"],
                                     ["compile"]])
def test_help_on_every_command(command, capsys):
    assert cli.main(command + ["--help"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: discgym")
    if command == ["run"]:
        for opt in ("--time", "--seed", "--n", "--temperature", "--integrator", "--every",
                    "--plot", "--gif", "--mp4", "--csv", "--save", "--resume", "energy_balance"):
            assert opt in out, opt


def test_compile_refuses_unknown_env_ids_before_compiling(capsys, monkeypatch):
    def boom(*a):
        raise AssertionError("compiled before refusing")

    monkeypatch.setattr(cli.compile, "_warm", boom)
    assert cli.main(["compile", "--env", "DiscReactor-v0", "--env", "NoSuch-v9"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown env id 'NoSuch-v9'" in err
    assert "DiscFlow-v0" in err  # the known ids are listed
    assert cli.main(["compile", "--jobs", "0"]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_compile_warms_the_kernels_of_an_env(capsys):
    # in this process (one job): the kernels the other tests use, loaded or compiled once
    assert cli.main(["compile", "--env", "DiscReactor-v0", "--integrator", "step",
                     "--jobs", "1", "--quiet"]) == 0
    assert "1 configuration(s)" in capsys.readouterr().out


def test_no_command_prints_help(capsys):
    assert cli.main([]) == 0
    assert "scenes" in capsys.readouterr().out


def test_show_prints_species_reactions_bounds(capsys):
    assert cli.main(["show", "reactor"]) == 0
    out = capsys.readouterr().out
    scene = dg.scenes.load("reactor")
    for s in scene.species:
        assert s.name in out
    for r in scene.reactions:
        assert r.label() in out
    b = scene.bounds
    assert f"box {b.width:g} x {b.height:g}" in out
    assert f"activation energy {scene.reactions[0].activation_energy:g}" in out


def test_show_toml_round_trips_and_does_not_clobber(tmp_path, capsys):
    assert cli.main(["show", "circle_gas", "--toml", "-"]) == 0
    text = capsys.readouterr().out
    assert dg.Scene.from_dict(tomllib.loads(text)) == dg.scenes.load("circle_gas")
    out = tmp_path / "mine.toml"
    assert cli.main(["show", "reactor", "--toml", str(out)]) == 0
    assert dg.Scene.from_toml(out) == dg.scenes.load("reactor")
    out.write_text(out.read_text() + "# my edits\n")
    assert cli.main(["show", "reactor", "--toml", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    assert out.read_text().endswith("# my edits\n")
    assert cli.main(["show", "reactor", "--toml", str(out), "--force"]) == 0
    assert not out.read_text().endswith("# my edits\n")
    # the written file is a scene file `show` and `run` accept
    assert cli.main(["show", str(out)]) == 0


# --------------------------------------------------------------------------------------------
# one full run feeds the checks of its outputs

#: the scene of the full run: small, elastic, and reacting within a few time units (the
#: built-in scenes are tuned for other purposes and may change)
MINI = dg.Scene(
    bounds=dg.Box(20.0, 20.0),
    species=[dg.Species("A", 0.5, 1.0), dg.Species("B", 0.5, 1.0),
             dg.Species("C", 0.6, 2.0, formation_energy=-0.5)],
    reactions=[dg.Combination("A", "B", "C", activation_energy=0.5, reverse_probability=0.1)],
    counts={"A": 50, "B": 50}, temperature=1.0, dt=0.02, restitution=1.0, name="mini",
    description="A + B -> C, for the CLI tests")
FULL = ["mini.toml", "--time", "3", "--seed", "5", "--n", "A=60,B=60", "--every", "0.1"]


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("full")
    (d / "mini.toml").write_text(MINI.to_toml())
    res = discgym("run", *FULL, "--plot", "r.png", "--gif", "r.gif", "--frames", "12",
                  "--size", "160", "--csv", "r.csv", "--save", "r.npz", cwd=d)
    return d, res


def test_run_summary_table(full_run):
    d, res = full_run
    out = res.stdout
    assert "t 0 -> 3 (done)" in out
    for word in ("species", "start", "end", "temperature kT", "pressure", "collisions",
                 "wall hits", "reactions fired", "A + B -> C", "energy drift", "events/s"):
        assert word in out, word
    rows = {}
    for line in out.splitlines():
        if line.strip():
            rows.setdefault(line.split()[0], line.split()[1:])  # the species table comes first
    assert rows["A"][0] == "60" and rows["B"][0] == "60" and rows["C"][0] == "0"
    assert "events/s" in res.stderr  # the progress bar
    for name in ("r.csv", "r.png", "r.gif", "r.npz"):
        assert any(line.startswith("wrote") and line.endswith(name)
                   for line in out.splitlines()), name


def test_run_csv_columns_and_conservation(full_run):
    d, _ = full_run
    header, cols = read_csv(d / "r.csv")
    scene = MINI
    expected = (["time"] + [f"n_{s}" for s in scene.species_names] +
                ["n_total", "temperature", "pressure", "kinetic", "internal", "formation",
                 "total_energy", "energy_input", "dissipated", "energy_balance", "collisions",
                 "wall_hits", "reactive_collisions"] +
                [f"fired[{r}]" for r in dg.Simulation(scene, counts={}).reactions()])
    assert header == expected
    t = np.array(cols["time"])
    assert len(t) == 31 and t[0] == 0.0 and t[-1] == pytest.approx(3.0)
    assert np.all(np.diff(t) > 0)
    n = sum(np.array(cols[f"n_{s}"]) for s in scene.species_names)
    assert np.array_equal(n, np.array(cols["n_total"]))
    assert cols["n_A"][0] == 60 and cols["n_B"][0] == 60
    p = np.array(cols["pressure"][1:])  # a short interval may see no wall hit: 0
    assert math.isnan(cols["pressure"][0]) and np.all(p >= 0) and p.mean() > 0
    # the scene is elastic (restitution 1): the energy is conserved to round-off
    e = np.array(cols["total_energy"])
    assert np.all(np.abs(np.array(cols["energy_balance"])) < 1e-9 * abs(e[0]) + 1e-9)
    assert np.allclose(e, e[0], rtol=0, atol=1e-9 * abs(e[0]))
    assert np.allclose(np.array(cols["kinetic"]) + cols["internal"] + np.array(cols["formation"]),
                       e)
    assert cols["dissipated"][-1] == 0.0 and cols["energy_input"][-1] == 0.0
    assert cols["collisions"][-1] > 0 and cols["fired[A + B -> C]"][-1] > 0
    assert np.all(np.diff(cols["collisions"]) >= 0)


def test_run_plot_and_gif_are_pictures(full_run):
    from PIL import Image

    d, _ = full_run
    with Image.open(d / "r.png") as im:
        assert im.format == "PNG" and min(im.size) > 300
    assert image_colours(d / "r.png") > 10  # not blank: axes, curves, text
    with Image.open(d / "r.gif") as im:
        assert im.format == "GIF" and im.size == (160, 160)
        assert 2 <= im.n_frames <= 13  # --frames 12, plus the final state
        im.seek(im.n_frames - 1)
        assert len(im.convert("RGB").getcolors(maxcolors=1 << 16)) > 3


def test_run_checkpoint_is_the_simulation(full_run):
    d, _ = full_run
    sim = dg.checkpoint.load(d / "r.npz")
    assert isinstance(sim, dg.Simulation)
    assert sim.time == pytest.approx(3.0)
    _, cols = read_csv(d / "r.csv")
    assert sim.counts()["C"] == cols["n_C"][-1]
    assert sim.total_energy() == pytest.approx(cols["total_energy"][-1], abs=1e-12)


def test_save_then_resume_continues_bit_identically(full_run, tmp_path, capsys):
    """Run 1.5 (in-process), resume for 1.5 more (subprocess): the same state as the full run
    of 3 in one go, bit for bit (the sampling interval does not change the trajectory)."""
    d, _ = full_run
    assert cli.main(["run", str(d / FULL[0]), "--time", "1.5", *FULL[3:7], "--save",
                     str(tmp_path / "half.npz"), "--quiet"]) == 0
    capsys.readouterr()
    res = discgym("run", "--resume", "half.npz", "--time", "1.5", "--save", "end.npz",
                  "--csv", "more.csv", "-q", cwd=tmp_path)
    assert "resumed from half.npz" in res.stdout and "t 1.5 -> 3" in res.stdout
    full = dg.checkpoint.load(d / "r.npz")
    resumed = dg.checkpoint.load(tmp_path / "end.npz")
    assert resumed.time == pytest.approx(full.time, abs=1e-12)  # clocks sum different chunks
    assert np.array_equal(resumed.positions, full.positions)
    assert np.array_equal(resumed.velocities, full.velocities)
    assert np.array_equal(resumed.species, full.species)
    assert resumed.reactions() == full.reactions() and resumed.counters() == full.counters()
    _, cols = read_csv(tmp_path / "more.csv")
    assert cols["time"][0] == pytest.approx(1.5) and cols["time"][-1] == pytest.approx(3.0)


def test_resume_refuses_conflicting_options_and_bad_files(tmp_path, capsys):
    # a pickle is never loaded (it would run code), whatever it holds
    pickled = tmp_path / "sim.pkl"
    pickled.write_bytes(pickle.dumps(dg.Simulation(MINI, seed=0)))
    assert cli.main(["run", "--resume", str(pickled), "--time", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a pickled Simulation" in err
    assert "discgym.checkpoint.save" in err
    bogus = tmp_path / "bogus.npz"
    np.savez(bogus, x=np.zeros(3))
    assert cli.main(["run", "--resume", str(bogus), "--time", "1"]) == 2
    assert "not a discgym checkpoint" in capsys.readouterr().err
    for content in (b"\x00\x01 not an archive", b""):
        garbage = tmp_path / "garbage.npz"
        garbage.write_bytes(content)
        assert cli.main(["run", "--resume", str(garbage), "--time", "1"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "not a discgym checkpoint" in err
    one = tmp_path / "one.npz"  # a batch of one reactor resumes
    dg.checkpoint.save(one, [dg.Simulation(MINI, seed=0)])
    assert cli.main(["run", "--resume", str(one), "--time", "0.1", "-q"]) == 0
    capsys.readouterr()
    batch = tmp_path / "batch.npz"
    dg.checkpoint.save(batch, [dg.Simulation(MINI, seed=0), dg.Simulation(MINI, seed=1)])
    assert cli.main(["run", "--resume", str(batch), "--time", "1"]) == 2
    assert "a checkpoint of 2 reactors" in capsys.readouterr().err
    assert cli.main(["run", "--resume", str(tmp_path / "missing.pkl"), "--time", "1"]) == 2
    assert "no such file" in capsys.readouterr().err
    assert cli.main(["run", "--resume", str(bogus), "--time", "1", "--seed", "3"]) == 2
    assert "--seed cannot be used with --resume" in capsys.readouterr().err
    assert cli.main(["run", "--time", "1"]) == 2
    assert "--resume" in capsys.readouterr().err
    real = tmp_path / "real.npz"
    dg.checkpoint.save(real, dg.Simulation(MINI, seed=0))
    if cli.integrator_supported():
        assert cli.main(["run", "--resume", str(real), "--time", "1", "--integrator",
                         "event"]) == 2
        assert "runs the 'step' integrator" in capsys.readouterr().err
    assert cli.main(["run", "ideal_gas", "--resume", str(real), "--time", "1"]) == 2
    assert "differs from ideal_gas" in capsys.readouterr().err


# --------------------------------------------------------------------------------------------
# errors are for people


def test_malformed_scene_file_names_key_and_line(tmp_path):
    text = dg.scenes.load("reactor").to_toml()
    lines = text.splitlines()
    k = lines.index("[[species]]", lines.index("[[species]]") + 1)  # the second species
    lines.insert(k + 3, "masss = 3.0")
    (tmp_path / "bad.toml").write_text("\n".join(lines) + "\n")
    res = discgym("run", "bad.toml", "--time", "1", cwd=tmp_path, check=False)
    assert res.returncode == 2
    err = res.stderr.strip()
    assert "species[1].masss" in err and "unknown key" in err
    assert f"bad.toml:{k + 4}" in err
    assert len(err.splitlines()) == 1 and "Traceback" not in err


def test_bad_values_and_syntax_in_scene_files(tmp_path, capsys):
    text = dg.scenes.load("ideal_gas").to_toml()
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("radius"))
    lines[k] = "radius = -0.5"
    (tmp_path / "neg.toml").write_text("\n".join(lines) + "\n")
    assert cli.main(["show", str(tmp_path / "neg.toml")]) == 2
    err = capsys.readouterr().err
    assert "species[0].radius" in err and "must be > 0" in err and f"neg.toml:{k + 1}" in err
    (tmp_path / "syntax.toml").write_text('name = "x"\n[bounds\n')
    assert cli.main(["run", str(tmp_path / "syntax.toml"), "--time", "1"]) == 2
    err = capsys.readouterr().err
    assert "not valid TOML" in err and "line 2" in err
    assert cli.main(["run", str(tmp_path / "missing.toml"), "--time", "1"]) == 2
    assert "not found" in capsys.readouterr().err


def test_unknown_scene_name(capsys):
    assert cli.main(["run", "reactr", "--time", "1"]) == 2
    err = capsys.readouterr().err
    assert "unknown scene 'reactr'" in err and "did you mean 'reactor'" in err
    assert "ideal_gas" in err  # lists the built-ins
    assert cli.main(["show", "nonsense"]) == 2
    assert "unknown scene 'nonsense'" in capsys.readouterr().err


def test_bad_counts_and_numbers(capsys, tmp_path):
    for argv, msg in [
        (["--n", "Q=3"], "unknown species 'Q'"),
        (["--n", "A=x"], "not a whole number"),
        (["--n", "A"], "SPECIES=COUNT"),
        (["--n", "A=-1"], ">= 0"),
        (["--n", "A=100000"], "cannot fit"),
        (["--temperature", "-1"], "temperature"),
        (["--every", "0"], "--every"),
        (["--csv", str(tmp_path / "no" / "dir.csv")], "does not exist"),
    ]:
        assert cli.main(["run", "reactor", "--time", "1", *argv]) == 2, argv
        assert msg in capsys.readouterr().err, argv
    assert cli.main(["run", "reactor", "--time", "-1"]) == 2
    assert "--time" in capsys.readouterr().err


def test_counts_override_only_the_named_species(tmp_path, capsys):
    path = tmp_path / "c.csv"
    assert cli.main(["run", "reactor", "--time", "0", "--n", "A=10", "--csv", str(path),
                     "-q"]) == 0
    _, cols = read_csv(path)
    assert cols["n_A"] == [10.0] and cols["n_B"] == [dg.scenes.load("reactor").counts["B"]]
    assert cli.parse_counts("A=1, B=2,", ["A", "B"]) == {"A": 1, "B": 2}


@pytest.mark.parametrize("option, module", [("--plot", "matplotlib"), ("--gif", "PIL")])
def test_missing_optional_dependency_names_the_extra(option, module, monkeypatch, tmp_path,
                                                     capsys):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    assert cli.main(["run", "ideal_gas", "--time", "1", option, str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert 'pip install "discgym[render]"' in err and module in err
    assert not (tmp_path / "x").exists()


def test_mp4_without_ffmpeg_says_what_to_install(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    assert cli.main(["run", "ideal_gas", "--time", "1", "--mp4", str(tmp_path / "x.mp4")]) == 2
    assert "pip install imageio imageio-ffmpeg" in capsys.readouterr().err


@pytest.mark.skipif(importlib.util.find_spec("imageio_ffmpeg") is None,
                    reason="imageio-ffmpeg is not installed")
def test_mp4(tmp_path, capsys):
    import imageio.v3 as iio

    path = tmp_path / "m.mp4"
    assert cli.main(["run", "ideal_gas", "--n", "A=50", "--time", "0.5", "--mp4", str(path),
                     "--size", "101", "--frames", "8", "-q"]) == 0
    video = iio.imread(path)
    assert video.shape[0] == 8 and video.shape[1:] == (102, 102, 3)


def test_integrator_switch(tmp_path, capsys):
    path = tmp_path / "e.csv"
    argv = ["run", "ideal_gas", "--n", "A=50", "--time", "0.2", "--seed", "1", "--csv",
            str(path), "-q"]
    assert cli.main(argv + ["--integrator", "step"]) == 0
    capsys.readouterr()
    code = cli.main(argv + ["--integrator", "event"])
    err = capsys.readouterr().err
    if cli.integrator_supported():
        assert code == 0, err
        _, cols = read_csv(path)
        assert cols["time"][-1] == pytest.approx(0.2)
    else:
        assert code == 2
        assert "--integrator event is not available in this version" in err


def test_adaptive_sampling_keeps_an_even_series(tmp_path, capsys):
    """Without --every: 100-200 evenly spaced samples; merged intervals keep the pressure
    a time average (the summary's mean pressure equals the series' weighted mean)."""
    path = tmp_path / "a.csv"
    assert cli.main(["run", "ideal_gas", "--n", "A=60", "--time", "13", "--seed", "4",
                     "--csv", str(path), "-q"]) == 0
    out = capsys.readouterr().out
    _, cols = read_csv(path)
    t = np.array(cols["time"])
    assert 100 <= len(t) <= 202 and t[0] == 0 and t[-1] == pytest.approx(13.0)
    d = np.diff(t)
    assert np.allclose(d[:-1], 0.08) and 0 < d[-1] <= 0.08 + 1e-9  # 650 steps: 4 per sample
    p = np.array(cols["pressure"][1:])
    mean = float(out.split("pressure (mean over the run)")[1].split()[0])
    assert (p * d).sum() / d.sum() == pytest.approx(mean, rel=1e-5)


def test_progress_bar_without_tqdm(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "tqdm", None)
    assert cli.main(["run", "ideal_gas", "--n", "A=50", "--time", "1", "--seed", "2"]) == 0
    err = capsys.readouterr().err
    assert "100%" in err and "t 1/1" in err and "events/s" in err


# --------------------------------------------------------------------------------------------
# Ctrl-C


@pytest.mark.skipif(sys.platform == "win32", reason="SIGINT to a child process is POSIX")
def test_ctrl_c_stops_cleanly_and_writes_the_outputs(tmp_path):
    proc = subprocess.Popen(
        RUN + ["run", "ideal_gas", "--n", "A=100", "--time", "1e6", "--seed", "3",
               "--csv", "i.csv", "--plot", "i.png", "--gif", "i.gif", "--size", "100",
               "--save", "i.npz"],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stderr.readline()  # printed once the run (and its Ctrl-C handler) starts
        assert first.startswith("running ideal_gas"), first
        time.sleep(1.5)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=TIMEOUT)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, (out, err)
    assert "Traceback" not in err and "interrupted at t" in err
    assert "(interrupted)" in out and "energy drift" in out
    header, cols = read_csv(tmp_path / "i.csv")
    t = np.array(cols["time"])
    assert 0 < t[-1] < 1e6
    # adaptive sampling: 100-200 evenly spaced samples wherever the run stopped
    assert 100 <= len(t) <= 202
    steps = np.diff(t)[:-1]
    assert np.allclose(steps, steps[0], rtol=1e-6)
    assert image_colours(tmp_path / "i.png") > 10
    from PIL import Image

    with Image.open(tmp_path / "i.gif") as im:
        assert im.n_frames > 10
    sim = dg.checkpoint.load(tmp_path / "i.npz")
    assert sim.time == cols["time"][-1]  # the checkpoint is where the series stops
    assert sim.overlaps() == 0 and len(sim) == 100


# --------------------------------------------------------------------------------------------
# bench


def test_bench_missing_module_is_a_clear_error(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "discgym.bench", None)
    assert cli.main(["bench"]) == 2
    assert "not available in this version" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.skipif(importlib.util.find_spec("discgym.bench") is None,
                    reason="discgym.bench is not part of this checkout")
def test_bench_runs_quick_mode(tmp_path):
    res = discgym("bench", "--sections", "scaling", "--sizes", "100", "--seconds", "0.05",
                  cwd=tmp_path)
    assert "(quick)" in res.stdout + res.stderr
    assert "disc-steps" in res.stdout + res.stderr



def test_a_run_in_which_nothing_changes_plots_plain_axes(tmp_path, monkeypatch):
    # a gas of one species: nothing reacts, so kT and the energies are constant to
    # round-off; their axes are labelled by plain values around the constant, not by an
    # offset of 1e-15
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    from discgym import cli

    figures = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, *a, **k: figures.append(fig))
    gas = dg.Scene(bounds=dg.Box(20.0, 20.0), species=[dg.Species("A", 0.5, 1.0)],
                   counts={"A": 150}, temperature=1.0, dt=0.02, restitution=1.0, name="gas",
                   description="a gas of one species")
    (tmp_path / "gas.toml").write_text(gas.to_toml())
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "gas.toml", "--time", "5", "--plot", "gas.png"]) in (0, None)
    (fig,) = figures
    fig.canvas.draw()
    counts, temperature, energies = fig.axes[:3]
    for ax in (temperature, energies):
        assert ax.yaxis.get_offset_text().get_text() == "", ax.get_ylabel()
        lo, hi = ax.get_ylim()
        assert hi - lo > 1e-3 * max(abs(lo), abs(hi)), (ax.get_ylabel(), lo, hi)
    kT = temperature.lines[0].get_ydata()
    assert 0 < np.ptp(kT) < 1e-9 * kT[0]  # (round-off moved it: the case to show)
    assert temperature.get_ylim()[0] < kT[0] < temperature.get_ylim()[1]
