"""Domain randomisation: nature draws each episode's θ_0, and θ sets split for generalisation.

Domain randomisation is nature's move before the first transition: at every reset
:class:`DomainRandomisation` draws θ_0 for the episode from per-parameter distributions
(:class:`Uniform`, :class:`LogUniform`, :class:`Normal`, :class:`Choice`, :class:`Dirichlet`),
from a finite :class:`ThetaSet`, or from a sampler of your own, using nature's generator — so
``reset(seed=s)`` reproduces the draw. The draw is hidden from the decision agent: it is not a
change (no flag, no size, no change time), detectors start from the nominal θ_0 they were bound
to, and a planning model assumes the nominal θ_0 (plus the changes the agent is told of at
``detailed``). The ground truth (:meth:`~ns_pz.views.NSGymEnv.ground_truth`) holds the drawn θ_0.
Within the episode θ is held, or follows the nature given as ``then=`` (a drift, a schedule, a
learned adversary), starting from the draw.

A :class:`ThetaSet` is a finite set of parameter values: a product grid or a seeded sample,
split into training and test members (CARL-style generalisation: train on one part of the
context space, evaluate on held-out contexts) and usable both as a randomisation source and as
the grid of :func:`ns_pz.learning.evaluate_robustness`.
"""

from __future__ import annotations

import itertools
import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ns_pz.checks import count, seed_value
from ns_pz.nature.policies import Nature, Proposal
from ns_pz.params import SIMPLEX, Params, ParamSpec, Value

if TYPE_CHECKING:
    from ns_pz.process import NSProcess


class ParamDistribution(ABC):
    """A distribution over one parameter's values."""

    @abstractmethod
    def sample(self, rng: np.random.Generator) -> Value:
        """One value."""

    @abstractmethod
    def support(self) -> tuple[float, float]:
        """The smallest interval holding every value (per element for a vector)."""

    def check(self, owner: str, spec: ParamSpec) -> None:
        """Raise ``ValueError`` unless every value lies within ``spec``'s bounds.

        Args:
            owner: How the message names the parameter (``"CartPoleParams.masspole"``).
            spec: The parameter's spec.
        """
        if spec.kind == SIMPLEX:
            raise TypeError(
                f"{owner} is a probability vector; {self!r} draws scalars (use Dirichlet or "
                "Choice of vectors)"
            )
        low, high = self.support()
        if not (spec.contains(low) and spec.contains(high)):
            raise ValueError(f"{self!r} draws {owner} outside its allowed range {spec.allowed()}")


class Uniform(ParamDistribution):
    """Uniform on ``[low, high]``."""

    def __init__(self, low: float, high: float) -> None:
        self.low, self.high = _interval("Uniform", low, high)

    def sample(self, rng: np.random.Generator) -> float:
        """One value."""
        return float(rng.uniform(self.low, self.high))

    def support(self) -> tuple[float, float]:
        """``(low, high)``."""
        return self.low, self.high

    def __repr__(self) -> str:
        return f"Uniform({self.low!r}, {self.high!r})"


class LogUniform(ParamDistribution):
    """Log-uniform on ``[low, high]``, ``0 < low``: equal odds for each factor of scale."""

    def __init__(self, low: float, high: float) -> None:
        self.low, self.high = _interval("LogUniform", low, high)
        if self.low <= 0:
            raise ValueError(f"LogUniform(low={low!r}) needs low > 0")

    def sample(self, rng: np.random.Generator) -> float:
        """One value."""
        return float(math.exp(rng.uniform(math.log(self.low), math.log(self.high))))

    def support(self) -> tuple[float, float]:
        """``(low, high)``."""
        return self.low, self.high

    def __repr__(self) -> str:
        return f"LogUniform({self.low!r}, {self.high!r})"


class Normal(ParamDistribution):
    """Normal of ``mean`` and ``std``, truncated to ``[low, high]`` by redrawing.

    The truncation bounds are required, so that every draw lies inside the parameter's range
    (a clip would pile probability on the bounds).
    """

    def __init__(self, mean: float, std: float, *, low: float, high: float) -> None:
        self.low, self.high = _interval("Normal", low, high)
        self.mean = _finite("Normal(mean)", mean)
        self.std = _finite("Normal(std)", std)
        if self.std <= 0:
            raise ValueError(f"Normal(std={std!r}) must be > 0")
        if not self.low <= self.mean <= self.high:
            raise ValueError(f"Normal(mean={mean!r}) lies outside [low, high]=[{low}, {high}]")

    def sample(self, rng: np.random.Generator) -> float:
        """One value (redrawn until inside ``[low, high]``)."""
        while True:
            value = float(rng.normal(self.mean, self.std))
            if self.low <= value <= self.high:
                return value

    def support(self) -> tuple[float, float]:
        """``(low, high)``."""
        return self.low, self.high

    def __repr__(self) -> str:
        return f"Normal({self.mean!r}, {self.std!r}, low={self.low!r}, high={self.high!r})"


class Choice(ParamDistribution):
    """One of finitely many values (scalars or probability vectors), with optional weights."""

    def __init__(self, values: Sequence[Any], weights: Sequence[float] | None = None) -> None:
        if isinstance(values, (str, bytes)) or not isinstance(values, Sequence) or not values:
            raise ValueError(f"Choice(values={values!r}) needs a non-empty sequence of values")
        self.values = [v if np.ndim(v) == 0 else tuple(float(x) for x in v) for v in values]
        self.weights = None if weights is None else _weights(weights, len(self.values))

    def sample(self, rng: np.random.Generator) -> Value:
        """One of the values."""
        return self.values[int(rng.choice(len(self.values), p=self.weights))]

    def support(self) -> tuple[float, float]:
        """The smallest and largest value (over all elements for vectors)."""
        flat = np.concatenate([np.ravel(np.asarray(v, dtype=float)) for v in self.values])
        return float(flat.min()), float(flat.max())

    def check(self, owner: str, spec: ParamSpec) -> None:
        """Each value must be a valid value of the parameter.

        Raises:
            ParamOutOfRange / ValueError: A value the parameter does not allow.
        """
        for value in self.values:
            spec.check(owner, value)

    def __repr__(self) -> str:
        return f"Choice({self.values!r})"


class Dirichlet(ParamDistribution):
    """Dirichlet over a probability vector: ``alpha`` large → draws close to ``alpha/sum``."""

    def __init__(self, alpha: Sequence[float]) -> None:
        self.alpha = tuple(_finite("Dirichlet(alpha)", a) for a in alpha)
        if len(self.alpha) < 2 or min(self.alpha) <= 0:
            raise ValueError(f"Dirichlet(alpha={alpha!r}) needs at least 2 entries, each > 0")

    def sample(self, rng: np.random.Generator) -> tuple[float, ...]:
        """One probability vector (renormalised in float64 so it sums to 1)."""
        draw = rng.dirichlet(self.alpha)
        return tuple(float(p) for p in draw / draw.sum())

    def support(self) -> tuple[float, float]:
        """``(0, 1)``."""
        return 0.0, 1.0

    def check(self, owner: str, spec: ParamSpec) -> None:
        """The parameter must be a probability vector of ``len(alpha)`` outcomes."""
        if spec.kind != SIMPLEX:
            raise TypeError(f"{owner} is a scalar; Dirichlet draws probability vectors")
        if spec.size != len(self.alpha):
            raise ValueError(
                f"{self!r} has {len(self.alpha)} entries; {owner} has {spec.size} outcomes"
            )

    def __repr__(self) -> str:
        return f"Dirichlet({self.alpha!r})"


class ThetaSet(Sequence[Mapping[str, Value]]):
    """A finite set of parameter values (each a mapping of names to values; others default).

    Build one with :meth:`grid` (a product) or :meth:`sample` (seeded draws), or from a list of
    mappings; :meth:`split` holds out test members.
    """

    def __init__(self, members: Sequence[Mapping[str, Any]]) -> None:
        if isinstance(members, Mapping) or not isinstance(members, Sequence) or not members:
            raise ValueError(
                f"ThetaSet(members={members!r}) needs a non-empty list of mappings of parameter "
                "names to values (ThetaSet.grid builds a product)"
            )
        for member in members:
            if not isinstance(member, Mapping):
                raise TypeError(f"ThetaSet member {member!r} must be a mapping of names to values")
        self.members = tuple(dict(m) for m in members)

    @classmethod
    def grid(cls, values: Mapping[str, Sequence[Any]]) -> ThetaSet:
        """The product of per-parameter values (``{"masspole": [0.05, 0.1], "length": ...}``)."""
        if not isinstance(values, Mapping) or not values:
            raise ValueError(f"grid values={values!r} must be a non-empty mapping name -> values")
        names = list(values)
        axes = []
        for name in names:
            axis = values[name]
            if isinstance(axis, (str, bytes)) or np.ndim(axis) == 0 or len(axis) == 0:
                raise ValueError(f"grid values[{name!r}]={axis!r} must be a non-empty sequence")
            axes.append([v if np.ndim(v) == 0 else tuple(v) for v in axis])
        return cls([dict(zip(names, combo, strict=True)) for combo in itertools.product(*axes)])

    @classmethod
    def sample(
        cls, distributions: Mapping[str, ParamDistribution], size: int, *, seed: int
    ) -> ThetaSet:
        """``size`` draws from per-parameter distributions, reproducible from ``seed``.

        Raises:
            ValueError: ``size`` below 1, or ``seed`` no int >= 0 (``None`` too: it would
                draw another set at every call).
        """
        size = count("size", size)
        _check_distributions(distributions)
        rng = np.random.default_rng(seed_value("seed", seed))
        return cls([{n: d.sample(rng) for n, d in distributions.items()} for _ in range(size)])

    def split(self, test_fraction: float, *, seed: int) -> tuple[ThetaSet, ThetaSet]:
        """A seeded random (train, test) partition with ``round(test_fraction * len)`` tests.

        Raises:
            ValueError: ``test_fraction`` outside (0, 1), a part would be empty, or ``seed``
                is no int >= 0.
        """
        fraction = _finite("test_fraction", test_fraction)
        if not 0 < fraction < 1:
            raise ValueError(f"test_fraction={test_fraction!r} must lie in (0, 1)")
        tests = round(fraction * len(self))
        if not 0 < tests < len(self):
            raise ValueError(
                f"test_fraction={test_fraction!r} of {len(self)} members leaves a part empty"
            )
        order = np.random.default_rng(seed_value("seed", seed)).permutation(len(self))
        test = sorted(int(i) for i in order[:tests])
        train = sorted(int(i) for i in order[tests:])
        return ThetaSet([self.members[i] for i in train]), ThetaSet([self.members[i] for i in test])

    def names(self) -> list[str]:
        """The parameters any member sets, in first-seen order."""
        return list(dict.fromkeys(name for member in self.members for name in member))

    def __getitem__(self, index: Any) -> Any:
        return self.members[index]

    def __len__(self) -> int:
        return len(self.members)

    def __iter__(self) -> Iterator[Mapping[str, Value]]:
        return iter(self.members)

    def __repr__(self) -> str:
        return f"ThetaSet({len(self)} members over {self.names()})"


Sampler = Callable[[Params, np.random.Generator], Mapping[str, Any]]
"""``sampler(nominal θ_0, rng) -> {name: value}``: the draw of a user's own randomisation."""


class DomainRandomisation(Nature):
    """Draws θ_0 at every reset; θ is then held, or moved by ``then``.

    Args:
        source: What to draw from: a mapping of parameter names to
            :class:`ParamDistribution` (parameters not named keep the nominal θ_0), a
            :class:`ThetaSet` (one member, uniformly), or a ``sampler(θ_0, rng) -> {name:
            value}`` of your own.
        then: The nature that acts within the episode, from the drawn θ_0 on (default: none,
            θ held for the episode).

    An explicit ``reset(options={"params": ...})`` sets the episode's θ_0 itself: nothing is
    drawn then.

    Raises:
        TypeError / ValueError: A source or distribution that cannot serve the family (checked
            at bind, before any episode).
    """

    def __init__(
        self,
        source: Mapping[str, ParamDistribution] | ThetaSet | Sampler,
        *,
        then: Nature | None = None,
    ) -> None:
        if isinstance(source, Mapping):
            _check_distributions(source)
        elif not isinstance(source, ThetaSet) and not callable(source):
            raise TypeError(
                f"source={source!r} must be a mapping of names to ParamDistribution, a ThetaSet "
                "or a sampler(theta0, rng) -> mapping"
            )
        if then is not None and not isinstance(then, Nature):
            raise TypeError(f"then={then!r} must be an ns_pz Nature or None")
        if isinstance(then, DomainRandomisation):
            raise TypeError("then= cannot be another DomainRandomisation (θ_0 is drawn once)")
        self.source = source
        self.then = then

    def bind(self, params_cls: type[Params]) -> None:
        """Check every distribution or member against the parameters, then bind ``then``.

        Raises:
            UnknownParam: A name that is not a parameter.
            TypeError / ValueError / ParamOutOfRange: A draw the parameter cannot take.
        """
        if isinstance(self.source, Mapping):
            params_cls.check_names(self.source)
            for name, distribution in self.source.items():
                distribution.check(f"{params_cls.__name__}.{name}", params_cls.spec(name))
        elif isinstance(self.source, ThetaSet):
            for member in self.source:
                params_cls().replace(**member)
        if self.then is not None:
            self.then.bind(params_cls)

    def initial_params(self, theta0: Params, rng: np.random.Generator) -> Params:
        """The episode's θ_0: ``theta0`` with the drawn values.

        Raises:
            TypeError: A sampler of one's own returned no mapping.
            ParamOutOfRange / UnknownParam: It returned a value the parameter does not allow.
        """
        source = self.source
        if isinstance(source, Mapping):
            draw: Mapping[str, Any] = {name: d.sample(rng) for name, d in source.items()}
        elif isinstance(source, ThetaSet):
            draw = source[int(rng.integers(len(source)))]
        else:
            draw = source(theta0, rng)
            if not isinstance(draw, Mapping):
                raise TypeError(
                    f"the sampler {source!r} returned {draw!r}; it must return a mapping of "
                    "parameter names to values"
                )
        return theta0.replace(**draw)

    def initial_memory(self) -> Any:
        """``then``'s memory."""
        return None if self.then is None else self.then.initial_memory()

    def act(self, process: NSProcess) -> Proposal:
        """``then``'s move (none if θ is held)."""
        return None if self.then is None else self.then.act(process)

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """``then``'s proposal (none if θ is held)."""
        if self.then is None:
            return None
        return self.then.propose(t, theta, budget_left, memory, rng)

    def __repr__(self) -> str:
        then = "" if self.then is None else f", then={self.then!r}"
        return f"DomainRandomisation({self.source!r}{then})"


def _check_distributions(distributions: Mapping[str, Any]) -> None:
    if not distributions:
        raise ValueError("the distributions mapping is empty: name at least one parameter")
    for name, distribution in distributions.items():
        if not isinstance(distribution, ParamDistribution):
            raise TypeError(
                f"distributions[{name!r}]={distribution!r} must be a ParamDistribution "
                "(Uniform, LogUniform, Normal, Choice, Dirichlet)"
            )


def _finite(label: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{label}={value!r} must be a real number")
    if not math.isfinite(value):
        raise ValueError(f"{label}={value!r} must be finite")
    return float(value)


def _interval(owner: str, low: Any, high: Any) -> tuple[float, float]:
    low_f, high_f = _finite(f"{owner}(low)", low), _finite(f"{owner}(high)", high)
    if low_f > high_f:
        raise ValueError(f"{owner}(low={low!r}, high={high!r}) needs low <= high")
    return low_f, high_f


def _weights(weights: Sequence[float], size: int) -> np.ndarray:
    array = np.asarray(weights, dtype=float)
    if array.shape != (size,) or not np.all(np.isfinite(array)) or np.any(array < 0):
        raise ValueError(f"weights={weights!r} must be {size} finite numbers >= 0")
    if array.sum() <= 0:
        raise ValueError(f"weights={weights!r} must not all be 0")
    return array / array.sum()
