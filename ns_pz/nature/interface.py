"""Nature's seat as a policy meets it: one observation encoding and one action convention.

Every nature that is not a schedule — a network being trained in the game or in
:func:`ns_pz.single_agent`, a trained policy put back with :class:`ns_pz.nature.PolicyNature` —
sees and acts through one :class:`NatureInterface`, so a policy trained in one place acts the
same in every other.

**Observation** (``Box``, float32, always finite), in this order:

* ``time``: ``t / max_episode_steps`` (``t`` itself when the episode has no limit);
* ``offset`` (one per flat θ element, field order): ``(θ - θ_0) / allowance``, how many per-step
  allowances each element has moved since reset;
* ``budget`` (``2 + number of parameters``): the fraction left of the total budget, of the
  normalised budget and of each parameter's own budget, in [0, 1]: 1.0 for a budget that does
  not exist, 0.0 for a budget of 0 (nature frozen: nothing left, as for a spent budget);
* ``budgeted``: 1.0 if any budget applies, else 0.0;
* with ``observes_state=True``: the decision agent's state (Gymnasium's ``flatten`` of the base
  observation: one-hot for a grid cell) and its last action (flattened likewise; zeros before the
  first).

**Actions**:

* ``"normalized"`` (default for learners): ``Box(-1, 1)`` per flat θ element. A scalar moves by
  ``action × allowance``. A probability vector moves by its centred action scaled by the
  allowance, shortened so the total-variation distance is at most the allowance, then
  projected onto the simplex. The allowance of a parameter is its Lipschitz bound, or, when it
  has none, ``default_step`` times its size at θ_0 (``|θ_0|``; the width of its range if θ_0 is
  0; 1 for a probability vector). A fraction of the value rather than of the range: physical
  ranges are wide (CartPole's gravity may lie in [0, 1000]), and 1 % of them would let one
  action move gravity by 10 m/s².
* ``"delta"``: Δθ itself, ``Box(-(high - low), high - low)`` per flat element (the game's
  default, exact for scripted values).

Only the parameters nature may move (:attr:`NatureConstraints.movable
<ns_pz.nature.constraints.NatureConstraints.movable>`) have action elements, in field order.
Zero means "no change" in both. The game then projects the proposal onto the allowed set
(:func:`ns_pz.nature.constraints.admit`), whatever the action.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from operator import sub, truediv
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium import spaces

from ns_pz.checks import flag
from ns_pz.family import EnvFamily
from ns_pz.nature.constraints import NatureConstraints, budget_fractions_left
from ns_pz.params import SIMPLEX, Params

if TYPE_CHECKING:
    from ns_pz.process import NSProcess

NATURE_ACTIONS = ("normalized", "delta")
DEFAULT_STEP = 0.01
"""Per-step allowance of a parameter without a Lipschitz bound, as a fraction of its θ_0 size."""


def check_default_step(default_step: Any) -> float:
    """``default_step`` as a float, if it is a number in (0, 1].

    Raises:
        TypeError: Not a real number.
        ValueError: Outside (0, 1].
    """
    if isinstance(default_step, bool) or not isinstance(default_step, (int, float)):
        raise TypeError(f"default_step={default_step!r} must be a number in (0, 1]")
    if not 0.0 < default_step <= 1.0:
        raise ValueError(f"default_step={default_step!r} must be in (0, 1]")
    return float(default_step)


class NatureInterface:
    """Observation encoding and action decoding of nature's seat for one family and constraints.

    Args:
        family: The environment family.
        theta0: θ_0 (it scales the allowance of parameters without a Lipschitz bound).
        constraints: Lipschitz bounds (they set the allowances) and budgets (observed).
        max_episode_steps: The time limit (scales ``time``), or ``None``.
        action: ``"normalized"`` or ``"delta"`` (see the module docstring).
        observes_state: Add the decision agent's state and last action to the observation.
        default_step: Allowance of a parameter without a Lipschitz bound, as a fraction of its
            size at θ_0; in (0, 1].

    Raises:
        ValueError: An option outside its allowed values.
    """

    def __init__(
        self,
        family: EnvFamily,
        theta0: Params,
        constraints: NatureConstraints,
        max_episode_steps: int | None,
        *,
        action: str = "normalized",
        observes_state: bool = False,
        default_step: float = DEFAULT_STEP,
    ) -> None:
        if action not in NATURE_ACTIONS:
            raise ValueError(f"nature_action={action!r}; allowed: {NATURE_ACTIONS}")
        flag("nature_observes_state", observes_state)
        check_default_step(default_step)
        params_cls = family.params_cls
        self.action_mode = action
        self.observes_state = observes_state
        self._params_cls = params_cls
        self._constraints = constraints
        self._limit = max_episode_steps
        self._layout = [(spec, start, stop) for spec, start, stop in params_cls.flat_layout()]
        low, high = params_cls.flat_bounds()
        width = high - low
        allowance = np.empty_like(width)
        for spec, start, stop in self._layout:
            bound = constraints.lipschitz_of(spec.name)
            if bound is None:
                size = 1.0 if spec.kind == SIMPLEX else abs(getattr(theta0, spec.name))
                bound = default_step * (size or spec.width)
                if not math.isfinite(bound):
                    raise ValueError(
                        f"{params_cls.__name__}.{spec.name} is 0 at θ_0 and unbounded, so it has "
                        "no default per-step allowance; give it a Lipschitz bound"
                    )
            allowance[start:stop] = bound
        self.allowance = allowance
        """Per-step allowance of each flat θ element (``[flat size]``)."""
        self._offset_scale = np.where(allowance > 0.0, allowance, 1.0)
        # The action's elements: those of the movable parameters, renumbered from 0.
        moved = [entry for entry in self._layout if constraints.moves(entry[0].name)]
        acted = np.array([i for _, start, stop in moved for i in range(start, stop)], np.intp)
        self._layout, at = [], 0
        for spec, start, stop in moved:
            self._layout.append((spec, at, at + stop - start))
            at += stop - start
        if action == "normalized":
            self.action_space: spaces.Box = spaces.Box(-1.0, 1.0, (len(acted),), np.float32)
        else:
            self.action_space = spaces.Box(-width[acted], width[acted], dtype=np.float64)  # type: ignore[arg-type]
        self._state_space = family.observation_space if observes_state else None
        self._action_of_agent = family.action_space if observes_state else None
        self._flat_state = _flat_values_of(family.observation_space)
        self._flat_action = _flat_values_of(family.action_space, clip=True)
        self.observation_space = self._observation_space(width)
        self._slots = {spec.name: (start, stop) for spec, start, stop in self._layout}
        self._action_low = np.asarray(self.action_space.low, np.float64)
        self._action_high = np.asarray(self.action_space.high, np.float64)
        n_budgets = 2 + len(params_cls.names())
        self._no_budgets = (1.0,) * n_budgets
        self._budgets_at = 1 + len(width)
        self._theta0: Params | None = None
        self._theta0_values: list[float] = []
        self._scales = self._offset_scale.tolist()
        self._action_scales = self._offset_scale[acted].tolist()
        self._allowances = allowance[acted].tolist()
        self._lows = self._action_low.tolist()
        self._highs = self._action_high.tolist()
        self._no_action = np.zeros(len(acted), self.action_space.dtype)
        self._no_last_action: list[float] = []
        if observes_state:
            self._no_last_action = [0.0] * spaces.flatdim(family.action_space)

    # -- observation ------------------------------------------------------------------------
    def _observation_space(self, width: np.ndarray) -> spaces.Box:
        reach = (width / self._offset_scale).astype(np.float32)
        n_budgets = 2 + len(self._params_cls.names())
        time_high = 1.0 if self._limit is not None else np.inf
        low: list[np.ndarray] = [np.zeros(1), -reach, np.zeros(n_budgets), np.zeros(1)]
        high: list[np.ndarray] = [np.full(1, time_high), reach, np.ones(n_budgets), np.ones(1)]
        for space in (self._state_space, self._action_of_agent):
            if space is not None:
                flat = spaces.flatten_space(space)
                if not isinstance(flat, spaces.Box):
                    raise TypeError(f"nature cannot observe a state in {space} (not flat)")
                low.append(flat.low)
                high.append(flat.high)
        return spaces.Box(
            np.concatenate(low).astype(np.float32),
            np.concatenate(high).astype(np.float32),
            dtype=np.float32,
        )

    def observe(self, process: NSProcess) -> np.ndarray:
        """Nature's observation of ``process`` now (a fresh array)."""
        theta0 = process.theta0
        if theta0 is not self._theta0:  # θ_0 may differ per episode (reset options)
            self._theta0, self._theta0_values = theta0, theta0.flat_values()
        # Built as one list of floats, then one array: the same float64 arithmetic as array
        # operations, rounded to float32 once, at a fraction of the cost for a few parameters.
        row = [process.t if self._limit is None else process.t / self._limit]
        # (θ - θ_0) / scale element by element, looped in C (equal lengths by construction).
        offsets = map(sub, process.theta.flat_values(), self._theta0_values)
        row += map(truediv, offsets, self._scales)
        constraints = self._constraints
        if constraints.has_budget:
            row += budget_fractions_left(constraints, self._params_cls, process.spent)
        else:
            row += self._no_budgets
        row.append(float(constraints.has_budget))
        if self._state_space is not None:  # then the agent's action space is known too
            row += self._flat_state(process.family.observe(process.state))
            last = process.last_action
            row += self._no_last_action if last is None else self._flat_action(last)
            if len(row) != self.observation_space.shape[0]:
                raise ValueError(
                    f"nature's observation has {len(row)} entries, its space "
                    f"{self.observation_space.shape[0]}: {process.family!r}.observe() returned "
                    "an observation outside its observation space"
                )
        return np.array(row, np.float32)

    # -- actions ----------------------------------------------------------------------------
    def proposal(self, action: Any, theta: Params) -> dict[str, Any] | None:
        """The new θ values ``action`` asks for (``None`` for no change), before projection.

        Raises:
            ValueError: ``action`` is not a real vector inside :attr:`action_space`.
        """
        values = self._checked(action)
        if not any(values):
            return None
        if self.action_mode == "normalized":
            return self._normalized_proposal(values, theta)
        proposal: dict[str, Any] = {}
        for spec, start, stop in self._layout:
            chunk = values[start:stop]
            if any(chunk):
                value = getattr(theta, spec.name)
                if spec.kind == SIMPLEX:
                    proposal[spec.name] = tuple([p + d for p, d in zip(value, chunk, strict=True)])
                else:
                    proposal[spec.name] = value + chunk[0]
        return proposal

    def _normalized_proposal(self, values: list[float], theta: Params) -> dict[str, Any]:
        allowance = self._allowances
        proposal: dict[str, Any] = {}
        for spec, start, stop in self._layout:
            if spec.kind != SIMPLEX:  # a scalar: one element, no slice needed
                if values[start]:
                    value = getattr(theta, spec.name)
                    proposal[spec.name] = value + allowance[start] * values[start]
                continue
            chunk = values[start:stop]
            if not any(chunk):
                continue
            mean = sum(chunk) / len(chunk)
            centred = [c - mean for c in chunk]
            shrink = max(0.5 * sum(map(abs, centred)), 1.0)
            step = allowance[start] / shrink
            proposal[spec.name] = tuple(
                [p + step * c for p, c in zip(getattr(theta, spec.name), centred, strict=True)]
            )
        return proposal

    def action_of(self, theta: Params, proposal: Any) -> np.ndarray:
        """The action (clipped into the action space) that asks to move ``theta`` to ``proposal``.

        Args:
            theta: The θ in force.
            proposal: New values by parameter name, or ``None`` (a parameter nature may not
                move has no element: its value is left out).
        """
        # Zeros (inside the action space, scaled or not), then the moved elements one by one:
        # a NumPy element assignment rounds a float as building the array from a list would.
        delta = self._no_action.copy()
        if not proposal:
            return delta
        slots = self._slots
        for name, value in proposal.items():
            slot = slots.get(name)
            if slot is None:
                theta.spec(name)  # raises UnknownParam
                continue
            start, stop = slot
            current = getattr(theta, name)
            if stop - start == 1:
                delta[start] = self._in_space(float(value) - current, start)
                continue
            if len(value) != stop - start:
                raise ValueError(
                    f"proposal[{name!r}]={value!r} has {len(value)} elements; "
                    f"{name!r} has {stop - start}"
                )
            for i, (p, c) in enumerate(zip(value, current, strict=True), start):
                delta[i] = self._in_space(float(p) - c, i)
        return delta

    def _in_space(self, change: float, i: int) -> float:
        """Element ``i`` of the action for a change of θ's flat element ``i``.

        Scaled (normalised) and clipped in float64 (the caller made ``change`` a Python float,
        so a NumPy float32 proposal is not worked out in float32); NaN stays NaN, as with
        ``np.clip``.
        """
        if self.action_mode == "normalized":
            change = change / self._action_scales[i]
        low, high = self._lows[i], self._highs[i]
        return low if change < low else high if change > high else change

    def _checked(self, action: Any) -> list[float]:
        """``action`` as a list of Python numbers, each inside the action space's bounds.

        Compared with the bounds as exact doubles, as NumPy compares the arrays (a float32 value
        or bound is exact as a double); NaN fails every comparison.
        """
        space = self.action_space
        if isinstance(action, np.ndarray) and action.dtype.kind in "fiu":
            values = action.tolist() if action.ndim == 1 else None
        elif isinstance(action, (list, tuple)) and all(
            type(x) in (int, float) or isinstance(x, (np.floating, np.integer)) for x in action
        ):
            values = np.asarray(action, np.float64).tolist()
        else:
            raise ValueError(
                f"nature action={action!r} must be a real vector in the action space {space}"
            )
        if values is None or len(values) != len(self._lows):
            raise ValueError(f"nature action={action!r} is outside the action space {space}")
        total = sum(values)  # NaN if the action holds NaN, or +inf and -inf (unbounded Δθ)
        if total != total:
            raise ValueError(f"nature action={action!r} is outside the action space {space}")
        for value, low, high in zip(values, self._lows, self._highs, strict=False):
            if not low <= value <= high:
                raise ValueError(f"nature action={action!r} is outside the action space {space}")
        return values


def _flat_values_of(space: spaces.Space[Any], clip: bool = False) -> Callable[[Any], list[Any]]:
    """A function giving ``spaces.flatten(space, x)`` as a list of Python numbers.

    Boxes and ``Discrete`` (one-hot) directly, at a fraction of ``flatten``'s dispatch; other
    spaces through ``flatten``. With ``clip``, a Box's values are clipped into its bounds (the
    agent's last action: the dynamics clip one out of bounds, as Gymnasium's do). The functions
    are instances of module-level classes, not closures, so an interface (and every game, view
    and seat holding one) can be pickled.
    """
    if isinstance(space, spaces.Box):
        return _BoxValues(space, clip)
    if isinstance(space, spaces.Discrete):
        return _OneHot(space)
    return _Flattened(space)


class _BoxValues:
    """A Box element as a flat list of Python numbers, optionally clipped into the Box."""

    def __init__(self, space: spaces.Box, clip: bool) -> None:
        self.dtype = space.dtype
        self.clip = clip
        self.lows = space.low.ravel().tolist()
        self.highs = space.high.ravel().tolist()

    def __call__(self, x: Any) -> list[Any]:
        values = np.asarray(x, self.dtype).ravel().tolist()
        if not self.clip:
            return values
        bounds = zip(values, self.lows, self.highs, strict=True)
        return [lo if v < lo else hi if v > hi else v for v, lo, hi in bounds]


class _OneHot:
    """A ``Discrete`` element as its one-hot list."""

    def __init__(self, space: spaces.Discrete) -> None:
        self.size = int(space.n)
        self.start = int(space.start)

    def __call__(self, x: Any) -> list[Any]:
        values = [0] * self.size
        values[int(x) - self.start] = 1
        return values


class _Flattened:
    """Any other space's element through Gymnasium's ``flatten``."""

    def __init__(self, space: spaces.Space[Any]) -> None:
        self.space = space

    def __call__(self, x: Any) -> list[Any]:
        return np.asarray(spaces.flatten(self.space, x)).ravel().tolist()
