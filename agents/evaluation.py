"""Run agents on environments and summarise their returns."""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from ns_pz.agents.base import Agent

from ns_pz.views import NSGymEnv


@dataclass(frozen=True)
class Episode:
    """One evaluation episode.

    Attributes:
        seed: The episode's seed.
        episode_return: Sum of the rewards.
        length: Transitions.
        change_times: True change times (transition indices, from the ground truth).
        alarm_times: Transitions ``t`` after which the agent's observation (``relative_time``
            ``t + 1``) had a change flag raised: the alarms as
            :func:`ns_pz.monitor.detection_metrics` scores them (none at level ``none``).
    """

    seed: int
    episode_return: float
    length: int
    change_times: tuple[int, ...]
    alarm_times: tuple[int, ...] = ()


def run_episode(
    env: gym.Env[Any, Any],
    agent: Agent,
    seed: int,
    stop: Callable[[int], bool] | None = None,
) -> Episode:
    """Play one episode; the environment and the agent are both seeded from ``seed``.

    ``env`` is an ns_pz view, bare or wrapped (``gym.make``'s stack: it is stepped through its
    wrappers, and the view beneath gives the planning model and the ground truth). The agent
    gets a planning model every step if it asks for one (:attr:`Agent.needs_model`).
    ``stop``, if given, is called after every transition with the transitions so far; True ends
    the play there, before the episode's end (``bench estimate`` caps its timing this way).

    Raises:
        TypeError: ``env`` is not an ns_pz view.
    """
    view = env.unwrapped
    if not isinstance(view, NSGymEnv):
        raise TypeError(f"env={env!r} must be an ns_pz view (gym.make('ns_pz/...') or make_gym)")
    observation, _ = env.reset(seed=seed)
    agent.reset(np.random.default_rng([seed, 0xA6E]))  # a stream apart from the env's
    total, length, done = 0.0, 0, False
    alarms = []
    while not done:
        model = view.planning_model() if agent.needs_model else None
        action = agent.act(observation, model)
        next_observation, reward, terminated, truncated, _ = env.step(action)
        agent.observe(observation, action, float(reward), next_observation, terminated)
        observation = next_observation
        total += float(reward)
        if observation["env_change"].any():
            alarms.append(length)
        length += 1
        done = terminated or truncated or (stop is not None and stop(length))
    return Episode(seed, total, length, view.ground_truth().change_times, tuple(alarms))


def evaluate(
    make_env: Callable[[], gym.Env[Any, Any]], agent: Agent, seeds: range | list[int]
) -> list[Episode]:
    """One episode per seed, each in a fresh environment."""
    return [run_episode(make_env(), agent, seed) for seed in seeds]


def mean_and_standard_error(values: list[float]) -> tuple[float, float]:
    """Mean and standard error (ddof=1; 0 for a single value)."""
    mean = statistics.fmean(values)
    if len(values) < 2:
        return mean, 0.0
    return mean, statistics.stdev(values) / math.sqrt(len(values))
