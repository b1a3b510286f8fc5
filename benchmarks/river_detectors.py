"""ns_pz's TabularCusumMonitor beside river's drift detectors, on the same streams and seeds.

Streams: each transition's state and action drawn uniformly (non-terminal states), the next
state drawn from the family's outcome table under θ_0 before the change and θ_1 from it on,
1,300 transitions with the change at 300; and an unchanging control (θ_0 throughout):

* FrozenLake 4x4, slip 0.7 → 0.4 (equal split);
* CliffWalking, slip 1.0 → 0.8 (equal split).

River's detectors see one number per transition, the natural per-step statistic of a tabular
world: 1 if the move went as intended (the next state is the intended outcome's), else 0 (DDM
and HDDM_W, river's detectors of error rates, see 1 for a move not as intended).
``TabularCusumMonitor`` sees the transition itself. River's detectors restart themselves after a
drift; every ``drift_detected`` is an alarm. Scores (:func:`ns_pz.monitor.detection_metrics`):
detection rate, median delay (the first alarm at or after the change), and pre-change false
alarms per 1,000 pre-change steps (in the control: per 1,000 steps, ``1000 / ARL₀``).

Run: ``python benchmarks/bench_detectors.py --river`` (needs ``pip install river``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from ns_pz.agents.exact import equal_split
from ns_pz.envs.cliff_walking import CliffWalkingFamily, CliffWalkingParams
from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

from ns_pz.monitor import TabularCusumMonitor, detection_metrics

BINARY = ("DDM", "HDDM_W")
"""River's detectors of a rising error rate: fed 1 - (moved as intended)."""
STEPS = 1300
CHANGE = 300
STREAMS = {
    "FrozenLake 0.7 → 0.4": (FrozenLakeFamily, FrozenLakeParams, 0.7, 0.4, 3),
    "CliffWalking 1.0 → 0.8": (CliffWalkingFamily, CliffWalkingParams, 1.0, 0.8, 4),
}


def stream(family: Any, theta0: Any, theta1: Any, change: int | None, seed: int) -> Iterator[Any]:
    """``(observation, intended)`` per transition: θ_1 from ``change`` on (never if ``None``)."""
    tables = [family.outcomes(theta0), family.outcomes(theta1)]
    live = [s for s in range(tables[0].probs.shape[0]) if not family.is_terminal_state(s)]
    rng = np.random.default_rng(seed)
    for t in range(STEPS):
        table = tables[int(change is not None and t >= change)]
        state, action = int(rng.choice(live)), int(rng.integers(table.probs.shape[1]))
        outcome = rng.choice(table.probs.shape[2], p=table.probs[state, action])
        reached = int(table.next_states[state, action, outcome])
        observation = {
            "last_state": state,
            "last_action": action,
            "last_reward": np.array([table.rewards[state, action, outcome]], np.float32),
            "state": reached,
            "relative_time": np.array([t + 1.0], np.float32),
        }
        yield observation, float(reached == tables[0].next_states[state, action, 0])


def river_detectors() -> dict[str, Callable[[], Any]]:
    """River's detectors at their defaults, each with how it reads the statistic."""
    from river import drift

    return {
        "ADWIN": drift.ADWIN,
        "PageHinkley": drift.PageHinkley,
        "KSWIN": lambda: drift.KSWIN(seed=0),
        "HDDM_W": drift.binary.HDDMW,
        "DDM": drift.binary.DDM,
    }


def alarms_of(name: str, make: Callable[[], Any], data: list[tuple[Any, float]]) -> list[int]:
    """Transition indices at which a river detector flags a drift."""
    detector = make()
    alarms = []
    for t, (_, intended) in enumerate(data):
        detector.update(1.0 - intended if name in BINARY else intended)
        if detector.drift_detected:
            alarms.append(t)
    return alarms


def cusum_alarms(monitor: TabularCusumMonitor, data: list[tuple[Any, float]]) -> list[int]:
    """Transition indices at which the CUSUM bank alarms."""
    memory = monitor.initial_memory()
    rng = np.random.default_rng(0)
    for observation, _ in data:
        monitor.notify(observation, None, memory, rng)
    return list(memory.alarms)


def print_table(seeds: int) -> None:
    """Print detection rate, median delay and pre-change false alarms for every detector."""
    print("| stream | detector | detected | median delay | pre-change FA/1k | control FA/1k | s |")
    print("|---|---|---|---|---|---|---|")
    for label, (family_cls, params_cls, p0, p1, size) in STREAMS.items():
        family = family_cls()
        theta0 = params_cls(slip=equal_split(p0, size))
        theta1 = params_cls(slip=equal_split(p1, size))
        changed = [list(stream(family, theta0, theta1, CHANGE, s)) for s in range(seeds)]
        control = [list(stream(family, theta0, theta0, None, s)) for s in range(seeds)]
        monitor = TabularCusumMonitor()
        monitor.bind(family, theta0)
        runners: dict[str, Callable[[list[tuple[Any, float]]], list[int]]] = {
            "TabularCusumMonitor(h=10)": lambda data, m=monitor: cusum_alarms(m, data),
        }
        for name, make in river_detectors().items():
            runners[f"river {name}"] = lambda data, n=name, k=make: alarms_of(n, k, data)
        for name, run in runners.items():
            start = time.perf_counter()
            scored = detection_metrics(([CHANGE], run(data), STEPS) for data in changed)
            quiet = detection_metrics(([], run(data), STEPS) for data in control)
            delay = "n/a" if scored.detected == 0 else f"{scored.median_delay:.0f}"
            print(
                f"| {label} | {name} | {scored.detected}/{scored.changes} | {delay} | "
                f"{scored.pre_change_false_alarms_per_1000:.2f} | "
                f"{quiet.pre_change_false_alarms_per_1000:.2f} | "
                f"{time.perf_counter() - start:.1f} |",
                flush=True,
            )
