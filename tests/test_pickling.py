"""Pickling: every game, a view holding a learned nature, and every seat round-trip and step on.

Async vector envs, Ray workers and multiprocessing send environments between processes with
``pickle``; a copy that pickles must then behave exactly as the original.
"""

from __future__ import annotations

import pickle
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import ns_pz
from ns_pz.game import DECISION, MONITOR, NATURE
from ns_pz.nature import PolicyNature, RandomNature

MUJOCO = {
    "ns_pz/Ant-v0",
    "ns_pz/HalfCheetah-v0",
    "ns_pz/Hopper-v0",
    "ns_pz/Humanoid-v0",
    "ns_pz/HumanoidStandup-v0",
    "ns_pz/InvertedDoublePendulum-v0",
    "ns_pz/InvertedPendulum-v0",
    "ns_pz/Pusher-v0",
    "ns_pz/Reacher-v0",
    "ns_pz/Swimmer-v0",
    "ns_pz/Walker2d-v0",
}


def _flat(value: Any) -> list[float]:
    if isinstance(value, dict):
        return [x for key in sorted(value) for x in _flat(value[key])]
    return np.asarray(value, np.float64).ravel().tolist()


def _play(game: Any, steps: int, actions: np.random.Generator) -> list[list[float]]:
    """Turns of ``game`` from where it is: the same action stream gives the same trace."""
    trace = []
    for _ in range(steps):
        if all(game.terminations.values()) or all(game.truncations.values()):
            break
        agent = game.agent_selection
        if agent == DECISION:
            action = _action(game.action_space(DECISION), actions)
        else:
            action = game.policy_action(agent)
        game.step(action)
        observation, reward, *_ = game.last()
        trace.append([*_flat(observation), float(reward)])
    return trace


def _action(space: gym.Space, actions: np.random.Generator) -> Any:
    if isinstance(space, gym.spaces.Discrete):
        return int(space.start + actions.integers(space.n))
    if isinstance(space, gym.spaces.MultiDiscrete):
        return actions.integers(space.nvec).astype(space.dtype)
    low = np.where(np.isfinite(space.low), space.low, -1.0)
    high = np.where(np.isfinite(space.high), space.high, 1.0)
    return actions.uniform(low, high).astype(space.dtype)


@pytest.mark.parametrize("env_id", [e for e in ns_pz.registered_envs() if e not in MUJOCO])
def test_every_game_pickles_and_the_copy_steps_as_the_original(env_id: str) -> None:
    """A random nature (its own generator and memory) mid-episode: same turns after the copy."""
    game = ns_pz.make(env_id, nature=RandomNature(0.05), max_episode_steps=40)
    game.reset(seed=3)
    _play(game, 9, np.random.default_rng(0))  # part-way through an episode
    copy = pickle.loads(pickle.dumps(game))
    assert _play(copy, 30, np.random.default_rng(1)) == _play(game, 30, np.random.default_rng(1))


def test_a_mujoco_game_pickles() -> None:
    """One MuJoCo family (their simulator state is not a plain Python value)."""
    pytest.importorskip("mujoco")
    game = ns_pz.make("ns_pz/Hopper-v0", nature=RandomNature(0.05), max_episode_steps=20)
    game.reset(seed=3)
    copy = pickle.loads(pickle.dumps(game))
    assert _play(copy, 12, np.random.default_rng(1)) == _play(game, 12, np.random.default_rng(1))


class _Push:
    """A picklable nature policy: a fixed push (module-level, no closure)."""

    def __call__(self, observation: np.ndarray) -> np.ndarray:
        return np.array([-0.5, 0.5, 0.0], np.float32)


@pytest.mark.parametrize("observes_state", [False, True])
def test_a_view_holding_a_policy_nature_pickles_and_steps_identically(observes_state: bool) -> None:
    """Nature's seat interface (with its state encoders) travels with the view."""
    nature = PolicyNature(_Push(), observes_state=observes_state)
    env = gym.make("ns_pz/FrozenLake-v0", nature=nature, max_episode_steps=30)
    env.reset(seed=5)
    env.step(1)
    copy = pickle.loads(pickle.dumps(env))
    for a in [2, 1, 1, 2, 0, 3, 2]:
        assert _flat(copy.step(a)[0]) == _flat(env.step(a)[0])
    assert copy.unwrapped.process.theta == env.unwrapped.process.theta


@pytest.mark.parametrize(
    ("learner", "observes_state"),
    [(NATURE, False), (NATURE, True), (MONITOR, False), (MONITOR, True), (DECISION, True)],
)
def test_every_seat_pickles_and_steps_identically(learner: str, observes_state: bool) -> None:
    """The learner env of each seat; nature (learning or a policy) seeing the state or not."""
    policies: dict[str, Any] = {}
    if learner != DECISION:
        policies[DECISION] = _Left()
    if learner != NATURE:
        policies[NATURE] = _Push()
    kwargs: dict[str, Any] = {"nature_observes_state": observes_state}
    if learner == MONITOR:
        kwargs["monitor_reward"] = "detection"
    seat = ns_pz.single_agent(
        "ns_pz/FrozenLake-v0", learner, policies, max_episode_steps=50, **kwargs
    )
    seat.reset(seed=2)
    actions = np.random.default_rng(4)
    seat.step(_action(seat.action_space, actions))
    copy = pickle.loads(pickle.dumps(seat))
    for _ in range(10):
        action = _action(seat.action_space, actions)
        expected, got = seat.step(action), copy.step(action)
        assert _flat(got[0]) == _flat(expected[0]) and got[1:4] == expected[1:4]
        if expected[2] or expected[3]:
            break


class _Left:
    """A picklable decision policy: always push left."""

    def __call__(self, observation: Any) -> int:
        return 0
