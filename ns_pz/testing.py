"""The conformance suite every registered environment passes.

:func:`check_ns_env` runs, for one environment id:

* PettingZoo's ``api_test`` and ``seed_test`` on the AEC game (they draw nature's actions from
  its whole action space, so θ moves at every step and often hits its bounds);
* Gymnasium's ``check_env`` on the Gymnasium view, at every notification level;
* the ns_pz invariants: θ is a valid parameter set after every nature move, whatever nature
  asks for; no θ object is ever mutated; the same seed gives the same θ trajectory,
  notifications and states; the turn order is nature → monitor → agent; the game and the view
  give identical trajectories and hand the agent planning models with the same θ, for the
  same seed and actions.

``tests/test_conformance.py`` runs it over :func:`ns_pz.registered_envs`, so registering an
environment is what gets it tested.
"""

from __future__ import annotations

import copy
import warnings
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.utils.env_checker import check_env, data_equivalence
from pettingzoo.test import api_test, seed_test

from ns_pz.envs.registry import make, make_gym
from ns_pz.game import AGENTS, DECISION, MONITOR, NATURE, NSGame
from ns_pz.monitor.monitors import Monitor, OracleMonitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.nature.constraints import NatureConstraints
from ns_pz.nature.policies import Nature, RandomNature
from ns_pz.params import Params

STRESS_SCALE = 0.2
"""Relative size of the random steps the stress nature takes (large enough to hit bounds)."""


def check_ns_env(env_id: str, *, num_cycles: int = 60, **kwargs: Any) -> None:
    """Run the whole conformance suite on ``env_id``; raise ``AssertionError`` on a failure.

    Args:
        env_id: A registered id.
        num_cycles: Time steps each dynamic check runs for.
        **kwargs: Passed to the environment (e.g. family arguments such as ``map_name``).
    """
    check_game_api(env_id, num_cycles, **kwargs)
    check_view_api(env_id, **kwargs)
    check_theta_invariants(env_id, num_cycles, **kwargs)
    check_reproducible(env_id, num_cycles, **kwargs)
    check_turn_order(env_id, **kwargs)
    check_game_matches_view(env_id, num_cycles, **kwargs)


def _stress_game(env_id: str, num_cycles: int, **kwargs: Any) -> NSGame:
    kwargs.setdefault("nature", RandomNature(STRESS_SCALE))
    kwargs.setdefault("notification", "detailed")
    kwargs.setdefault("max_episode_steps", num_cycles)
    return make(env_id, **kwargs)


def check_game_api(env_id: str, num_cycles: int = 60, **kwargs: Any) -> None:
    """PettingZoo's ``api_test`` and ``seed_test`` on the game."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # style advice (dict observations, ...)
        api_test(_stress_game(env_id, num_cycles, **kwargs), num_cycles=num_cycles)
        seed_test(lambda: _stress_game(env_id, num_cycles, **kwargs), num_cycles=num_cycles)


def check_view_api(env_id: str, **kwargs: Any) -> None:
    """Gymnasium's ``check_env`` (determinism, spaces, close) on the view at every level."""
    for level in NotificationLevel:
        env = make_gym(
            env_id, nature=RandomNature(STRESS_SCALE), notification=level.value, **kwargs
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            check_env(env, skip_render_check=True)


def check_theta_invariants(env_id: str, num_cycles: int = 60, **kwargs: Any) -> None:
    """θ stays valid and unmutated under a learned-style nature taking arbitrary actions.

    Nature's actions are drawn from its whole action space (so they often ask for values out of
    bounds) with a Lipschitz bound and a budget in force; every θ the game reports must pass
    validation, respect the bound and the budget, and still hold the values it had when first
    seen at the end of the run.
    """
    lipschitz, budget = 0.5, 3.0
    game = make(
        env_id,
        constraints=NatureConstraints(lipschitz=lipschitz, budget=budget),
        max_episode_steps=num_cycles,
        **kwargs,
    )
    game.reset(seed=7)
    rng = np.random.default_rng(7)
    space = game.nature_action_space
    seen: list[tuple[Params, dict[str, Any]]] = []
    previous = game.ground_truth().theta
    for agent in game.agent_iter():
        _, _, terminated, truncated, _ = game.last()
        if terminated or truncated:
            game.step(None)
            continue
        if agent == NATURE:
            delta = (
                rng.uniform(space.low, space.high)
                if np.isfinite(space.low).all()
                else (rng.normal(0.0, 10.0, space.shape))
            )
            game.step(np.clip(delta, space.low, space.high))
            truth = game.ground_truth()
            theta = truth.theta
            _assert_valid(theta)
            sizes = theta.change_sizes(previous)
            assert max(sizes) <= lipschitz + 1e-9, f"Lipschitz bound broken: {sizes}"
            assert truth.total_change <= budget + 1e-9, f"budget broken: {truth.total_change}"
            seen.append((theta, copy.deepcopy(theta.as_dict())))
            previous = theta
        else:
            action = game.policy_action(MONITOR) if agent == MONITOR else None
            game.step(action if action is not None else _action(game, DECISION, rng))
    for theta, values in seen:
        assert theta.as_dict() == values, f"a θ object was mutated: {values} -> {theta.as_dict()}"


def _assert_valid(theta: Params) -> None:
    rebuilt = type(theta)(**theta.as_dict())  # construction validates every field
    assert rebuilt == theta


def check_reproducible(env_id: str, num_cycles: int = 60, **kwargs: Any) -> None:
    """The same seed gives the same θ trajectory, notifications, states and rewards."""

    def rollout(seed: int, episodes: int = 5) -> list[Any]:
        game = _stress_game(env_id, num_cycles, **kwargs)
        record: list[Any] = []
        for episode in range(episodes):
            game.reset(seed=seed if episode == 0 else None)
            for index, agent in enumerate(game.agent_iter()):
                observation, reward, terminated, truncated, _ = game.last()
                record.append((agent, observation, reward, game.ground_truth().theta))
                if terminated or truncated:
                    game.step(None)
                    continue
                if agent == DECISION:
                    space = game.action_space(agent)
                    space.seed(index)
                    game.step(space.sample())
                else:  # nature: the stress policy, drawing from the game's seeded generator
                    game.step(game.policy_action(agent))
        return record

    first, second, other = rollout(3), rollout(3), rollout(4)
    assert data_equivalence(first, second), "same seed, different trajectories"
    assert not data_equivalence(first, other), "different seeds gave identical trajectories"


def check_turn_order(env_id: str, **kwargs: Any) -> None:
    """Agents take turns nature → monitor → agent, and all three end together."""
    game = _stress_game(env_id, 4, **kwargs)
    game.reset(seed=0)
    order = []
    rng = np.random.default_rng(0)
    for agent in game.agent_iter():
        _, _, terminated, truncated, _ = game.last()
        order.append((agent, terminated or truncated))
        game.step(None if terminated or truncated else _action(game, agent, rng))
    live = [agent for agent, done in order if not done]
    cycles = len(live) // 3
    assert live == list(AGENTS) * cycles, f"turn order broken: {live}"
    finished = [agent for agent, done in order if done]
    assert finished == list(AGENTS), f"agents did not end together: {finished}"
    assert not game.agents


def check_game_matches_view(
    env_id: str,
    num_cycles: int = 60,
    *,
    monitors: tuple[Monitor, ...] | None = None,
    natures: tuple[Nature, ...] | None = None,
    **kwargs: Any,
) -> None:
    """The game driven by its configured policies and the view give the same trajectory.

    Checked at every level for each nature and monitor (default: a memoryless random nature
    and a stateful one; the oracle and a stateful, randomised monitor that also speaks at
    ``t = 0``): observations, planning θ, rewards, ends and ground truth, step by step.
    """
    if natures is None:
        natures = (RandomNature(STRESS_SCALE), WanderingNature())
    if monitors is None:
        monitors = (OracleMonitor(), NoisyMemoryMonitor())
    for level in NotificationLevel:
        for nature, monitor in zip(natures, monitors, strict=False):
            _compare_game_and_view(env_id, num_cycles, level, nature, monitor, **kwargs)


def _compare_game_and_view(
    env_id: str,
    num_cycles: int,
    level: NotificationLevel,
    nature: Nature,
    monitor: Monitor,
    **kwargs: Any,
) -> None:
    options = dict(
        nature=nature,
        monitor=monitor,
        notification=level.value,
        max_episode_steps=num_cycles,
        **kwargs,
    )
    where = f"{level}, {nature!r}, {monitor!r}"
    game = make(env_id, **options)
    view = make_gym(env_id, **options)
    actions = np.random.default_rng(1)
    game.reset(seed=11)
    view_obs, _ = view.reset(seed=11)
    while True:
        game.step(game.policy_action(NATURE))
        game.step(game.policy_action(MONITOR))
        game_obs = game.observe(DECISION)
        assert data_equivalence(game_obs, view_obs), f"{where}: {game_obs} != {view_obs}"
        assert game.ground_truth() == view.ground_truth(), f"{where}: ground truth differs"
        planned = game.planning_model().theta, view.planning_model().theta
        assert planned[0] == planned[1], f"{where}: planning θ differs: {planned}"
        action = _action(game, DECISION, actions)
        game.step(action)
        view_obs, reward, terminated, truncated, _ = view.step(action)
        assert game.rewards[DECISION] == reward, where
        assert game.terminations[DECISION] == terminated, where
        assert game.truncations[DECISION] == truncated, where
        if terminated or truncated:
            assert game.ground_truth() == view.ground_truth(), f"{where}: ground truth differs"
            break


class NoisyMemoryMonitor(Monitor):
    """A test monitor with memory and randomness: what a detector looks like to the cycle.

    It raises a flag on a random parameter with a probability that grows with the number of
    calls this episode (kept in its memory), draws from its generator on every call, and
    speaks from ``t = 0`` on, so any difference in when or how often the game and the view ask
    it shows in the notifications.
    """

    def initial_memory(self) -> list[int]:
        """The number of calls so far, in a one-element list."""
        return [0]

    def notify(
        self,
        observation: dict[str, Any] | None,
        truth: Any,
        memory: Any,
        rng: np.random.Generator,
    ) -> tuple[tuple[int, ...], tuple[float, ...]]:
        """A random flag, likelier as the episode goes on."""
        memory[0] += 1
        size = self.size
        flags = [0] * size
        sizes = [0.0] * size
        if rng.random() < min(0.1 * memory[0], 0.9):
            index = int(rng.integers(size))
            flags[index] = 1
            sizes[index] = float(rng.random())
        return tuple(flags), tuple(sizes)

    def bind(self, family: Any, theta0: Any) -> None:
        """Learn how many parameters there are."""
        self.size = len(family.params_cls.names())

    def __repr__(self) -> str:
        return "NoisyMemoryMonitor()"


class WanderingNature(Nature):
    """A test nature with memory: random steps whose size grows with each step it takes."""

    def initial_memory(self) -> list[int]:
        """The number of moves so far, in a one-element list."""
        return [0]

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Any:
        """Every other step, a random step of every parameter, larger as moves accumulate."""
        if rng.random() < 0.5:
            return None
        memory[0] += 1
        scale = min(0.02 * memory[0], STRESS_SCALE)
        return RandomNature(scale).propose(t, theta, budget_left, None, rng)

    def __repr__(self) -> str:
        return "WanderingNature()"


def _action(env: Any, agent: str, rng: np.random.Generator) -> Any:
    """A seeded random action of ``agent`` (the decision agent's, or any game agent's)."""
    space = env.action_space(agent)
    if hasattr(space, "n"):
        return int(space.start + rng.integers(space.n))
    if isinstance(space, spaces.Box):
        return rng.uniform(space.low, space.high).astype(space.dtype)
    space.seed(int(rng.integers(2**31)))
    return space.sample()
