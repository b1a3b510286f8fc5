"""What nature is allowed to do, and the projection that enforces it.

Bounds come from the parameter specs. :class:`NatureConstraints` adds which parameters nature may
move at all (``movable``; the others stay at θ_0), a Lipschitz bound (the largest change of one
parameter in one step) and a total budget (the largest sum of change sizes over an episode). Sizes
are measured as in :meth:`ns_pz.params.Params.change_sizes`: absolute difference for a scalar, W1
with the discrete ground metric (total variation) for a vector.

:func:`admit` turns any proposal into an allowed θ in three stages:

1. a proposed value of a parameter nature may not move is dropped; every other one is
   projected onto its spec (clipped into the bounds; a vector projected onto the simplex);
2. a parameter whose change exceeds its Lipschitz bound is moved only part of the way, along the
   straight line from the old value towards the projected one;
3. if the changes together exceed the budget left, all of them are shortened by one common
   factor along the same lines.

Bounds and the simplex are convex, so every point on those lines is allowed: the result is a
valid θ whatever the proposal, which is what keeps a learned adversary inside the rules.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from ns_pz.nature.updates import check_real
from ns_pz.params import SIMPLEX, Params, ParamSpec, Value


@dataclass(frozen=True)
class NatureConstraints:
    """Limits on nature beyond the parameter bounds.

    Change sizes are those of :meth:`ns_pz.params.Params.change_sizes`, each in its parameter's
    own unit (N, kg, s; total variation for a probability vector).

    Attributes:
        movable: The parameters nature may move, by name; the others stay at θ_0 (a move of one
            is dropped, and a learned nature's action space leaves them out). ``None``: every
            parameter. With ``lipschitz`` and ``budget`` naming only some parameters, the ones
            not named are unbounded, not frozen: ``movable`` is the way to freeze them.
        lipschitz: Largest change size per step, one number for every parameter or a mapping
            from parameter name to its bound (parameters not named are unbounded). ``None``:
            no per-step bound.
        budget: Largest sum of change sizes over an episode: one number for all parameters
            together (meaningful when they share a unit, e.g. one slip vector), or a mapping from
            parameter name to that parameter's own budget in its unit (parameters not named are
            unlimited). ``None``: unlimited.
        normalized_budget: Largest sum over an episode of change sizes each divided by the
            width of its parameter's range (``high - low``; 1 for a probability vector): one
            dimensionless total across parameters of different units. ``None``: unlimited.
    """

    lipschitz: float | Mapping[str, float] | None = None
    budget: float | Mapping[str, float] | None = None
    normalized_budget: float | None = None
    movable: tuple[str, ...] | None = None
    _per_param: Mapping[str, float] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    _budget_per_param: Mapping[str, float] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    total_budget: float | None = field(default=None, init=False, repr=False, compare=False)
    """The budget shared by all parameters (a single-number ``budget``), or ``None``."""
    has_budget: bool = field(default=False, init=False, repr=False, compare=False)
    """Whether any episode budget applies."""
    unconstrained: bool = field(default=True, init=False, repr=False, compare=False)
    """Whether nothing limits nature beyond the bounds."""

    def __hash__(self) -> int:
        """Equal constraints hash equally, per-parameter mappings included."""
        limits = (self.lipschitz, self.budget, self.normalized_budget, self.movable)
        return hash(tuple(_hashable(v) for v in limits))

    def __post_init__(self) -> None:
        if self.movable is not None:
            object.__setattr__(self, "movable", _check_movable(self.movable))
        if isinstance(self.budget, Mapping):
            per = {n: _check_limit(f"budget[{n!r}]", v) for n, v in self.budget.items()}
            object.__setattr__(self, "_budget_per_param", per)
            object.__setattr__(self, "budget", dict(self.budget))  # ours: the caller's may change
        elif self.budget is not None:
            _check_limit("budget", self.budget)
        if self.normalized_budget is not None:
            _check_limit("normalized_budget", self.normalized_budget)
        if isinstance(self.lipschitz, Mapping):
            per = {n: _check_limit(f"lipschitz[{n!r}]", v) for n, v in self.lipschitz.items()}
            object.__setattr__(self, "_per_param", per)
            object.__setattr__(self, "lipschitz", dict(self.lipschitz))
        elif self.lipschitz is not None:
            _check_limit("lipschitz", self.lipschitz)
        # Read at every change nature makes: stored once rather than derived each time.
        total = None if isinstance(self.budget, Mapping) else self.budget
        has_budget = self.budget is not None or self.normalized_budget is not None
        object.__setattr__(self, "total_budget", total)
        object.__setattr__(self, "has_budget", has_budget)
        unconstrained = self.lipschitz is None and not has_budget and self.movable is None
        object.__setattr__(self, "unconstrained", unconstrained)

    def check_names(self, params_cls: type[Params]) -> None:
        """Check the constraints fit a parameter set.

        Raises:
            UnknownParam: A bound, budget or movable parameter names no parameter.
            ValueError: ``normalized_budget`` is set but a parameter has an unbounded range.
        """
        params_cls.check_names(self.movable or ())
        params_cls.check_names(self._per_param)
        params_cls.check_names(self._budget_per_param)
        if self.normalized_budget is not None:
            for spec in params_cls.specs():
                if not math.isfinite(spec.width):
                    raise ValueError(
                        f"normalized_budget={self.normalized_budget!r} needs bounded parameters; "
                        f"{params_cls.__name__}.{spec.name} ranges over {spec.allowed()}"
                    )

    def moves(self, name: str) -> bool:
        """Whether nature may move parameter ``name`` (see :attr:`movable`)."""
        return self.movable is None or name in self.movable

    def lipschitz_of(self, name: str) -> float | None:
        """The per-step bound of one parameter, or ``None``."""
        if self.lipschitz is None or isinstance(self.lipschitz, Mapping):
            return self._per_param.get(name)
        return float(self.lipschitz)

    def budget_of(self, name: str) -> float | None:
        """The episode budget of one parameter alone (a per-parameter ``budget``), or ``None``."""
        return self._budget_per_param.get(name)


def budget_fractions_left(
    constraints: NatureConstraints, params_cls: type[Params], spent: Mapping[str, float]
) -> tuple[float, ...]:
    """What is left of each budget as a fraction in [0, 1]: total, normalised, per parameter.

    Args:
        constraints: The budgets.
        params_cls: The parameter set (its field order orders the per-parameter fractions).
        spent: Change size charged to each parameter so far this episode (missing: 0).

    Returns:
        ``(total, normalised, *per_parameter)``; 1.0 for a budget that does not exist (nothing
        limits nature, as if nothing were spent of a budget), 0.0 for a budget of 0 (nature is
        frozen, as if the budget were spent), so an observation tells the two apart.
    """
    total_budget = constraints.total_budget
    total = _fraction(total_budget, math.fsum(spent.values()))
    normalized = _fraction(constraints.normalized_budget, _normalized_spent(params_cls, spent))
    per = [_fraction(constraints.budget_of(n), spent.get(n, 0.0)) for n in params_cls.names()]
    return (total, normalized, *per)


def admit(
    theta: Params,
    proposal: Mapping[str, object],
    constraints: NatureConstraints,
    spent: Mapping[str, float],
    *,
    sizes_wanted: bool = True,
) -> tuple[Params, dict[str, float] | None]:
    """Project nature's proposal onto the allowed set.

    Args:
        theta: The current θ.
        proposal: New values for some parameters, by name. Values may be out of bounds.
        constraints: Lipschitz bounds and budgets.
        spent: Change size charged to each parameter so far this episode (missing: 0).
        sizes_wanted: Compute the change sizes even when no bound or budget needs them.

    Returns:
        The new θ (``theta`` itself when nothing changes) and the size of each change that
        happened, by parameter name (a parameter that did not change may be missing);
        ``None`` for the sizes when nothing needed them and they were not wanted.

    Raises:
        UnknownParam: A proposed name is not a parameter.
        ParamOutOfRange: A proposed value is NaN or has the wrong shape.
    """
    owner = type(theta).__name__
    layout = Params.layout_of(theta)
    by_name = layout.by_name
    granted: dict[str, Value] = {}
    sizes: dict[str, float] = {}
    if constraints.unconstrained:  # nature's every change: the short path
        for name, raw in proposal.items():
            spec = by_name.get(name) or theta.spec(name)  # theta.spec raises UnknownParam
            new = spec.project(owner, raw)
            old = getattr(theta, name)
            if new != old:
                granted[name] = new
                if sizes_wanted:
                    sizes[name] = spec.distance(old, new)
        new_theta = layout.evolve(theta, granted) if granted else theta
        return new_theta, (sizes if sizes_wanted else None)
    for name, raw in proposal.items():
        spec = by_name.get(name) or theta.spec(name)  # theta.spec raises UnknownParam
        if not constraints.moves(name):
            continue
        old = getattr(theta, name)
        new = spec.project(owner, raw)
        if new == old:
            continue
        size = spec.distance(old, new)
        limit = constraints.lipschitz_of(name)
        own = constraints.budget_of(name)
        if own is not None:
            left = remaining(own, spent.get(name, 0.0))
            limit = left if limit is None else min(limit, left)
        if limit is not None and size > limit:
            new = _towards(spec, old, new, limit / size)
            size = spec.distance(old, new)
            if size == 0.0:  # the bound allows no move at all
                continue
        granted[name] = new
        sizes[name] = size
    if not granted:
        return theta, sizes
    factor = _shared_budget_factor(type(theta), constraints, spent, sizes)
    if factor < 1.0:
        granted, sizes = _within_budget(theta, granted, sizes, factor)
        if not granted:
            return theta, sizes
    return layout.evolve(theta, granted), sizes


def _shared_budget_factor(
    params_cls: type[Params],
    constraints: NatureConstraints,
    spent: Mapping[str, float],
    sizes: Mapping[str, float],
) -> float:
    """The common factor (<= 1) that keeps the changes within the total and normalised budgets."""
    factor = 1.0
    total_budget = constraints.total_budget
    if total_budget is not None:
        left = remaining(total_budget, math.fsum(spent.values()))
        total = math.fsum(sizes.values())
        if total > left:
            factor = left / total
    if constraints.normalized_budget is not None:
        left = remaining(constraints.normalized_budget, _normalized_spent(params_cls, spent))
        total = _normalized_spent(params_cls, sizes)
        if total > left:
            factor = min(factor, left / total)
    return factor


def _hashable(value: Any) -> Any:
    return tuple(sorted(value.items())) if isinstance(value, Mapping) else value


def remaining(budget: float, spent: float) -> float:
    """What is left of ``budget`` after ``spent``; 0 within rounding of an exhausted budget.

    A budget used up by steps that should sum to it exactly (0.1 + 0.1 + 0.1 against 0.3) can
    leave a remainder of a few ulps; granting it would make a change of 1e-17 that an oracle
    monitor notifies as a real one.
    """
    left = budget - spent
    return left if left > _ROUNDING * budget else 0.0


_ROUNDING = 1e-9
"""Relative remainder of a budget treated as nothing left."""


def _normalized_spent(params_cls: type[Params], sizes: Mapping[str, float]) -> float:
    return math.fsum(size / params_cls.spec(name).width for name, size in sizes.items())


def _fraction(budget: float | None, spent: float) -> float:
    if budget is None:
        return 1.0
    if budget == 0.0:
        return 0.0
    return min(remaining(budget, spent) / budget, 1.0)


def _within_budget(
    theta: Params, granted: dict[str, Value], sizes: dict[str, float], factor: float
) -> tuple[dict[str, Value], dict[str, float]]:
    """Shorten every granted change by ``factor``; drop those that vanish."""
    kept: dict[str, Value] = {}
    kept_sizes: dict[str, float] = {}
    for name, new in granted.items():
        spec = theta.spec(name)
        old = getattr(theta, name)
        moved = _towards(spec, old, new, factor)
        size = spec.distance(old, moved)
        if size > 0.0:
            kept[name] = moved
            kept_sizes[name] = size
    return kept, kept_sizes


def _towards(spec: ParamSpec, old: Value, new: Value, fraction: float) -> Value:
    """The point ``fraction`` of the way from ``old`` to ``new`` (0 <= fraction <= 1)."""
    if spec.kind == SIMPLEX:
        return tuple(o + fraction * (n - o) for o, n in zip(old, new, strict=True))  # type: ignore[arg-type]
    moved = old + fraction * (new - old)  # type: ignore[operator]
    return moved if spec.contains(moved) else old


def _check_movable(movable: object) -> tuple[str, ...]:
    """``movable`` as a tuple of distinct names, at least one.

    Raises:
        TypeError: Not a list or tuple of strings (a bare string is refused: ``("length",)``).
        ValueError: Empty, or a name repeated.
    """
    if not isinstance(movable, (list, tuple)) or not all(isinstance(n, str) for n in movable):
        raise TypeError(
            f"movable={movable!r} must be a tuple of parameter names, e.g. ('length', 'force_mag')"
        )
    if not movable:
        raise ValueError(
            "movable=() freezes every parameter; for a nature that never acts leave nature out "
            "(StaticNature)"
        )
    if len(set(movable)) != len(movable):
        raise ValueError(f"movable={movable!r} names a parameter twice")
    return tuple(movable)


def _check_limit(name: str, value: object) -> float:
    number = check_real(name, value)
    if number < 0:
        raise ValueError(f"{name}={value!r} must be >= 0")
    return number
