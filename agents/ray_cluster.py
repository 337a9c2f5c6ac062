"""A Ray cluster of several nodes on this one machine, every node on 127.0.0.1: the multi-node
path of agents/train_rllib.py, tried without other machines and without leaving loopback.

    python agents/ray_cluster.py --nodes 2 --cpus-per-node 1 -- --env-runners 2 --iterations 1

starts a head node and ``--nodes - 1`` worker nodes (Ray's own multi-node test cluster,
``ray.cluster_utils.Cluster``: each node its own raylet, object store and worker processes,
registered with the head's GCS, as ``ray start`` makes them), runs agents/train_rllib.py on it
with ``--address`` (the arguments after ``--``, checked before any node starts), and stops
every node at the end, also on failure, Ctrl-C or SIGTERM. While training runs it samples the
TCP sockets of the cluster's processes (its raylets, GCS, agents, env runners) and of the
driver. It prints where the env runners ran and how many sockets the run listened on, and
exits 1 if any listened on or connected to an address other than loopback, or if a driver
without the cluster's token was not refused (``--report FILE`` writes all of it, the training
rows and the processes' ids as JSON).

Why not ``ray start`` here: Ray 2.60 replaces a loopback ``--node-ip-address`` and ``--address``
by the machine's reachable address unless clusters are switched off
(``RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0``), and ``ray start --address`` refuses to start a
worker node when they are; another loopback address (127.0.0.2) is kept but taken as an
outside one, and Ray's gRPC servers then listen on all interfaces. Nodes started from Python
(``Cluster.add_node``) with clusters switched off keep 127.0.0.1, and Ray's servers then
listen on 127.0.0.1 only. Token authentication (``RAY_AUTH_MODE=token``) is on with a fresh
token for this cluster only (``RAY_AUTH_TOKEN`` in its processes' environment).

The cluster's files (Ray's temp dir, with the head's address file ``ray_current_cluster``) are
all in a fresh folder (``dg-ray-*``, in ``$RAY_TMPDIR`` if set, else the system's temporary
folder) removed at the end: nothing is read from or left in Ray's default ``/tmp/ray``.
"""

from __future__ import annotations

import argparse
import contextlib
import ipaddress
import json
import os
import secrets
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: Environment of the cluster's processes and of the driver, restored on exit.
CLUSTER_ENV = ("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "RAY_AUTH_MODE", "RAY_AUTH_TOKEN",
               "RAY_AUTH_TOKEN_PATH", "RAY_USAGE_STATS_ENABLED", "RAY_TMPDIR")


def _reset_auth_state() -> None:
    # (Ray caches its config and the token per process: read them again from the environment)
    from ray._raylet import AuthenticationTokenLoader, Config

    Config.initialize("")
    AuthenticationTokenLoader.instance().reset_cache()


@contextlib.contextmanager
def loopback_cluster(nodes: int = 2, cpus_per_node: int = 1,
                     object_store_mb: int = 100):
    """A Ray cluster of ``nodes`` nodes (a head and ``nodes - 1`` workers) of
    ``cpus_per_node`` logical CPUs each, every one on 127.0.0.1, token authentication on;
    yields the :class:`ray.cluster_utils.Cluster` (its ``address`` is the GCS's
    127.0.0.1:PORT). Every node is stopped, the environment restored and the cluster's temp
    folder removed on exit, whatever happens inside.

    The temp folder is a fresh one (in ``$RAY_TMPDIR`` if set, else the system's); the nodes
    get its ``ray/`` subfolder, and ``RAY_TMPDIR`` is the folder itself meanwhile, so that
    Ray's default temp dir (``$RAY_TMPDIR/ray``) is the nodes' one: ``Cluster.add_node``
    writes the head's address file (``ray_current_cluster``) in the default one whatever the
    head was given, and ``Cluster.shutdown`` removes it there (so not another cluster's)."""
    if nodes < 1 or cpus_per_node < 1:
        raise ValueError(f"nodes and cpus_per_node must be >= 1, got {nodes}, {cpus_per_node}")
    from ray._private import ray_constants
    from ray.cluster_utils import Cluster

    # (a short path: Ray's unix sockets live under it)
    if os.environ.get("RAY_TMPDIR"):
        os.makedirs(os.environ["RAY_TMPDIR"], exist_ok=True)  # (as Ray makes its temp dir)
    temp_root = tempfile.mkdtemp(prefix="dg-ray-", dir=os.environ.get("RAY_TMPDIR") or None)
    temp_dir = os.path.join(temp_root, "ray")
    os.mkdir(temp_dir)
    old_env = {k: os.environ.get(k) for k in CLUSTER_ENV}
    old_flag = ray_constants.ENABLE_RAY_CLUSTER
    # clusters "off": Ray then keeps 127.0.0.1 as every node's address (the constant is read
    # by this process, the variable by the nodes' processes, which inherit it)
    os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    ray_constants.ENABLE_RAY_CLUSTER = False
    os.environ["RAY_AUTH_MODE"] = "token"
    os.environ["RAY_AUTH_TOKEN"] = secrets.token_hex(32)
    os.environ.pop("RAY_AUTH_TOKEN_PATH", None)
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    os.environ["RAY_TMPDIR"] = temp_root  # (Ray's default temp dir: temp_dir)
    cluster = None
    try:
        _reset_auth_state()
        cluster = Cluster(shutdown_at_exit=True)
        for i in range(nodes):
            kwargs = dict(num_cpus=cpus_per_node, node_ip_address="127.0.0.1",
                          object_store_memory=object_store_mb * 2**20)
            if i == 0:
                kwargs.update(include_dashboard=False, temp_dir=temp_dir)
            cluster.add_node(**kwargs)
        cluster.wait_for_nodes()
        yield cluster
    finally:
        if cluster is not None:
            cluster.shutdown()
        for k, v in old_env.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        ray_constants.ENABLE_RAY_CLUSTER = old_flag
        with contextlib.suppress(Exception):
            _reset_auth_state()
        shutil.rmtree(temp_root, ignore_errors=True)


def cluster_processes(cluster) -> list:
    """The live processes of the cluster's nodes (GCS, raylets, agents, ...) and all their
    descendants (the worker processes a raylet starts), as :class:`psutil.Process`."""
    import psutil

    procs = {}
    for node in cluster.list_all_nodes():
        for infos in node.all_processes.values():
            for info in infos:
                with contextlib.suppress(psutil.Error):
                    p = psutil.Process(info.process.pid)
                    procs[p.pid] = p
                    for c in p.children(recursive=True):
                        procs[c.pid] = c
    return list(procs.values())


def is_loopback(ip: str) -> bool:
    addr = ipaddress.ip_address(ip)
    mapped = getattr(addr, "ipv4_mapped", None)  # ([::ffff:127.0.0.1], gRPC's dual stack)
    return (mapped or addr).is_loopback


class SocketWatch:
    """Samples, every ``period`` seconds in a thread, the TCP sockets of the cluster's
    processes and of this one (the driver): the addresses they listen on and the remote
    addresses they are connected to, with the processes seen."""

    def __init__(self, cluster, period: float = 1.0):
        self.cluster, self.period = cluster, period
        self.listening: set[tuple[str, int, str]] = set()
        self.remote: set[tuple[str, str]] = set()
        self.processes: dict[int, tuple[str, float]] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def sample(self) -> None:
        import psutil

        procs = cluster_processes(self.cluster) + [psutil.Process()]
        names = {}
        for p in procs:
            with contextlib.suppress(psutil.Error):
                names[p.pid] = p.name()
                self.processes.setdefault(p.pid, (p.name(), p.create_time()))
        for c in psutil.net_connections(kind="tcp"):
            if c.pid not in names:
                continue
            if c.status == psutil.CONN_LISTEN:
                self.listening.add((c.laddr.ip, c.laddr.port, names[c.pid]))
            elif c.raddr:
                self.remote.add((c.raddr.ip, names[c.pid]))

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            with contextlib.suppress(Exception):  # (a process may end between the calls)
                self.sample()

    def __enter__(self):
        self.sample()
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()
        with contextlib.suppress(Exception):
            self.sample()

    def outside(self) -> list[str]:
        """The addresses seen that are not loopback, as text (empty: all on loopback)."""
        return sorted({f"listen {ip}:{port} ({name})" for ip, port, name in self.listening
                       if not is_loopback(ip)}
                      | {f"connected to {ip} ({name})" for ip, name in self.remote
                         if not is_loopback(ip)})


def env_runner_nodes(cluster) -> list[str]:
    """The node id of every RLlib env runner (actor) the cluster has run, from the GCS's
    actor table (dead actors stay listed)."""
    table = cluster.global_state.actor_table(None)
    return [a["Address"]["NodeID"] for a in table.values()
            if "EnvRunner" in a.get("ActorClassName", "")]


def refuses_without_token(address: str, timeout: float = 120) -> bool:
    """Whether a driver without the cluster's token (no ``RAY_AUTH_TOKEN``, no
    ``RAY_AUTH_MODE``, a home without ``~/.ray/auth_token``) is refused: token authentication
    is on. (A separate process: Ray keeps its token per process.)"""
    import subprocess

    env = {k: v for k, v in os.environ.items() if k not in CLUSTER_ENV[1:4]}
    with tempfile.TemporaryDirectory() as home:
        env["HOME"] = home
        res = subprocess.run(
            [sys.executable, "-c", f"import ray; ray.init(address={address!r}); print('in')"],
            env=env, capture_output=True, text=True, timeout=timeout)
    return res.returncode != 0 and "AuthenticationError" in res.stderr


def run(nodes: int, cpus_per_node: int, train_argv: list[str]) -> dict:
    """agents/train_rllib.py on a loopback cluster of ``nodes`` nodes; returns the report:
    the nodes, the env runners' nodes, the training rows, the sockets seen (listening,
    connected) and the processes seen (pid -> name, start time)."""
    import train_rllib
    from argcheck import usage

    if "--address" in train_argv or any(a.startswith("--address=") for a in train_argv):
        raise usage("address", "is set here (the local cluster's)")
    # (a bad argument is refused before any node starts)
    train_rllib.check_args(train_rllib.parse([*train_argv, "--address", "127.0.0.1:6379"]))
    with loopback_cluster(nodes, cpus_per_node) as cluster:
        gcs = cluster.address
        node_ids = [n.node_id for n in cluster.list_all_nodes()]
        addresses = sorted({n.node_ip_address for n in cluster.list_all_nodes()})
        refused = refuses_without_token(gcs)
        t0 = time.perf_counter()
        with SocketWatch(cluster) as watch:
            rows = train_rllib.main([*train_argv, "--address", gcs])
        wall = time.perf_counter() - t0
        runners = env_runner_nodes(cluster)
    return {
        "gcs_address": gcs,
        "nodes": node_ids,
        "node_addresses": addresses,
        "refuses_a_driver_without_the_token": refused,
        "env_runner_nodes": runners,
        "rows": rows,
        "wall_s": round(wall, 2),
        "listening": sorted(f"{ip}:{port} {name}" for ip, port, name in watch.listening),
        "connected_to": sorted({ip for ip, _ in watch.remote}),
        "outside_loopback": watch.outside(),
        "processes": {str(pid): list(v) for pid, v in watch.processes.items()
                      if pid != os.getpid()},
    }


def check_report(path: str) -> Path:
    """The ``--report`` file: not a folder, in a folder that exists and is writable (checked
    before any node starts, as the other arguments)."""
    from argcheck import usage

    report = Path(path)
    if report.is_dir():
        raise usage("report", f"{report} is a folder")
    parent = report.absolute().parent
    if not parent.is_dir():
        raise usage("report", f"{parent} is not a folder" if parent.exists()
                    else f"no folder {parent}")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise usage("report", f"{parent} is not writable")
    if report.exists() and not os.access(report, os.W_OK):
        raise usage("report", f"{report} is not writable")
    return report


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                usage="%(prog)s [--nodes N] [--cpus-per-node C] "
                                      "[--report FILE] -- TRAIN_RLLIB_ARGS")
    p.add_argument("--nodes", type=int, default=2, help="Ray nodes (a head + N-1 workers)")
    p.add_argument("--cpus-per-node", type=int, default=1,
                   help="logical CPUs of each node (env runners take one each)")
    p.add_argument("--report", default=None, help="write the report to this JSON file")
    argv = sys.argv[1:] if argv is None else list(argv)
    train_argv = argv[argv.index("--") + 1:] if "--" in argv else []
    args = p.parse_args(argv[:argv.index("--")] if "--" in argv else argv)
    if args.nodes < 1 or args.cpus_per_node < 1:
        p.error("--nodes and --cpus-per-node must be at least 1")
    if args.report is not None:
        check_report(args.report)
    report = run(args.nodes, args.cpus_per_node, train_argv)
    runners = report["env_runner_nodes"]
    print(f"{len(report['nodes'])} node(s) on {', '.join(report['node_addresses'])}; "
          f"{len(runners)} env runner(s) on {len(set(runners))} node(s); listened on "
          f"{len(report['listening'])} socket(s); {report['wall_s']:.1f} s")
    if args.report:
        Path(args.report).write_text(json.dumps(report, indent=2))
    bad = 0
    if report["outside_loopback"]:
        print("not on loopback:", "; ".join(report["outside_loopback"]), file=sys.stderr)
        bad = 1
    if not report["refuses_a_driver_without_the_token"]:
        print("a driver without the cluster's token was not refused", file=sys.stderr)
        bad = 1
    return bad


if __name__ == "__main__":
    import argcheck

    argcheck.run(main)
