"""render_mode on every family, in the Gymnasium view and the AEC game (issue 9, item 4)."""

from __future__ import annotations

import importlib.util
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.error import DependencyNotInstalled
from gymnasium.utils.env_checker import check_env
from ns_pz.envs.registry import MUJOCO_TASKS
from ns_pz.envs.rendering import AGENT, CELL
from pettingzoo.test import render_test

import ns_pz
from ns_pz import ResetNeeded
from ns_pz.rendering import HumanWindow

GRIDS = (
    "ns_pz/Bridge-v0",
    "ns_pz/BridgeSplit-v0",
    "ns_pz/CliffWalking-v0",
    "ns_pz/FrozenLake-v0",
    "ns_pz/FrozenLake8x8-v0",
)
MUJOCO = tuple(f"ns_pz/{name}-v0" for name, _, _ in MUJOCO_TASKS)
"""The MuJoCo tasks draw with MuJoCo's renderer, which needs an OpenGL context chosen before
mujoco is imported (``MUJOCO_GL``): ``tests/test_mujoco.py`` renders them in a subprocess."""
HAS_PYGAME = importlib.util.find_spec("pygame") is not None
needs_pygame = pytest.mark.skipif(not HAS_PYGAME, reason='needs pip install "ns_pz[render]"')


def _modes(env_id: str) -> tuple[str, ...]:
    return ns_pz.spec(env_id).build_family({}, set()).render_modes


def _cases(modes: tuple[str, ...]) -> list:
    """(env id, mode) pairs, marked to skip without pygame where pygame draws."""
    cases = []
    for env_id in ns_pz.registered_envs():
        if env_id in MUJOCO:
            continue
        for mode in _modes(env_id):
            if mode in modes:
                drawn_by_pygame = mode == "human" or env_id not in GRIDS
                marks = [needs_pygame] if drawn_by_pygame else []
                cases.append(pytest.param(env_id, mode, marks=marks, id=f"{env_id}-{mode}"))
    return cases


def _check_result(result: object, mode: str) -> None:
    if mode == "rgb_array":
        assert isinstance(result, np.ndarray) and result.dtype == np.uint8
        assert result.ndim == 3 and result.shape[2] == 3 and min(result.shape[:2]) > 0
    elif mode == "ansi":
        assert isinstance(result, str) and result.strip()
    else:
        assert result is None


@pytest.fixture
def headless(monkeypatch):
    """SDL's dummy video driver for pygame windows: "human" mode runs without a display."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")


def test_every_family_declares_its_render_modes():
    """Grid worlds draw human, rgb_array and ansi; classic control human and rgb_array."""
    for env_id in ns_pz.registered_envs():
        expected = ["human", "rgb_array", "ansi"] if env_id in GRIDS else ["human", "rgb_array"]
        for env in (gym.make(env_id), ns_pz.make(env_id)):
            assert env.metadata["render_modes"] == expected
            assert env.metadata["render_fps"] > 0
        assert gym.make(env_id).render_mode is None


@pytest.mark.parametrize(("env_id", "mode"), _cases(("rgb_array", "ansi")))
def test_the_view_renders_after_reset_after_a_step_and_at_the_end(env_id, mode):
    """gymnasium.make(..., render_mode=mode): a frame or text after reset, steps and the end."""
    env = gym.make(env_id, render_mode=mode, max_episode_steps=3)
    assert env.render_mode == mode
    env.action_space.seed(0)
    env.reset(seed=0)
    _check_result(env.render(), mode)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        _check_result(env.render(), mode)
        done = terminated or truncated
    env.close()


@pytest.mark.parametrize(("env_id", "mode"), _cases(("rgb_array", "ansi")))
def test_the_game_renders_after_reset_and_after_each_turn(env_id, mode):
    """ns_pz.make(..., render_mode=mode): render() follows PettingZoo's signature."""
    game = ns_pz.make(env_id, render_mode=mode)
    game.reset(seed=0)
    _check_result(game.render(), mode)
    for _ in range(3):  # nature, monitor, agent
        agent = game.agent_selection
        action = game.action_space(agent).sample() if agent == "agent" else None
        game.step(game.policy_action(agent) if action is None else action)
        _check_result(game.render(), mode)
    game.close()


@needs_pygame
@pytest.mark.parametrize("env_id", ["ns_pz/FrozenLake-v0", "ns_pz/CartPole-v0"])
def test_human_mode_draws_into_a_window_after_every_reset_and_step(env_id, headless, monkeypatch):
    """render() returns None; reset and step redraw the window; planning copies draw nothing."""
    shown: list[tuple[int, ...]] = []
    original = HumanWindow.show
    monkeypatch.setattr(
        HumanWindow, "show", lambda self, frame: (shown.append(frame.shape), original(self, frame))
    )
    env = gym.make(env_id, render_mode="human")
    env.reset(seed=0)
    env.step(0)
    assert env.render() is None
    assert len(shown) == 3
    copy = env.unwrapped.get_planning_env()
    assert copy.render_mode is None
    copy.step(0)
    assert len(shown) == 3
    env.close()


@needs_pygame
@pytest.mark.parametrize("env_id", ["ns_pz/CliffWalking-v0", "ns_pz/Pendulum-v0"])
def test_pettingzoo_render_test_passes_on_the_game(env_id, headless):
    """PettingZoo's render_test, every declared mode (human included)."""
    render_test(lambda render_mode=None: ns_pz.make(env_id, render_mode=render_mode))


@needs_pygame
@pytest.mark.parametrize("env_id", ["ns_pz/FrozenLake-v0", "ns_pz/MountainCar-v0"])
def test_check_env_passes_with_a_render_mode(env_id, headless):
    """Gymnasium's check_env with its render checks on (it makes the env in every mode)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        check_env(gym.make(env_id, render_mode="rgb_array").unwrapped)


@pytest.mark.parametrize(
    ("env_id", "mode", "allowed"),
    [
        ("ns_pz/CartPole-v0", "ansi", "[None, 'human', 'rgb_array']"),
        ("ns_pz/FrozenLake-v0", "rgb", "[None, 'human', 'rgb_array', 'ansi']"),
        ("ns_pz/Bridge-v0", "rgb_array_list", "[None, 'human', 'rgb_array', 'ansi']"),
    ],
)
def test_an_unsupported_mode_is_refused_naming_it_and_the_allowed_ones(env_id, mode, allowed):
    """The view, the game and gymnasium.make refuse it at construction."""
    match = f"render_mode={mode!r} is not supported by .*; allowed: {allowed}"
    match = match.replace("[", r"\[").replace("]", r"\]")
    for make in (ns_pz.make_gym, ns_pz.make, gym.make):
        with pytest.raises(ValueError, match=match):
            make(env_id, render_mode=mode)


def test_render_before_reset_raises_and_no_mode_renders_nothing():
    """Rendering needs a state; without a render mode render() returns None."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", render_mode="ansi")
    with pytest.raises(ResetNeeded, match="render"):
        env.render()
    plain = ns_pz.make_gym("ns_pz/FrozenLake-v0")
    plain.reset(seed=0)
    assert plain.render() is None


def test_grid_pictures_show_the_agent_where_it_is():
    """The agent's disc sits in its cell of the frame; its letter is highlighted in the text."""
    env = ns_pz.make_gym("ns_pz/CliffWalking-v0", render_mode="rgb_array")
    env.reset(seed=0)
    env.step(0)  # UP from the start (3, 0), deterministic: cell (2, 0)
    frame = env.render()
    assert frame.shape == (4 * CELL, 12 * CELL, 3)
    centre = CELL // 2
    assert tuple(frame[2 * CELL + centre, centre]) == AGENT
    assert tuple(frame[3 * CELL + centre, centre]) != AGENT
    text_env = ns_pz.make_gym("ns_pz/CliffWalking-v0", render_mode="ansi")
    text_env.reset(seed=0)
    text_env.step(1)  # RIGHT from the start: into the cliff, back to the start
    lines = text_env.render().splitlines()
    assert lines[0] == "  (Right)"
    assert lines[4] == "\x1b[41mS\x1b[0mCCCCCCCCCCG"


@needs_pygame
def test_classic_control_pictures_follow_the_geometry_in_theta():
    """CartPole's pole length and the Acrobot's link lengths are θ's."""
    for env_id, change in (
        ("ns_pz/CartPole-v0", {"length": 1.5}),
        ("ns_pz/Acrobot-v0", {"link_length_1": 0.4, "link_length_2": 1.6}),
    ):
        env = ns_pz.make_gym(env_id, render_mode="rgb_array")
        env.reset(seed=0)
        before = env.render()
        env.set_params(**change)
        assert not np.array_equal(env.render(), before)
        twin = ns_pz.make_gym(env_id, render_mode="rgb_array", params=change)
        twin.reset(seed=0)
        np.testing.assert_array_equal(twin.render(), env.render())


def test_without_pygame_classic_control_frames_name_the_extra(monkeypatch):
    """Grid frames need only NumPy; classic control and windows say what to install."""
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "pygame" else real(name, *a)
    )
    with pytest.raises(DependencyNotInstalled, match=r'CartPoleEnv.*pip install "ns_pz\[render\]"'):
        ns_pz.make_gym("ns_pz/CartPole-v0", render_mode="rgb_array")
    with pytest.raises(DependencyNotInstalled, match=r"render_mode='human'.*ns_pz\[render\]"):
        ns_pz.make("ns_pz/FrozenLake-v0", render_mode="human")
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", render_mode="rgb_array")
    env.reset(seed=0)
    assert env.render().shape == (4 * CELL, 4 * CELL, 3)


def test_record_video_writes_a_video(tmp_path):
    """gymnasium.wrappers.RecordVideo records an episode of the view (needs moviepy)."""
    pytest.importorskip("moviepy")
    env = gym.make("ns_pz/FrozenLake-v0", render_mode="rgb_array", max_episode_steps=20)
    env = gym.wrappers.RecordVideo(env, str(tmp_path / "videos"), episode_trigger=lambda _: True)
    env.reset(seed=0)
    env.action_space.seed(0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        done = terminated or truncated
    env.close()
    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 0
