"""MuJoCo families: Gymnasium's v5 locomotion and control tasks with physical constants as θ.

A family owns one Gymnasium MuJoCo env (its ``MjModel`` and ``MjData``) as a simulator and
steps it with that env's own ``step``, so frame skip, reward, termination and observation are
Gymnasium v5's exactly. θ is applied to the model before a step, and only when it changed:

* ``gravity``: the z component of ``opt.gravity`` in m/s² (negative: down), as NS-Gym changes it;
* ``*_mass``: ``body_mass`` of one body (inertia unchanged, as NS-Gym does);
* ``*_damping``: ``dof_damping`` of one joint;
* ``*_friction``: the sliding friction ``geom_friction[:, 0]`` of one geom.

A mass change makes MuJoCo's derived constants stale (subtree masses, inverse weights at
``qpos0``, ``stat``); :func:`mujoco.mj_setConst` recomputes them. Every step restores the
integration state afterwards, so a θ changed at run time gives exactly the trajectory of a model
built with that θ.

The state is an immutable ``bytes`` value (see :class:`StateLayout`): the full integration
state (``mj_getState`` with ``mjSTATE_INTEGRATION``: time, positions, velocities, activations,
warm start, controls and applied forces), the ``MjData`` fields Gymnasium's ``step`` reads
before simulating (Ant's ``xpos``, Humanoid's ``xipos``: they hold the positions of the last
substep, not of the integration state), and the observation, which some tasks compute from
forces of the last substep (``cfrc_ext``) and so is not a function of the integration state.
Saving and restoring a state is copying a reference; loading it into the simulator is one
``mj_setState``.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
import operator
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import mujoco
import numpy as np
from ns_pz.envs.continuous import check_box_action

from ns_pz.family import EnvFamily
from ns_pz.params import Params, scalar

GRAVITY = "gravity"
MASS = "mass"
DAMPING = "damping"
FRICTION = "friction"

_INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION
_GRAVITY_BOUNDS = (-50.0, 0.0)


@dataclass(frozen=True)
class Knob:
    """One θ field and where it lives in the model.

    Attributes:
        name: The θ field (NS-Gym's name).
        kind: :data:`GRAVITY`, :data:`MASS`, :data:`DAMPING` or :data:`FRICTION`.
        element: The body (mass), joint (damping) or geom (friction) it sets; empty for gravity.
        default: The compiled model's value (exact, so that default θ leaves the model as built).
    """

    name: str
    kind: str
    element: str
    default: float

    def field(self) -> Any:
        """The dataclass field declaring this parameter, with its bounds and unit."""
        if self.kind == GRAVITY:
            low, high = _GRAVITY_BOUNDS
            return scalar(self.default, low=low, high=high, unit="m/s^2", doc="z of gravity")
        if self.kind == MASS:
            return scalar(
                self.default,
                low=self.default / 10,
                high=self.default * 10,
                unit="kg",
                doc=f"mass of body {self.element!r} (a tenth to ten times Gymnasium's)",
            )
        high = max(self.default * 10, 1.0)
        what = "damping of joint" if self.kind == DAMPING else "sliding friction of geom"
        unit = "N m s/rad" if self.kind == DAMPING else ""
        return scalar(self.default, low=0.0, high=high, unit=unit, doc=f"{what} {self.element!r}")

    def slot(self, model: Any) -> tuple[np.ndarray, int]:
        """The model array and flat index this parameter is written to."""
        if self.kind == GRAVITY:
            return model.opt.gravity, 2
        if self.kind == MASS:
            return model.body_mass, model.body(self.element).id
        if self.kind == DAMPING:
            return model.dof_damping, int(model.jnt_dofadr[model.joint(self.element).id])
        if self.kind == FRICTION:
            return model.geom_friction.reshape(-1), 3 * model.geom(self.element).id
        raise ValueError(f"Knob.kind={self.kind!r}; allowed: gravity, mass, damping, friction")


def params_class(name: str, knobs: Sequence[Knob], doc: str) -> type[Params]:
    """A frozen :class:`Params` dataclass with one scalar field per knob, in order."""
    fields = [(knob.name, float, knob.field()) for knob in knobs]
    cls = dataclasses.make_dataclass(
        name, fields, bases=(Params,), frozen=True, slots=True, namespace={"__doc__": doc}
    )
    cls.__module__ = "ns_pz.envs.mujoco_tasks"
    return cls


@dataclass(frozen=True)
class StateLayout:
    """Where each part of a state lies in its ``bytes`` (float64 offsets and counts).

    Attributes:
        integration: Size of the ``mjSTATE_INTEGRATION`` state.
        carried: ``(MjData field, shape)`` of each field restored before a step.
        observation: Size of the observation.
    """

    integration: int
    carried: tuple[tuple[str, tuple[int, ...]], ...]
    observation: int

    @property
    def observation_offset(self) -> int:
        """Offset of the observation, in float64 entries."""
        return self.integration + sum(math.prod(shape) for _, shape in self.carried)

    @property
    def size(self) -> int:
        """Number of float64 entries in a state."""
        return self.observation_offset + self.observation


class MujocoFamily(EnvFamily):
    """A Gymnasium v5 MuJoCo task stepped on its own model, with :attr:`knobs` as θ.

    Subclasses set :attr:`gymnasium_env` (``"module:Class"``), :attr:`knobs`,
    :attr:`params_cls` (from :func:`params_class`) and, if the task's ``step`` reads
    kinematics before simulating, :attr:`carried`. The action space is Gymnasium's; finite
    actions outside it are passed on as given (MuJoCo clamps the controls, the control cost
    sees the action), as Gymnasium does.
    """

    gymnasium_env: ClassVar[str]
    knobs: ClassVar[tuple[Knob, ...]]
    carried: ClassVar[tuple[str, ...]] = ()
    """``MjData`` fields Gymnasium's ``step`` reads before it simulates."""

    def __init__(self) -> None:
        module, _, name = self.gymnasium_env.partition(":")
        self._env = getattr(importlib.import_module(module), name)()
        model, data = self._env.model, self._env.data
        self._model, self._data = model, data
        self.observation_space = self._env.observation_space
        self.action_space = self._env.action_space
        self._slots = [knob.slot(model) for knob in self.knobs]
        self._is_mass = [knob.kind == MASS for knob in self.knobs]
        self._read_theta = operator.attrgetter(*(knob.name for knob in self.knobs))
        self._theta: Params = self.default_params()
        self._values: tuple[float, ...] = self._as_tuple(self._theta)
        carried = tuple((field, getattr(data, field).shape) for field in self.carried)
        self.layout = StateLayout(
            mujoco.mj_stateSize(model, _INTEGRATION), carried, self._env.observation_space.shape[0]
        )
        self._buffer = np.empty(self.layout.integration)
        self._carried_views = [getattr(data, field) for field in self.carried]
        self._planner: MujocoFamily | None = None

    def _as_tuple(self, theta: Params) -> tuple[float, ...]:
        values = self._read_theta(theta)
        return values if isinstance(values, tuple) else (values,)

    def apply(self, theta: Params) -> None:
        """Write ``theta`` into the model (the fields that differ), then fix derived constants.

        Leaves ``MjData``'s integration state as it was (:meth:`step` does this by itself).
        """
        if theta is not self._theta:
            mujoco.mj_getState(self._model, self._data, self._buffer, _INTEGRATION)
            self._write(theta)
            mujoco.mj_setState(self._model, self._data, self._buffer, _INTEGRATION)

    def _write(self, theta: Params) -> None:
        """Write ``theta`` into the model; ``mj_setConst`` (which moves ``MjData``) for masses."""
        values = self._as_tuple(theta)
        masses = False
        for index, (value, old) in enumerate(zip(values, self._values, strict=True)):
            if value != old:
                array, position = self._slots[index]
                array[position] = value
                masses = masses or self._is_mass[index]
        if masses:
            mujoco.mj_setConst(self._model, self._data)
        self._theta, self._values = theta, values

    def initial_state(self, rng: np.random.Generator) -> bytes:
        """Gymnasium's reset under the default θ (see :meth:`initial_state_under`)."""
        return self.initial_state_under(self.default_params(), rng)

    def initial_state_under(self, theta: Params, rng: np.random.Generator) -> bytes:
        """Gymnasium's reset (``reset_model``'s noise drawn from ``rng``) under ``theta``.

        θ matters where the first observation reads inertias (Humanoid's ``cinert``).
        """
        if theta is not self._theta:
            self._write(theta)  # mj_resetData below resets what mj_setConst moved
        env = self._env
        env.np_random = rng
        mujoco.mj_resetData(self._model, self._data)
        observation = env.reset_model()
        return self._pack(observation)

    def _pack(self, observation: np.ndarray) -> bytes:
        mujoco.mj_getState(self._model, self._data, self._buffer, _INTEGRATION)
        parts = [self._buffer.tobytes()]
        parts.extend(view.tobytes() for view in self._carried_views)
        parts.append(np.asarray(observation, dtype=np.float64).tobytes())
        return b"".join(parts)

    def load(self, state: bytes) -> None:
        """Put ``state`` into the simulator (integration state and carried fields)."""
        layout = self.layout
        mujoco.mj_setState(
            self._model, self._data, np.frombuffer(state, count=layout.integration), _INTEGRATION
        )
        offset = layout.integration * 8
        for view, (_, shape) in zip(self._carried_views, layout.carried, strict=True):
            count = math.prod(shape)
            view[...] = np.frombuffer(state, count=count, offset=offset).reshape(shape)
            offset += count * 8

    def check_action(self, action: Any) -> np.ndarray:
        """A new float32 array of the action space's shape; finite values outside are kept.

        Raises:
            ValueError: Not numeric, of another shape, or not finite.
        """
        space = self.action_space
        if (  # the common case, checked cheaply
            type(action) is np.ndarray
            and action.dtype == space.dtype
            and action.shape == space.shape
            and np.isfinite(action).all()
        ):
            return action.copy()  # ours: the process keeps it as the last action
        return check_box_action(space, action)  # type: ignore[arg-type]

    def step(
        self, state: bytes, action: Any, theta: Params, rng: np.random.Generator
    ) -> tuple[bytes, float, bool]:
        """One Gymnasium step (``frame_skip`` MuJoCo steps) from ``state`` under ``theta``."""
        if theta is not self._theta:
            self._write(theta)  # load() below restores what mj_setConst moved
        self.load(state)
        observation, reward, terminated, _, _ = self._env.step(action)
        return self._pack(observation), float(reward), bool(terminated)

    def observe(self, state: bytes) -> np.ndarray:
        """Gymnasium's observation of ``state`` (float64), as stored in it."""
        offset = self.layout.observation_offset * 8
        return np.frombuffer(state, offset=offset).copy()

    def check_state(self, state: Any) -> bytes:
        """``state`` if it is a state of this family: ``bytes`` of the right size, all finite.

        Raises:
            ValueError: Another type, another size, or NaN / infinity inside.
        """
        size = self.layout.size
        if not isinstance(state, bytes) or len(state) != size * 8:
            raise ValueError(
                f"state={state!r:.80} is not a state of {self!r}; allowed: bytes of {size} "
                "float64 values, as get_state() returns"
            )
        if not np.isfinite(np.frombuffer(state)).all():
            raise ValueError(f"state of {self!r} holds NaN or infinity; allowed: finite values")
        return state

    def planning_model(self, theta: Params, state: bytes, rng: np.random.Generator) -> Any:
        """A stationary model under ``theta`` at ``state``, on a simulator of its own.

        Every planning model of this family shares one second simulator, so planning under
        another θ does not re-apply θ to the environment's simulator at each step.
        """
        from ns_pz.planning import PlanningModel

        if self._planner is None:
            self._planner = type(self)()
        return PlanningModel(self._planner, theta, state, rng)

    def __deepcopy__(self, memo: dict[int, Any]) -> MujocoFamily:
        """A new family with a simulator of its own (states and θ are values, never shared)."""
        return type(self)()

    def __reduce__(self) -> tuple[type, tuple[()]]:
        return type(self), ()


def task_family(
    name: str, gymnasium_env: str, knobs: tuple[Knob, ...], carried: tuple[str, ...] = ()
) -> type[MujocoFamily]:
    """The family of Gymnasium's ``{name}-v5`` with ``knobs`` as θ (``{name}Params``).

    Args:
        name: The task's name (``"HalfCheetah"``).
        gymnasium_env: Gymnasium's env class, ``"module:Class"``.
        knobs: The θ fields, in order.
        carried: :attr:`MujocoFamily.carried`.
    """
    params_cls = params_class(
        f"{name}Params", knobs, f"θ of {name}-v5: {', '.join(k.name for k in knobs)}."
    )
    namespace = {
        "__doc__": f"Gymnasium's {name}-v5 with :class:`{name}Params` as θ.",
        "__module__": params_cls.__module__,
        "gymnasium_env": gymnasium_env,
        "knobs": knobs,
        "params_cls": params_cls,
        "carried": carried,
    }
    return type(f"{name}Family", (MujocoFamily,), namespace)
