r"""What whole trials cost, measured, against ``bench estimate``'s projection of the same trials.

For one spec, size, agent (by label) and cell (setting and notification column), each seed's
trial is played exactly as the runner plays it (:func:`ns_pz.experiments.trials.run_trial`:
``spec.make_env``, the agent from the catalogue, ``run_episode``), and its episode length,
CPU seconds and CPU seconds per step are printed, with the CPU seconds per step over the steps
the estimate would time (those played within its cap, the first excluded) and over the rest.
The last column is what ``bench estimate`` projects for the same trial
(:func:`ns_pz.experiments.estimate._time_trial`, its cap ``--cap`` seconds, default 1):
``<=`` marks a projection to the horizon (an upper bound), ``=`` an episode it timed whole.

``--max-steps N`` cuts a trial after N steps (the row says so) to keep a measurement bounded.
``--stand-in`` projects as the estimate does for an agent playing a stand-in network (every
episode to the horizon). Times are CPU seconds of this process (``time.process_time``), so they
hold on a shared machine; print ``uptime`` with them all the same.

Run (networks train into the cache first if missing; use a throwaway one)::

    NS_PZ_CACHE_DIR=/tmp/cache python benchmarks/bench_trial_costs.py cartpole-continuous \\
        --agent DDQN-WN --setting continuous --column WN --seeds 0 1
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from ns_pz.agents.catalog import agent_entry
from ns_pz.agents.evaluation import run_episode

from ns_pz.experiments import estimate, load_spec
from ns_pz.experiments.spec import LEVEL_LABELS, ExperimentSpec
from ns_pz.experiments.trials import Trial, expand


@dataclass(frozen=True)
class TrialCost:
    """One trial as played: its length, CPU seconds, and when each step ended."""

    length: int
    cpu: float
    ends: np.ndarray
    """``[length]`` CPU seconds from the trial's start to the end of each step."""
    wall_ends: np.ndarray
    """``[length]`` wall seconds from the trial's start to the end of each step."""
    cut: bool
    episode_return: float


def pick(spec: ExperimentSpec, agent: str, setting: str, column: str) -> list[Trial]:
    """The trials of one agent label in one cell (``column``: WN, WON, WD or a level name).

    Raises:
        ValueError: No trial matches (the message lists what the spec holds).
    """
    levels = {label: level for level, label in LEVEL_LABELS.items()}
    level = levels.get(column, column)
    trials = [
        t
        for t in expand(spec)
        if t.agent.label == agent and t.cell.setting == setting and t.cell.notification == level
    ]
    if not trials:
        cells = sorted({(t.cell.setting, LEVEL_LABELS[t.cell.notification]) for t in expand(spec)})
        agents = sorted({t.agent.label for t in expand(spec)})
        raise ValueError(
            f"no trial of agent={agent!r} in setting={setting!r}, column={column!r}; "
            f"agents: {agents}; cells: {cells}"
        )
    return trials


def play(spec: ExperimentSpec, trial: Trial, max_steps: int | None) -> TrialCost:
    """Play ``trial`` as the runner does (cut after ``max_steps`` steps if given)."""
    cpu0, wall0 = time.process_time(), time.perf_counter()
    ends: list[float] = []
    wall_ends: list[float] = []

    def stop(steps: int) -> bool:
        ends.append(time.process_time() - cpu0)
        wall_ends.append(time.perf_counter() - wall0)
        return max_steps is not None and steps >= max_steps

    env = spec.make_env(trial.cell)
    agent = agent_entry(trial.agent.name).make(env, trial.agent.hyper)
    episode = run_episode(env, agent, trial.seed, stop)
    cpu = time.process_time() - cpu0
    if len(ends) < episode.length:  # the episode's last step ends it before `stop` is asked
        ends.append(cpu)
        wall_ends.append(time.perf_counter() - wall0)
    cut = max_steps is not None and max_steps < spec.horizon and episode.length >= max_steps
    return TrialCost(
        episode.length, cpu, np.asarray(ends), np.asarray(wall_ends), cut, episode.episode_return
    )


def rates(cost: TrialCost, cap: float) -> tuple[float, float]:
    """CPU s/step over steps 2.. within ``cap`` wall seconds, and over the steps after them."""
    within = int(np.searchsorted(cost.wall_ends, cap, side="left")) + 1
    within = min(max(within, 2), cost.length)
    early = (cost.ends[within - 1] - cost.ends[0]) / max(within - 1, 1)
    rest = cost.length - within
    late = (cost.ends[-1] - cost.ends[within - 1]) / rest if rest > 0 else float("nan")
    return early, late


def main(argv: list[str] | None = None) -> None:
    """Parse the arguments and print one row per seed."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("spec")
    parser.add_argument("--size", default="full", choices=["quick", "full"])
    parser.add_argument("--agent", required=True, help="agent label, e.g. DDQN-WN")
    parser.add_argument("--setting", required=True, help="cell setting, e.g. masspole=1")
    parser.add_argument("--column", default="WN", help="WN, WON or WD")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--max-steps", type=int, default=None)
    parser.add_argument("--cap", type=float, default=estimate.CELL_SECONDS)
    parser.add_argument("--stand-in", action="store_true")
    parser.add_argument("--no-estimate", action="store_true")
    args = parser.parse_args(argv)
    if args.max_steps is not None and args.max_steps < 1:
        parser.error(f"--max-steps={args.max_steps} must be >= 1")
    spec = load_spec(args.spec, args.size)
    trials = {t.seed: t for t in pick(spec, args.agent, args.setting, args.column)}
    missing = [seed for seed in args.seeds if seed not in trials]
    if missing:
        parser.error(f"seeds {missing} are not in the spec (its seeds: {spec.seeds()})")
    agent_entry(trials[args.seeds[0]].agent.name).make(  # train/load networks, untimed
        spec.make_env(trials[args.seeds[0]].cell), trials[args.seeds[0]].agent.hyper
    )
    print(
        f"{spec.name} ({spec.size}, horizon {spec.horizon}) {args.agent} {args.setting} "
        f"{args.column}; CPU seconds; estimate cap {args.cap:g} s"
    )
    print("seed  length  return   CPU s  CPU s/step  early s/step  late s/step  estimate CPU s")
    for seed in args.seeds:
        cost = play(spec, trials[seed], args.max_steps)
        early, late = rates(cost, args.cap)
        projected: Any = "-"
        if not args.no_estimate:
            _, cpu, cut = estimate._time_trial(spec, trials[seed], args.cap, args.stand_in)
            projected = f"{'<=' if cut or args.stand_in else '='} {cpu:.1f}"
        length = f"{cost.length}{' cut' if cost.cut else ''}"
        print(
            f"{seed:4d}  {length:>6}  {cost.episode_return:6.0f}  {cost.cpu:6.1f}  "
            f"{cost.cpu / cost.length:10.4f}  {early:12.4f}  {late:11.4f}  {projected:>14}",
            flush=True,
        )


if __name__ == "__main__":
    main()
