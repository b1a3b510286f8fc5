"""Training one seat with Stable-Baselines3, in one or many environments at once.

Needs the ``learn`` extra (stable-baselines3 and torch).

* :func:`train` trains one SB3 model in an environment of :func:`ns_pz.single_agent` (or a
  vector of them: :func:`make_seat_env`; for the decision agent, the batched core:
  :func:`make_agent_vec_env`).
* :func:`train_adversaries` trains several natures against a fixed decision agent, each from
  its own seed, and ranks them on selection episodes; :func:`train_adversary` returns the
  strongest. A single PPO run finds a strong adversary only some of the time (three seeds
  against one CartPole controller gave returns of 500, 500 and 43.7), so restarts matter.

Opponents act deterministically by default (``predict(..., deterministic=True)``);
``deterministic_opponent=False`` samples them from the episode's seed instead. The learner's
own sampling is seeded by SB3 from ``seed``. One seed reproduces a run on the same machine and
torch build.
"""

from __future__ import annotations

import inspect
import sys
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
import stable_baselines3
from gymnasium import spaces
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.logger import HumanOutputFormat, KVWriter, Logger
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv

from ns_pz.checks import SB3_SEEDS, count, flag, seed_value
from ns_pz.learning.rollouts import episode_returns
from ns_pz.learning.seats import single_agent
from ns_pz.nature.interface import DEFAULT_STEP
from ns_pz.nature.learned import PolicyNature
from ns_pz.process import DECISION, NATURE

VEC_ENVS = ("dummy", "subproc")
"""How ``n_envs > 1`` environments run: in this process, or one subprocess each."""

SELECTION_SEED = 20_000
"""Selection episodes of :func:`train_adversaries` use seeds ``seed + SELECTION_SEED ...``."""


@dataclass(frozen=True)
class TrainArgs:
    """How one seat is trained."""

    algo: str = "PPO"
    """A Stable-Baselines3 algorithm by name (``"PPO"``, ``"A2C"``, ``"SAC"``, ``"DQN"``...)."""
    total_timesteps: int = 20_000
    """Learner steps per training call (per RARL round for that side), over all environments."""
    hyperparameters: Mapping[str, Any] = field(default_factory=dict)
    """Keyword arguments of the SB3 constructor (``n_steps``, ``learning_rate``, ``verbose``...;
    not ``policy``, ``env`` or ``seed``, which training sets). PPO's ``n_steps`` is per
    environment: with ``n_envs`` environments a rollout holds ``n_steps * n_envs`` steps."""

    def __post_init__(self) -> None:
        algo = getattr(stable_baselines3, self.algo, None) if isinstance(self.algo, str) else None
        if not (isinstance(algo, type) and issubclass(algo, BaseAlgorithm)):
            raise ValueError(f"algo={self.algo!r} is not a Stable-Baselines3 algorithm")
        object.__setattr__(self, "total_timesteps", count("total_timesteps", self.total_timesteps))
        if not isinstance(self.hyperparameters, Mapping):
            raise TypeError(
                f"hyperparameters={self.hyperparameters!r} must be a mapping of keyword arguments"
            )
        allowed = set(inspect.signature(algo.__init__).parameters) - _SET_BY_TRAINING
        for name in self.hyperparameters:
            if name not in allowed:
                why = "training sets it" if name in _SET_BY_TRAINING else "no such argument"
                raise ValueError(
                    f"hyperparameters[{name!r}] is not allowed for {self.algo} ({why}); "
                    f"allowed: {sorted(allowed)}"
                )


_SET_BY_TRAINING = frozenset({"self", "policy", "env", "seed", "_init_setup_model"})


def make_model(env: gym.Env | VecEnv, args: TrainArgs, seed: int) -> BaseAlgorithm:
    """A fresh SB3 model of ``args.algo`` on ``env`` (``MultiInputPolicy`` for Dict spaces).

    Quiet unless ``args.hyperparameters`` sets ``verbose``. Without ``tensorboard_log`` its
    logger writes nowhere but standard output (at ``verbose >= 1``): SB3's default logger
    would create an empty ``SB3-<date>`` folder in the temporary directory at every ``learn``.
    """
    policy = "MultiInputPolicy" if isinstance(env.observation_space, spaces.Dict) else "MlpPolicy"
    algo = getattr(stable_baselines3, args.algo)
    kwargs = {"verbose": 0, **args.hyperparameters}
    model = algo(policy, env, seed=seed, **kwargs)
    if model.tensorboard_log is None:
        outputs: list[KVWriter] = [HumanOutputFormat(sys.stdout)] if model.verbose >= 1 else []
        model.set_logger(Logger(folder=None, output_formats=outputs))
    return model


def train(env: gym.Env | VecEnv, args: TrainArgs, seed: int) -> BaseAlgorithm:
    """Train a fresh model of ``args`` on ``env`` for ``args.total_timesteps`` steps."""
    model = make_model(env, args, seed)
    model.learn(total_timesteps=args.total_timesteps)
    return model


def make_seat_env(
    make_env: Callable[[], gym.Env], n_envs: int = 1, vec_env: str = "dummy"
) -> gym.Env | VecEnv:
    """One environment from ``make_env``, or ``n_envs`` of them as an SB3 vector env.

    Each environment of a vector is wrapped in SB3's ``Monitor`` (episode statistics in the
    logs) and seeded by the model (``seed + i`` for the ``i``-th).

    Args:
        make_env: Builds one environment; with ``vec_env="subproc"`` it is pickled (with
            cloudpickle) into each subprocess, with what it refers to (the opponent's policy).
        n_envs: Environments stepped at once, >= 1.
        vec_env: ``"dummy"`` (in this process, one after another: the learner's forward pass
            is batched) or ``"subproc"`` (one process each: the environments and the opponents'
            policies run in parallel).

    Raises:
        ValueError: ``n_envs`` below 1 or an unknown ``vec_env``.
    """
    n_envs = count("n_envs", n_envs)
    if vec_env not in VEC_ENVS:
        raise ValueError(f"vec_env={vec_env!r}; allowed: {VEC_ENVS}")
    if n_envs == 1:
        return make_env()
    cls = SubprocVecEnv if vec_env == "subproc" else DummyVecEnv
    kwargs = {"start_method": "spawn"} if vec_env == "subproc" else None
    return make_vec_env(make_env, n_envs=n_envs, vec_env_cls=cls, vec_env_kwargs=kwargs)


def make_agent_vec_env(env_id: str, n_envs: int, **env_kwargs: Any) -> VecEnv:
    """The decision agent's seat as ``n_envs`` environments stepped in one batched call.

    The native vector env (:func:`ns_pz.envs.registry.make_vec`, same-step resets) as an SB3
    ``VecEnv`` (:class:`~ns_pz.learning.sb3_vec.SB3VecEnv`), with SB3's episode statistics
    (``VecMonitor``). For the agent against a nature that needs no live opponent (scripted,
    domain-randomised, a trained :class:`~ns_pz.nature.PolicyNature`), it replaces
    ``make_seat_env(lambda: single_agent(env_id, "agent", ...), n_envs)``. For PPO on CartPole
    the learner's updates dominate: 16,384 steps with 8 environments and domain randomisation
    took 3.1–3.8 CPU-seconds here against 3.3–4.1 with SB3's ``DummyVecEnv`` of single envs
    (three runs each, ``benchmarks/bench_robust.py --throughput``), no measurable difference;
    the batched step pays where the environment, not the learner, is the cost. Where a family
    has no batched kernel the views are stepped one by one inside, with the same result.

    Args:
        env_id: A registered id.
        n_envs: Environments, >= 1; the model seeds the ``i``-th with ``seed + i``.
        **env_kwargs: :func:`~ns_pz.envs.registry.make_vec`'s arguments (``nature``,
            ``constraints``, ``max_episode_steps``, ``notification``...), less
            ``autoreset_mode``, which SB3 fixes.

    Raises:
        ValueError: ``n_envs`` below 1, or ``autoreset_mode`` given.
    """
    from stable_baselines3.common.vec_env import VecMonitor

    from ns_pz.envs.registry import make_vec
    from ns_pz.learning.sb3_vec import SB3VecEnv

    n_envs = count("n_envs", n_envs)
    if "autoreset_mode" in env_kwargs:
        raise ValueError(
            f"autoreset_mode={env_kwargs['autoreset_mode']!r}: SB3 resets in the same step, "
            "leave it out"
        )
    vector = make_vec(env_id, n_envs, autoreset_mode="SameStep", **env_kwargs)
    return VecMonitor(SB3VecEnv(vector))


@dataclass
class AdversaryTrials:
    """Natures trained against one agent, and how strong each proved on selection episodes."""

    models: list[BaseAlgorithm]
    selection_returns: list[float]
    """The agent's mean return against each nature on the selection episodes (lower: stronger)."""
    best: int
    """Index of the strongest nature."""

    @property
    def strongest(self) -> BaseAlgorithm:
        """The strongest nature's model."""
        return self.models[self.best]


def train_adversaries(
    env_id: str,
    agent: Any,
    *,
    restarts: int = 3,
    args: TrainArgs | None = None,
    seed: int = 0,
    selection_episodes: int = 10,
    selection_seed: int | None = None,
    n_envs: int = 1,
    vec_env: str = "dummy",
    deterministic_opponent: bool = True,
    nature_reward: str = "zero_sum",
    nature_action: str = "normalized",
    nature_observes_state: bool = False,
    default_step: float = DEFAULT_STEP,
    **env_kwargs: Any,
) -> AdversaryTrials:
    """Train ``restarts`` natures against a fixed agent and rank them on selection episodes.

    Nature ``k`` trains from seed ``seed + k``. With more than one, each is then scored by the
    agent's mean return (the agent deterministic, nature as put back by
    :class:`~ns_pz.nature.PolicyNature`: deterministic) on ``selection_episodes`` episodes of
    seeds ``selection_seed ...`` (default ``seed + 20,000 ...``), which no training episode
    uses; the lowest is the strongest. Score the strongest on yet other episodes (as
    :func:`ns_pz.learning.evaluate_robustness` does): the minimum over restarts is biased low.

    Args:
        env_id: A registered id.
        agent: The decision agent (a callable, an SB3 model or an ns_pz ``Agent``).
        restarts: Natures trained, >= 1.
        args: How each nature trains (default: PPO for 20,000 steps).
        seed: The first training seed.
        selection_episodes: Episodes per nature for the ranking, >= 1.
        selection_seed: The first selection seed.
        n_envs: Environments each nature trains in at once (:func:`make_seat_env`).
        vec_env: ``"dummy"`` or ``"subproc"``.
        deterministic_opponent: Whether the agent acts deterministically in training (an SB3
            agent: ``predict(..., deterministic=True)``); ``False`` samples it from the seed.
        nature_reward: ``"zero_sum"`` or ``"regret"`` (see :func:`ns_pz.single_agent`).
        nature_action: Nature's action convention, ``"normalized"`` or ``"delta"``.
        nature_observes_state: Nature sees the agent's state and last action.
        default_step: Allowance of a parameter without a Lipschitz bound (fraction of θ_0).
        **env_kwargs: The environment's arguments (``constraints``, ``notification``, ...).

    Raises:
        TypeError / ValueError: A bad argument, before any training.
    """
    restarts = count("restarts", restarts)
    selection_episodes = count("selection_episodes", selection_episodes)
    seed = seed_value("seed", seed, SB3_SEEDS)
    if args is not None and not isinstance(args, TrainArgs):
        raise TypeError(f"args={args!r} must be a TrainArgs or None (PPO for 20,000 steps)")
    if selection_seed is None:
        first = seed + SELECTION_SEED
    else:
        first = seed_value("selection_seed", selection_seed)
    make_env = NatureSeatFactory(
        env_id,
        agent,
        {
            "nature_reward": nature_reward,
            "nature_action": nature_action,
            "nature_observes_state": nature_observes_state,
            "default_step": default_step,
            "deterministic": flag("deterministic_opponent", deterministic_opponent),
            **env_kwargs,
        },
    )
    make_env().close()  # every argument checked before any training
    models, scores = [], []
    for k in range(restarts):
        env = make_seat_env(make_env, n_envs, vec_env)
        try:
            models.append(train(env, args or TrainArgs(), seed + k))
        finally:
            env.close()
        if restarts > 1:
            nature = PolicyNature(
                models[-1],
                action=nature_action,
                observes_state=nature_observes_state,
                default_step=default_step,
            )
            seeds = range(first, first + selection_episodes)
            scores.append(_agent_mean(env_id, agent, nature, seeds, env_kwargs))
    return AdversaryTrials(models, scores, int(np.argmin(scores)) if scores else 0)


def train_adversary(
    env_id: str,
    agent: Any,
    *,
    args: TrainArgs | None = None,
    seed: int = 0,
    restarts: int = 1,
    selection_episodes: int = 10,
    n_envs: int = 1,
    vec_env: str = "dummy",
    deterministic_opponent: bool = True,
    nature_reward: str = "zero_sum",
    nature_action: str = "normalized",
    nature_observes_state: bool = False,
    default_step: float = DEFAULT_STEP,
    **env_kwargs: Any,
) -> BaseAlgorithm:
    """Train nature against a fixed decision agent; returns the SB3 model.

    With ``restarts > 1``, the strongest of that many (see :func:`train_adversaries`, whose
    arguments these are). Put it back anywhere with ``PolicyNature(model,
    action=nature_action, observes_state=nature_observes_state, default_step=default_step)``.
    """
    return train_adversaries(
        env_id,
        agent,
        restarts=restarts,
        args=args,
        seed=seed,
        selection_episodes=selection_episodes,
        n_envs=n_envs,
        vec_env=vec_env,
        deterministic_opponent=deterministic_opponent,
        nature_reward=nature_reward,
        nature_action=nature_action,
        nature_observes_state=nature_observes_state,
        default_step=default_step,
        **env_kwargs,
    ).strongest


class NatureSeatFactory:
    """Builds nature's seat against a fixed agent; picklable, so subprocesses can build it too.

    Args:
        env_id: A registered id.
        agent: The decision agent.
        options: :func:`ns_pz.single_agent`'s keyword arguments.
    """

    def __init__(self, env_id: str, agent: Any, options: Mapping[str, Any]) -> None:
        self.env_id = env_id
        self.agent = agent
        self.options = dict(options)

    def __call__(self) -> gym.Env:
        """A new environment of nature's seat."""
        return single_agent(self.env_id, NATURE, {DECISION: self.agent}, **self.options)


def _agent_mean(
    env_id: str, agent: Any, nature: PolicyNature, seeds: range, env_kwargs: Mapping[str, Any]
) -> float:
    env = single_agent(env_id, DECISION, {NATURE: nature}, **env_kwargs)
    try:
        return float(np.mean(episode_returns(env, agent, seeds)))
    finally:
        env.close()
