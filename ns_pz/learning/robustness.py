"""How robust is a policy? Its returns over a θ grid, a suite of natures and fresh adversaries.

:func:`evaluate_robustness` plays a decision policy (a callable, an SB3 model or an ns_pz
``Agent``) in the agent's view of an environment under several *conditions*:

* ``nominal``: θ_0 as configured, with the configured nature (stationary by default);
* ``grid``: each member of a θ set (:class:`~ns_pz.nature.ThetaSet`, or per-parameter values
  whose product is taken) as the episode's θ_0;
* ``nature``: each nature of a suite (schedules, :class:`~ns_pz.nature.DomainRandomisation`,
  trained natures (:class:`~ns_pz.nature.PolicyNature`)), by label;
* ``adversary``: natures trained against this very policy (:class:`AdversarySearch`: several
  training seeds, the strongest picked on selection episodes, scored on the evaluation ones).

Every condition plays the same episode seeds ``seed, seed + 1, ...`` (common random numbers),
so two policies evaluated with the same ``seed`` meet the same start states and the same
random draws of nature, and conditions are paired seed by seed. The report gives, per group
and per nature, the mean, the worst condition's mean (over a grid), the lower ``alpha``-quantile
and the CVaR of the episode returns, each with a percentile bootstrap interval over seeds
(:mod:`ns_pz.learning.statistics`), as a table and a figure.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ns_pz.checks import count, flag, fraction, seed_value
from ns_pz.learning.rollouts import episode_returns
from ns_pz.learning.statistics import Estimate, bootstrap, cvar, decimals_for, lower_quantile
from ns_pz.nature.interface import DEFAULT_STEP, NATURE_ACTIONS, check_default_step
from ns_pz.nature.policies import Nature
from ns_pz.nature.randomised import ThetaSet
from ns_pz.params import Params
from ns_pz.regret import NATURE_REWARDS
from ns_pz.seat_policies import check_policy

NOMINAL = "nominal"
"""The group (and row) of the condition θ_0 with the configured nature."""
GRID = "grid"
"""The group (and row) of the θ grid's members."""
NATURES = "nature"
"""The group of the suite's natures (each a row of its own label)."""
ADVERSARY = "adversary"
"""The group (and row) of the strongest freshly trained adversary."""

SELECTION_SEED_OFFSET = 1_000_000
"""Selection episodes of trained adversaries use seeds from ``seed + SELECTION_SEED_OFFSET``."""
TRAINING_SEED_OFFSET = 2_000_000
"""Adversary ``k`` trains with seed ``seed + TRAINING_SEED_OFFSET + k``."""


@dataclass(frozen=True)
class AdversarySearch:
    """Natures trained against the evaluated policy; the strongest one is scored.

    Needs the ``learn`` extra (Stable-Baselines3 and torch).
    """

    trials: int = 3
    """Natures trained, each from its own seed."""
    args: Any = None
    """How each trains (a :class:`ns_pz.learning.TrainArgs`; default PPO for 20,000 steps)."""
    selection_episodes: int = 10
    """Episodes (seeds disjoint from the evaluation's) on which the strongest is picked."""
    n_envs: int = 1
    """Environments each nature trains in at once (see :func:`ns_pz.learning.train_adversary`)."""
    nature_reward: str = "zero_sum"
    """Nature's payoff in training (see :func:`ns_pz.single_agent`)."""
    nature_action: str = "normalized"
    """Nature's action convention."""
    nature_observes_state: bool = False
    """Whether nature sees the agent's state and last action."""
    default_step: float = DEFAULT_STEP
    """Allowance of a parameter without a Lipschitz bound (fraction of θ_0)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "trials", count("trials", self.trials))
        object.__setattr__(
            self, "selection_episodes", count("selection_episodes", self.selection_episodes)
        )
        object.__setattr__(self, "n_envs", count("n_envs", self.n_envs))
        if self.nature_reward not in NATURE_REWARDS:
            raise ValueError(f"nature_reward={self.nature_reward!r}; allowed: {NATURE_REWARDS}")
        if self.nature_action not in NATURE_ACTIONS:
            raise ValueError(f"nature_action={self.nature_action!r}; allowed: {NATURE_ACTIONS}")
        flag("nature_observes_state", self.nature_observes_state)
        object.__setattr__(self, "default_step", check_default_step(self.default_step))
        train_args = isinstance(getattr(self.args, "algo", None), str) and hasattr(
            self.args, "total_timesteps"
        )  # a TrainArgs, told apart without importing Stable-Baselines3
        if self.args is not None and not train_args:
            raise TypeError(
                f"args={self.args!r} must be an ns_pz.learning.TrainArgs (or None: PPO for "
                "20,000 steps)"
            )


@dataclass(frozen=True)
class Condition:
    """The returns of one condition, one per evaluation seed."""

    label: str
    group: str
    """``"nominal"``, ``"grid"``, ``"nature"`` or ``"adversary"``."""
    returns: tuple[float, ...]
    params: Mapping[str, Any] | None = None
    """The grid member's θ_0 values (grid conditions only)."""

    @property
    def mean(self) -> float:
        """Mean return."""
        return float(np.mean(self.returns))


@dataclass(frozen=True)
class Summary:
    """Statistics of a row of the report (a group of conditions or one condition)."""

    label: str
    conditions: int
    mean: Estimate
    worst: Estimate | None
    """The worst condition's mean (rows of several conditions only)."""
    quantile: Estimate
    cvar: Estimate


@dataclass
class RobustnessReport:
    """What :func:`evaluate_robustness` measured."""

    env_id: str
    seeds: tuple[int, ...]
    alpha: float
    confidence: float
    conditions: list[Condition]
    rows: list[Summary]
    adversaries: list[Any] = field(default_factory=list)
    """The trained adversary models, in training-seed order."""
    selection_returns: list[float] = field(default_factory=list)
    """The policy's mean return against each trained adversary on the selection episodes."""
    strongest: int | None = None
    """Index of the adversary scored (the lowest selection return)."""

    def row(self, label: str) -> Summary:
        """The summary row of ``label`` (``"nominal"``, ``"grid"``, a nature's label, ...).

        Raises:
            KeyError: No such row; the message lists them.
        """
        for summary in self.rows:
            if summary.label == label:
                return summary
        raise KeyError(f"no row {label!r}; rows: {[s.label for s in self.rows]}")

    def table(self) -> str:
        """The summary as a Markdown table (value [low, high] per statistic).

        Returns are shown with 3 decimals when every one lies below 10 in size, else 1.
        """
        q = f"{self.alpha:g}"
        lines = [
            f"| condition | n | mean | worst | {q}-quantile | CVaR {q} |",
            "|---|---|---|---|---|---|",
        ]
        largest = max(abs(v) for c in self.conditions for v in c.returns)
        digits = decimals_for(largest)
        for s in self.rows:
            worst = "" if s.worst is None else s.worst.format(digits)
            cells = (s.mean.format(digits), worst, s.quantile.format(digits), s.cvar.format(digits))
            lines.append(f"| {s.label} | {s.conditions} | " + " | ".join(cells) + " |")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary of every condition's returns and every summary row."""

        def estimate(e: Estimate | None) -> list[float] | None:
            return None if e is None else [e.value, e.low, e.high]

        return {
            "env_id": self.env_id,
            "seeds": list(self.seeds),
            "alpha": self.alpha,
            "confidence": self.confidence,
            "conditions": [
                {
                    "label": c.label,
                    "group": c.group,
                    "params": None if c.params is None else dict(c.params),
                    "returns": list(c.returns),
                }
                for c in self.conditions
            ],
            "rows": [
                {
                    "label": s.label,
                    "conditions": s.conditions,
                    "mean": estimate(s.mean),
                    "worst": estimate(s.worst),
                    "quantile": estimate(s.quantile),
                    "cvar": estimate(s.cvar),
                }
                for s in self.rows
            ],
            "selection_returns": self.selection_returns,
            "strongest": self.strongest,
        }

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text."""
        return json.dumps(self.to_dict(), indent=1)

    def plot(self, path: str | None = None) -> Any:
        """A figure: a heatmap of the grid's means (a 2-parameter product grid) and a bar per row.

        Needs matplotlib (the ``plot`` extra). Saved to ``path`` if given.

        Returns:
            The matplotlib ``Figure``.
        """
        from ns_pz.learning.robustness_plot import plot_report

        return plot_report(self, path)


def evaluate_robustness(
    policy: Any,
    env_id: str,
    *,
    grid: ThetaSet | Mapping[str, Sequence[Any]] | None = None,
    natures: Mapping[str, Nature] | None = None,
    adversaries: AdversarySearch | None = None,
    episodes: int = 20,
    seed: int = 0,
    alpha: float = 0.1,
    confidence: float = 0.95,
    bootstrap_reps: int = 2000,
    **env_kwargs: Any,
) -> RobustnessReport:
    """Score ``policy`` under θ_0, a θ grid, a suite of natures and fresh adversaries.

    Args:
        policy: The decision policy: a callable ``obs -> action``, an SB3 model (asked
            deterministically) or an ns_pz ``Agent``.
        env_id: A registered id.
        grid: θ_0 values to evaluate at: a :class:`~ns_pz.nature.ThetaSet` or a mapping of
            parameter names to values (their product). Each member overrides the
            parameters it names of ``env_kwargs["params"]`` and is every episode's θ_0 (set
            at reset, as ``reset(options={"params": ...})`` does): a nature of
            ``env_kwargs`` that draws θ_0 (:class:`~ns_pz.nature.DomainRandomisation`) does
            not redraw it, and one that changes θ within an episode does so from it. The
            decision agent knows θ_0 as it knows the ``params`` of an environment: an ns_pz
            ``Agent`` plans with it (at every notification level), where under domain
            randomisation its model has the nominal θ_0 and the drawn one stays hidden.
        natures: A suite of natures by label, each replacing ``env_kwargs["nature"]``.
        adversaries: Train natures against ``policy`` and score the strongest.
        episodes: Evaluation episodes per condition (seeds ``seed ...``).
        seed: The first evaluation seed; also seeds the bootstrap and adversary training.
        alpha: Level of the lower quantile and the CVaR, in (0, 1).
        confidence: Coverage of the bootstrap intervals, in (0, 1).
        bootstrap_reps: Bootstrap resamples per statistic.
        **env_kwargs: The environment's arguments for every condition (``params``,
            ``nature``, ``constraints``, ``notification``, ``max_episode_steps``, ...).

    Returns:
        A :class:`RobustnessReport`.

    Raises:
        TypeError / ValueError: A bad argument, before any episode runs.
    """
    from ns_pz.learning.seats import single_agent

    check_policy(policy, "agent", "policy")
    episodes = count("episodes", episodes)
    bootstrap_reps = count("bootstrap_reps", bootstrap_reps)
    seed = seed_value("seed", seed)
    alpha = fraction("alpha", alpha)
    confidence = fraction("confidence", confidence)
    members = _grid_members(grid)
    suite = _check_natures(natures, env_kwargs)
    if adversaries is not None and not isinstance(adversaries, AdversarySearch):
        raise TypeError(f"adversaries={adversaries!r} must be an AdversarySearch or None")
    seeds = tuple(range(seed, seed + episodes))
    nominal = single_agent(env_id, "agent", **env_kwargs)  # every env argument checked here
    view: Any = nominal.unwrapped  # the agent's view (an NSGymEnv)
    try:  # every grid member checked before any episode: its θ_0 (UnknownParam, out of range)
        theta0s = [view.process.base_theta0.replace(**m) for m in members]
    finally:
        nominal.close()

    def play(theta0: Params | None = None, **overrides: Any) -> tuple[float, ...]:
        options = None
        if theta0 is not None:  # the episodes' θ_0, not redrawn (see grid above)
            overrides["params"] = theta0
            options = {"params": theta0}
        env = single_agent(env_id, "agent", **{**env_kwargs, **overrides})
        try:
            return tuple(episode_returns(env, policy, seeds, options))
        finally:
            env.close()

    conditions = [Condition(NOMINAL, NOMINAL, play())]
    for member, theta0 in zip(members, theta0s, strict=True):
        label = ", ".join(f"{k}={_short(v)}" for k, v in member.items())
        conditions.append(Condition(label, GRID, play(theta0), _plain(member)))
    for label, nature in suite.items():
        conditions.append(Condition(label, NATURES, play(nature=nature)))
    report_extra: dict[str, Any] = {}
    if adversaries is not None:
        report_extra = _find_adversary(policy, env_id, adversaries, int(seed), env_kwargs)
        strongest = report_extra.pop("nature")
        conditions.append(Condition(ADVERSARY, ADVERSARY, play(nature=strongest)))
    rng = np.random.default_rng(int(seed))
    rows = _summarise(conditions, alpha, confidence, bootstrap_reps, rng)
    return RobustnessReport(
        env_id, seeds, float(alpha), float(confidence), conditions, rows, **report_extra
    )


def _summarise(
    conditions: list[Condition], alpha: float, confidence: float, reps: int, rng: Any
) -> list[Summary]:
    def summary(label: str, group: list[Condition]) -> Summary:
        table = np.array([c.returns for c in group]).T  # [episodes, conditions]: seeds paired
        kw = {"confidence": confidence, "reps": reps, "rng": rng}

        def pooled(batch: np.ndarray) -> np.ndarray:  # [batch, episodes * conditions]
            return batch.reshape(len(batch), -1)

        worst = None
        if len(group) > 1:
            worst = bootstrap(table, lambda b: b.mean(axis=1).min(axis=-1), **kw)
        return Summary(
            label,
            len(group),
            bootstrap(table, lambda b: pooled(b).mean(axis=-1), **kw),
            worst,
            bootstrap(table, lambda b: lower_quantile(pooled(b), alpha), **kw),
            bootstrap(table, lambda b: cvar(pooled(b), alpha), **kw),
        )

    rows = [summary(NOMINAL, [conditions[0]])]
    grid = [c for c in conditions if c.group == GRID]
    if grid:
        rows.append(summary(GRID, grid))
    rows.extend(summary(c.label, [c]) for c in conditions if c.group in (NATURES, ADVERSARY))
    if len(conditions) > 1:
        rows.append(summary("all", conditions))
    return rows


def _find_adversary(
    policy: Any, env_id: str, search: AdversarySearch, seed: int, env_kwargs: dict[str, Any]
) -> dict[str, Any]:
    from ns_pz.learning.seats import single_agent
    from ns_pz.learning.training import train_adversary
    from ns_pz.nature.learned import PolicyNature

    models, selection = [], []
    selection_seeds = range(
        seed + SELECTION_SEED_OFFSET, seed + SELECTION_SEED_OFFSET + search.selection_episodes
    )
    nature_options = {
        "action": search.nature_action,
        "observes_state": search.nature_observes_state,
        "default_step": search.default_step,
    }
    kwargs = {k: v for k, v in env_kwargs.items() if k != "nature"}
    for k in range(search.trials):
        model = train_adversary(
            env_id,
            policy,
            args=search.args,
            seed=seed + TRAINING_SEED_OFFSET + k,
            n_envs=search.n_envs,
            nature_reward=search.nature_reward,
            nature_action=search.nature_action,
            nature_observes_state=search.nature_observes_state,
            default_step=search.default_step,
            **kwargs,
        )
        env = single_agent(env_id, "agent", nature=PolicyNature(model, **nature_options), **kwargs)
        selection.append(float(np.mean(episode_returns(env, policy, selection_seeds))))
        models.append(model)
    strongest = int(np.argmin(selection))
    return {
        "nature": PolicyNature(models[strongest], **nature_options),
        "adversaries": models,
        "selection_returns": selection,
        "strongest": strongest,
    }


def _grid_members(grid: Any) -> list[dict[str, Any]]:
    if grid is None:
        return []
    if isinstance(grid, ThetaSet):
        return [dict(m) for m in grid]
    if isinstance(grid, Mapping):
        return [dict(m) for m in ThetaSet.grid(grid)]
    raise TypeError(
        f"grid={grid!r} must be a ThetaSet, a mapping of parameter names to values, or None"
    )


def _check_natures(natures: Any, env_kwargs: Mapping[str, Any]) -> dict[str, Nature]:
    if natures is None:
        return {}
    if not isinstance(natures, Mapping):
        raise TypeError(f"natures={natures!r} must be a mapping of labels to ns_pz Natures")
    for label, nature in natures.items():
        if not isinstance(label, str) or label in (NOMINAL, GRID, ADVERSARY, "all"):
            raise ValueError(
                f"natures has the label {label!r}; labels are strings other than "
                f"{[NOMINAL, GRID, ADVERSARY, 'all']}"
            )
        if not isinstance(nature, Nature):
            raise TypeError(f"natures[{label!r}]={nature!r} must be an ns_pz Nature")
    return dict(natures)


def _plain(member: Mapping[str, Any]) -> dict[str, Any]:
    """A grid member's values as Python numbers and lists (JSON text takes no NumPy scalar)."""
    return {name: np.asarray(value).tolist() for name, value in member.items()}


def _short(value: Any) -> str:
    if np.ndim(value) == 0:
        return f"{float(value):.4g}"
    return "(" + ", ".join(f"{float(v):.3g}" for v in value) + ")"


__all__ = [
    "ADVERSARY",
    "AdversarySearch",
    "Condition",
    "GRID",
    "NATURES",
    "NOMINAL",
    "RobustnessReport",
    "Summary",
    "evaluate_robustness",
]
