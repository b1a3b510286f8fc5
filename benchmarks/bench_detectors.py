"""How well do the detector monitors detect the shipped single-change settings?

For each shipped single-change spec with a detector column (``[monitor]``: FrozenLake and
CliffWalking with ``cusum``, CartPole with ``prediction_error``), every setting is played in the
detector cell (the spec's env, θ_0, change and horizon, the detector at its level) by the agents
asked for, one episode per seed of the spec's size; the change times and the alarms are scored
with :func:`ns_pz.monitor.detection_metrics`:

* **delay**: steps from a change to the alarm that detects it (the oracle's is 0; an alarm on
  the change's first transition is 0, Lorden's convention counts it 1), as mean / median / 90th
  percentile;
* **pre FA/1k**: false alarms before the first change per 1,000 pre-change steps; in the
  ``control`` row (the same env, θ_0, detector, agent and seeds, nature static) that is
  ``1000 / ARL₀``, the rate the literature calls the false-alarm rate;
* **post FA/1k**: the other false alarms (re-alarms after a detection, while the detector learns
  the new θ) per 1,000 steps after the first change;
* **missed**: changes never detected (an episode may end first: FrozenLake's often do).

Without ``--max-delay`` any later alarm inside a change's interval detects it, so a detector
that misses a change and raises a false alarm much later is scored as detecting it late;
``--max-delay N`` counts only alarms within ``N`` steps (the others are false alarms).

What a detector can see depends on the trajectory, so the table names the agent that drove it.

Run: ``python benchmarks/bench_detectors.py`` (``--size full``, ``--agents random snapshot_vi``,
``--specs ...``, ``--max-delay N``; ``--smoke``: two episodes per setting, a seconds-long check
that it runs). ``--learned`` prints instead the table of a learned monitor against
never/always-alarm and the CUSUM (:mod:`learned_monitor`); ``--river`` the CUSUM bank beside
river's drift detectors on synthetic streams with an unchanging control (:mod:`river_detectors`).
"""

from __future__ import annotations

import argparse
import time
from typing import Any

from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.evaluation import run_episode
from ns_pz.envs.registry import make_gym

from ns_pz.experiments.spec import DETECTOR, Cell, ExperimentSpec, load_spec
from ns_pz.monitor import DetectionSummary, detection_metrics

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
    settings: list[Any] = [*spec.settings(), "control"]
    for index, setting in enumerate(settings):
        cell = Cell(setting, DETECTOR, index)
        start = time.perf_counter()
        scored = []
        for seed in list(spec.seeds())[:episodes]:
            env = spec.make_env(cell) if setting != "control" else control_env(spec)
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


def control_env(spec: ExperimentSpec) -> Any:
    """The spec's detector cell without a change: the same env, θ_0, detector and horizon."""
    assert spec.monitor is not None  # measure() checked
    return make_gym(
        spec.env,
        params=spec.theta0(),
        notification=spec.level_of(DETECTOR),
        monitor=spec.monitor.make(),
        max_episode_steps=spec.horizon,
        **spec.env_kwargs,
    )


def cells(s: DetectionSummary) -> str:
    """The delay and false-alarm cells of one row."""
    delay = (
        "n/a"
        if s.detected == 0
        else f"{s.mean_delay:.1f} / {s.median_delay:.0f} / {s.p90_delay:.0f}"
    )
    post_steps = s.steps - s.pre_change_steps
    pre = "n/a" if not s.pre_change_steps else f"{s.pre_change_false_alarms_per_1000:.2f}"
    post = "n/a" if not post_steps else f"{1000.0 * s.post_change_false_alarms / post_steps:.2f}"
    return f"{s.missed} | {delay} | {pre} | {post}"


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
    parser.add_argument(
        "--learned", action="store_true", help="the learned-monitor table (needs SB3) instead"
    )
    parser.add_argument("--train-steps", type=int, default=40_000)
    parser.add_argument("--train-seeds", type=int, default=5)
    parser.add_argument("--eval-episodes", type=int, default=200)
    parser.add_argument("--settings", nargs="+", default=None, help="--learned: which settings")
    parser.add_argument("--variants", nargs="+", default=None, help="--learned: which monitors")
    parser.add_argument("--workers", type=int, default=1, help="--learned: training processes")
    parser.add_argument(
        "--river", action="store_true", help="beside river's detectors (needs river) instead"
    )
    parser.add_argument("--seeds", type=int, default=20, help="streams per setting (--river)")
    args = parser.parse_args()
    if args.river:
        from river_detectors import print_table as river_table  # benchmarks/river_detectors.py

        river_table(1 if args.smoke else args.seeds)
        return
    if args.learned:
        from learned_monitor import print_table  # benchmarks/learned_monitor.py

        steps, seeds, episodes = args.train_steps, args.train_seeds, args.eval_episodes
        if args.smoke:
            steps, seeds, episodes = 128, 1, 2
        print_table(steps, seeds, episodes, args.settings, args.variants, args.workers)
        return
    cap = 2 if args.smoke else args.episodes
    print(
        "| spec | detector | setting | agent | episodes | steps | changes | missed | "
        "delay mean / median / p90 | pre FA/1k | post FA/1k | s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.specs:
        spec = load_spec(name, args.size)
        available = {a.name for a in spec.agents}
        for agent_name in args.agents:
            if agent_name not in available:
                continue
            episodes = spec.episodes if cap is None else min(cap, spec.episodes)
            for row in measure(spec, agent_name, episodes, args.max_delay):
                s = row["summary"]
                print(
                    f"| {row['spec']} | {row['monitor']} | {row['setting']} | {row['agent']} | "
                    f"{s.episodes} | {s.steps} | {s.changes} | {cells(s)} | "
                    f"{row['seconds']:.1f} |"
                )


if __name__ == "__main__":
    main()
