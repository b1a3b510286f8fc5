"""The registry: gymnasium.make and ns_pz.make, argument routing, errors, import hygiene."""

from __future__ import annotations

import importlib.util
import subprocess
import sys

import gymnasium as gym
import pytest

import ns_pz
from ns_pz import UnknownEnvironment


def run_python(code: str, cwd) -> subprocess.CompletedProcess:
    """Run code in a fresh interpreter, outside the source tree (so the installed ns_pz loads)."""
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=cwd
    )


def test_registered_ids():
    """The first families are registered under Name-vN ids."""
    assert {"ns_pz/CartPole-v0", "ns_pz/FrozenLake-v0", "ns_pz/FrozenLake8x8-v0"} <= set(
        ns_pz.registered_envs()
    )


@pytest.mark.parametrize("env_id", ns_pz.registered_envs())
def test_every_id_builds_through_both_makes(env_id):
    """gymnasium.make gives the view, ns_pz.make the game, for every id."""
    assert isinstance(gym.make(env_id).unwrapped, ns_pz.NSGymEnv)
    assert isinstance(ns_pz.make(env_id), ns_pz.NSGame)


def test_unknown_id_suggests_close_matches():
    """A typo gets an error naming the closest registered ids."""
    with pytest.raises(UnknownEnvironment, match="Did you mean 'ns_pz/FrozenLake-v0'"):
        ns_pz.make("ns_pz/FrozenLak-v0")
    with pytest.raises(ValueError, match="no environment 'nothing' is registered"):
        ns_pz.make_gym("nothing")


def test_unknown_argument_lists_what_is_allowed():
    """An argument neither the NS-MDP nor the family takes is a TypeError listing both."""
    with pytest.raises(TypeError, match=r"no argument 'is_slippery' here; allowed: \[.*'map_name'"):
        ns_pz.make("ns_pz/FrozenLake-v0", is_slippery=True)
    with pytest.raises(TypeError, match="no argument 'ground_truth_info'") as error:
        ns_pz.make("ns_pz/FrozenLake-v0", ground_truth_info=True)  # a view option, not the game's
    assert "'ground_truth_info'" not in str(error.value).split("allowed:")[1]


def test_family_arguments_reach_the_family():
    """Family arguments (the map) and NS arguments (the level) are routed apart."""
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", map_name="8x8", notification="detailed")
    assert env.family.observation_space.n == 64
    assert env.notification_level == "detailed"
    with pytest.raises(ValueError, match="notification='full' is not a notification level"):
        ns_pz.make_gym("ns_pz/FrozenLake-v0", notification="full")


def test_module_prefixed_id_imports_ns_pz_by_itself(tmp_path):
    """gymnasium.make('ns_pz:ns_pz/...') works in a fresh interpreter that never imported ns_pz."""
    code = (
        "import gymnasium as gym; e = gym.make('ns_pz:ns_pz/FrozenLake-v0');"
        " print(type(e.unwrapped).__name__)"
    )
    out = run_python(code, tmp_path)
    assert out.stdout.strip() == "NSGymEnv"


def test_import_loads_no_torch_and_no_compiler(tmp_path):
    """Import ns_pz stays light: no torch, numba, jax, scipy, SB3, Ray, pygame or MuJoCo.

    ``ns_pz.rllib`` is importable without loading ray (it imports ray inside its functions).
    """
    code = (
        "import sys, ns_pz, ns_pz.nature, ns_pz.monitor, ns_pz.seats, ns_pz.rllib;"
        " heavy = ('torch', 'numba', 'jax', 'scipy', 'stable_baselines3', 'ray', 'pygame',"
        " 'mujoco');"
        " print([m for m in heavy if m in sys.modules])"
    )
    out = run_python(code, tmp_path)
    assert out.stdout.strip() == "[]"


def test_compat_bridge_is_made_after_plain_import_without_loading_compat(tmp_path):
    """``import ns_pz`` registers ns_pz_compat/Bridge-v0 lazily: compat loads on make only."""
    out = run_python(
        "import sys, gymnasium, ns_pz\n"
        "print('ns_pz.compat' in sys.modules)\n"
        "env = gymnasium.make('ns_pz_compat/Bridge-v0')\n"
        "env.reset(seed=0); env.step(0)\n"
        "print(type(env.unwrapped).__module__, env.spec.max_episode_steps)",
        tmp_path,
    )
    assert out.stdout.split() == ["False", "ns_pz.compat.envs.Bridge", "100"]


def test_mujoco_tasks_are_registered_only_with_mujoco(tmp_path):
    """Without the mujoco extra no MuJoCo id is listed (so nothing tries to run one)."""
    code = (
        "import sys; sys.modules['mujoco'] = None; import ns_pz;"
        " print([e for e in ns_pz.registered_envs() if 'Cheetah' in e or 'Humanoid' in e])"
    )
    assert run_python(code, tmp_path).stdout.strip() == "[]"
    if importlib.util.find_spec("mujoco") is not None:
        code = "import ns_pz; print(sum('Humanoid' in e for e in ns_pz.registered_envs()))"
        assert run_python(code, tmp_path).stdout.strip() == "2"
