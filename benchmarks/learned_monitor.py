"""A learned monitor against never/always-alarm and the CUSUM, in the monitor's seat.

The setting: CliffWalking (goal +100), a uniformly random decision agent, the slip
1.0 → 0.8 (equal split) at transition 30, 100-step episodes, the monitor paid by
``monitor_reward="detection"`` (-1 per step a change stays undetected, -10 per false alarm;
the last transition judged as silence). Every policy is scored by its mean episode reward in
the seat over the same evaluation seeds:

* **never** / **always**: flags 0 / 1 at every turn;
* **first impossible**: the one-bit rule over :class:`~ns_pz.monitor.MonitorFeatures`: alarm
  on the first transition impossible under θ_0, never again;
* **CUSUM**: :class:`~ns_pz.monitor.TabularCusumMonitor` (``h = 10``) reading the seat's
  monitor observation;
* **PPO**: Stable-Baselines3 PPO (``MultiInputPolicy``, SB3's defaults) trained in the seat with
  :class:`~ns_pz.monitor.MonitorFeatures`, one row per training seed, with its training time.

Run: ``python benchmarks/bench_detectors.py --learned`` (``--train-steps N``,
``--train-seeds K``, ``--eval-episodes M``); needs the ``learn`` extra (SB3, torch).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from functools import partial
from typing import Any

import numpy as np

import ns_pz
from ns_pz import DECISION, MONITOR
from ns_pz.monitor import MonitorFeatures, TabularCusumMonitor

ENV_ID = "ns_pz/CliffWalking-v0"
HORIZON = 100
CHANGE_AT = 30
EVAL_SEED0 = 10_000


def seat(features: MonitorFeatures | None) -> Any:
    """The monitor's seat of the benchmark setting (a random agent, 1.0 → 0.8 at 30)."""
    from gymnasium import spaces
    from ns_pz.agents.baselines import RandomAgent
    from ns_pz.agents.exact import equal_split

    from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

    nature = ScriptedNature(
        {"slip": DistributionStepWiseUpdate(DiscreteScheduler({CHANGE_AT}), [equal_split(0.8, 4)])}
    )
    return ns_pz.single_agent(
        ENV_ID,
        MONITOR,
        {DECISION: RandomAgent(spaces.Discrete(4))},
        monitor_reward="detection",
        monitor_features=features,
        nature=nature,
        notification="basic",
        max_episode_steps=HORIZON,
        goal_reward=100.0,
    )


def evaluate(
    env: Any,
    policy: Callable[[Any], Any],
    episodes: int,
    reset_fn: Callable[[], None] | None = None,
) -> tuple[float, float, float]:
    """Mean episode reward, its standard error, and alarms per episode over the eval seeds."""
    totals, alarms = [], 0
    for episode in range(episodes):
        obs, _ = env.reset(seed=EVAL_SEED0 + episode)
        if reset_fn is not None:
            reset_fn()
        total, done = 0.0, False
        while not done:
            flags = np.asarray(policy(obs), np.int64).reshape(1)
            alarms += int(flags[0])
            obs, reward, terminated, truncated, _ = env.step(flags)
            total += float(reward)
            done = terminated or truncated
        totals.append(total)
    mean = float(np.mean(totals))
    return mean, float(np.std(totals, ddof=1) / np.sqrt(len(totals))), alarms / episodes


def cusum_policy(env: Any) -> tuple[Callable[[Any], Any], Callable[[], None]]:
    """TabularCusumMonitor reading the seat's observation; a fresh memory per episode."""
    process = env.unwrapped.process
    detector = TabularCusumMonitor(threshold=10.0)
    detector.bind(process.family, process.base_theta0)
    state: dict[str, Any] = {}

    def reset() -> None:
        state["memory"] = detector.initial_memory()

    def act(obs: Any) -> Any:
        flags, _ = detector.notify(obs, None, state["memory"], np.random.default_rng(0))
        return [flags[0]]

    return act, reset


def first_impossible(obs: Any) -> Any:
    """Alarm on the first transition impossible under θ_0, never again."""
    memory = obs["memory"]
    return [int(memory[2] > 0 and memory[1] == 0)]


def rows(train_steps: int, train_seeds: int, episodes: int) -> Iterator[tuple[str, str, str, str]]:
    """(policy, mean ± s.e., alarms per episode, training cost) for each policy, as measured."""
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(1)  # small networks: threads only contend

    features = MonitorFeatures(horizon=HORIZON)
    plain, rich = seat(None), seat(features)

    def row(
        name: str, result: tuple[float, float, float], cost: str = ""
    ) -> tuple[str, str, str, str]:
        mean, error, alarms = result
        return name, f"{mean:.2f} ± {error:.2f}", f"{alarms:.2f}", cost

    yield row("never alarm", evaluate(plain, lambda obs: [0], episodes))
    yield row("always alarm", evaluate(plain, lambda obs: [1], episodes))
    yield row("first impossible (features)", evaluate(rich, first_impossible, episodes))
    act, reset = cusum_policy(plain)
    yield row("TabularCusumMonitor(h=10)", evaluate(plain, act, episodes, reset))
    for seed in range(train_seeds):
        env = seat(features)
        start = time.perf_counter()
        rollout = min(2048, train_steps)  # SB3's default, or less for a smoke run
        model = PPO("MultiInputPolicy", env, n_steps=rollout, seed=seed, device="cpu", verbose=0)
        model.learn(total_timesteps=train_steps)
        seconds = time.perf_counter() - start
        result = evaluate(rich, partial(_greedy, model), episodes)
        yield row(f"PPO + features, seed {seed}", result, f"{train_steps:,} steps, {seconds:.0f} s")


def _greedy(model: Any, obs: Any) -> Any:
    return model.predict(obs, deterministic=True)[0]


def print_table(train_steps: int, train_seeds: int, episodes: int) -> None:
    """Print the learned-monitor table."""
    print("| monitor policy | mean episode reward | alarms / episode | training |")
    print("|---|---|---|---|")
    for name, reward, alarms, cost in rows(train_steps, train_seeds, episodes):
        print(f"| {name} | {reward} | {alarms} | {cost} |", flush=True)
