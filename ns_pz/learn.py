"""Training any seat with Stable-Baselines3: a nature adversary, and RARL-style alternation.

Needs the ``learn`` extra (stable-baselines3 and torch; on a CPU-only machine install
``torch==2.13.0`` first, see the README). Nothing else in ns_pz imports this module.

* :func:`train` trains one SB3 model in an environment of :func:`ns_pz.single_agent`.
* :func:`train_adversary` trains nature against a fixed decision agent.
* :func:`rarl` alternates (Pinto et al., 2017): each round the agent learns against the frozen
  nature, then nature against the frozen agent, with a checkpoint of both and a log line per
  round.

Opponents act deterministically (``predict(..., deterministic=True)``), so they draw nothing
from torch's generator; the learner's own sampling is seeded by SB3 from ``seed``. One seed
reproduces a run on the same machine and torch build.
"""

from __future__ import annotations

import inspect
import json
import math
import os
import statistics
import sys
import time
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import stable_baselines3
from gymnasium import spaces
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.logger import HumanOutputFormat, KVWriter, Logger

from ns_pz.checks import count
from ns_pz.nature.interface import DEFAULT_STEP
from ns_pz.nature.learned import PolicyNature
from ns_pz.process import DECISION, NATURE
from ns_pz.regret import RegretReference
from ns_pz.seat_policies import DecisionPolicy, call_policy, check_policy, is_agent
from ns_pz.seats import single_agent
from ns_pz.views import NSGymEnv


@dataclass(frozen=True)
class TrainArgs:
    """How one seat is trained."""

    algo: str = "PPO"
    """A Stable-Baselines3 algorithm by name (``"PPO"``, ``"A2C"``, ``"SAC"``, ``"DQN"``...)."""
    total_timesteps: int = 20_000
    """Learner steps per training call (per RARL round for that side)."""
    hyperparameters: Mapping[str, Any] = field(default_factory=dict)
    """Keyword arguments of the SB3 constructor (``n_steps``, ``learning_rate``, ``verbose``...;
    not ``policy``, ``env`` or ``seed``, which training sets)."""

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


def make_model(env: gym.Env, args: TrainArgs, seed: int) -> BaseAlgorithm:
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


def train(env: gym.Env, args: TrainArgs, seed: int) -> BaseAlgorithm:
    """Train a fresh model of ``args`` on ``env`` for ``args.total_timesteps`` steps."""
    model = make_model(env, args, seed)
    model.learn(total_timesteps=args.total_timesteps)
    return model


def train_adversary(
    env_id: str,
    agent: Any,
    *,
    args: TrainArgs | None = None,
    seed: int = 0,
    nature_reward: str = "zero_sum",
    nature_action: str = "normalized",
    nature_observes_state: bool = False,
    default_step: float = DEFAULT_STEP,
    **env_kwargs: Any,
) -> BaseAlgorithm:
    """Train nature against a fixed decision agent; returns the SB3 model.

    Put it back anywhere with ``PolicyNature(model, action=nature_action,
    observes_state=nature_observes_state, default_step=default_step)``.

    Args:
        env_id: A registered id.
        agent: The decision agent (a callable, an SB3 model or an ns_pz ``Agent``).
        args: How nature trains (default: PPO for 20,000 steps).
        seed: Seeds SB3 and every episode.
        nature_reward: ``"zero_sum"`` or ``"regret"`` (see :func:`ns_pz.single_agent`).
        nature_action: Nature's action convention, ``"normalized"`` or ``"delta"``.
        nature_observes_state: Nature sees the agent's state and last action.
        default_step: Allowance of a parameter without a Lipschitz bound (fraction of θ_0).
        **env_kwargs: The environment's arguments (``constraints``, ``notification``, ...).
    """
    env = single_agent(
        env_id,
        NATURE,
        {DECISION: agent},
        nature_reward=nature_reward,
        nature_action=nature_action,
        nature_observes_state=nature_observes_state,
        default_step=default_step,
        **env_kwargs,
    )
    return train(env, args or TrainArgs(), seed)


@dataclass(frozen=True)
class RoundLog:
    """What one RARL round did."""

    round: int
    agent_timesteps: int
    nature_timesteps: int
    agent_seconds: float
    nature_seconds: float
    agent_return_mean: float
    """Mean return of the agent against the round's final nature, over the evaluation seeds."""
    agent_return_se: float


@dataclass
class RarlResult:
    """The two trained models and the log of every round."""

    agent: BaseAlgorithm
    nature: BaseAlgorithm
    log: list[RoundLog]


def rarl(
    env_id: str,
    *,
    rounds: int = 3,
    agent_args: TrainArgs | None = None,
    nature_args: TrainArgs | None = None,
    seed: int = 0,
    out_dir: str | os.PathLike[str] | None = None,
    eval_episodes: int = 10,
    nature_reward: str = "zero_sum",
    regret_reference: RegretReference | None = None,
    nature_action: str = "normalized",
    nature_observes_state: bool = False,
    default_step: float = DEFAULT_STEP,
    **env_kwargs: Any,
) -> RarlResult:
    """Robust adversarial RL: agent and nature take turns learning against each other.

    Each round the agent learns for ``agent_args.total_timesteps`` against the nature as it is
    (round 1: an untrained nature), then nature learns for ``nature_args.total_timesteps``
    against the agent as it is; both continue their training from round to round.

    Args:
        env_id: A registered id.
        rounds: Number of rounds, >= 1.
        agent_args: How the agent trains (default: PPO, 20,000 steps a round).
        nature_args: How nature trains (default: PPO, 20,000 steps a round).
        seed: Seeds both models and every episode.
        out_dir: Where ``round_K/agent.zip``, ``round_K/nature.zip`` and ``log.jsonl`` go
            (written as each round ends); ``None``: nothing is written. A folder that already
            holds a run is refused.
        eval_episodes: Episodes (seeds ``seed + 10_000 ...``) of the agent against the round's
            nature, for the log.
        nature_reward: Nature's payoff, ``"zero_sum"`` (RARL's) or another of
            :func:`ns_pz.single_agent`'s.
        regret_reference: The reference of ``"regret"`` (see :func:`ns_pz.single_agent`).
        nature_action: Nature's action convention, ``"normalized"`` or ``"delta"``; the agent
            meets nature's model under the same one.
        nature_observes_state: Nature sees the agent's state and last action.
        default_step: Allowance of a parameter without a Lipschitz bound (see
            :mod:`ns_pz.nature.interface`).
        **env_kwargs: The environment's arguments (``constraints``, ``notification``, ...).

    Raises:
        ValueError: ``rounds`` or ``eval_episodes`` below 1, or ``out_dir`` holds a run.
    """
    rounds = count("rounds", rounds)
    eval_episodes = count("eval_episodes", eval_episodes)
    if out_dir is not None:
        held = [
            p.name
            for p in Path(out_dir).glob("*")
            if p.name == "log.jsonl" or p.name.startswith("round_")
        ]
        if held:
            raise ValueError(
                f"out_dir={str(out_dir)!r} already holds a RARL run ({', '.join(sorted(held))}); "
                "give a new folder"
            )
    agent_args = agent_args or TrainArgs()
    nature_args = nature_args or TrainArgs()
    nature_seat = _Seat()
    agent_seat = _Seat()
    nature_policy = PolicyNature(
        nature_seat,
        action=nature_action,
        observes_state=nature_observes_state,
        default_step=default_step,
    )
    agent_env = single_agent(env_id, DECISION, {NATURE: nature_policy}, **env_kwargs)
    eval_env = single_agent(env_id, DECISION, {NATURE: nature_policy}, **env_kwargs)
    nature_env = single_agent(
        env_id,
        NATURE,
        {DECISION: agent_seat},
        nature_reward=nature_reward,
        nature_action=nature_action,
        nature_observes_state=nature_observes_state,
        default_step=default_step,
        regret_reference=regret_reference,
        **env_kwargs,
    )
    agent_model = agent_seat.model = make_model(agent_env, agent_args, seed)
    nature_model = nature_seat.model = make_model(nature_env, nature_args, seed + 1)
    log: list[RoundLog] = []
    for index in range(1, rounds + 1):
        started = time.perf_counter()
        agent_model.learn(agent_args.total_timesteps, reset_num_timesteps=False)
        agent_seconds = time.perf_counter() - started
        started = time.perf_counter()
        nature_model.learn(nature_args.total_timesteps, reset_num_timesteps=False)
        nature_seconds = time.perf_counter() - started
        eval_seeds = range(seed + 10_000, seed + 10_000 + eval_episodes)
        returns = episode_returns(eval_env, agent_model, eval_seeds)
        mean, se = mean_and_se(returns)
        entry = RoundLog(
            index,
            agent_model.num_timesteps,
            nature_model.num_timesteps,
            agent_seconds,
            nature_seconds,
            mean,
            se,
        )
        log.append(entry)
        if out_dir is not None:
            _checkpoint(Path(out_dir), entry, agent_model, nature_model)
    return RarlResult(agent_model, nature_model, log)


def episode_returns(env: gym.Env, policy: Any, seeds: range | list[int]) -> list[float]:
    """The learner's return in ``env``, one episode per seed, ``policy`` deterministic.

    ``policy`` is a callable ``obs -> action``, an SB3-style model or, in an agent's view
    (:func:`ns_pz.single_agent` with ``learner="agent"``), an ns_pz ``Agent``, which is handed
    the planning model the notification level allows and a generator from the seed.

    Raises:
        TypeError: ``policy`` cannot act, or is an ns_pz ``Agent`` outside an agent's view.
    """
    view: Any = env.unwrapped
    decide = None
    if is_agent(policy):
        if not isinstance(view, NSGymEnv):
            raise TypeError(
                f"policy={policy!r} is an ns_pz Agent, which plays the decision agent's seat "
                f"only; {env!r} is not an agent's view"
            )
        decide = DecisionPolicy(policy)
    else:
        check_policy(policy, NATURE, "policy")
    returns = []
    for seed in seeds:
        observation, _ = env.reset(seed=seed)
        if decide is not None:
            decide.reset(view.process.seat_rng())
        total, done = 0.0, False
        while not done:
            if decide is not None:
                action = decide(view.process)
            else:
                action = call_policy(policy, observation, deterministic=True)
            observation, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            done = terminated or truncated
        returns.append(total)
    return returns


def mean_and_se(values: list[float]) -> tuple[float, float]:
    """Mean and standard error (ddof=1; 0 for one value)."""
    mean = statistics.fmean(values)
    se = statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0
    return mean, se


class _Seat:
    """Stands for a model that is still being built, so two models can play against each other."""

    model: BaseAlgorithm | None = None

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[Any, Any]:
        if self.model is None:
            raise RuntimeError("the opponent's model is not built yet")
        return self.model.predict(observation, deterministic=True)


def _checkpoint(out: Path, entry: RoundLog, agent: BaseAlgorithm, nature: BaseAlgorithm) -> None:
    folder = out / f"round_{entry.round}"
    folder.mkdir(parents=True, exist_ok=True)
    agent.save(folder / "agent.zip")
    nature.save(folder / "nature.zip")
    with open(out / "log.jsonl", "a", encoding="utf-8") as handle:
        handle.write(json.dumps(asdict(entry)) + "\n")
