"""The Ray backend on a cluster started apart from the run, with a worker killed mid-run.

The cluster is a head node started by ``ray start --head`` in a subprocess (its own temporary
folder and port), reached through ``--address`` as a real cluster is. It is stopped by ending
that subprocess's process group, not by ``ray stop``: ``ray stop`` ends every Ray process of the
machine, other test runs' included.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

import ns_pz
from ns_pz.experiments import LocalBackend, ResultStore, expand, load_spec, run_spec

pytest.importorskip("ray", reason="the ray backend needs Ray (pip install 'ns_pz[ray]')")

SPEC = """
version = 1
name = "slow"
title = "FrozenLake with a slow random agent"
env = "ns_pz/FrozenLake-v0"
params = { slip = 0.7 }
notifications = ["detailed", "none"]

[change]
kind = "single"
param = "slip"
first_step = 1
to = [0.4, 0.9]

[sizes.quick]
episodes = 5
horizon = 20

[[agents]]
name = "agents_for_tests:slow_random"
label = "slow"
params = { pause = 0.08, marker = "MARKER" }
"""
"""20 trials: 2 settings × 2 levels × 5 seeds, each a few tenths of a second."""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@dataclass(frozen=True)
class Cluster:
    """A running cluster: its address, and the environment its drivers need (its token)."""

    address: str
    env: dict[str, str]


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[Cluster]:
    """A one-node Ray cluster of two CPUs."""
    port = _free_port()
    # A short folder: Ray's socket paths must fit in 107 characters.
    temp = tempfile.mkdtemp(prefix="ray-", dir="/tmp")
    source = str(Path(ns_pz.__file__).resolve().parent.parent)
    tests = str(Path(__file__).resolve().parent)
    path = os.pathsep.join(p for p in (source, tests, os.environ.get("PYTHONPATH", "")) if p)
    env = {**os.environ, "PYTHONPATH": path, "NS_PZ_CACHE_DIR": str(tmp_path / "cache")}
    # Ray 2.60 clusters check a token: this one's is made here, for it and its driver only.
    env.update(RAY_AUTH_MODE="token", RAY_AUTH_TOKEN=secrets.token_hex(32))
    env.pop("RAY_AUTH_TOKEN_PATH", None)
    env.pop("RAY_ADDRESS", None)
    ray = Path(sys.executable).parent / "ray"
    head = subprocess.Popen(
        [str(ray), "start", "--head", "--block", f"--port={port}", f"--temp-dir={temp}"]
        + ["--num-cpus=2", "--include-dashboard=false", "--disable-usage-stats"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group: stopped below, and nothing else
    )
    try:
        _wait_for_port(port, head)
        yield Cluster(f"127.0.0.1:{port}", env)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(head.pid, signal.SIGTERM)
        try:
            head.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(head.pid, signal.SIGKILL)
            head.wait()
        _kill_leftovers(temp)


def _wait_for_port(port: int, head: subprocess.Popen, seconds: float = 60.0) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if head.poll() is not None:
            pytest.fail(f"ray start --head ended: {head.stderr.read()[-2000:]}")
        with socket.socket() as probe, contextlib.suppress(OSError):
            probe.connect(("127.0.0.1", port))
            time.sleep(2.0)  # the port opens before the rest of the head is up
            return
        time.sleep(0.2)
    pytest.fail(f"no Ray head on port {port} after {seconds} s")


def _kill_leftovers(temp: str) -> None:
    """End any process of this cluster still alive (its command line names its folder)."""
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        with contextlib.suppress(OSError):
            if temp.encode() in (proc / "cmdline").read_bytes():
                os.kill(int(proc.name), signal.SIGKILL)


def test_a_worker_killed_mid_run_loses_and_repeats_nothing(
    tmp_path: Path, cluster: Cluster
) -> None:
    """SIGKILL a Ray worker while it plays a trial: every trial still has one ok row, as local."""
    marker = tmp_path / "pids"
    marker.mkdir()
    path = tmp_path / "slow.toml"
    path.write_text(SPEC.replace("MARKER", str(marker)))
    killed: list[int] = []

    def kill_one_worker() -> None:
        deadline = time.monotonic() + 60
        while not killed and time.monotonic() < deadline:
            # Not the driver: loading the spec let the agent act once there.
            pids = [int(p.name) for p in marker.iterdir() if int(p.name) != driver.pid]
            if pids:
                time.sleep(0.1)  # mid-trial
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
            time.sleep(0.05)

    argv = [sys.executable, "-m", "ns_pz.cli", "bench", "run", str(path), "--backend", "ray"]
    argv += ["--address", cluster.address, "--out", str(tmp_path / "ray")]
    driver = subprocess.Popen(
        argv, env=cluster.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT
    )
    killer = threading.Thread(target=kill_one_worker, daemon=True)
    killer.start()
    try:
        log, _ = driver.communicate(timeout=120)
    finally:
        driver.kill()
    killer.join()
    assert driver.returncode == 0, log.decode()[-3000:]
    assert killed and killed[0] != driver.pid
    with pytest.raises(ProcessLookupError):
        os.kill(killed[0], 0)  # it is gone
    spec = load_spec(path, "quick")
    rows = ResultStore(tmp_path / "ray" / "slow-quick").rows()
    assert sorted(r["trial"] for r in rows) == sorted(t.key for t in expand(spec))
    assert {r["status"] for r in rows} == {"ok"}
    csv = (tmp_path / "ray" / "slow-quick" / "results.csv").read_text()
    assert csv.count("\n") == len(rows) + 1  # one line per trial, none twice
    run_spec(spec, tmp_path / "local", LocalBackend(2))
    local = ResultStore(tmp_path / "local").rows()
    keep = ("trial", "return", "length", "change_times", "status")
    assert [{k: r[k] for k in keep} for r in rows] == [{k: r[k] for k in keep} for r in local]
