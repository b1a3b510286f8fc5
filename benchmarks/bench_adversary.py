"""A learned nature against every scripted schedule.

On FrozenLake (a value-iteration snapshot agent, notification ``none`` and ``detailed``) and
on CartPole (a fixed linear controller that balances the stationary pole for 500 steps), a PPO
nature and every schedule of a grid over the vocabulary (schedulers × update functions) play
under the same constraints, enforced by the game (:class:`ns_pz.nature.NatureConstraints`): the
table gives the agent's return against the PPO nature and against the scripted schedule that
hurt it most (and how many schedules were tried).

Which way of training gives a robust agent (RARL, domain randomisation, ...) is measured by
``bench_robust.py``.

The PPO column gives the mean ± standard error over training seeds, and the strongest seed's
nature, chosen as the worst schedule is (on other episodes than it is scored on) and scored ±
standard error over episodes, as the scripted column is: both are then the strongest attack a
search found (the PPO search costs its seeds' training). Run from the repository root with the
``learn`` extra installed::

    python benchmarks/bench_adversary.py            # the README's table (several minutes)
    python benchmarks/bench_adversary.py --quick    # a smoke run (tests/test_benchmarks.py)
"""

from __future__ import annotations

import argparse
import itertools
import math
import statistics
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from ns_pz.agents import SnapshotValueIteration

from ns_pz import nature as N
from ns_pz.learn import TrainArgs, train_adversary
from ns_pz.nature import NatureConstraints, PolicyNature
from ns_pz.seat_policies import DecisionPolicy

LAKE = "ns_pz/FrozenLake-v0"
CARTPOLE = "ns_pz/CartPole-v0"
LAKE_LIMITS = NatureConstraints(lipschitz=0.1, budget=0.6)
"""The slip vector moves by at most 0.1 (total variation) a step and 0.6 an episode."""
CARTPOLE_MOVES = {"force_mag": (0.5, 8.0), "length": (0.02, 0.35), "tau": (0.002, 0.04)}
"""CartPole's parameters nature may move: (Lipschitz bound per step, budget per episode)."""
CARTPOLE_LIMITS = NatureConstraints(
    lipschitz={name: step for name, (step, _) in CARTPOLE_MOVES.items()},
    budget={
        **{name: total for name, (_, total) in CARTPOLE_MOVES.items()},
        **{name: 0.0 for name in ("gravity", "masscart", "masspole")},  # frozen
    },
)
GAIN = np.array([0.1, 0.3, 1.0, 0.5])


def balance(observation: dict[str, Any]) -> int:
    """CartPole's fixed controller: push right when ``GAIN · state > 0`` (x, ẋ, angle, ω)."""
    return int(GAIN @ observation["state"] > 0)


@dataclass(frozen=True)
class Setting:
    """One comparison: an environment, its constraints, the agent, the scripted grid."""

    env_id: str
    agent: Callable[[], Any]
    grid: Callable[[], Iterator[tuple[str, Any]]]
    env_kwargs: dict[str, Any] = field(default_factory=dict)


# -- the scripted grid --------------------------------------------------------------------------
def schedulers() -> Iterator[tuple[str, N.Scheduler]]:
    """Representative schedulers: when a change fires (every one starts at step 1)."""
    yield "continuous", N.ContinuousScheduler(start=1)
    yield "periodic(5)", N.PeriodicScheduler(period=5, start=1)
    yield "random(0.3)", N.RandomScheduler(probability=0.3, start=1)
    yield "discrete(1,10,20,40)", N.DiscreteScheduler([1, 10, 20, 40])
    yield "burst", N.BurstScheduler(on_duration=5, off_duration=10, start=1)


def lake_grid() -> Iterator[tuple[str, N.ScriptedNature]]:
    """Every slip-vector update that fits (with steps of the Lipschitz bound) × every scheduler."""
    corners = [(0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.5, 0.5)]
    for (when, _), (how, make) in itertools.product(
        schedulers(),
        [
            ("decrement(0.1)", lambda s: N.DistributionDecrementUpdate(s, k=0.1)),
            ("uniform drift(0.3)", lambda s: N.UniformDrift(s, rate=0.3)),
            *[
                (f"towards {c}", lambda s, c=c: N.TargetReversion(s, target=c, theta=0.5))
                for c in corners
            ],
            ("cyclic +1/-1", lambda s: N.DistributionCyclicUpdate(s, dist_list=corners[:2])),
            ("stepwise to +1", lambda s: N.DistributionStepWiseUpdate(s, [corners[0]])),
            ("random categorical", lambda s: N.RandomCategorical(s)),
        ],
    ):
        yield f"{how} @ {when}", N.ScriptedNature({"slip": make(_fresh(when))})


def cartpole_grid() -> Iterator[tuple[str, N.ScriptedNature]]:
    """Each scalar update (steps of the Lipschitz bound) on each movable parameter, and on all."""
    rules: list[tuple[str, Callable[[N.Scheduler, float], Any]]] = [
        ("increment", lambda s, k: N.IncrementUpdate(s, k=k)),
        ("decrement", lambda s, k: N.DecrementUpdate(s, k=k)),
        ("random walk", lambda s, k: N.RandomWalk(s, sigma=k)),
        ("oscillating", lambda s, k: N.OscillatingUpdate(s, delta=k)),
    ]
    targets = [*([name] for name in CARTPOLE_MOVES), list(CARTPOLE_MOVES)]
    for (when, _), (how, make), names in itertools.product(schedulers(), rules, targets):
        updates = {n: make(_fresh(when), CARTPOLE_MOVES[n][0]) for n in names}
        yield f"{how} {'+'.join(names)} @ {when}", N.ScriptedNature(updates)
    # The directions that hurt, all at once: a weaker push, a shorter pole, a coarser clock.
    for when, _ in schedulers():
        updates = {
            "force_mag": N.DecrementUpdate(_fresh(when), k=CARTPOLE_MOVES["force_mag"][0]),
            "length": N.DecrementUpdate(_fresh(when), k=CARTPOLE_MOVES["length"][0]),
            "tau": N.IncrementUpdate(_fresh(when), k=CARTPOLE_MOVES["tau"][0]),
        }
        yield f"weaker+shorter+coarser @ {when}", N.ScriptedNature(updates)


def _fresh(name: str) -> N.Scheduler:
    return dict(schedulers())[name]


def lake_setting(notification: str) -> Setting:
    """FrozenLake from a sure-footed θ_0, 100 steps, value iteration on the snapshot."""
    kwargs = {
        "params": {"slip": (1.0, 0.0, 0.0)},
        "constraints": LAKE_LIMITS,
        "notification": notification,
        "max_episode_steps": 100,
    }
    return Setting(LAKE, lambda: SnapshotValueIteration(gamma=0.99), lake_grid, kwargs)


SETTINGS = {
    "FrozenLake, none": lake_setting("none"),
    "FrozenLake, detailed": lake_setting("detailed"),
    "CartPole, none": Setting(
        CARTPOLE,
        lambda: balance,
        cartpole_grid,
        {"constraints": CARTPOLE_LIMITS, "notification": "none", "max_episode_steps": 500},
    ),
}


# -- evaluation ---------------------------------------------------------------------------------
def agent_returns(setting: Setting, nature: Any, agent: Any, seeds: range) -> list[float]:
    """The agent's return against ``nature``, one episode per seed."""
    from ns_pz.envs.registry import make_gym

    process = make_gym(setting.env_id, nature=nature, **setting.env_kwargs).process
    decide = DecisionPolicy(agent)
    returns = []
    for seed in seeds:
        process.seed(seed)
        process.reset()
        decide.reset(process.seat_rng())
        returns.append(process.play_until(None, decide)[0])
    return returns


def mean_se(values: list[float]) -> tuple[float, float]:
    """Mean and standard error (ddof=1)."""
    se = statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0
    return statistics.fmean(values), se


def compare(name: str, setting: Setting, args: argparse.Namespace) -> dict[str, Any]:
    """PPO nature (over training seeds) against the whole scripted grid, for one setting."""
    episodes = range(10_000, 10_000 + args.episodes)
    agent = setting.agent()
    static = mean_se(agent_returns(setting, None, agent, episodes))
    # The worst schedule is picked on other episodes than it is scored on, so that the minimum
    # over the grid is not biased low by the noise of the episodes that picked it.
    picking = range(20_000, 20_000 + args.episodes)
    scripted = {
        label: mean_se(agent_returns(setting, nature, agent, picking))
        for label, nature in setting.grid()
    }
    worst = min(scripted, key=lambda label: scripted[label][0])
    worst_scored = mean_se(agent_returns(setting, dict(setting.grid())[worst], agent, episodes))
    started = time.perf_counter()
    learned, picked = [], []
    for seed in range(args.seeds):
        model = train_adversary(
            setting.env_id,
            agent,
            args=TrainArgs(total_timesteps=args.nature_steps, hyperparameters=PPO),
            seed=seed,
            nature_observes_state=True,
            **setting.env_kwargs,
        )
        nature = PolicyNature(model, observes_state=True)
        scored = agent_returns(setting, nature, agent, episodes)
        learned.append(statistics.fmean(scored))
        picked.append((statistics.fmean(agent_returns(setting, nature, agent, picking)), scored))
    seconds = (time.perf_counter() - started) / args.seeds
    # The strongest trained nature, chosen like the worst schedule: on the picking episodes.
    best = mean_se(min(picked, key=lambda p: p[0])[1])
    return {
        "setting": name,
        "static": static,
        "ppo": mean_se(learned),
        "best": best,
        "worst": (worst, *worst_scored),
        "beaten": sum(v[0] > best[0] for v in scripted.values()),
        "schedules": len(scripted),
        "seconds": seconds,
    }


PPO = {"n_steps": 512, "batch_size": 64, "learning_rate": 1e-3, "ent_coef": 0.01}


def main() -> None:
    """Run the comparisons and print the README's tables."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a smoke run (seconds)")
    parser.add_argument("--seeds", type=int, default=3, help="training seeds")
    parser.add_argument("--episodes", type=int, default=100, help="evaluation episodes")
    parser.add_argument("--nature-steps", type=int, default=20_000, help="PPO nature steps")
    parser.add_argument(
        "--settings",
        nargs="+",
        choices=sorted({name.split(",")[0] for name in SETTINGS}),
        help="environments to run (default: all)",
    )
    args = parser.parse_args()
    if args.quick:
        args.seeds, args.episodes, args.nature_steps = 1, 2, 512
    print(
        "agent's return: static θ_0 | PPO nature (mean over training seeds; the"
        " strongest seed's) | worst scripted schedule"
    )
    print(
        "| setting | static θ_0 | PPO, mean of seeds | PPO, strongest seed | worst scripted |"
        " schedules above the strongest PPO | PPO s/seed |"
    )
    print("|---|---|---|---|---|---|---|")
    for name, setting in SETTINGS.items():
        if args.settings and name.split(",")[0] not in args.settings:
            continue
        if args.quick:
            setting = Setting(
                setting.env_id,
                setting.agent,
                lambda g=setting.grid: itertools.islice(g(), 3),
                setting.env_kwargs,
            )
        r = compare(name, setting, args)
        label, worst, worst_se = r["worst"]
        print(
            f"| {name} | {r['static'][0]:.3f} ± {r['static'][1]:.3f} | "
            f"{r['ppo'][0]:.3f} ± {r['ppo'][1]:.3f} | {r['best'][0]:.3f} ± {r['best'][1]:.3f} "
            f"| {worst:.3f} ± {worst_se:.3f} ({label}) | {r['beaten']}/{r['schedules']} | "
            f"{r['seconds']:.0f} |"
        )
    print(f"\nseeds={args.seeds} episodes={args.episodes} nature_steps={args.nature_steps}")


if __name__ == "__main__":
    main()
