"""How well do the detector monitors detect the shipped single-change settings?

For each shipped single-change spec with a detector column (``[monitor]``: FrozenLake and
CliffWalking with ``cusum``, CartPole with ``prediction_error``), every setting is played in the
detector cell (the spec's env, θ_0, change and horizon, the detector at its level) by the agents
asked for, one episode per seed of the spec's size; the change times and the alarms are scored
with :func:`ns_pz.monitor.detection_metrics`:

* **delay**: mean steps from a change to the alarm that detects it (the oracle's is 0);
* **FA/1k**: false alarms per 1,000 steps;
* **missed**: changes never detected (an episode may end first: FrozenLake's often do).

Without ``--max-delay`` any later alarm inside a change's interval detects it, so a detector
that misses a change and raises a false alarm much later is scored as detecting it late;
``--max-delay N`` counts only alarms within ``N`` steps (the others are false alarms).

What a detector can see depends on the trajectory, so the table names the agent that drove it.

Run: ``python benchmarks/bench_detectors.py`` (``--size full``, ``--agents random snapshot_vi``,
``--specs ...``, ``--max-delay N``; ``--smoke``: two episodes per setting, a seconds-long check
that it runs).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.evaluation import run_episode

from ns_pz.experiments.spec import DETECTOR, Cell, ExperimentSpec, load_spec
from ns_pz.monitor import detection_metrics

SPECS = ("frozenlake-single", "cliffwalking-single", "cartpole-single")


def hyper_of(spec: ExperimentSpec, name: str) -> dict[str, Any]:
    """The spec's hyper-parameters for agent ``name`` (its defaults if the spec lacks it)."""
    for agent in spec.agents:
        if agent.name == name:
            return dict(agent.hyper)
    return {}


def measure(
    spec: ExperimentSpec, agent_name: str, episodes: int, max_delay: int | None = None
) -> list[dict[str, Any]]:
    """One row per setting: the detection scores of ``episodes`` seeds in the detector cell."""
    if spec.monitor is None:
        raise ValueError(f"spec {spec.name!r} has no [monitor] table (no detector column)")
    rows = []
    for index, setting in enumerate(spec.settings()):
        cell = Cell(setting, DETECTOR, index)
        start = time.perf_counter()
        scored = []
        for seed in list(spec.seeds())[:episodes]:
            env = spec.make_env(cell)
            agent = agent_entry(agent_name).make(env, hyper_of(spec, agent_name))
            episode = run_episode(env, agent, seed)
            scored.append((episode.change_times, episode.alarm_times, episode.length))
        summary = detection_metrics(scored, max_delay=max_delay)
        rows.append(
            {
                "spec": spec.name,
                "monitor": spec.monitor.name,
                "setting": setting,
                "agent": agent_name,
                "summary": summary,
                "seconds": time.perf_counter() - start,
            }
        )
    return rows


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--specs", nargs="+", default=list(SPECS))
    parser.add_argument("--size", default="quick", choices=("quick", "full"))
    parser.add_argument("--agents", nargs="+", default=["random", "snapshot_vi", "mcts"])
    parser.add_argument("--episodes", type=int, default=None, help="cap on seeds per setting")
    parser.add_argument("--smoke", action="store_true", help="two episodes per setting")
    parser.add_argument(
        "--max-delay", type=int, default=None, help="alarms later than this are false alarms"
    )
    args = parser.parse_args()
    cap = 2 if args.smoke else args.episodes
    print(
        "| spec | detector | setting | agent | episodes | steps | changes | missed | "
        "mean delay | FA/1k | s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.specs:
        spec = load_spec(name, args.size)
        available = {a.name for a in spec.agents}
        for agent_name in args.agents:
            if agent_name not in available:
                continue
            episodes = spec.episodes if cap is None else min(cap, spec.episodes)
            for row in measure(spec, agent_name, episodes, args.max_delay):
                s = row["summary"]
                delay = "n/a" if s.detected == 0 else f"{s.mean_delay:.1f}"
                print(
                    f"| {row['spec']} | {row['monitor']} | {row['setting']} | {row['agent']} | "
                    f"{s.episodes} | {s.steps} | {s.changes} | {s.missed} | {delay} | "
                    f"{s.false_alarms_per_1000:.2f} | {row['seconds']:.1f} |"
                )


if __name__ == "__main__":
    main()
