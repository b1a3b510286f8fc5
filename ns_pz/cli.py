"""The ``ns-pz`` command.

``ns-pz demo`` evaluates a random agent and a planning agent on FrozenLake and CartPole under
the NS-Gym paper's single and continuous changes, without and with notification, and prints
the mean return ± standard error of each cell. ``ns-pz envs`` lists the registered
environments and their parameters.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ns_pz.envs.registry import make_gym, registered_envs, spec
from ns_pz.nature import (
    ContinuousScheduler,
    DiscreteScheduler,
    DistributionDecrementUpdate,
    DistributionStepWiseUpdate,
    IncrementUpdate,
    ScriptedNature,
    StepWiseUpdate,
)
from ns_pz.nature.policies import Nature
from ns_pz.views import NSGymEnv


@dataclass(frozen=True)
class Setting:
    """One non-stationary setting of the demo: θ_0 and the change (first change at step 1)."""

    env_id: str
    name: str
    params: dict
    nature: Nature
    max_episode_steps: int


def demo_settings() -> list[Setting]:
    """The paper's schedules (EXPERIMENTS.md §3.1) with the first change at step k=1."""
    return [
        Setting(
            "ns_pz/FrozenLake-v0",
            "single: p 0.7 -> 0.4",
            {"slip": (0.7, 0.15, 0.15)},
            ScriptedNature(
                {"slip": DistributionStepWiseUpdate(DiscreteScheduler({1}), [(0.4, 0.3, 0.3)])}
            ),
            100,
        ),
        Setting(
            "ns_pz/FrozenLake-v0",
            "continuous: p 1 -> 0.4",
            {"slip": (1.0, 0.0, 0.0)},
            ScriptedNature(
                {"slip": DistributionDecrementUpdate(ContinuousScheduler(start=1, end=3), k=0.2)}
            ),
            100,
        ),
        Setting(
            "ns_pz/CartPole-v0",
            "single: masspole 0.1 -> 1.0",
            {},
            ScriptedNature({"masspole": StepWiseUpdate(DiscreteScheduler({1}), [1.0])}),
            300,
        ),
        Setting(
            "ns_pz/CartPole-v0",
            "continuous: masspole +0.1/step",
            {},
            ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=1), k=0.1)}),
            300,
        ),
    ]


def run_demo(episodes: int, seed: int, out: Callable[[str], None] = print) -> list[tuple]:
    """Evaluate every (setting, agent, level) cell and print the table; return its rows."""
    from ns_pz.agents import (
        RandomAgent,
        RandomShooting,
        SnapshotValueIteration,
        evaluate,
        mean_and_standard_error,
    )

    rows = []
    out("| env | change | agent | notification | return (mean ± SE) | episodes | seconds |")
    out("|---|---|---|---|---|---|---|")
    for setting in demo_settings():
        tabular = "FrozenLake" in setting.env_id
        planner = SnapshotValueIteration(gamma=0.99) if tabular else RandomShooting(8, 30)
        count = episodes if tabular else max(episodes // 10, 2)  # CartPole plans: 10x dearer
        cells = [("random", RandomAgent(make_gym(setting.env_id).action_space), "none")]
        cells += [(repr(planner), planner, level) for level in ("none", "detailed")]
        for agent_name, agent, level in cells:

            def make_env(setting: Setting = setting, level: str = level) -> NSGymEnv:
                return make_gym(
                    setting.env_id,
                    params=setting.params,
                    nature=setting.nature,
                    notification=level,
                    max_episode_steps=setting.max_episode_steps,
                )

            start = time.perf_counter()
            results = evaluate(make_env, agent, range(seed, seed + count))
            mean, error = mean_and_standard_error([r.episode_return for r in results])
            seconds = time.perf_counter() - start
            row = (setting.env_id, setting.name, agent_name, level, mean, error, count)
            rows.append(row)
            out(
                f"| {setting.env_id} | {setting.name} | {agent_name} | {level} | "
                f"{mean:.3f} ± {error:.3f} | {count} | {seconds:.1f} |"
            )
    return rows


def list_envs(out: Callable[[str], None] = print) -> None:
    """Print every registered environment with its parameters, defaults and bounds."""
    for env_id in registered_envs():
        env_spec = spec(env_id)
        out(f"{env_id}  (time limit {env_spec.max_episode_steps}): {env_spec.description}")
        for param in env_spec.family.params_cls.specs():
            unit = f" {param.unit}" if param.unit else ""
            out(
                f"    {param.name:10s} default {param.default!r}{unit}, allowed {param.allowed()}"
                f"  - {param.doc}"
            )


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``ns-pz``; returns the exit code."""
    parser = argparse.ArgumentParser(prog="ns-pz", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    demo = commands.add_parser("demo", help="evaluate agents on non-stationary envs, print a table")
    demo.add_argument(
        "--episodes",
        type=int,
        default=100,
        help="episodes per FrozenLake cell (CartPole cells run a tenth, at least 2)",
    )
    demo.add_argument("--seed", type=int, default=0, help="first seed (seeds are consecutive)")
    commands.add_parser("envs", help="list registered environments and their parameters")
    args = parser.parse_args(argv)
    if args.command == "demo":
        if args.episodes < 1:
            parser.error(f"--episodes={args.episodes} must be >= 1")
        run_demo(args.episodes, args.seed)
    else:
        list_envs()
    return 0


if __name__ == "__main__":
    sys.exit(main())
