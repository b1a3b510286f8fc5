"""Compiled simulation for search: which models have it, and how a model is turned into it.

A search runs compiled (numba, the ``fast`` extra) when the planning model's family has a
compiled step; otherwise it runs the reference Python path, which is correct and slower. Nothing
here imports numba: the kernels (:mod:`ns_pz.agents.search._kernels`) load on first use, and
their machine code is cached on disk, so only the first use on a machine compiles.

Built in: every tabular model (one with an outcome table ``model.outcomes``: FrozenLake,
CliffWalking, Bridge, ...) and CartPole. The tabular kernel samples as the slip grids do (one
uniform draw, the first outcome whose cumulative probability exceeds it), so for them it is
bit-identical to the reference path; a tabular family that samples its ``step`` differently gets
statistically identical transitions from its table, not the same ones.

Adding a family takes three pieces:

1. a ``NamedTuple`` class holding what the step needs (θ-derived floats and arrays);
2. a ``numba.njit(cache=True, inline="always")`` step ``step(data, state, out, action, rng) ->
   (reward, terminal)`` over ``float64`` state vectors that writes the next state into ``out``
   and draws randomness with ``rng.random()`` in the same order as the family's Python ``step``
   (then the compiled and reference searches agree bit for bit; test it as
   ``tests/test_mcts.py`` does for CartPole), registered with
   ``_kernels.register_step(DataClass, step)`` (``deterministic=True`` if it never draws:
   searches then walk known edges of their trees without simulating them again) in a module
   named in :data:`COMPILED_STEP_MODULES` (imported when the kernels load; ``_kernels`` itself
   shows both built-in steps);
3. ``register_compiled_family(FamilyClass, encode, to_vector, from_vector)`` in numba-free code
   (here, beside the built-ins): ``encode(model)`` builds the ``NamedTuple`` from the model's θ.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType
from typing import Any, NamedTuple

import numpy as np
from ns_pz.envs.cartpole import THETA_THRESHOLD_RADIANS, X_THRESHOLD, CartPoleFamily

COMPILED_STEP_MODULES: list[str] = ["ns_pz.agents.search._kernels"]
"""Modules that register compiled steps; imported, in order, the first time kernels are used."""

BACKENDS = ("auto", "compiled", "python")


CUMULATIVE, NEXT_STATE, REWARD, TERMINAL, NEXT_OFFSET, FIELDS = 0, 1, 2, 3, 4, 5
"""What :attr:`TabularData.table` holds for each outcome, by index along its last axis (of
length ``FIELDS``).

The kernels compile these numbers in, and numba's on-disk cache of ``_kernels.py`` does not
notice a change here: after changing them, delete that cache folder
(:mod:`~ns_pz.agents.search.numba_cache`).
"""


class TabularData(NamedTuple):
    """An outcome table (:class:`ns_pz.planning.TabularOutcomes`) as one C-contiguous array.

    A step draws ``u`` uniform in [0, 1) and takes the first outcome whose cumulative
    probability exceeds it; the Python model takes the last outcome of positive probability
    where rounding leaves the total at or below ``u``. Here the cumulative probability (summed
    in the Python model's order, so the same numbers) is infinite from the last outcome of
    positive probability on, which gives that outcome for every draw the others leave, without
    a rule apart (the outcomes after it have no probability).

    One array rather than one per quantity: the search reads the table at every step of its
    tree, and numba counts references to each array of the tuple each time (one more array in
    the table made ADA-MCTS's decisions about 5 % slower; one array in place of four, about
    30 % faster). A rollout reads every outcome of a row at each step (it counts rather than
    stops), which suits the few outcomes of the built-in grids.

    A rollout walks from outcome to outcome through ``NEXT_OFFSET``: where the next state's
    first entry lies in the table flattened, an ``int64`` held in the float's bits (read
    through an integer view of the array). It saves the conversion of ``NEXT_STATE`` to an
    integer and the multiplication by a state's length at every step, which lie on the chain
    of dependent instructions from one step to the next (a CliffWalking rollout step took
    7.3 ns against 12.3 ns).

    Attributes:
        table: ``[num_states, num_actions, num_outcomes, FIELDS]`` float64: each outcome's
            cumulative probability, next state, reward, terminal flag (1.0 or 0.0) and the next
            state's offset, at the indices ``CUMULATIVE``, ``NEXT_STATE``, ``REWARD``,
            ``TERMINAL`` and ``NEXT_OFFSET``.
    """

    table: np.ndarray


class CartPoleData(NamedTuple):
    """CartPole's θ as floats, its integrator and its termination thresholds."""

    gravity: float
    masscart: float
    masspole: float
    length: float
    force_mag: float
    tau: float
    euler: bool
    x_threshold: float
    theta_threshold: float


@dataclass(frozen=True)
class CompiledFamily:
    """How models of one family become compiled simulations.

    Attributes:
        encode: ``encode(model) -> data``, the family's ``NamedTuple`` under the model's θ.
        to_vector: A family state as a ``float64`` vector.
        from_vector: The inverse of ``to_vector``.
        float32_observation: Whether ``family.observe(state)`` is ``to_vector(state)`` rounded
            to float32 (CartPole): then a network over observations can run inside a compiled
            search (:func:`ns_pz.agents.learning.puct.puct_tree`).
    """

    encode: Callable[[Any], Any]
    to_vector: Callable[[Any], np.ndarray]
    from_vector: Callable[[np.ndarray], Any]
    float32_observation: bool = False


@dataclass(frozen=True)
class CompiledModel:
    """One planning model made ready for the kernels.

    Attributes:
        data: The family's ``NamedTuple`` under the model's θ.
        family: How states convert to and from vectors.
        num_actions: Size of the discrete action space.
        rng: The model's generator (transitions draw from it, as the model's own ``step``).
    """

    data: Any
    family: CompiledFamily
    num_actions: int
    rng: np.random.Generator


_FAMILIES: dict[type, CompiledFamily] = {}


def register_compiled_family(
    family_cls: type,
    encode: Callable[[Any], Any],
    to_vector: Callable[[Any], np.ndarray],
    from_vector: Callable[[np.ndarray], Any],
    float32_observation: bool = False,
) -> None:
    """Declare that models of ``family_cls`` (and its subclasses) can run compiled.

    Args:
        family_cls: The family class.
        encode: ``encode(model) -> data`` (an instance of the ``NamedTuple`` whose step is
            registered with ``_kernels.register_step``).
        to_vector: A state as a ``float64`` vector.
        from_vector: A ``float64`` vector as a state.
        float32_observation: The family's ``observe(state)`` is ``to_vector(state)`` rounded to
            float32 (see :class:`CompiledFamily`).

    Raises:
        TypeError: ``family_cls`` is not a class or a converter is not callable.
    """
    if not isinstance(family_cls, type):
        raise TypeError(f"family_cls={family_cls!r} must be a family class")
    for name, fn in (("encode", encode), ("to_vector", to_vector), ("from_vector", from_vector)):
        if not callable(fn):
            raise TypeError(f"{name}={fn!r} must be callable")
    _FAMILIES[family_cls] = CompiledFamily(
        encode, to_vector, from_vector, bool(float32_observation)
    )


def numba_available() -> bool:
    """Whether numba can be imported (without importing it)."""
    return importlib.util.find_spec("numba") is not None


def kernels() -> ModuleType:
    """The cached kernels module (imports numba and every step module on first call)."""
    for name in COMPILED_STEP_MODULES:
        importlib.import_module(name)
    return importlib.import_module("ns_pz.agents.search._kernels")


def warm_up() -> None:
    """Import the kernels and start numba now, where numba is installed.

    A process's first cached kernel costs numba's own start besides its own loading (about
    0.3 s on the development machine, once per process, whichever kernel it is). A benchmark
    worker calls this as it starts, while the runner still loads the spec, so its first search
    or network training does not wait for numba.
    """
    if numba_available():
        kernels().ready(0)


_UNCACHED = "ns_pz.agents.search._kernels_uncached"


def uncached_kernels() -> ModuleType:
    """A second copy of the kernels that never writes to numba's on-disk cache."""
    module = sys.modules.get(_UNCACHED)
    if module is None:
        source = kernels().__file__
        spec = importlib.util.spec_from_file_location(_UNCACHED, source)
        if spec is None or spec.loader is None:  # pragma: no cover - the file was just imported
            raise ImportError(f"cannot load a copy of {source}")
        module = importlib.util.module_from_spec(spec)
        sys.modules[_UNCACHED] = module
        spec.loader.exec_module(module)
    return module


def kernels_for(data_cls: type) -> ModuleType:
    """The kernels that serve ``data_cls``: cached if it lives in ``ns_pz``, else uncached.

    Numba's cache index names every type a kernel was compiled for; a class from a script or a
    test module in it would make the index unreadable by any process that cannot import that
    module. Classes in ``ns_pz`` modules can always be imported, so only they are cached.
    """
    return kernels() if data_cls.__module__.startswith("ns_pz.") else uncached_kernels()


def register_step(
    data_cls: type, step: Any, rollout: Any = None, deterministic: bool = False
) -> None:
    """Register the compiled ``step`` (and optional ``rollout``) of ``data_cls``'s family.

    See :func:`ns_pz.agents.search._kernels.register_step` for the contract (``deterministic``
    included); this picks the cached or uncached kernels (:func:`kernels_for`).
    """
    kernels_for(data_cls).register_step(data_cls, step, rollout, deterministic)


def compiled_family_of(model: Any) -> CompiledFamily | None:
    """The compiled family for ``model``, or None if it has none.

    Tabular models (with an ``outcomes`` table) always have one; other models have one if their
    family class (or a base class of it) was registered.
    """
    if hasattr(model, "outcomes"):
        return _TABULAR
    family = getattr(model, "family", None)
    for cls in type(family).__mro__:
        if cls in _FAMILIES:
            return _FAMILIES[cls]
    return None


def compile_model(model: Any, backend: str) -> CompiledModel | None:
    """The compiled form of ``model`` for ``backend``, or None for the reference path.

    Args:
        model: A planning model.
        backend: ``"auto"`` (compiled where possible), ``"compiled"`` (required) or ``"python"``.

    Raises:
        ValueError: ``backend`` is unknown, or ``"compiled"`` was asked for and is not possible,
            or the model's outcome table is one the compiled search cannot draw from as the
            Python model does (see :func:`_tabular_data`).
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend={backend!r} is not a backend; allowed: {list(BACKENDS)}")
    if backend == "python":
        return None
    family = compiled_family_of(model)
    if family is not None and numba_available() and _has_generator(model):
        return CompiledModel(family.encode(model), family, int(model.action_space.n), model.rng)
    if backend == "compiled":
        if not numba_available():
            reason = "numba is not installed (pip install 'ns_pz[fast]')"
        elif family is None:
            reason = f"{type(getattr(model, 'family', model)).__name__} has no compiled step"
        else:
            reason = "the model has no numpy Generator `rng` to draw transitions from"
        raise ValueError(f"backend='compiled' is not possible: {reason}")
    return None


# --- built-in families ----------------------------------------------------------------------
def _tabular_data(model: Any) -> TabularData:
    """The compiled table of ``model.outcomes`` (built by :func:`._kernels.pack_table`).

    Raises:
        ValueError: A row of probabilities that is no distribution the Python model could draw
            from (a NaN, a negative entry, no positive entry), where the kernels would pick an
            outcome it never would; a table that is not ``[states, actions, outcomes >= 1]``,
            whose arrays differ in shape, or whose next states are no states of it (the kernels
            would read outside it).
    """
    table = model.outcomes
    probs = np.asarray(table.probs, dtype=np.float64)
    if probs.ndim != 3 or probs.shape[2] == 0:
        raise ValueError(
            f"outcomes.probs has shape {probs.shape}; expected [states, actions, outcomes >= 1]"
        )
    parts = {
        "next_states": np.asarray(table.next_states, dtype=np.int64),
        "rewards": np.asarray(table.rewards, dtype=np.float64),
        "terminals": np.asarray(table.terminals, dtype=np.bool_),
    }
    for name, part in parts.items():  # the kernel reads them unchecked, as probs is read
        if part.shape != probs.shape:
            raise ValueError(
                f"outcomes.{name} has shape {part.shape}, probs has {probs.shape}; they must agree"
            )
    next_states = parts["next_states"]
    if next_states.size and (next_states.min() < 0 or next_states.max() >= probs.shape[0]):
        raise ValueError(
            f"outcomes.next_states must lie in [0, {probs.shape[0]}); they hold "
            f"{next_states.min()} .. {next_states.max()}"
        )
    packed, s, a = kernels().pack_table(probs, *parts.values())
    if s >= 0:
        raise ValueError(
            f"outcomes.probs[{s}, {a}] = {probs[s, a].tolist()} must be non-negative numbers, "
            "not all zero"
        )
    return TabularData(packed)


def _cartpole_data(model: Any) -> CartPoleData:
    theta = model.theta
    return CartPoleData(
        float(theta.gravity),
        float(theta.masscart),
        float(theta.masspole),
        float(theta.length),
        float(theta.force_mag),
        float(theta.tau),
        bool(model.family.kinematics_integrator == "euler"),
        X_THRESHOLD,
        THETA_THRESHOLD_RADIANS,
    )


_TABULAR = CompiledFamily(
    _tabular_data, lambda s: np.array([float(s)]), lambda v: int(round(float(v[0])))
)
register_compiled_family(
    CartPoleFamily,
    _cartpole_data,
    lambda s: np.array(s, dtype=np.float64),
    lambda v: tuple(float(x) for x in v),
    float32_observation=True,
)


def _has_generator(model: Any) -> bool:
    return isinstance(getattr(model, "rng", None), np.random.Generator)
