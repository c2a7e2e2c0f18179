"""A real Ray cluster on this machine for the tests and the speedup measurement: a head node and
worker nodes started with `ray start --block` on the loopback address 127.0.0.2, each in its own
process group so that one node can be killed (all its processes: raylet, object store, workers)
without touching the others, and everything is stopped by process group at the end (never by
process name).

Why 127.0.0.2 and not 127.0.0.1: Ray rewrites "127.0.0.1" and "localhost" (in `ray.init`'s
address and in a node's IP) to the address this machine routes outward from, so a driver given
127.0.0.1 connects to that interface; where it does not accept connections to itself (a CI
sandbox did not) the driver never reaches the cluster. Any other loopback address is kept as
given, so the whole cluster stays on the loopback interface."""

from __future__ import annotations

import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from typing import Dict, List, Optional


def _loopback_host() -> str:
    """127.0.0.2 where it can be bound (Linux routes all of 127/8 to the loopback interface;
    macOS configures 127.0.0.1 alone), else 127.0.0.1."""
    try:
        with socket.socket() as s:
            s.bind(("127.0.0.2", 0))
        return "127.0.0.2"
    except OSError:
        return "127.0.0.1"


#: The loopback address every node and driver uses (see the module's doc).
HOST = _loopback_host()


def _free_port() -> int:
    with socket.socket() as s:
        s.bind((HOST, 0))
        return s.getsockname()[1]


def use_fresh_auth_token() -> None:
    """Ray's token authentication for this process and the nodes and drivers it starts: a fresh
    token in the environment. Must run before `import ray` (Ray reads the mode when imported)."""
    os.environ["RAY_AUTH_MODE"] = "token"
    os.environ.setdefault("RAY_AUTH_TOKEN", secrets.token_hex(32))
    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"


class LocalCluster:
    def __init__(self) -> None:
        use_fresh_auth_token()
        # Short: Ray's unix socket paths under it must stay below 107 characters.
        self.temp = tempfile.mkdtemp(prefix="trc-", dir="/tmp")
        self.port = _free_port()
        self.address = f"{HOST}:{self.port}"
        self.env = dict(
            os.environ,
            # The tests' tasks are small; do not let Ray's memory monitor kill workers because
            # other programs on this machine use memory.
            RAY_memory_monitor_refresh_ms="0",
        )
        self.nodes: List[subprocess.Popen] = []
        self.ray_bin = os.path.join(os.path.dirname(sys.executable), "ray")

    def _start(self, args: List[str], name: str, env: Optional[Dict[str, str]]) -> subprocess.Popen:
        log = open(os.path.join(self.temp, f"{name}.log"), "w")
        proc = subprocess.Popen(
            [self.ray_bin, "start", "--block", f"--node-ip-address={HOST}", "--disable-usage-stats",
             "--object-store-memory=100000000", *args],
            env=dict(self.env, **(env or {})),
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        self.nodes.append(proc)
        return proc

    def start_head(self, num_cpus: int = 1, env: Optional[Dict[str, str]] = None) -> subprocess.Popen:
        return self._start(
            ["--head", f"--port={self.port}", f"--num-cpus={num_cpus}", "--include-dashboard=false",
             f"--temp-dir={self.temp}"],
            "head",
            env,
        )

    def add_node(self, num_cpus: int = 1, env: Optional[Dict[str, str]] = None) -> subprocess.Popen:
        return self._start([f"--address={self.address}", f"--num-cpus={num_cpus}"], f"node{len(self.nodes)}", env)

    def connect(self, nodes: int, timeout: float = 120.0) -> None:
        """Connects this process as the driver once `nodes` nodes are alive."""
        import ray

        deadline = time.monotonic() + timeout
        while not ray.is_initialized():
            try:
                ray.init(address=self.address, log_to_driver=False, configure_logging=False)
            except Exception as e:
                if time.monotonic() > deadline:
                    raise ConnectionError(f"no Ray driver connection to {self.address}: {self.logs()}") from e
                time.sleep(0.5)
        self.wait_for_nodes(nodes, deadline - time.monotonic())

    def wait_for_nodes(self, nodes: int, timeout: float = 120.0) -> None:
        import ray

        deadline = time.monotonic() + timeout
        while sum(1 for n in ray.nodes() if n["Alive"]) != nodes:
            if time.monotonic() > deadline:
                raise TimeoutError(f"{nodes} Ray nodes not alive after {timeout} s: {self.logs()}")
            time.sleep(0.3)

    def warm_up(self) -> None:
        """Runs a task on every alive node, so each has a worker process started (a node's first
        worker takes about a second to start: without this, short renders finish on the nodes
        that were warm)."""
        import ray
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

        @ray.remote(num_cpus=1)
        def ping() -> int:
            return os.getpid()

        nodes = [n["NodeID"] for n in ray.nodes() if n["Alive"]]
        ray.get([
            ping.options(scheduling_strategy=NodeAffinitySchedulingStrategy(n, soft=False)).remote()
            for n in nodes
        ])

    def kill_node(self, proc: subprocess.Popen) -> None:
        """SIGKILL to every process of one node (its process group)."""
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()

    def logs(self) -> str:
        out = []
        for name in sorted(os.listdir(self.temp)):
            if name.endswith(".log"):
                with open(os.path.join(self.temp, name)) as f:
                    out.append(f"--- {name}\n" + f.read()[-2000:])
        return "\n".join(out)

    def shutdown(self) -> None:
        import ray

        if ray.is_initialized():
            ray.shutdown()
        for proc in reversed(self.nodes):
            self.kill_node(proc)
        shutil.rmtree(self.temp, ignore_errors=True)
