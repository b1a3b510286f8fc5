"""Nature policies: who proposes the next θ.

A nature policy maps nature's observation (step ``t``, current θ, budget left) to a proposal,
a mapping from parameter names to new values (``None`` for no change). The game projects every
proposal onto the allowed set (:func:`ns_pz.nature.constraints.admit`).

Policies are shared, immutable settings. What a policy must remember within an episode (how
often each update function has fired) lives in a *memory* object that the environment creates
with :meth:`Nature.initial_memory` at every reset and hands back at every step, so one policy
instance can drive many environments at once.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ns_pz.nature.updates import DistributionUpdateFn, UpdateFn, check_real
from ns_pz.params import SIMPLEX, Params, Value

if TYPE_CHECKING:
    from ns_pz.process import NSProcess

Proposal = Mapping[str, Value] | None


class Nature(ABC):
    """Base of every nature policy."""

    def bind(self, params_cls: type[Params]) -> None:  # noqa: B027 - optional hook
        """Check, once, that the policy fits a parameter set; raise a clear error if not."""

    def initial_memory(self) -> Any:
        """Fresh per-episode memory (``None`` for a memoryless policy)."""
        return None

    def initial_params(self, theta0: Params, rng: np.random.Generator) -> Params | None:
        """The episode's θ_0 if this nature draws one at reset (``None``: keep ``theta0``).

        Called at every reset that does not set θ_0 explicitly, with the nominal θ_0 and
        nature's generator just seeded (:class:`~ns_pz.nature.DomainRandomisation`).
        """
        return None

    def act(self, process: NSProcess) -> Proposal:
        """The proposal for the process's current step; the game calls this once per step.

        The default asks :meth:`propose` with the step, θ, the budget left, the episode memory
        and nature's generator. Natures that read more of the process (a learned policy that
        observes the agent's state) override it.
        """
        return self.propose(
            process.t,
            process.theta,
            process.budget_left,
            process.nature_memory,
            process.nature_rng,  # type: ignore[arg-type]
        )

    @abstractmethod
    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """The proposed changes at step ``t``, or ``None`` for none.

        Args:
            t: Step index (transitions completed since reset); the proposal applies to transition t.
            theta: The θ in force so far (θ_{t-1}; θ_0 at t=0).
            budget_left: What remains of the change budget (``inf`` when unlimited).
            memory: This episode's memory, from :meth:`initial_memory`; may be updated in place.
            rng: Nature's generator, seeded at reset.
        """


class StaticNature(Nature):
    """Never changes θ: the environment is stationary."""

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """Always ``None``."""
        return None

    def __repr__(self) -> str:
        return "StaticNature()"


class ScriptedNature(Nature):
    """A schedule: each parameter follows one update function (NS-Gym's ``tunable_params``).

    Args:
        updates: Parameter name → update function. Scalar parameters take an
            :class:`~ns_pz.nature.updates.UpdateFn`, probability vectors a
            :class:`~ns_pz.nature.updates.DistributionUpdateFn`. Parameters not named stay fixed.

    Each step, parameters are visited in the order given; for each, the scheduler is asked
    first and the rule applied only if it fires, both drawing from nature's generator.
    """

    def __init__(self, updates: Mapping[str, UpdateFn | DistributionUpdateFn]) -> None:
        if not isinstance(updates, Mapping):
            raise TypeError(f"updates={updates!r} must be a mapping of parameter name to update fn")
        for name, fn in updates.items():
            if not isinstance(name, str):
                raise TypeError(f"parameter name {name!r} in updates must be a str")
            if not isinstance(fn, (UpdateFn, DistributionUpdateFn)):
                raise TypeError(
                    f"updates[{name!r}]={fn!r} must be an ns_pz update function "
                    "(IncrementUpdate, StepWiseUpdate, DistributionDecrementUpdate, ...)"
                )
        self.updates = dict(updates)
        self._entries = tuple(self.updates.items())
        self._stateful = frozenset(name for name, fn in self._entries if fn.stateful)

    def bind(self, params_cls: type[Params]) -> None:
        """Check names exist and each rule matches its parameter's kind.

        Raises:
            UnknownParam: A name is not a parameter of ``params_cls``.
            TypeError: A scalar rule on a probability vector, or the reverse.
            ValueError: A vector rule's vectors have the wrong length.
        """
        params_cls.check_names(self.updates)
        for name, fn in self._entries:
            spec = params_cls.spec(name)
            if spec.kind == SIMPLEX:
                if not isinstance(fn, DistributionUpdateFn):
                    raise TypeError(
                        f"{params_cls.__name__}.{name} is a probability vector; updates[{name!r}]"
                        f"={fn!r} is a scalar rule (use a Distribution* update function)"
                    )
                fn.check_size(name, spec.size)
            elif not isinstance(fn, UpdateFn):
                raise TypeError(
                    f"{params_cls.__name__}.{name} is a scalar; updates[{name!r}]={fn!r} is a "
                    "distribution rule (use a scalar update function)"
                )

    def initial_memory(self) -> dict[Any, Any]:
        """Fresh episode memory: firing counts (all zero) and stateful rules' memories.

        Counts are under the parameter's name, the memory of a stateful rule under
        ``("memory", name)``.
        """
        memory: dict[Any, Any] = dict.fromkeys(self.updates, 0)
        for name in self._stateful:
            memory["memory", name] = self.updates[name].initial_memory()
        return memory

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """New values for the parameters whose scheduler fires at ``t``."""
        proposal: dict[str, Value] | None = None
        for name, fn in self._entries:
            if fn.scheduler(t, rng):
                count = memory[name]
                memory[name] = count + 1
                if proposal is None:
                    proposal = {}
                value = getattr(theta, name)
                if name in self._stateful:
                    new = fn.update(value, t, count, rng, memory["memory", name])  # type: ignore[call-arg]
                else:
                    new = fn.update(value, t, count, rng)
                proposal[name] = new
        return proposal

    def __repr__(self) -> str:
        return f"ScriptedNature({self.updates!r})"


class RandomNature(Nature):
    """Perturbs every parameter at every step: a stress test and a domain-randomisation baseline.

    Scalars take a Gaussian step of standard deviation ``scale * (|value| + 1)``; each element of
    a probability vector takes a step of standard deviation ``scale``, after which the game
    projects the vector back onto the simplex.
    """

    def __init__(self, scale: float = 0.05) -> None:
        self.scale = check_real("scale", scale)
        if self.scale < 0:
            raise ValueError(f"scale={scale!r} must be >= 0")

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """A random step for every parameter."""
        proposal: dict[str, Value] = {}
        for spec in theta.specs():
            value = getattr(theta, spec.name)
            if spec.kind == SIMPLEX:
                noise = rng.normal(0.0, self.scale, size=spec.size)
                pairs = zip(value, noise, strict=True)  # type: ignore[call-overload]
                proposal[spec.name] = tuple(float(p + e) for p, e in pairs)
            else:
                step = self.scale * (abs(value) + 1.0) * float(rng.standard_normal())  # type: ignore[arg-type]
                proposal[spec.name] = value + step  # type: ignore[operator]
        return proposal

    def __repr__(self) -> str:
        return f"RandomNature(scale={self.scale!r})"


class TrajectoryNature(Nature):
    """Replays a recorded θ trajectory: at each recorded step, the θ recorded for it.

    Args:
        change_times: Steps at which θ changed (as :attr:`ns_pz.GroundTruth.change_times`).
        change_values: θ after each of those changes.

    Raises:
        TypeError: A time is not an int, a value not a parameter set (all of one class).
        ValueError: The two have different lengths, or the times are not increasing
            non-negative steps.
    """

    def __init__(self, change_times: tuple[int, ...] | list[int], change_values: Any) -> None:
        change_times = tuple(change_times)
        for t in change_times:
            if isinstance(t, bool) or not isinstance(t, (int, np.integer)):
                raise TypeError(f"change_times={change_times!r}: {t!r} is not an int step")
        times = tuple(int(t) for t in change_times)
        values = tuple(change_values)
        if len(times) != len(values):
            raise ValueError(
                f"change_times has {len(times)} entries but change_values {len(values)}"
            )
        if any(b <= a for a, b in zip(times, times[1:], strict=False)) or (times and times[0] < 0):
            raise ValueError(f"change_times={times!r} must be strictly increasing steps >= 0")
        classes = {type(value) for value in values}
        if not all(isinstance(value, Params) for value in values) or len(classes) > 1:
            raise TypeError(
                "change_values must be parameter sets of one class (as "
                f"GroundTruth.change_values), got {sorted(c.__name__ for c in classes)}"
            )
        self._by_time = dict(zip(times, values, strict=True))
        self._params_cls = classes.pop() if classes else None

    def bind(self, params_cls: type[Params]) -> None:
        """Check the recorded values are of this family's parameter class.

        Raises:
            TypeError: They are of another.
        """
        if self._params_cls is not None and self._params_cls is not params_cls:
            raise TypeError(
                f"TrajectoryNature recorded {self._params_cls.__name__} values; this "
                f"environment's parameters are {params_cls.__name__}"
            )

    def propose(
        self, t: int, theta: Params, budget_left: float, memory: Any, rng: np.random.Generator
    ) -> Proposal:
        """Every field of the θ recorded for ``t``, or ``None`` if none was."""
        target = self._by_time.get(t)
        return None if target is None else target.as_dict()

    def __repr__(self) -> str:
        return f"TrajectoryNature(change_times={tuple(self._by_time)!r})"
