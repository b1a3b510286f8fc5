"""Robust adversarial RL: agent and nature take turns learning, optionally against a population.

:func:`rarl` alternates (Pinto et al., 2017): each round the agent learns against nature as it
is, then nature learns against the agent as it is; both continue their training from round to
round. With ``population=K`` the agent instead meets, each episode, one nature drawn uniformly
from a pool: the current nature and the last ``K`` natures it met in earlier rounds (frozen
snapshots): fictitious-play style, so the agent cannot overfit to the latest adversary
and forget the earlier ones. Each round can also be scored against a fixed suite of natures
(``eval_suite``), the evaluation callback of a robust-RL run.

Each side's environments run in this process by default, where the opponent is the other
side's live model. With ``vec_env="subproc"`` they run in subprocesses, one each: as a side only
learns while the other is fixed, every phase ships a frozen copy of the opponent's policy (and
of the pool's snapshots) to a fresh set of subprocesses, seeded per phase.

Needs the ``learn`` extra (stable-baselines3 and torch).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from stable_baselines3.common.base_class import BaseAlgorithm

from ns_pz.checks import SB3_SEEDS, count, flag, seed_value
from ns_pz.learning.rollouts import episode_returns, mean_and_se
from ns_pz.learning.seats import single_agent
from ns_pz.learning.training import (
    VEC_ENVS,
    NatureSeatFactory,
    TrainArgs,
    make_model,
    make_seat_env,
)
from ns_pz.nature.interface import DEFAULT_STEP
from ns_pz.nature.learned import PolicyNature
from ns_pz.nature.policies import Nature, Proposal
from ns_pz.params import Params
from ns_pz.process import DECISION, NATURE
from ns_pz.regret import RegretReference

if TYPE_CHECKING:
    from ns_pz.process import NSProcess


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
    population: int = 1
    """Natures the agent met this round (1 without a population)."""
    suite_returns: Mapping[str, float] = field(default_factory=dict)
    """The agent's mean return against each nature of ``eval_suite`` after the round."""


@dataclass
class RarlResult:
    """The two trained models, the population of natures and the log of every round."""

    agent: BaseAlgorithm
    nature: BaseAlgorithm
    log: list[RoundLog]
    population: list[Any] = field(default_factory=list)
    """Frozen snapshots of nature's policy as the agent met it in each round (oldest first)."""


class PopulationNature(Nature):
    """Each episode, one nature of a pool, drawn uniformly with nature's generator.

    Args:
        members: The pool: natures (each is bound, and plays whole episodes).

    The pool may grow between episodes (:func:`rarl` appends each round's snapshot); an
    episode keeps the member it drew.
    """

    def __init__(self, members: Sequence[Nature]) -> None:
        if not members:
            raise ValueError("PopulationNature needs at least one member")
        for member in members:
            if not isinstance(member, Nature):
                raise TypeError(f"PopulationNature member {member!r} must be an ns_pz Nature")
        self.members = list(members)
        self._params_cls: type[Params] | None = None

    def bind(self, params_cls: type[Params]) -> None:
        """Bind every member (and members added later, as they are added)."""
        self._params_cls = params_cls
        for member in self.members:
            member.bind(params_cls)

    def add(self, member: Nature) -> None:
        """Add a member to the pool (bound at once if the pool is)."""
        if not isinstance(member, Nature):
            raise TypeError(f"member={member!r} must be an ns_pz Nature")
        if self._params_cls is not None:
            member.bind(self._params_cls)
        self.members.append(member)

    def initial_memory(self) -> Any:
        """``[member index or None, the member's memory]``; the member is drawn at step 0."""
        return [None, None]

    def act(self, process: NSProcess) -> Proposal:
        """The drawn member's move."""
        memory = process.nature_memory
        if memory[0] is None:
            rng = process.nature_rng
            memory[0] = int(rng.integers(len(self.members))) if rng is not None else 0
            memory[1] = self.members[memory[0]].initial_memory()
        member = self.members[memory[0]]
        process.nature_memory = memory[1]
        try:
            return member.act(process)
        finally:
            memory[1] = process.nature_memory
            process.nature_memory = memory

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """Not used: :meth:`act` asks the member (which may read more than the proposal's)."""
        raise NotImplementedError("PopulationNature acts through act(process)")

    def __repr__(self) -> str:
        return f"PopulationNature({len(self.members)} members)"


def rarl(
    env_id: str,
    *,
    rounds: int = 3,
    agent_args: TrainArgs | None = None,
    nature_args: TrainArgs | None = None,
    seed: int = 0,
    out_dir: str | os.PathLike[str] | None = None,
    eval_episodes: int = 10,
    eval_suite: Mapping[str, Nature] | None = None,
    population: int | None = None,
    n_envs: int = 1,
    vec_env: str = "dummy",
    deterministic_opponents: bool = True,
    nature_reward: str = "zero_sum",
    regret_reference: RegretReference | None = None,
    nature_action: str = "normalized",
    nature_observes_state: bool = False,
    default_step: float = DEFAULT_STEP,
    **env_kwargs: Any,
) -> RarlResult:
    """Robust adversarial RL: agent and nature take turns learning against each other.

    Each round the agent learns for ``agent_args.total_timesteps`` against the nature as it is
    (round 1: an untrained nature) or, with ``population``, against natures drawn from the
    pool; then nature learns for ``nature_args.total_timesteps`` against the agent as it is.

    Args:
        env_id: A registered id.
        rounds: Number of rounds, >= 1.
        agent_args: How the agent trains (default: PPO, 20,000 steps a round).
        nature_args: How nature trains (default: PPO, 20,000 steps a round).
        seed: Seeds both models and every episode.
        out_dir: Where ``round_K/agent.zip``, ``round_K/nature.zip`` and ``log.jsonl`` go
            (written as each round ends); ``None``: nothing is written. A folder that already
            holds a run, or a path that is a file, is refused before any training.
        eval_episodes: Episodes (seeds ``seed + 10_000 ...``) of the agent against the round's
            nature and against each nature of ``eval_suite``, for the log.
        eval_suite: Natures by label the agent is scored against after every round (the same
            seeds for each).
        population: Pool size: the agent trains against natures drawn per episode from the
            current nature and the last ``population`` natures it met in earlier rounds (round
            1: the untrained one); ``None`` (default): the current nature only (plain RARL).
        n_envs: Environments each side trains in at once.
        vec_env: ``"dummy"`` (in this process, the opponent's live model shared) or
            ``"subproc"`` (a subprocess each, rebuilt every phase with a frozen copy of the
            opponent; worth it where the cores outnumber the overhead of spawning them:
            the seeds of the episodes then differ from ``"dummy"``'s, so the runs do too).
        deterministic_opponents: Whether each side meets the other's deterministic policy
            (default) or samples it from the episode's seed.
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
        ValueError / TypeError: A bad argument, before any training.
    """
    rounds = count("rounds", rounds)
    eval_episodes = count("eval_episodes", eval_episodes)
    n_envs = count("n_envs", n_envs)
    seed = seed_value("seed", seed, SB3_SEEDS)
    for name, given in (("agent_args", agent_args), ("nature_args", nature_args)):
        if given is not None and not isinstance(given, TrainArgs):
            raise TypeError(f"{name}={given!r} must be a TrainArgs or None (PPO, 20,000 steps)")
    if "nature" in env_kwargs:
        raise TypeError(
            f"nature={env_kwargs['nature']!r}: rarl trains nature itself; score the agent "
            "against other natures with eval_suite"
        )
    if vec_env not in VEC_ENVS:
        raise ValueError(f"vec_env={vec_env!r}; allowed: {VEC_ENVS}")
    subproc = vec_env == "subproc" and n_envs > 1
    deterministic = flag("deterministic_opponents", deterministic_opponents)
    if population is not None:
        population = count("population", population)
    suite = _check_suite(eval_suite)
    _check_out_dir(out_dir)
    agent_args = agent_args or TrainArgs()
    nature_args = nature_args or TrainArgs()
    nature_seat, agent_seat = _Seat(), _Seat()
    conventions = {
        "action": nature_action,
        "observes_state": nature_observes_state,
        "default_step": default_step,
    }
    current = PolicyNature(nature_seat, deterministic=deterministic, **conventions)
    pool = PopulationNature([current]) if population is not None else None
    agent_nature = pool if pool is not None else current
    nature_options = {
        "nature_reward": nature_reward,
        "nature_action": nature_action,
        "nature_observes_state": nature_observes_state,
        "default_step": default_step,
        "regret_reference": regret_reference,
        "deterministic": deterministic,
        **env_kwargs,
    }
    agent_env = make_seat_env(_AgentSide(env_id, agent_nature, env_kwargs), n_envs)
    nature_env = make_seat_env(NatureSeatFactory(env_id, agent_seat, nature_options), n_envs)
    eval_seeds = range(seed + 10_000, seed + 10_000 + eval_episodes)
    evaluate = {"current": PolicyNature(nature_seat, **conventions), **suite}
    agent_model = agent_seat.model = make_model(agent_env, agent_args, seed)
    nature_model = nature_seat.model = make_model(nature_env, nature_args, seed + 1)
    if subproc:  # the in-process envs only gave the models their spaces
        agent_env.close()
        nature_env.close()
    snapshots: list[Any] = []
    log: list[RoundLog] = []
    for index in range(1, rounds + 1):
        met = 1 if pool is None else len(pool.members)
        started = time.perf_counter()
        if subproc:
            frozen = PolicyNature(
                _frozen(nature_model.policy), deterministic=deterministic, **conventions
            )
            met_now = frozen if pool is None else PopulationNature([frozen, *pool.members[1:]])
            agent_env = _phase_env(
                _AgentSide(env_id, met_now, env_kwargs), n_envs, seed + _PHASE_SEEDS * index
            )
        _learn(agent_model, agent_args.total_timesteps, agent_env if subproc else None)
        agent_seconds = time.perf_counter() - started
        # The nature the agent has just met joins the pool before it learns on: the agent's
        # next round meets it beside its successor (the current nature).
        snapshot = _frozen(nature_model.policy)
        snapshots.append(snapshot)
        if pool is not None:
            pool.add(PolicyNature(snapshot, deterministic=deterministic, **conventions))
            if len(pool.members) > cast(int, population) + 1:
                del pool.members[1]  # the oldest snapshot; the current nature stays first
        started = time.perf_counter()
        if subproc:
            factory = NatureSeatFactory(env_id, _frozen(agent_model.policy), nature_options)
            nature_env = _phase_env(
                factory, n_envs, seed + _PHASE_SEEDS * index + _PHASE_SEEDS // 2
            )
        _learn(nature_model, nature_args.total_timesteps, nature_env if subproc else None)
        nature_seconds = time.perf_counter() - started
        returns = {
            label: _returns(_AgentSide(env_id, nature, env_kwargs)(), agent_model, eval_seeds)
            for label, nature in evaluate.items()
        }
        mean, se = mean_and_se(returns.pop("current"))
        entry = RoundLog(
            index,
            agent_model.num_timesteps,
            nature_model.num_timesteps,
            agent_seconds,
            nature_seconds,
            mean,
            se,
            met,
            {label: float(np.mean(values)) for label, values in returns.items()},
        )
        log.append(entry)
        if out_dir is not None:
            _checkpoint(Path(out_dir), entry, agent_model, nature_model)
    if not subproc:
        agent_env.close()
        nature_env.close()
    return RarlResult(agent_model, nature_model, log, snapshots)


_PHASE_SEEDS = 100_000
"""Spacing of the subprocess phases' episode seeds (clear of the evaluation seeds)."""


class _AgentSide:
    """Builds the agent's seat against ``nature``; picklable, so subprocesses can build it."""

    def __init__(self, env_id: str, nature: Nature, env_kwargs: Mapping[str, Any]) -> None:
        self.env_id = env_id
        self.nature = nature
        self.env_kwargs = dict(env_kwargs)

    def __call__(self) -> Any:
        return single_agent(self.env_id, DECISION, {NATURE: self.nature}, **self.env_kwargs)


def _frozen(policy: Any) -> Any:
    """A copy of an SB3 policy in evaluation mode: a pool snapshot, or an opponent to ship.

    Built anew from the policy's constructor arguments and weights (as SB3's own ``save``
    does): a deep copy fails right after a gradient step, when the policy still holds the
    last action distribution, whose tensors are not graph leaves. The constructor's initial
    weights draw from torch's global generator, which SB3 seeded for training: the draw is
    made in a fork of it, so taking a snapshot changes no later sample.
    """
    import torch

    with torch.random.fork_rng(devices=[]):
        frozen = type(policy)(**policy._get_constructor_parameters())
    frozen.load_state_dict(policy.state_dict())
    frozen.set_training_mode(False)
    return frozen


def _learn(model: Any, steps: int, phase_env: Any | None) -> None:
    """``model`` learns on for ``steps`` steps; in ``phase_env`` (set, then closed) if given.

    A phase's subprocess envs are closed when learning ends, also when it raises.
    """
    if phase_env is not None:
        model.set_env(phase_env)
    try:
        model.learn(steps, reset_num_timesteps=False)
    finally:
        if phase_env is not None:
            phase_env.close()


def _phase_env(factory: Any, n_envs: int, seed: int) -> Any:
    """``n_envs`` subprocesses of ``factory``'s seat, whose next reset uses ``seed + i``."""
    env = make_seat_env(factory, n_envs, vec_env="subproc")
    env.seed(seed)
    return env


def _returns(env: Any, agent: BaseAlgorithm, seeds: range) -> list[float]:
    try:
        return episode_returns(env, agent, seeds)
    finally:
        env.close()


class _Seat:
    """Stands for a model that is still being built, so two models can play against each other."""

    model: BaseAlgorithm | None = None

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[Any, Any]:
        if self.model is None:
            raise RuntimeError("the opponent's model is not built yet")
        return self.model.predict(observation, deterministic=deterministic)


def _check_suite(suite: Any) -> dict[str, Nature]:
    if suite is None:
        return {}
    if not isinstance(suite, Mapping):
        raise TypeError(f"eval_suite={suite!r} must be a mapping of labels to ns_pz Natures")
    for label, nature in suite.items():
        if not isinstance(label, str) or label == "current":
            raise ValueError(
                f"eval_suite has the label {label!r}; use strings other than 'current'"
            )
        if not isinstance(nature, Nature):
            raise TypeError(f"eval_suite[{label!r}]={nature!r} must be an ns_pz Nature")
    return dict(suite)


def _check_out_dir(out_dir: str | os.PathLike[str] | None) -> None:
    if out_dir is None:
        return
    path = Path(out_dir)
    if path.exists() and not path.is_dir():
        raise ValueError(f"out_dir={str(out_dir)!r} is a file; give a folder")
    held = [p.name for p in path.glob("*") if p.name == "log.jsonl" or p.name.startswith("round_")]
    if held:
        raise ValueError(
            f"out_dir={str(out_dir)!r} already holds a RARL run ({', '.join(sorted(held))}); "
            "give a new folder"
        )


def _checkpoint(out: Path, entry: RoundLog, agent: BaseAlgorithm, nature: BaseAlgorithm) -> None:
    folder = out / f"round_{entry.round}"
    folder.mkdir(parents=True, exist_ok=True)
    agent.save(folder / "agent.zip")
    nature.save(folder / "nature.zip")
    with open(out / "log.jsonl", "a", encoding="utf-8") as handle:
        handle.write(json.dumps(asdict(entry)) + "\n")
