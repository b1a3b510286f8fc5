"""A learned monitor against never/always-alarm and the CUSUM, in the monitor's seat.

Two settings, each with a uniformly random decision agent, 100-step episodes and the monitor
paid by ``monitor_reward="detection"`` (-1 per step a change stays undetected, -10 per false
alarm; the last transition judged as silence):

* **cliffwalking**: CliffWalking (goal +100), the slip 1.0 → 0.8 (equal split) at transition
  30. Under θ_0 every move goes where it is meant to, so the first slip is impossible under θ_0:
  one bit of evidence detects the change.
* **frozenlake**: FrozenLake 8x8, the slip (0.7, 0.15, 0.15) → (0.4, 0.3, 0.3) at transition 5.
  Every outcome is possible before and after: detection is statistical, evidence adds up.

Every policy is scored by its mean episode reward in the seat over the same evaluation seeds:

* **never** / **always**: flags 0 / 1 at every turn;
* **first impossible**: the one-bit rule over :class:`~ns_pz.monitor.MonitorFeatures`: alarm
  on the first transition impossible under θ_0, never again;
* **CUSUM**: :class:`~ns_pz.monitor.TabularCusumMonitor` (``h = 10``) reading the seat's
  monitor observation;
* **learned** (one row per variant, trained with several seeds; the row gives the interquartile
  mean of the seeds' scores with its 95 % percentile-bootstrap interval over seeds,
  :func:`ns_pz.learning.aggregate_runs`, and each seed's score):

  - ``ppo``: Stable-Baselines3 PPO (``MultiInputPolicy``, SB3's defaults) with
    :class:`~ns_pz.monitor.MonitorFeatures`;
  - ``ppo+cusum``: the same with ``MonitorFeatures(detector=TabularCusumMonitor(threshold=10))``:
    the CUSUM's statistic, its alarm and its alarms since the monitor's last in the observation;
  - ``ppo+stack4``: the same as ``ppo`` with the last 4 turns' transitions (``stack=4``);
  - ``recurrent``: sb3-contrib's RecurrentPPO (``MultiInputLstmPolicy``, its defaults) with
    :class:`~ns_pz.monitor.MonitorFeatures`, its LSTM state carried through each episode.

Run: ``python benchmarks/bench_detectors.py --learned`` (``--settings``, ``--variants``,
``--train-steps N``, ``--train-seeds K``, ``--eval-episodes M``, ``--workers W``); needs the
``learn`` extra (SB3, sb3-contrib, torch).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from functools import partial
from typing import Any

import numpy as np

import ns_pz
from ns_pz import DECISION, MONITOR
from ns_pz.monitor import MonitorFeatures, TabularCusumMonitor

EVAL_SEED0 = 10_000

#: A policy for evaluation: ``(act(obs) -> flags, reset() at each episode's start)``.
Policy = tuple[Callable[[Any], Any], Callable[[], None]]


@dataclass(frozen=True)
class Setting:
    """One detection problem: the env, θ_0, the change and the horizon."""

    label: str
    env_id: str
    change_at: int
    horizon: int = 100
    theta0: dict[str, Any] = field(default_factory=dict)
    env_kwargs: dict[str, Any] = field(default_factory=dict)

    def changed_slip(self) -> Any:
        """The slip after the change."""
        if self.env_id == "ns_pz/CliffWalking-v0":
            from ns_pz.agents.exact import equal_split

            return equal_split(0.8, 4)
        return (0.4, 0.3, 0.3)


SETTINGS = {
    "cliffwalking": Setting(
        "CliffWalking, slip 1.0 → 0.8 at 30",
        "ns_pz/CliffWalking-v0",
        change_at=30,
        env_kwargs={"goal_reward": 100.0},
    ),
    "frozenlake": Setting(
        "FrozenLake 8x8, slip 0.7 → 0.4 at 5",
        "ns_pz/FrozenLake-v0",
        change_at=5,
        theta0={"slip": (0.7, 0.15, 0.15)},
        env_kwargs={"map_name": "8x8"},
    ),
}
"""The benchmark's settings, by name."""

VARIANTS = ("ppo", "ppo+cusum", "ppo+stack4", "recurrent")
"""The learned monitors, by name (see the module doc)."""


def features_of(variant: str, horizon: int) -> MonitorFeatures:
    """The observation features a learned variant trains and plays with (a fresh instance)."""
    if variant == "ppo+cusum":
        return MonitorFeatures(horizon=horizon, detector=TabularCusumMonitor(threshold=10.0))
    if variant == "ppo+stack4":
        return MonitorFeatures(horizon=horizon, stack=4)
    return MonitorFeatures(horizon=horizon)


def seat(setting: Setting, features: MonitorFeatures | None) -> Any:
    """The monitor's seat of ``setting`` (a random decision agent)."""
    from gymnasium import spaces
    from ns_pz.agents.baselines import RandomAgent

    from ns_pz.nature import DiscreteScheduler, DistributionStepWiseUpdate, ScriptedNature

    update = DistributionStepWiseUpdate(
        DiscreteScheduler({setting.change_at}), [setting.changed_slip()]
    )
    return ns_pz.single_agent(
        setting.env_id,
        MONITOR,
        {DECISION: RandomAgent(spaces.Discrete(4))},
        monitor_reward="detection",
        monitor_features=features,
        nature=ScriptedNature({"slip": update}),
        notification="basic",
        max_episode_steps=setting.horizon,
        **({"params": setting.theta0} if setting.theta0 else {}),
        **setting.env_kwargs,
    )


def evaluate(env: Any, policy: Policy, episodes: int) -> tuple[float, float, float]:
    """Mean episode reward, its standard error, and alarms per episode over the eval seeds."""
    act, reset = policy
    totals, alarms = [], 0
    for episode in range(episodes):
        obs, _ = env.reset(seed=EVAL_SEED0 + episode)
        reset()
        total, done = 0.0, False
        while not done:
            flags = np.asarray(act(obs), np.int64).reshape(1)
            alarms += int(flags[0])
            obs, reward, terminated, truncated, _ = env.step(flags)
            total += float(reward)
            done = terminated or truncated
        totals.append(total)
    mean = float(np.mean(totals))
    return mean, float(np.std(totals, ddof=1) / np.sqrt(len(totals))), alarms / episodes


def stateless(act: Callable[[Any], Any]) -> Policy:
    """A policy with nothing to reset."""
    return act, lambda: None


def cusum_policy(env: Any) -> Policy:
    """TabularCusumMonitor reading the seat's observation; a fresh memory per episode."""
    process = env.unwrapped.process
    detector = TabularCusumMonitor(threshold=10.0)
    detector.bind(process.family, process.base_theta0)
    state: dict[str, Any] = {}
    rng = np.random.default_rng(0)  # the detector draws nothing from it

    def reset() -> None:
        state["memory"] = detector.initial_memory()

    def act(obs: Any) -> Any:
        flags, _ = detector.notify(obs, None, state["memory"], rng)
        return [flags[0]]

    return act, reset


def first_impossible(obs: Any) -> Any:
    """Alarm on the first transition impossible under θ_0, never again."""
    memory = obs["memory"]
    return [int(memory[2] > 0 and memory[1] == 0)]


def model_policy(model: Any, recurrent: bool) -> Policy:
    """A trained model acting greedily; a recurrent one carries its state through an episode."""
    if not recurrent:
        return stateless(lambda obs: model.predict(obs, deterministic=True)[0])
    memory: dict[str, Any] = {}

    def reset() -> None:
        memory.update(state=None, start=True)

    def act(obs: Any) -> Any:
        start = np.array([memory["start"]])
        flags, memory["state"] = model.predict(
            obs, state=memory["state"], episode_start=start, deterministic=True
        )
        memory["start"] = False
        return flags

    return act, reset


def train_and_score(
    setting_name: str, variant: str, seed: int, steps: int, episodes: int
) -> tuple[float, float, float]:
    """Train ``variant`` with ``seed`` for ``steps``; its (score, alarms/episode, seconds)."""
    import torch

    torch.set_num_threads(1)  # small networks: threads only contend
    setting = SETTINGS[setting_name]
    features = features_of(variant, setting.horizon)
    env = seat(setting, features)
    rollout = min(2048 if variant != "recurrent" else 128, steps)  # the defaults, or less
    start = time.perf_counter()
    if variant == "recurrent":
        from sb3_contrib import RecurrentPPO

        model: Any = RecurrentPPO(
            "MultiInputLstmPolicy", env, n_steps=rollout, seed=seed, device="cpu", verbose=0
        )
    else:
        from stable_baselines3 import PPO

        model = PPO("MultiInputPolicy", env, n_steps=rollout, seed=seed, device="cpu", verbose=0)
    model.learn(total_timesteps=steps)
    seconds = time.perf_counter() - start
    mean, _, alarms = evaluate(
        seat(setting, features), model_policy(model, variant == "recurrent"), episodes
    )
    return mean, alarms, seconds


def _report(job: tuple[Any, ...], future: Any) -> None:
    """One line on stderr for a finished training run (a long table's partial results)."""
    if future.exception() is None:
        score, alarms, seconds = future.result()
        print(f"{job[:3]}: {score:.2f}, {alarms:.2f} alarms, {seconds:.0f} s", file=sys.stderr)


def baseline_rows(setting: Setting, episodes: int) -> Iterator[tuple[str, str, str]]:
    """(policy, mean ± s.e., alarms per episode) of the fixed policies."""
    plain, rich = seat(setting, None), seat(setting, MonitorFeatures(horizon=setting.horizon))
    policies = [
        ("never alarm", plain, stateless(lambda obs: [0])),
        ("always alarm", plain, stateless(lambda obs: [1])),
        ("first impossible (features)", rich, stateless(first_impossible)),
        ("TabularCusumMonitor(h=10)", plain, cusum_policy(plain)),
    ]
    for name, env, policy in policies:
        mean, error, alarms = evaluate(env, policy, episodes)
        yield name, f"{mean:.2f} ± {error:.2f}", f"{alarms:.2f}"


def print_table(
    train_steps: int,
    train_seeds: int,
    episodes: int,
    settings: list[str] | None = None,
    variants: list[str] | None = None,
    workers: int = 1,
) -> None:
    """Print the learned-monitor table, one block of rows per setting."""
    from ns_pz.learning import aggregate_runs

    settings = list(SETTINGS) if settings is None else settings
    variants = list(VARIANTS) if variants is None else variants
    print(
        "| setting | monitor policy | episode reward | alarms / episode | per training seed | "
        "training |"
    )
    print("|---|---|---|---|---|---|")
    jobs = [
        (name, variant, seed, train_steps, episodes)
        for name in settings
        for variant in variants
        for seed in range(train_seeds)
    ]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = {job: pool.submit(train_and_score, *job) for job in jobs}
        for job, future in futures.items():  # each seed as it ends, on stderr
            future.add_done_callback(partial(_report, job))
        for name in settings:
            setting = SETTINGS[name]
            for policy, reward, alarms in baseline_rows(setting, episodes):
                print(f"| {setting.label} | {policy} | {reward} | {alarms} |  |  |", flush=True)
            for variant in variants:
                results = [
                    futures[(name, variant, s, train_steps, episodes)].result()
                    for s in range(train_seeds)
                ]
                scores = [score for score, _, _ in results]
                iqm = aggregate_runs(scores) if len(scores) > 1 else None
                reward = f"{scores[0]:.2f}" if iqm is None else iqm.format(2)
                alarms = float(np.mean([a for _, a, _ in results]))
                seconds = float(np.mean([s for _, _, s in results]))
                each = ", ".join(f"{score:.1f}" for score in scores)
                print(
                    f"| {setting.label} | {variant} | {reward} | {alarms:.2f} | {each} | "
                    f"{train_steps:,} steps, {seconds:.0f} s a seed |",
                    flush=True,
                )
