"""Gymnasium's ``info`` of a MuJoCo task kept inside a state, and MuJoCo's instability warnings.

A state of a MuJoCo family ends with the values of the ``info`` Gymnasium returned when the state
was made (its reset info for a start state, its step info after a step), as float64, and one
status number saying which of the two it is and whether the step that made it was unstable. So
``info`` is a function of the state, like the observation, and the view passes it on
(:meth:`~ns_pz.family.EnvFamily.info`). Values come back as Python floats (Gymnasium gives some
as ``int`` or ``float32``) and arrays as float64 arrays (Humanoid's tendon lengths).

Instability: when a position, velocity or acceleration becomes NaN or huge, MuJoCo puts a warning
in ``MjData.warning`` and resets the simulation to the model's rest pose on its own, in the middle
of the step. The family reads the three warning counters after each step (three integer reads);
see :class:`~ns_pz.envs.mujoco_family.MujocoFamily` for what it does then.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from typing import Any

import mujoco
import numpy as np

UNSTABLE_WARNINGS = (
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
    mujoco.mjtWarning.mjWARN_BADQACC,
)
"""The warnings after which MuJoCo resets the simulation: bad position, velocity, acceleration."""

START, STEPPED, UNSTABLE = 0.0, 1.0, 2.0
"""Status of a state: a start state; made by a step; made by an unstable step (plus a bit per
warning of :data:`UNSTABLE_WARNINGS` that fired, bit 0 for the first)."""


def warning_bits(numbers: np.ndarray) -> int:
    """A bit per warning of :data:`UNSTABLE_WARNINGS` whose counter in ``numbers`` is not 0."""
    return sum(1 << bit for bit, warning in enumerate(UNSTABLE_WARNINGS) if numbers[warning])


def warning_names(status: float) -> tuple[str, ...]:
    """The names of the warnings an unstable status records."""
    bits = int(status - UNSTABLE)
    return tuple(w.name for bit, w in enumerate(UNSTABLE_WARNINGS) if bits >> bit & 1)


class InfoLayout:
    """The keys and shapes of a task's reset and step ``info``, as Gymnasium gives them.

    Args:
        reset: ``(key, shape)`` of each reset-info entry, in Gymnasium's order.
        step: ``(key, shape)`` of each step-info entry.
    """

    def __init__(
        self,
        reset: tuple[tuple[str, tuple[int, ...]], ...],
        step: tuple[tuple[str, tuple[int, ...]], ...],
    ) -> None:
        self.reset, self.step = reset, step
        self.size = max(_count(reset), _count(step))
        """float64 entries the info takes in a state (the larger of the two)."""
        self.scalars = all(shape == () for _, shape in reset + step)
        """Whether every entry of both is a scalar (packed and read by one ``struct`` call)."""
        self._keys = (tuple(key for key, _ in reset), tuple(key for key, _ in step))
        # float64 values, then zero bytes up to size: one Struct per kind, reset first
        self._structs = tuple(
            struct.Struct(f"={_count(e)}d{8 * (self.size - _count(e))}x") for e in (reset, step)
        )

    @classmethod
    def of(cls, reset_info: Mapping[str, Any], step_info: Mapping[str, Any]) -> InfoLayout:
        """The layout of the given examples of the two."""

        def shapes(info: Mapping[str, Any]) -> tuple[tuple[str, tuple[int, ...]], ...]:
            return tuple((key, np.shape(value)) for key, value in info.items())

        return cls(shapes(reset_info), shapes(step_info))

    def pack(self, info: Mapping[str, Any], step: bool) -> bytes:
        """The values of ``info`` (of the step or reset kind) as float64 bytes of :attr:`size`."""
        if self.scalars:
            return self._structs[step].pack(*info.values())
        values = [np.ravel(np.asarray(v, dtype=np.float64)) for v in info.values()]
        return self._structs[step].pack(*np.concatenate(values).tolist())

    def unpack(self, state: bytes, offset: int, step: bool) -> dict[str, Any]:
        """The info dict whose values lie in ``state`` from byte ``offset`` on.

        Scalars come back as ``float``, arrays as float64 arrays of their own.
        """
        values = self._structs[step].unpack_from(state, offset)
        if self.scalars:  # the common case
            return dict(zip(self._keys[step], values, strict=True))
        info: dict[str, Any] = {}
        start = 0
        for key, shape in self.step if step else self.reset:
            count = math.prod(shape)
            if shape == ():
                info[key] = values[start]
            else:
                info[key] = np.array(values[start : start + count]).reshape(shape)
            start += count
        return info


def _count(entries: tuple[tuple[str, tuple[int, ...]], ...]) -> int:
    return sum(math.prod(shape) for _, shape in entries)
