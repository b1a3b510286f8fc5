r"""What whole trials cost, measured, against ``bench estimate``'s projection of the same trials.

For one spec, size, agent (by label) and cell (setting and notification column), each seed's
trial is played exactly as the runner plays it (:func:`ns_pz.experiments.trials.run_trial`:
``spec.make_env``, the agent from the catalogue, ``run_episode``), and its episode length,
return, CPU seconds and CPU seconds per step are printed. Then what ``bench estimate``'s rule
makes of this run's own step times under its earlier rule ("before": cut at the cap ``--cap``,
default 1 s; the time per step after the first projected to the horizon) and its present one
("now": cut at the cap once 32 steps are played, or at five caps; the time per step past the
first quarter), with the steps
each timed in brackets; ``<=`` marks a projection to the horizon (an upper bound), ``=`` an
episode timed whole. The last column is the estimate's own timing of the same trial, played
again (:func:`ns_pz.experiments.estimate._time_trial`).

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


def cut_at(cost: TrialCost, cap: float, min_steps: int, limit: float) -> int | None:
    """Steps a capped timing of this run would have played (None: the episode ended first).

    The cut falls after the first step that ends with ``cap`` wall seconds passed, two steps
    played, and ``min_steps`` played or ``limit`` seconds passed.
    """
    for steps in range(2, cost.length + 1):
        elapsed = cost.wall_ends[steps - 1]
        if elapsed >= cap and (steps >= min_steps or elapsed >= limit):
            return None if steps == cost.length and not cost.cut else steps
    return None


def projections(
    cost: TrialCost, cap: float, horizon: int, stand_in: bool = False
) -> tuple[str, str]:
    """CPU s the estimate's rule projects from this run's own step times: before, now.

    An episode the rule would not cut is projected all the same from every step it played when
    ``--max-steps`` truncated it or ``stand_in`` is set (the estimate projects a stand-in
    network's every episode to the horizon).

    Before: cut at the cap, projected at the time per step after the first. Now:
    :data:`~ns_pz.experiments.estimate.MIN_STEPS` steps (up to
    :data:`~ns_pz.experiments.estimate.OVERRUN` caps), projected past the first quarter
    (:func:`~ns_pz.experiments.estimate.projected_time`). ``<=``: projected, ``=``: whole.
    """
    out = []
    for min_steps, limit in ((2, cap), (estimate.MIN_STEPS, cap * estimate.OVERRUN)):
        steps = cut_at(cost, cap, min_steps, limit)
        if steps is None and (cost.cut or stand_in) and cost.length >= 2:
            steps = cost.length
        if steps is None or steps >= horizon:
            out.append(f"= {cost.cpu:.1f}")
            continue
        ends = [(w, c) for w, c in zip(cost.wall_ends[:steps], cost.ends[:steps], strict=True)]
        if min_steps == 2:  # before: only the first step as warm-up
            first, last = ends[0][1], ends[-1][1]
            cpu = first + (last - first) * (horizon - 1) / (steps - 1)
        else:
            cpu = estimate.projected_time(ends, horizon)[1]
        out.append(f"<= {cpu:.1f} ({steps})")
    return out[0], out[1]


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
    print(
        "seed  length  return   CPU s  CPU s/step   projected before   projected now"
        "   estimate CPU s"
    )
    for seed in args.seeds:
        cost = play(spec, trials[seed], args.max_steps)
        before, now = projections(cost, args.cap, spec.horizon, args.stand_in)
        projected: Any = "-"
        if not args.no_estimate:
            _, cpu, cut = estimate._time_trial(spec, trials[seed], args.cap, args.stand_in)
            projected = f"{'<=' if cut or args.stand_in else '='} {cpu:.1f}"
        length = f"{cost.length}{' cut' if cost.cut else ''}"
        print(
            f"{seed:4d}  {length:>6}  {cost.episode_return:6.0f}  {cost.cpu:6.1f}  "
            f"{cost.cpu / cost.length:10.4f}  {before:>17}  {now:>14}  {projected:>15}",
            flush=True,
        )


if __name__ == "__main__":
    main()
