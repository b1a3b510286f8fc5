"""What nature is allowed to do, and the projection that enforces it.

Bounds come from the parameter specs. :class:`NatureConstraints` adds a Lipschitz bound (the
largest change of one parameter in one step) and a total budget (the largest sum of change sizes
over an episode). Sizes are measured as in :meth:`ns_pz.params.Params.change_sizes`: absolute
difference for a scalar, W1 with the discrete ground metric (total variation) for a vector.

:func:`admit` turns any proposal into an allowed θ in three stages:

1. each proposed value is projected onto its spec (clipped into the bounds; a vector projected
   onto the simplex);
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

from ns_pz.nature.updates import check_real
from ns_pz.params import SIMPLEX, Params, ParamSpec, Value


@dataclass(frozen=True)
class NatureConstraints:
    """Limits on nature beyond the parameter bounds.

    Attributes:
        lipschitz: Largest change size per step, one number for every parameter or a mapping
            from parameter name to its bound (parameters not named are unbounded). ``None``:
            no per-step bound.
        budget: Largest sum of change sizes over an episode. ``None``: unlimited.
    """

    lipschitz: float | Mapping[str, float] | None = None
    budget: float | None = None
    _per_param: Mapping[str, float] = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.budget is not None:
            _check_limit("budget", self.budget)
        if isinstance(self.lipschitz, Mapping):
            per = {n: _check_limit(f"lipschitz[{n!r}]", v) for n, v in self.lipschitz.items()}
            object.__setattr__(self, "_per_param", per)
        elif self.lipschitz is not None:
            _check_limit("lipschitz", self.lipschitz)

    def check_names(self, params_cls: type[Params]) -> None:
        """Raise :class:`~ns_pz.errors.UnknownParam` if a Lipschitz bound names no parameter."""
        params_cls.check_names(self._per_param)

    def lipschitz_of(self, name: str) -> float | None:
        """The per-step bound of one parameter, or ``None``."""
        if self.lipschitz is None or isinstance(self.lipschitz, Mapping):
            return self._per_param.get(name)
        return float(self.lipschitz)


def admit(
    theta: Params,
    proposal: Mapping[str, object],
    constraints: NatureConstraints,
    budget_left: float,
) -> tuple[Params, dict[str, float] | None]:
    """Project nature's proposal onto the allowed set.

    Args:
        theta: The current θ.
        proposal: New values for some parameters, by name. Values may be out of bounds.
        constraints: Lipschitz bound and budget.
        budget_left: What remains of the episode budget (``inf`` when there is none).

    Returns:
        The new θ (``theta`` itself when nothing changes) and the size of each change that
        happened, by parameter name; ``None`` instead of the sizes when no Lipschitz bound or
        budget applies, as they are then not needed to decide anything.

    Raises:
        UnknownParam: A proposed name is not a parameter.
        ParamOutOfRange: A proposed value is NaN or has the wrong shape.
    """
    owner = type(theta).__name__
    by_name = Params.layout_of(theta).by_name
    granted: dict[str, Value] = {}
    if constraints.lipschitz is None and budget_left == math.inf:
        for name, raw in proposal.items():
            spec = by_name.get(name) or theta.spec(name)  # theta.spec raises UnknownParam
            new = spec.project(owner, raw)
            if new != getattr(theta, name):
                granted[name] = new
        return (theta.evolve_trusted(granted) if granted else theta), None
    sizes: dict[str, float] = {}
    free = constraints.lipschitz is None
    for name, raw in proposal.items():
        spec = by_name.get(name) or theta.spec(name)  # theta.spec raises UnknownParam
        old = getattr(theta, name)
        new = spec.project(owner, raw)
        if new == old:
            continue
        size = spec.distance(old, new)
        if not free:
            limit = constraints.lipschitz_of(name)
            if limit is not None and size > limit:
                new = _towards(spec, old, new, limit / size)
                size = spec.distance(old, new)
                if size == 0.0:  # the bound allows no move at all
                    continue
        granted[name] = new
        sizes[name] = size
    if not granted:
        return theta, sizes
    if budget_left != math.inf:
        total = math.fsum(sizes.values())
        if total > budget_left:
            granted, sizes = _within_budget(theta, granted, sizes, budget_left / total)
            if not granted:
                return theta, sizes
    return theta.evolve_trusted(granted), sizes


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


def _check_limit(name: str, value: object) -> float:
    number = check_real(name, value)
    if number < 0:
        raise ValueError(f"{name}={value!r} must be >= 0")
    return number
