"""Parameter sets θ: immutable values with one spec per parameter.

A family declares its θ as a frozen dataclass whose fields are made with :func:`scalar` or
:func:`simplex`::

    @dataclass(frozen=True, slots=True)
    class CartPoleParams(Params):
        masspole: float = scalar(0.1, low=0.0, low_open=True, unit="kg")

        @property
        def polemass_length(self) -> float:  # derived, so it can never go stale
            return self.masspole * self.length

Constructing a ``Params`` validates every field, so an invalid θ cannot exist. Nature's moves
create new values (:meth:`Params.replace`); the old value stays valid for logs and planners.

Change sizes (:meth:`Params.change_sizes`) are the absolute difference for a scalar and the
Wasserstein-1 distance for a probability vector. The ground metric between the outcomes of a
probability vector is the discrete metric (distance 1 between any two different outcomes), under
which W1 equals the total-variation distance ``0.5 * sum(|p - q|)``.
"""

from __future__ import annotations

import dataclasses
import difflib
import itertools
import math
import operator
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, Self, cast

import numpy as np

from ns_pz.errors import ParamOutOfRange, UnknownParam

SCALAR = "scalar"
SIMPLEX = "simplex"
SIMPLEX_ATOL = 1e-8
"""How far from 1 the sum of a probability vector may be."""

_SPEC_KEY = "ns_pz.param"

Value = float | tuple[float, ...]


@dataclass(frozen=True)
class ParamSpec:
    """What one parameter may be: its name, kind, default, bounds and unit.

    Attributes:
        name: The field name in the parameter set.
        kind: ``"scalar"`` or ``"simplex"`` (a probability vector).
        default: The value a family is built with.
        low: Lower bound of a scalar (``-inf`` for none). Elements of a probability vector always
            lie in ``[0, 1]``.
        high: Upper bound of a scalar (``inf`` for none).
        low_open: Whether ``low`` itself is excluded (a mass must be ``> 0``).
        high_open: Whether ``high`` itself is excluded.
        unit: Physical unit, for display.
        doc: One line saying what the parameter means.
        outcomes: For a probability vector, the name of each element, in order.
    """

    name: str
    kind: str
    default: Value
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    unit: str = ""
    doc: str = ""
    outcomes: tuple[str, ...] = ()
    size: int = field(init=False)
    """Number of floats the parameter takes in a flat vector."""
    finite_range: tuple[float, float] = field(init=False, repr=False, compare=False)
    """The least and greatest admissible finite float of a scalar: a float ``v`` is admissible
    exactly when ``lo <= v <= hi`` (open bounds and infinities folded in; NaN fails)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "size", len(self.outcomes) if self.kind == SIMPLEX else 1)
        biggest = sys.float_info.max
        low = math.nextafter(self.low, math.inf) if self.low_open else max(self.low, -biggest)
        high = math.nextafter(self.high, -math.inf) if self.high_open else min(self.high, biggest)
        object.__setattr__(self, "finite_range", (float(low), float(high)))

    @property
    def width(self) -> float:
        """Widest possible change: ``high - low`` (``inf`` if unbounded); 1 for a vector (TV)."""
        return 1.0 if self.kind == SIMPLEX else self.high - self.low

    def allowed(self) -> str:
        """The allowed set, as an error message shows it."""
        if self.kind == SIMPLEX:
            return f"probability vectors of length {self.size} (elements in [0, 1], sum 1)"
        left = "(" if self.low_open else "["
        right = ")" if self.high_open else "]"
        return f"{left}{self.low}, {self.high}{right}"

    def contains(self, value: float) -> bool:
        """Whether a finite scalar lies inside the bounds."""
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def check(self, owner: str, value: Any) -> Value:
        """Validate ``value`` and return it in canonical form (float, or tuple of floats).

        Args:
            owner: Name of the parameter-set class, for the message.
            value: The candidate value.

        Raises:
            ParamOutOfRange: The value is not a finite number inside the bounds, or not a
                probability vector of the right length.
        """
        where = f"{owner}.{self.name}={value!r}"
        if self.kind == SCALAR:
            number = _as_float(value, where)
            if not math.isfinite(number):
                raise ParamOutOfRange(f"{where} is not finite; allowed: {self.allowed()}")
            if not self.contains(number):
                raise ParamOutOfRange(f"{where} is outside {self.allowed()}")
            return number
        vector = _as_vector(value, where, self.size)
        if not all(math.isfinite(p) for p in vector):
            raise ParamOutOfRange(f"{where} is not finite; allowed: {self.allowed()}")
        if any(p < 0.0 or p > 1.0 for p in vector):
            raise ParamOutOfRange(f"{where} has an element outside [0, 1]")
        total = math.fsum(vector)
        if abs(total - 1.0) > SIMPLEX_ATOL:
            raise ParamOutOfRange(
                f"{where} sums to {total!r}, not 1 (tolerance {SIMPLEX_ATOL}); "
                f"allowed: {self.allowed()}"
            )
        return vector

    def project(self, owner: str, value: Any) -> Value:
        """Return the admissible value nearest to ``value`` (Euclidean distance).

        Used on nature's proposals: a nature may ask for anything, the game grants the nearest
        allowed value. NaN has no nearest value and is refused.

        Raises:
            ParamOutOfRange: ``value`` contains NaN or is not a number / vector of the right size.
        """
        # Fast paths for values that are already admissible (NaN fails every comparison).
        if type(value) is float:
            low, high = self.finite_range
            if low <= value <= high and self.kind == SCALAR:
                return value
        elif type(value) is tuple and len(value) == self.size and self.kind == SIMPLEX:
            if _on_simplex(value):
                return value
        where = f"{owner}.{self.name}={value!r}"
        if self.kind == SCALAR:
            number = _as_float(value, where)
            if math.isnan(number):
                raise ParamOutOfRange(f"{where} is NaN; allowed: {self.allowed()}")
            if number <= self.low:
                number = math.nextafter(self.low, math.inf) if self.low_open else self.low
            elif number >= self.high:
                number = math.nextafter(self.high, -math.inf) if self.high_open else self.high
            if not math.isfinite(number):  # an unbounded side has no nearest finite value
                raise ParamOutOfRange(f"{where} has no nearest finite value in {self.allowed()}")
            return number
        vector = _as_vector(value, where, self.size)
        if not all(math.isfinite(p) for p in vector):
            raise ParamOutOfRange(f"{where} is not finite; allowed: {self.allowed()}")
        if all(0.0 <= p <= 1.0 for p in vector) and abs(math.fsum(vector) - 1.0) <= SIMPLEX_ATOL:
            return vector
        return self.check("projection of " + where, project_to_simplex(vector))  # type: ignore[return-value]

    def distance(self, a: Value, b: Value) -> float:
        """Size of the change from ``a`` to ``b``: ``|a - b|``, or W1 (= TV) for a vector."""
        if self.kind == SCALAR:
            return abs(b - a)  # type: ignore[operator]
        written_out = _TOTAL_VARIATIONS.get(self.size)
        if written_out is not None:
            try:
                return written_out(a, b)
            except ValueError:  # a vector of another length: the message below
                pass
        if len(a) != self.size or len(b) != self.size:  # type: ignore[arg-type]
            raise ValueError(
                f"{self.name}: the distance of {a!r} and {b!r} needs two vectors of "
                f"{self.size} elements"
            )
        return 0.5 * sum(map(abs, map(operator.sub, b, a)))  # type: ignore[arg-type]

    def flat_bounds(self) -> tuple[list[float], list[float]]:
        """Lower and upper bound of each float this parameter takes in a flat vector."""
        if self.kind == SIMPLEX:
            return [0.0] * self.size, [1.0] * self.size
        return [self.low], [self.high]


def _written_out_total_variation(size: int) -> Callable[[Any, Any], float]:
    """``0.5 * sum(|b_i - a_i|)`` for two vectors of ``size`` elements, one term at a time.

    Summed left to right as ``sum`` does on Python 3.11, in under half its time: the size of
    every change nature makes to a slip vector. (Python 3.12's ``sum`` compensates rounding
    errors, so there every size keeps ``sum``.)
    """
    a = ", ".join(f"a{i}" for i in range(size))
    b = ", ".join(f"b{i}" for i in range(size))
    terms = " + ".join(f"abs(b{i} - a{i})" for i in range(size))
    namespace: dict[str, Any] = {}
    source = f"def total_variation(a, b):\n    {a}, = a\n    {b}, = b\n    return 0.5 * ({terms})"
    exec(source, namespace)  # noqa: S102 - generated from an int, nothing else
    return namespace["total_variation"]  # type: ignore[no-any-return]


_TOTAL_VARIATIONS = (
    {size: _written_out_total_variation(size) for size in range(2, 9)}
    if sys.version_info < (3, 12)
    else {}
)
"""Written-out distances of probability vectors of 2 to 8 outcomes (larger ones, and every
size on Python 3.12 and later, use ``sum``)."""


def _on_simplex(vector: tuple[float, ...]) -> bool:
    """Whether every element is a Python float in [0, 1] and the sum is 1 within the tolerance.

    One pass (NaN fails the range test): the check of every change nature makes to a slip
    vector, where ``min``, ``max`` and ``sum`` took twice as long. Other numbers (a NumPy
    float32 sums in float32 and could pass a sum that is off in float64) take the slow path,
    which makes them floats.
    """
    total = 0.0
    for p in vector:
        if type(p) is not float or not 0.0 <= p <= 1.0:
            return False
        total += p
    return abs(total - 1.0) <= SIMPLEX_ATOL


def project_to_simplex(vector: Sequence[float]) -> tuple[float, ...]:
    """Euclidean projection of a finite vector onto the probability simplex.

    Sort-based algorithm (Held, Wolfe & Crowder 1974): subtract the threshold that makes the
    positive part sum to one. The projection is unchanged by adding a constant to every
    element, so the largest is first shifted to 0, which keeps huge inputs exact enough.
    """
    top = max(vector)
    vector = [p - top for p in vector]
    ordered = sorted(vector, reverse=True)
    running = 0.0
    threshold = 0.0
    for count, value in enumerate(ordered, start=1):
        running += value
        candidate = (running - 1.0) / count
        if value - candidate > 0.0:
            threshold = candidate
    return tuple(max(p - threshold, 0.0) for p in vector)


def scalar(
    default: float,
    *,
    low: float = -math.inf,
    high: float = math.inf,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
    doc: str = "",
) -> Any:
    """Declare a scalar parameter field of a :class:`Params` dataclass.

    Raises:
        ValueError: A NaN bound, ``low > high``, an empty open interval, or a default outside
            the declared range (caught here, at the declaration, not at the first θ).
    """
    meta = {
        "kind": SCALAR,
        "low": float(low),
        "high": float(high),
        "low_open": low_open,
        "high_open": high_open,
        "unit": unit,
        "doc": doc,
    }
    spec = ParamSpec(name="default", default=float(default), **meta)  # type: ignore[arg-type]
    lowest, highest = spec.finite_range
    if math.isnan(spec.low) or math.isnan(spec.high) or lowest > highest:
        raise ValueError(f"scalar(low={low!r}, high={high!r}) declares an empty or NaN range")
    try:
        spec.check("scalar", spec.default)
    except ParamOutOfRange:
        raise ValueError(
            f"scalar(default={default!r}) is outside the declared range {spec.allowed()}"
        ) from None
    return field(default=spec.default, metadata={_SPEC_KEY: meta})


def simplex(default: Sequence[float], *, outcomes: Sequence[str], doc: str = "") -> Any:
    """Declare a probability-vector parameter field of a :class:`Params` dataclass.

    Args:
        default: The default vector; must lie on the simplex.
        outcomes: One name per element, in order (``("intended", "clockwise", ...)``).
        doc: One line saying what the vector means.

    Raises:
        ValueError: No outcome, a length mismatch, or a default off the simplex.
    """
    if len(default) != len(outcomes) or len(outcomes) == 0:
        raise ValueError(
            f"simplex default has {len(default)} elements but outcomes names {len(outcomes)} "
            "(at least one)"
        )
    meta = {"kind": SIMPLEX, "low": 0.0, "high": 1.0, "outcomes": tuple(outcomes), "doc": doc}
    spec = ParamSpec(name="default", default=tuple(default), **meta)  # type: ignore[arg-type]
    try:
        vector = spec.check("simplex", spec.default)
    except ParamOutOfRange:
        raise ValueError(
            f"simplex(default={tuple(default)!r}) is not a probability vector"
        ) from None
    return field(default=vector, metadata={_SPEC_KEY: meta})


class Params:
    """Base of every parameter set θ. Subclasses are ``@dataclass(frozen=True, slots=True)``.

    Instances are immutable and validated at construction. The field order is the documented
    fixed order used by flat vectors, ``env_change`` and ``delta_change``.
    """

    __slots__ = ()
    _layouts: ClassVar[dict[type, _Layout]] = {}

    def __post_init__(self) -> None:
        owner = type(self).__name__
        for spec in self.specs():
            object.__setattr__(self, spec.name, spec.check(owner, getattr(self, spec.name)))

    @classmethod
    def _layout(cls) -> _Layout:
        layout = Params._layouts.get(cls)
        if layout is None:
            specs = tuple(_spec_of(cls, f) for f in dataclasses.fields(cls))  # type: ignore[arg-type]
            stops = list(itertools.accumulate(s.size for s in specs))
            slices = tuple((s, stop - s.size, stop) for s, stop in zip(specs, stops, strict=True))
            by_name = {s.name: s for s in specs}
            names = tuple(s.name for s in specs)
            scalars = None
            if all(s.kind == SCALAR for s in specs):
                get = operator.attrgetter(*names)
                scalars = get if len(names) > 1 else (lambda theta, get=get: (get(theta),))
            layout = _Layout(specs, names, by_name, slices, scalars, _evolver(cls, names))
            Params._layouts[cls] = layout
        return layout

    @staticmethod
    def layout_of(theta: Params) -> _Layout:
        """Lookup tables of ``theta``'s class (built on first use; an unpickled θ may be first)."""
        return Params._layouts.get(type(theta)) or type(theta)._layout()

    @classmethod
    def specs(cls) -> tuple[ParamSpec, ...]:
        """The spec of every parameter, in field order."""
        return cls._layout().specs

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """Parameter names in field order."""
        return cls._layout().names

    @classmethod
    def spec(cls, name: str) -> ParamSpec:
        """The spec of one parameter.

        Raises:
            UnknownParam: ``name`` is not a parameter of this set.
        """
        found = cls._layout().by_name.get(name)
        if found is None:
            raise UnknownParam(_unknown_message(cls, name))
        return found

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> Self:
        """Build from a mapping of names to values; names not given keep their default.

        Raises:
            UnknownParam: A name is not a parameter of this set.
            ParamOutOfRange: A value is invalid.
        """
        cls.check_names(values)
        return cls(**values)

    @classmethod
    def check_names(cls, names: Iterable[str]) -> None:
        """Raise :class:`UnknownParam` for the first name this set does not declare."""
        known = cls.names()
        for name in names:
            if name not in known:
                raise UnknownParam(_unknown_message(cls, name))

    def replace(self, **changes: Any) -> Self:
        """A new, validated θ with some parameters changed; ``self`` is untouched.

        Raises:
            UnknownParam: A name is not a parameter of this set.
            ParamOutOfRange: A new value is invalid.
        """
        self.check_names(changes)
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]

    def evolve_trusted(self, changes: Mapping[str, Value]) -> Self:
        """A new θ with ``changes`` applied *without* validation.

        For the game's hot path only, after it has projected every value onto its spec; callers
        outside ns_pz should use :meth:`replace`.
        """
        return Params.layout_of(self).evolve(self, changes)  # type: ignore[no-any-return]

    def as_dict(self) -> dict[str, Value]:
        """Parameter values by name, in field order."""
        return {name: getattr(self, name) for name in self.names()}

    def flat(self) -> np.ndarray:
        """All parameters as one float64 vector, in field order (vectors expanded)."""
        return np.array(self.flat_values(), dtype=np.float64)

    def flat_values(self) -> list[float]:
        """All parameters as one list of floats, in field order (vectors expanded)."""
        layout = Params.layout_of(self)
        if layout.scalars is not None:
            return list(layout.scalars(self))
        out: list[float] = []
        for spec in layout.specs:
            value = getattr(self, spec.name)
            if spec.kind == SIMPLEX:
                out.extend(value)
            else:
                out.append(value)
        return out

    @classmethod
    def flat_layout(cls) -> tuple[tuple[ParamSpec, int, int], ...]:
        """Where each parameter sits in :meth:`flat`: ``(spec, start, stop)`` in field order."""
        return cls._layout().slices

    @classmethod
    def flat_bounds(cls) -> tuple[np.ndarray, np.ndarray]:
        """Per-element lower and upper bounds of :meth:`flat` (float64)."""
        lows: list[float] = []
        highs: list[float] = []
        for spec in cls.specs():
            low, high = spec.flat_bounds()
            lows.extend(low)
            highs.extend(high)
        return np.array(lows, dtype=np.float64), np.array(highs, dtype=np.float64)

    def change_sizes(self, previous: Params) -> tuple[float, ...]:
        """Size of each parameter's change from ``previous`` to ``self`` (0.0 if unchanged).

        Raises:
            TypeError: ``previous`` is not a parameter set of the same class.
        """
        if type(previous) is not type(self):
            raise TypeError(
                f"change_sizes(previous={previous!r}) needs a {type(self).__name__} (the θ "
                "changed from)"
            )
        return tuple(
            spec.distance(getattr(previous, spec.name), getattr(self, spec.name))
            for spec in self.specs()
        )


@dataclass(frozen=True)
class _Layout:
    """Per-class lookup tables, built once."""

    specs: tuple[ParamSpec, ...]
    names: tuple[str, ...]
    by_name: dict[str, ParamSpec]
    slices: tuple[tuple[ParamSpec, int, int], ...]
    scalars: Callable[[Any], tuple[float, ...]] | None
    """Every value as a tuple, when all parameters are scalars (a fast path of ``flat``)."""
    evolve: Callable[[Any, Mapping[str, Any]], Any]
    """``evolve(theta, changes)``: the body of :meth:`Params.evolve_trusted` for this class."""


def _evolver(cls: type, names: tuple[str, ...]) -> Callable[[Any, Mapping[str, Any]], Any]:
    """A function that copies a θ of ``cls`` with some fields replaced, without validation.

    Written out field by field (as ``dataclasses`` writes ``__init__``) and storing through the
    slots' own descriptors, it takes half the time of a loop of ``object.__setattr__`` on
    CartPole's six fields, and it runs for every change nature makes. A class without slots
    gets the loop.
    """
    slots = [getattr(cls, name, None) for name in names]
    if not all(type(slot).__name__ == "member_descriptor" for slot in slots):

        def evolve_by_setattr(theta: Any, changes: Mapping[str, Any]) -> Any:
            new: Any = object.__new__(cls)
            for name in names:
                object.__setattr__(new, name, changes.get(name, getattr(theta, name)))
            return new

        return evolve_by_setattr
    namespace: dict[str, Any] = {"new_object": object.__new__, "cls": cls}
    lines = ["def evolve(theta, changes):", "    new = new_object(cls)", "    get = changes.get"]
    for i, (name, slot) in enumerate(zip(names, slots, strict=True)):
        namespace[f"set_{i}"] = slot.__set__  # type: ignore[union-attr]
        lines.append(f"    set_{i}(new, get({name!r}, theta.{name}))")
    lines.append("    return new")
    exec("\n".join(lines), namespace)  # noqa: S102 - our own field names, checked identifiers
    return namespace["evolve"]  # type: ignore[no-any-return]


def _spec_of(cls: type, f: dataclasses.Field[Any]) -> ParamSpec:
    meta = f.metadata.get(_SPEC_KEY)
    if meta is None:
        raise TypeError(
            f"{cls.__name__}.{f.name} must be declared with ns_pz.params.scalar() or simplex()"
        )
    return ParamSpec(name=f.name, default=cast(Value, f.default), **meta)


def _unknown_message(cls: type[Params], name: str) -> str:
    known = cls.names()
    close = difflib.get_close_matches(name, known, n=3)
    hint = f" (did you mean {', '.join(map(repr, close))}?)" if close else ""
    return f"{cls.__name__} has no parameter {name!r}{hint}; known: {', '.join(known)}"


def _as_float(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        if isinstance(value, np.ndarray) and value.shape == ():
            return float(value)
        raise ParamOutOfRange(f"{where} is not a real number")
    return float(value)


def _as_vector(value: Any, where: str, size: int) -> tuple[float, ...]:
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ParamOutOfRange(f"{where} is not a sequence of {size} probabilities")
    try:
        vector = tuple(float(p) for p in value)
    except (TypeError, ValueError):
        raise ParamOutOfRange(f"{where} is not a sequence of {size} probabilities") from None
    if len(vector) != size:
        raise ParamOutOfRange(f"{where} has {len(vector)} elements, expected {size}")
    return vector
