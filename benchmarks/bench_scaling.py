"""Wall and CPU time of one benchmark table on 1 and 2 workers, networks included.

Each run starts with no trained network in the cache (compiled search kernels stay cached, as on
any machine after its first run), so its time includes training every network the table needs.
CPU time is the run's and its worker processes' (user + system). Run from the repository root::

    python benchmarks/bench_scaling.py                          # quick FrozenLake single, 1 and 2
    python benchmarks/bench_scaling.py --size full --workers 2  # one figure
    python benchmarks/bench_scaling.py --project 16             # 1 and 2, then 16 projected

``--project N`` projects ``N`` workers from the 1-worker run by playing the runner's schedule on
paper (:func:`ns_pz.experiments.projection.project`): the networks train first, one per worker,
for the time the 1-worker run's log gives them; each trial takes the time its row of the
1-worker run recorded and starts on the first free worker once its networks are ready; every
worker first pays a start-up measured apart (:func:`worker_startup`: a fresh process's imports
and its first use of every agent in every cell). A run on one idle core takes its CPU time.
The runner works alone before the workers get their first trial (imports, loading and checking
the spec) and after the last row (packing, the CSV, the tables): that time, measured as the
wall time of the same command resumed on the finished folder (it plays no trial; its workers
start and are stopped unused: 0.3-0.5 s more with 2 workers on the 2-core machine), is added.
Meanwhile the runner's process hands out trials and writes every row beside the workers, on a
core of its own: its CPU time in the 1-worker run bounds the projection from below. The
projected speed-up is an upper bound (the wall time a lower bound): it assumes a trial costs on
16 busy cores what it costs on one. On a 16-core machine (2026-11-28) it projected 18.2 s for
the full FrozenLake table from that machine's 1-worker run, and 16 workers took 18.6 s there.
The second worker's extra CPU measures the same start-up too, but within the noise of two whole
runs (between -27 and 19 s on the 2-core development machine); it is printed beside it.

The cache used is ``--cache`` (default: a folder under the system's temporary folder, kept
between calls so the compiled kernels are built once); the user's cache is never touched.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

from ns_pz.experiments.projection import GroupTime, project
from ns_pz.experiments.runner import needed_networks
from ns_pz.experiments.spec import ExperimentSpec, load_spec
from ns_pz.experiments.trials import expand

#: ``ns-pz`` in a process that says, last on stderr, the CPU time it used itself (the runner's
#: own: handing out trials, writing rows, the tables), its workers' apart.
_RUN_AND_TELL = """
import resource, sys
from ns_pz.cli import main
if __name__ == "__main__":
    try:
        code = main(sys.argv[1:])
    finally:
        used = resource.getrusage(resource.RUSAGE_SELF)
        print(f"runner CPU {used.ru_utime + used.ru_stime:.2f} s", file=sys.stderr)
    sys.exit(code)
"""


def run_once(
    spec: str, size: str, workers: int, cache: Path, extra: list[str], log: Path | None = None
) -> dict:
    """Run ``spec`` into a fresh folder with an empty artefact cache; wall and CPU seconds.

    The run's stderr (its progress and training lines) goes to ``log`` as it is written, so a
    run stopped from outside still leaves its progress behind; by default to a temporary file.
    The same command with ``--resume`` then runs once more on the finished folder: it plays no
    trial, so its wall time (``"serial"``) is what the runner does alone, before the workers get
    work (imports, loading and checking the spec, reading the folder) and after the last row
    (packing the rows, the CSV, the tables). It reads every stored row, which a fresh run does
    not, so it overstates that a little. ``None`` when a trial failed (resuming would replay it).
    """
    shutil.rmtree(cache / "artefacts", ignore_errors=True)
    out = Path(tempfile.mkdtemp(prefix="bench-scaling-"))
    env = {**os.environ, "NS_PZ_CACHE_DIR": str(cache)}
    argv = [sys.executable, "-c", _RUN_AND_TELL, "bench", "run", spec, "--size", size]
    argv += ["--workers", str(workers), "--out", str(out), *extra]
    command = " ".join(["ns-pz", *argv[3:]])  # for messages: the wrapper's code left out
    log = log or out / "stderr.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()[0]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    try:
        with open(log, "w") as stream:
            done = subprocess.run(argv, env=env, stdout=subprocess.DEVNULL, stderr=stream)
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        text = log.read_text()
        rows = []
        for path in sorted(out.rglob("results.csv")):
            with open(path, newline="") as handle:
                rows += list(csv.DictReader(handle))
        if done.returncode not in (0, 1):
            raise RuntimeError(f"{command} failed:\n{text[-3000:]}")
        serial = None  # a run with failed trials would play them again: no serial figure
        if done.returncode == 0:
            start = time.perf_counter()
            again = subprocess.run([*argv, "--resume"], env=env, capture_output=True, text=True)
            serial = time.perf_counter() - start
            if again.returncode != 0:
                raise RuntimeError(f"{command} --resume failed:\n{again.stderr[-3000:]}")
    finally:
        shutil.rmtree(out, ignore_errors=True)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    runner = re.findall(r"^runner CPU ([0-9.]+) s$", text, re.M)
    return {
        "wall": wall,
        "cpu": cpu,
        "runner_cpu": float(runner[-1]) if runner else None,
        "serial": serial,
        "load": (load, os.getloadavg()[0]),
        "log": text,
        "rows": rows,
    }


def main() -> None:
    """Parse the options, time each worker count, print one line each."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", default="frozenlake-single")
    parser.add_argument("--size", default="quick", choices=("quick", "full"))
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--cache", default=str(Path(tempfile.gettempdir()) / "ns-pz-scaling"))
    parser.add_argument("--log", action="store_true", help="print each run's stderr")
    parser.add_argument(
        "--log-dir", default=None, help="write each run's stderr to DIR/WORKERS.log as it runs"
    )
    parser.add_argument("--project", type=int, default=None, help="project N workers (see above)")
    args, extra = parser.parse_known_args()
    # Stopped from outside (`timeout`), end the run in hand too: subprocess.run kills its child
    # when the SystemExit passes through it.
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    cache = Path(args.cache)
    results = {}
    for workers in args.workers:
        log = Path(args.log_dir) / f"{workers}.log" if args.log_dir else None
        result = results[workers] = run_once(args.spec, args.size, workers, cache, extra, log)
        if args.log:
            print(result["log"])
        runner, serial = result["runner_cpu"], result["serial"]
        print(
            f"{args.spec} {args.size} --workers {workers}: wall {result['wall']:.1f} s, "
            f"CPU {result['cpu']:.1f} s (the runner's own {_seconds(runner)}), alone before and "
            f"after the trials {_seconds(serial)}, "
            f"load {result['load'][0]:.2f} -> {result['load'][1]:.2f}",
            flush=True,
        )
    if args.project is not None and 1 in results:
        spec = load_spec(args.spec, args.size)
        startup = worker_startup(args.spec, args.size, cache)
        if 2 in results:
            extra = results[2]["cpu"] - results[1]["cpu"]
            print(f"the second worker's extra CPU: {extra:.1f} s")
        print(projected(spec, results[1], startup, args.project))


def _seconds(value: float | None) -> str:
    """``value`` as seconds for a line of output; "n/a" where the run did not measure it."""
    return "n/a" if value is None else f"{value:.1f} s"


_STARTUP_PROBE = """
import json, sys, time
from ns_pz.experiments.spec import load_spec
from ns_pz.experiments.trials import expand
from ns_pz.experiments.work import run_batch
spec = load_spec(sys.argv[1], sys.argv[2])
firsts = {}
for trial in expand(spec):
    firsts.setdefault((trial.cell, trial.agent.label), trial)
trials = list(firsts.values())
imported = time.process_time()
run_batch(spec, trials)
cold = time.process_time()
run_batch(spec, trials)
warm = time.process_time()
print(json.dumps({"imported": imported, "cold": cold - imported, "warm": warm - cold}))
"""


def worker_startup(spec: str, size: str, cache: Path) -> dict:
    """What a fresh worker pays before its trials cost what the 1-worker run's rows say.

    A new process (the networks already in ``cache``) imports the runner and plays the first
    seed of every agent × cell twice: the start-up is its CPU time until the trials began (the
    interpreter and the imports) plus the first round's excess over the second (loading
    networks and compiled kernels, building each cell's models). A worker of a big run meets
    only some of those firsts, and the 1-worker run's rows hold them once already, so this
    overstates its start-up a little. Call it after a run that left the networks in ``cache``
    (else its first round trains them). (``bench estimate`` charges the imports alone:
    :func:`ns_pz.experiments.estimate.worker_startup`.)

    Raises:
        RuntimeError: The probe failed; its stderr is in the message.

    Returns:
        ``{"seconds", "imports", "first_uses", "trials"}``.
    """
    env = {**os.environ, "NS_PZ_CACHE_DIR": str(cache)}
    argv = [sys.executable, "-c", _STARTUP_PROBE, spec, size]
    done = subprocess.run(argv, env=env, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"the start-up probe failed:\n{done.stderr[-3000:]}")
    probe = json.loads(done.stdout.strip().splitlines()[-1])
    first_uses = max(0.0, probe["cold"] - probe["warm"])
    trials = len({(t.cell, t.agent.label) for t in expand(load_spec(spec, size))})
    return {
        "seconds": probe["imported"] + first_uses,
        "imports": probe["imported"],
        "first_uses": first_uses,
        "trials": trials,
    }


def projected(spec: ExperimentSpec, one: dict, startup: dict, workers: int) -> str:
    """``workers`` workers projected from the 1-worker run and :func:`worker_startup`.

    Raises:
        ValueError: The 1-worker run's log lacks a network's ``trained ... in X s`` line.
    """
    trained = dict(re.findall(r"^trained (.*) in ([0-9.]+) s$", one["log"], re.M))
    keys: dict[str, set[str]] = defaultdict(set)  # agent label -> its networks' keys
    networks = {}
    for label, need in needed_networks(spec, expand(spec)):
        keys[label].add(need.request.key)
        if need.label not in trained:
            raise ValueError(f"the 1-worker run's log has no 'trained {need.label} in ...' line")
        networks[need.request.key] = float(trained[need.label])
    times: dict[tuple[str, str, str], list[float]] = defaultdict(list)  # in table order
    for row in one["rows"]:
        if not row["wall_time"]:  # a trial lost with its worker records no time
            continue
        times[(row["setting"], row["notification"], row["agent"])].append(float(row["wall_time"]))
    groups = [
        GroupTime(sum(seconds) / len(seconds), len(seconds), frozenset(keys[agent]))
        for (_, _, agent), seconds in times.items()
    ]
    plan = project(sorted(networks.items()), groups, workers, startup["seconds"])
    serial = one.get("serial") or 0.0
    wall = plan.wall + serial
    runner = one.get("runner_cpu")
    bound = ""
    if runner is not None:
        wall = max(wall, runner)
        bound = f"; the runner's own process, {runner:.1f} CPU-s, bounds it"
        if runner < plan.wall + serial:
            bound = f"; the runner's own process used {runner:.1f} CPU-s, less"
    return (
        f"projected on {workers} workers (the runner's schedule; trial and training times of "
        f"the 1-worker run; {startup['seconds']:.1f} s of start-up per worker: "
        f"{startup['imports']:.1f} s of imports, {startup['first_uses']:.1f} s of first uses over "
        f"{startup['trials']} agent x cell trials): {plan.text()}; plus {serial:.1f} s the "
        f"runner works alone (before the first trial and after the last){bound} ({wall:.1f} s): "
        f"{one['cpu'] / wall:.1f}x one idle core ({one['cpu']:.1f} s)"
    )


if __name__ == "__main__":
    main()
