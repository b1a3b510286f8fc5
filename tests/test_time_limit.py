"""One truncation mechanism: a view made by gymnasium.make truncates by itself (issue 9, item 6)."""

from __future__ import annotations

import warnings

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import TimeLimit

import ns_pz

UP = 0  # on CliffWalking's top row, UP stays put: episodes never terminate, only truncate
CLIFF = "ns_pz/CliffWalking-v0"  # registered limit: 200


def _steps_until_truncated(env: gym.Env, limit: int = 2000) -> int | None:
    for step in range(1, limit + 1):
        _, _, terminated, truncated, _ = env.step(UP)
        assert not terminated
        if truncated:
            return step
    return None


def _to_top_row(env: gym.Env) -> None:
    env.reset(seed=0)
    for _ in range(3):
        env.step(UP)


def _wrappers(env: gym.Env) -> list[type]:
    kinds = []
    while isinstance(env, gym.Wrapper):
        kinds.append(type(env))
        env = env.env
    return kinds


@pytest.mark.parametrize("max_episode_steps", [None, 20, 500])
def test_planning_env_from_gymnasium_make_continues_the_episode_limit(max_episode_steps):
    """It truncates after the steps the episode has left (it used to run on forever)."""
    kwargs = {} if max_episode_steps is None else {"max_episode_steps": max_episode_steps}
    env = gym.make(CLIFF, **kwargs)
    limit = max_episode_steps or 200
    _to_top_row(env)
    for _ in range(7):
        env.step(UP)
    planning = env.unwrapped.get_planning_env()
    assert _steps_until_truncated(planning) == limit - 10
    assert _steps_until_truncated(env) == limit - 10


@pytest.mark.parametrize("max_episode_steps", [None, 20, 500])
def test_the_view_through_gymnasium_make_truncates_once_at_its_limit(max_episode_steps):
    """No TimeLimit on top of the view's own clock; gymnasium.make's argument sets the limit."""
    kwargs = {} if max_episode_steps is None else {"max_episode_steps": max_episode_steps}
    env = gym.make(CLIFF, **kwargs)
    limit = max_episode_steps or 200
    assert TimeLimit not in _wrappers(env)
    assert env.unwrapped.max_episode_steps == limit
    assert env.spec.max_episode_steps == limit
    env.reset(seed=0)
    assert _steps_until_truncated(env) == limit
    rebuilt = gym.make(env.spec)  # the spec rebuilds the same stack and limit
    assert _wrappers(rebuilt) == _wrappers(env)
    assert rebuilt.unwrapped.max_episode_steps == limit


def test_minus_one_means_no_limit_as_in_gymnasium():
    """gymnasium.make(..., max_episode_steps=-1) applies no limit, and the view has none."""
    env = gym.make(CLIFF, max_episode_steps=-1)
    assert env.unwrapped.max_episode_steps is None
    env.reset(seed=0)
    assert _steps_until_truncated(env, limit=1000) is None


def test_check_env_and_vector_envs_keep_working():
    """check_env passes on the stack gymnasium.make builds; make_vec sub-envs get the limit."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        check_env(gym.make(CLIFF).unwrapped)
        check_env(gym.make("ns_pz/CartPole-v0", max_episode_steps=50))
    vector = gym.make_vec(CLIFF, num_envs=2, vectorization_mode="sync")
    assert [e.unwrapped.max_episode_steps for e in vector.envs] == [200, 200]
    vector.close()


def test_view_time_limit_refuses_other_envs():
    """The wrapper only hands limits to ns_pz views."""
    from ns_pz.envs.time_limit import ViewTimeLimit

    with pytest.raises(TypeError, match="wraps ns_pz views only"):
        ViewTimeLimit(TimeLimit(gym.make("CartPole-v1").unwrapped, 5))
    assert ns_pz.make_gym(CLIFF).max_episode_steps == 200
