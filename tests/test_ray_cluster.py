"""The multi-node path of agents/train_rllib.py on a real multi-node Ray cluster on this
machine: two Ray nodes (a head and a worker, each its own raylet) on 127.0.0.1 only, started
by agents/ray_cluster.py, the script connected with ``--address``, its kernels warmed once per
node, an env runner on each node, one training iteration, every process stopped at the end.

The test watches from outside (psutil) every process the run starts: all listen on and
connect to loopback addresses only, both raylets appear, and none is left once the run ends.
The run has ``RAY_TMPDIR`` and ``TMPDIR`` on fresh empty folders (a machine that never ran
Ray: no ``ray/`` folder there) and leaves nothing in either.
Skipped only where Ray is not installed (CI installs it: the ``ecosystem`` extra).

A bad ``--report`` is refused before any node starts (no Ray needed)."""

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from test_clients import RLLIB_ONE_ITERATION

ROOT = Path(__file__).resolve().parents[1]


def is_loopback(ip: str) -> bool:
    import ipaddress

    addr = ipaddress.ip_address(ip)
    return (getattr(addr, "ipv4_mapped", None) or addr).is_loopback


def watch(proc: subprocess.Popen, timeout: float):
    """Until ``proc`` ends: every half second, its descendants and their TCP sockets.
    Returns (processes seen: pid -> (name, start time), listening (ip, port, name),
    remote (ip, name))."""
    import psutil

    seen, listening, remote = {}, set(), set()
    root = psutil.Process(proc.pid)
    end = time.monotonic() + timeout
    while proc.poll() is None and time.monotonic() < end:
        with contextlib.suppress(psutil.Error):
            for p in root.children(recursive=True):
                # (the latest name: a child caught between fork and exec still has its
                # parent's name, "python", and a raylet so first seen would be missed)
                with contextlib.suppress(psutil.Error):
                    seen[p.pid] = (p.name(), p.create_time())
        names = {pid: v[0] for pid, v in seen.items()} | {proc.pid: "driver"}
        for c in psutil.net_connections(kind="tcp"):
            if c.pid in names:
                if c.status == psutil.CONN_LISTEN:
                    listening.add((c.laddr.ip, c.laddr.port, names[c.pid]))
                elif c.raddr:
                    remote.add((c.raddr.ip, names[c.pid]))
        time.sleep(0.5)
    return seen, listening, remote


def still_running(seen: dict) -> list:
    import psutil

    alive = []
    for pid, (_, started) in seen.items():
        with contextlib.suppress(psutil.Error):
            p = psutil.Process(pid)
            if p.create_time() == started and p.status() != psutil.STATUS_ZOMBIE:
                alive.append(p)
    return alive


def stop(proc: subprocess.Popen, seen: dict) -> None:
    """The run and every process it started, by their ids (its own process group first)."""
    import psutil

    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(30)
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    left = still_running(seen)
    for p in left:
        with contextlib.suppress(psutil.Error):
            p.terminate()
    _, alive = psutil.wait_procs(left, timeout=10)
    for p in alive:
        with contextlib.suppress(psutil.Error):
            p.kill()


@pytest.fixture
def fresh_temp_dirs():
    """Two fresh empty folders, for ``RAY_TMPDIR`` and ``TMPDIR`` (short paths: Ray's unix
    sockets live under them; pytest's tmp_path is too long), removed after the test."""
    dirs = [Path(tempfile.mkdtemp(prefix="dg")) for _ in range(2)]
    yield dirs
    for d in dirs:
        shutil.rmtree(d, ignore_errors=True)


@pytest.mark.slow  # (about a minute: two nodes' daemons, two env runners)
def test_train_rllib_on_two_ray_nodes_on_loopback(tmp_path, fresh_temp_dirs):
    pytest.importorskip("ray")
    report_path = tmp_path / "report.json"
    cmd = [sys.executable, str(ROOT / "agents" / "ray_cluster.py"), "--nodes", "2",
           "--cpus-per-node", "1", "--report", str(report_path), "--",
           *RLLIB_ONE_ITERATION, "--env-runners", "2", "--out", str(tmp_path / "run")]
    # Ray's temp folders as on a machine that never ran Ray (no ray/ in them): the run
    # failed there once (Cluster.add_node wrote $RAY_TMPDIR/ray/ray_current_cluster)
    ray_tmpdir, tmpdir = fresh_temp_dirs
    env = dict(os.environ, RAY_USAGE_STATS_ENABLED="0", NUMBA_NUM_THREADS="1",
               RAY_TMPDIR=str(ray_tmpdir), TMPDIR=str(tmpdir))
    log = open(tmp_path / "log.txt", "w+")
    proc = subprocess.Popen(cmd, cwd=tmp_path, env=env, stdout=log, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)
    seen = {}
    try:
        seen, listening, remote = watch(proc, timeout=600)
        returncode = proc.wait(30)
        # what still runs a while after the run ended (Ray's workers exit once their raylet
        # has gone)
        deadline = time.monotonic() + 20
        while (left := still_running(seen)) and time.monotonic() < deadline:
            time.sleep(0.5)
    finally:
        stop(proc, seen)  # (on any failure too: nothing of the run outlives the test)
        log.close()
    out = (tmp_path / "log.txt").read_text()
    assert returncode == 0, out[-4000:]
    assert left == [], left  # the run stopped every node's processes itself
    report = json.loads(report_path.read_text())
    # two nodes, both on 127.0.0.1, the script on the GCS at 127.0.0.1
    assert len(set(report["nodes"])) == 2
    assert report["node_addresses"] == ["127.0.0.1"]
    assert report["gcs_address"].startswith("127.0.0.1:")
    # the kernels warmed once on each node, then an env runner on each node
    assert "numba kernels ready on 2 node(s)" in out
    assert sorted(report["env_runner_nodes"]) == sorted(report["nodes"])
    # one iteration of both runners' samples
    (row,) = report["rows"]
    assert row["env_steps"] >= 2 * 4 * 32
    assert row["episodes"] >= 2 * (4 * 32 // 8 - 4)
    assert (tmp_path / "run" / "progress.csv").exists()
    # seen from outside: both raylets, every socket on loopback (listening and connected)
    raylets = {pid for pid, (name, _) in seen.items() if name == "raylet"}
    assert len(raylets) == 2, seen
    assert {name for *_, name in listening} >= {"raylet", "gcs_server"}
    assert [s for s in listening if not is_loopback(s[0])] == []
    assert remote and [s for s in remote if not is_loopback(s[0])] == []
    assert report["outside_loopback"] == []  # (the script's own watch agrees)
    assert report["refuses_a_driver_without_the_token"]  # (token authentication is on)
    # the cluster's temp folder (in RAY_TMPDIR) removed; nothing of Ray's in TMPDIR
    assert list(ray_tmpdir.iterdir()) == []
    assert [p.name for p in tmpdir.iterdir() if "ray" in p.name] == []


@pytest.mark.parametrize("where", ["in a missing folder", "a folder", "under a file"])
def test_a_bad_report_is_refused_before_any_node_starts(tmp_path, monkeypatch, capsys,
                                                         where):
    """``--report`` into a missing folder, onto a folder, under a file: one line naming
    --report, exit 2, and no node started (the cluster is never entered)."""
    monkeypatch.syspath_prepend(str(ROOT / "agents"))
    import argcheck
    import ray_cluster

    def no_cluster(*args, **kwargs):
        raise AssertionError("a Ray node was started")

    monkeypatch.setattr(ray_cluster, "loopback_cluster", no_cluster)
    (tmp_path / "file").write_text("")
    report = {"in a missing folder": tmp_path / "missing" / "report.json",
              "a folder": tmp_path,
              "under a file": tmp_path / "file" / "report.json"}[where]
    argv = ["--nodes", "2", "--report", str(report), "--", *RLLIB_ONE_ITERATION,
            "--env-runners", "2", "--out", str(tmp_path / "run")]
    with pytest.raises(SystemExit) as e:
        argcheck.run(lambda: ray_cluster.main(argv))
    err = capsys.readouterr().err
    assert e.value.code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert "error: --report: " in err, err
    assert not (tmp_path / "run").exists() and not (tmp_path / "missing").exists()
