"""An optional dependency's absence names the extra that installs it (imports hidden here)."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable

import numpy as np
import pytest

from ns_pz.errors import MissingExtra
from ns_pz.extras import require


@pytest.fixture
def hide(monkeypatch: pytest.MonkeyPatch) -> Callable[[str], None]:
    """Make a package (and everything under it) unimportable for the test, as if not installed."""

    def hidden(package: str) -> None:
        for name in [n for n in sys.modules if n == package or n.startswith(package + ".")]:
            monkeypatch.setitem(sys.modules, name, None)
        monkeypatch.setitem(sys.modules, package, None)

    return hidden


def test_require_names_the_extra(hide: Callable[[str], None]) -> None:
    """The message names the package and the extra; an unknown package is a caller error."""
    hide("scipy")
    with pytest.raises(MissingExtra, match=r'this needs scipy, .*pip install "ns_pz\[game\]"'):
        require("scipy.optimize", "this")
    with pytest.raises(ImportError):  # MissingExtra is an ImportError
        require("scipy", "this")
    with pytest.raises(ValueError, match="module='numpy' is in no ns_pz extra"):
        require("numpy", "this")


def test_a_mixed_matrix_game_without_scipy_names_the_game_extra(
    hide: Callable[[str], None],
) -> None:
    """Matching pennies has no pure saddle point: solving it needs scipy's LP solver."""
    from ns_pz.agents.exact.matrix_game import solve_matrix_games

    pennies = np.array([[[1.0, -1.0], [-1.0, 1.0]]])
    hide("scipy")
    with pytest.raises(MissingExtra, match=r'needs scipy.*"ns_pz\[game\]"'):
        solve_matrix_games(pennies)
    saddle = np.array([[[1.0, 2.0], [0.0, 0.5]]])  # pure: no scipy needed
    assert solve_matrix_games(saddle).values[0] == 1.0


def test_the_paper_agents_train_without_torch(
    hide: Callable[[str], None], tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """DDQN and AlphaZero train in NumPy: with torch unimportable both networks still train."""
    from ns_pz.agents.learning.config import AlphaZeroArgs, DDQNArgs
    from ns_pz.agents.learning.trained import alphazero_needed, ddqn_needed, obtain

    import ns_pz

    monkeypatch.setenv("NS_PZ_CACHE_DIR", str(tmp_path))
    hide("torch")
    env = ns_pz.make_gym("ns_pz/FrozenLake-v0", params={"slip": [0.7, 0.15, 0.15]})
    needs = [
        ddqn_needed(env, DDQNArgs(total_steps=600, learning_starts=100)),
        alphazero_needed(env, AlphaZeroArgs(episodes=2, iterations=4, max_episode_steps=10)),
    ]
    for need in needs:
        assert all(np.all(np.isfinite(w)) for w in obtain(need).values())


def test_sb3_vec_without_stable_baselines3_names_the_learn_extra(
    hide: Callable[[str], None], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Importing the SB3 vector env without SB3 names the learn extra."""
    for name in ("ns_pz.sb3_vec", "ns_pz.learning.sb3_vec"):  # its new home and the old name
        monkeypatch.delitem(sys.modules, name, raising=False)
    hide("stable_baselines3")
    with pytest.raises(MissingExtra, match=r'needs stable_baselines3.*"ns_pz\[learn\]"'):
        import ns_pz.sb3_vec  # noqa: F401


def test_rllib_without_ray_names_the_rllib_extra(hide: Callable[[str], None]) -> None:
    """RLlib helpers without Ray name the rllib extra (not ray: it pins its own Gymnasium)."""
    import ns_pz.rllib

    hide("ray")
    with pytest.raises(MissingExtra, match=r'needs ray.*"ns_pz\[rllib\]"'):
        ns_pz.rllib.register("ns_pz/FrozenLake-v0")


def test_plots_without_matplotlib_name_the_plot_extra(
    hide: Callable[[str], None], tmp_path
) -> None:
    """``bench plot`` without matplotlib names the plot extra."""
    from ns_pz.experiments.report import plot

    hide("matplotlib")
    with pytest.raises(RuntimeError, match=r'matplotlib: pip install "ns_pz\[plot\]"'):
        plot([], "t", tmp_path)


def test_envs_listing_mentions_the_mujoco_tasks_only_without_the_extra(
    hide: Callable[[str], None],
) -> None:
    """``ns-pz envs`` says the MuJoCo tasks exist, and how to get them, when they are missing."""
    from ns_pz.cli import list_envs

    lines: list[str] = []
    list_envs(lines.append)
    if importlib.util.find_spec("mujoco") is not None:
        assert not any("mujoco extra" in line for line in lines)
    hide("mujoco")
    lines.clear()
    list_envs(lines.append)
    assert 'pip install "ns_pz[mujoco]"' in lines[-1] and "HalfCheetah" not in lines[-1]
