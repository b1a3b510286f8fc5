"""The game under RLlib: nature and the decision agent (and optionally the monitor) as PPO policies.

Needs the ``rllib`` extra (``ray[rllib]``, which pins Gymnasium 1.2.x, and torch; PyPI's Linux
torch is the CUDA build: for the CPU-only wheel install torch first from
``https://download.pytorch.org/whl/cpu``). Ray is imported only inside the functions that need
it (without it they raise :class:`~ns_pz.errors.MissingExtra` naming the extra), and nothing
else in ns_pz imports this module.

RLlib's :class:`~ray.rllib.env.wrappers.pettingzoo_env.PettingZooEnv` turns an AEC game into a
``MultiAgentEnv`` (one agent acts per step: the one whose turn it is). Two things of
:class:`~ns_pz.game.NSGame` would stop RLlib's default PPO modules, and :class:`GameForRLlib`
changes them:

* **Observations are flattened** (``flatten=True``, the default): every ``Dict`` observation
  (the agent's ``state`` + notification, the monitor's last transition) becomes one float32
  ``Box`` by :func:`gymnasium.spaces.flatten` — a ``Discrete`` state becomes its one-hot, the
  ``Dict`` keys are taken in their sorted order (``delta_change``, ``env_change``,
  ``relative_time``, ``state`` for the agent). Nature's observation is already a flat ``Box``.
  With ``flatten=False`` the ``Dict`` spaces are passed through: then add RLlib's
  ``FlattenObservations(multi_agent=True)`` env-to-module connector yourself
  (:func:`ppo_config` does that for you).
* **No seat has an action space RLlib refuses**: nature acts with ``Box(-1, 1)`` per
  parameter (the game's ``nature_action="normalized"``), the agent with its family's action
  space, and the monitor, when it is a learner (``scripted_monitor=False``), with one 0/1 flag
  per parameter (``MultiDiscrete``; ``monitor_action="flags"``), paid by the game's
  ``monitor_reward`` (``"detection"`` or a function; required then). By default
  (``scripted_monitor=True``) the monitor is not an RL agent at all: its turns are played by
  the game's configured monitor (the oracle unless ``monitor=`` says otherwise), and RLlib sees
  a two-agent game of nature and agent.

Episodes are seeded by RLlib's ``reset(seed=...)``; everything else follows the game's seeding.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv

from ns_pz.extras import require
from ns_pz.game import NSGame
from ns_pz.process import DECISION, MONITOR, NATURE

__all__ = ["GameForRLlib", "env_creator", "ppo_config", "register"]


class GameForRLlib(AECEnv):
    """An :class:`~ns_pz.game.NSGame` as RLlib's PPO can train it (see the module docstring).

    Args:
        game: The game; built with ``nature_action="normalized"`` and, when the monitor learns,
            ``monitor_action="flags"``.
        scripted_monitor: Play the monitor's turns with the game's monitor policy and hide the
            monitor from the learners.
        flatten: Flatten ``Dict`` observations into float32 ``Box`` vectors.

    Raises:
        ValueError: The game's nature or monitor action space is one RLlib refuses (a nature
            acting with raw Δθ may be fine for RLlib but is not what a network should drive;
            a ``Dict`` monitor action is refused).
    """

    metadata: dict[str, Any] = {"name": "ns_pz_game_rllib", "is_parallelizable": False}

    def __init__(
        self, game: NSGame, *, scripted_monitor: bool = True, flatten: bool = True
    ) -> None:
        super().__init__()
        if game.nature_action != "normalized":
            raise ValueError(
                f"nature_action={game.nature_action!r}: a learning nature needs "
                "nature_action='normalized' (Box(-1, 1) per parameter)"
            )
        if not scripted_monitor and isinstance(game.action_space(MONITOR), spaces.Dict):
            raise ValueError(
                "scripted_monitor=False needs monitor_action='flags': RLlib's PPO cannot act "
                "in the Dict action space of monitor_action='dict'"
            )
        self.game = game
        self.scripted_monitor = scripted_monitor
        self.flatten = flatten
        self.possible_agents = [a for a in game.possible_agents if self._learns(a)]
        self.render_mode = game.render_mode
        self._spaces = {agent: game.observation_space(agent) for agent in game.possible_agents}
        self._observation_spaces = {
            agent: _flat_space(space) if flatten else space for agent, space in self._spaces.items()
        }

    def _learns(self, agent: str) -> bool:
        return agent != MONITOR or not self.scripted_monitor

    # -- PettingZoo's AEC state, read from the game --------------------------------------------
    @property
    def agents(self) -> list[str]:  # type: ignore[override]
        """The learners still in the episode."""
        return [a for a in self.game.agents if self._learns(a)]

    @property
    def agent_selection(self) -> str:  # type: ignore[override]
        """The learner whose turn it is."""
        return self.game.agent_selection

    @property
    def rewards(self) -> dict[str, float]:  # type: ignore[override]
        """Rewards of the last step, by learner."""
        return {a: r for a, r in self.game.rewards.items() if self._learns(a)}

    @property
    def terminations(self) -> dict[str, bool]:  # type: ignore[override]
        """Terminations by learner."""
        return {a: d for a, d in self.game.terminations.items() if self._learns(a)}

    @property
    def truncations(self) -> dict[str, bool]:  # type: ignore[override]
        """Truncations by learner."""
        return {a: d for a, d in self.game.truncations.items() if self._learns(a)}

    @property
    def infos(self) -> dict[str, dict[str, Any]]:  # type: ignore[override]
        """Infos by learner."""
        return {a: i for a, i in self.game.infos.items() if self._learns(a)}

    @property
    def _cumulative_rewards(self) -> dict[str, float]:  # type: ignore[override]
        return {a: r for a, r in self.game._cumulative_rewards.items() if self._learns(a)}

    def observation_space(self, agent: str) -> spaces.Space[Any]:
        """The (flattened) observation space of a learner."""
        return self._observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Space[Any]:
        """The action space of a learner."""
        return self.game.action_space(agent)

    # -- turns -------------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict[str, Any] | None = None) -> None:
        """Reset the game (``seed`` seeds everything) and play up to a learner's turn."""
        self.game.reset(seed=seed, options=options)
        self._play_monitor()

    def step(self, action: Any) -> None:
        """The selected learner's turn, then the scripted monitor's, if it comes next."""
        self.game.step(action)
        self._play_monitor()

    def _play_monitor(self) -> None:
        game = self.game
        while self.scripted_monitor and game.agents and game.agent_selection == MONITOR:
            done = game.terminations[MONITOR] or game.truncations[MONITOR]
            game.step(None if done else game.policy_action(MONITOR))

    def observe(self, agent: str) -> Any:
        """A learner's (flattened) observation."""
        observation = self.game.observe(agent)
        if not self.flatten:
            return observation
        return np.asarray(spaces.flatten(self._spaces[agent], observation), np.float32)

    def last(self, observe: bool = True) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """PettingZoo's ``last()`` for the selected learner."""
        _, reward, terminated, truncated, info = self.game.last(observe=False)
        observation = self.observe(self.agent_selection) if observe else None
        return observation, reward, terminated, truncated, info

    def render(self) -> Any:
        """The game's rendering."""
        return self.game.render()

    def close(self) -> None:
        """Close the game."""
        self.game.close()


def _flat_space(space: spaces.Space[Any]) -> spaces.Space[Any]:
    if isinstance(space, spaces.Box) and len(space.shape) == 1:
        return space
    flat = spaces.flatten_space(space)
    if not isinstance(flat, spaces.Box):
        raise TypeError(f"cannot flatten the observation space {space} into a Box")
    return spaces.Box(flat.low.astype(np.float32), flat.high.astype(np.float32), dtype=np.float32)


def env_creator(
    env_id: str, *, scripted_monitor: bool = True, flatten: bool = True, **game_kwargs: Any
) -> Callable[[Any], Any]:
    """A function ``env_config -> PettingZooEnv`` for ``ray.tune.registry.register_env``.

    Args:
        env_id: A registered id.
        scripted_monitor: Hide the monitor and play it with the game's monitor policy.
        flatten: Flatten ``Dict`` observations (see :class:`GameForRLlib`).
        **game_kwargs: The game's arguments (``params``, ``constraints``, ``notification``,
            ``max_episode_steps``, ``nature_observes_state``...); ``nature_action`` is set to
            ``"normalized"`` and, with a learning monitor, ``monitor_action`` to ``"flags"``;
            a learning monitor needs ``monitor_reward`` (``"detection"`` or a function).
            RLlib's ``env_config`` entries override them.

    The returned function raises ``ValueError`` when ``scripted_monitor=False`` and neither
    the game's arguments nor ``env_config`` give a ``monitor_reward``.
    """
    import ns_pz

    game_kwargs["nature_action"] = "normalized"
    if not scripted_monitor:
        game_kwargs["monitor_action"] = "flags"

    def create(env_config: Any = None) -> Any:
        kwargs = {**game_kwargs, **dict(env_config or {})}
        if not scripted_monitor and kwargs.get("monitor_reward") is None:
            raise ValueError(
                "scripted_monitor=False makes the monitor a learner, which needs a reward: "
                "pass monitor_reward='detection' or a function fn(process, flags) -> float "
                "(in the game's arguments or env_config; without one the game pays the monitor "
                "0 and it learns nothing)"
            )
        PettingZooEnv = _rllib("ray.rllib.env.wrappers.pettingzoo_env").PettingZooEnv

        game = ns_pz.make(env_id, **kwargs)
        return PettingZooEnv(GameForRLlib(game, scripted_monitor=scripted_monitor, flatten=flatten))

    return create


def register(env_id: str, **kwargs: Any) -> str:
    """Register ``env_id``'s game with Ray Tune under ``"ns_pz_rllib/<name>"``; returns that name.

    Registering the same id again (with other arguments) replaces the earlier registration in
    this process, for algorithms built afterwards.

    Args:
        env_id: A registered id.
        **kwargs: As in :func:`env_creator`.
    """
    register_env = _rllib("ray.tune.registry").register_env

    name = "ns_pz_rllib/" + env_id.split("/")[-1]
    register_env(name, env_creator(env_id, **kwargs))
    return name


def ppo_config(
    env_id: str,
    *,
    scripted_monitor: bool = True,
    flatten: bool = True,
    seed: int = 0,
    train_batch_size: int = 1000,
    minibatch_size: int = 128,
    num_epochs: int = 4,
    **game_kwargs: Any,
) -> Any:
    """A ``PPOConfig`` (new API stack) with one PPO policy per learner seat of ``env_id``'s game.

    Each seat (``"nature"``, ``"agent"`` and, with ``scripted_monitor=False``, ``"monitor"``)
    is mapped to a policy of its own name with a default RLModule, so nature learns its own
    payoff (``nature_reward``, zero-sum by default) against the learning agent. Sampling runs
    in the driver process (``num_env_runners=0``); raise it with ``config.env_runners(...)``.

    Args:
        env_id: A registered id.
        scripted_monitor: Hide the monitor and play it with the game's monitor policy;
            ``False`` gives the monitor a PPO policy of its own too (flag actions).
        flatten: Flatten ``Dict`` observations in the environment; ``False`` flattens them
            with RLlib's ``FlattenObservations`` env-to-module connector instead.
        seed: ``config.debugging(seed=...)``: RLlib's and the episodes' seeds.
        train_batch_size: Env steps (of all learners together) per training iteration.
        minibatch_size: PPO's SGD minibatch.
        num_epochs: PPO's epochs over each batch.
        **game_kwargs: The game's arguments (see :func:`env_creator`).

    Returns:
        A ``ray.rllib.algorithms.ppo.PPOConfig``; ``config.build_algo()`` gives the algorithm.
    """
    PPOConfig = _rllib("ray.rllib.algorithms.ppo").PPOConfig
    MultiRLModuleSpec = _rllib("ray.rllib.core.rl_module.multi_rl_module").MultiRLModuleSpec
    RLModuleSpec = _rllib("ray.rllib.core.rl_module.rl_module").RLModuleSpec

    name = register(env_id, scripted_monitor=scripted_monitor, flatten=flatten, **game_kwargs)
    seats = [NATURE, DECISION] if scripted_monitor else [NATURE, MONITOR, DECISION]
    config = (
        PPOConfig()
        .environment(name)
        .env_runners(num_env_runners=0, **_connector(flatten))
        .multi_agent(policies=set(seats), policy_mapping_fn=_seat_policy)
        .rl_module(
            rl_module_spec=MultiRLModuleSpec(rl_module_specs={s: RLModuleSpec() for s in seats})
        )
        .training(
            train_batch_size=train_batch_size, minibatch_size=minibatch_size, num_epochs=num_epochs
        )
        .debugging(seed=seed)
    )
    return config


def _seat_policy(agent_id: Any, episode: Any, **kwargs: Any) -> str:
    """Every seat is trained by the policy of its own name."""
    return str(agent_id)


def _connector(flatten: bool) -> dict[str, Any]:
    if flatten:
        return {}
    FlattenObservations = _rllib("ray.rllib.connectors.env_to_module").FlattenObservations

    return {
        "env_to_module_connector": lambda env, spaces=None, device=None: FlattenObservations(
            multi_agent=True
        )
    }


def _rllib(module: str) -> Any:
    """``module`` of Ray, or a :class:`~ns_pz.errors.MissingExtra` naming the ``rllib`` extra."""
    return require(module, "ns_pz.learning.rllib", extra="rllib")
