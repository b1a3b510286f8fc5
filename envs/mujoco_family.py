"""MuJoCo families: Gymnasium's v5 locomotion and control tasks with physical constants as θ.

A family owns one Gymnasium MuJoCo env (its ``MjModel`` and ``MjData``) as a simulator and
steps it with that env's own ``step``, so frame skip, reward, termination and observation are
Gymnasium v5's exactly. θ is applied to the model before a step, and only when it changed.
θ is made of knobs (:mod:`ns_pz.envs.mujoco_knobs`: gravity and its tilt, body masses,
joint damping and dry friction, a friction factor on every geom, a gear factor on every
actuator); Gymnasium's ``info`` and MuJoCo's instability warnings travel in the state
(:mod:`ns_pz.envs.mujoco_info`).

A mass or gear change makes MuJoCo's derived constants stale (subtree masses, inverse weights at
``qpos0``, ``stat``); :func:`mujoco.mj_setConst` recomputes them. Every step restores the
integration state afterwards, so a θ changed at run time gives exactly the trajectory of a model
built with that θ.

The state is an immutable ``bytes`` value (see :class:`StateLayout`): the full integration
state (``mj_getState`` with ``mjSTATE_INTEGRATION``: time, positions, velocities, activations,
warm start, controls and applied forces), the ``MjData`` fields Gymnasium's ``step`` reads
before simulating (Ant's ``xpos``, Humanoid's ``xipos``: they hold the positions of the last
substep, not of the integration state), and the observation, which some tasks compute from
forces of the last substep (``cfrc_ext``) and so is not a function of the integration state,
then Gymnasium's ``info`` and a status. Saving and restoring a state is copying a reference;
loading it into the simulator is one ``mj_setState``.
"""

from __future__ import annotations

import importlib
import math
import operator
import struct
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import mujoco
import numpy as np
from ns_pz.envs.continuous import check_box_action
from ns_pz.envs.mujoco_info import (
    START,
    STEPPED,
    UNSTABLE,
    UNSTABLE_WARNINGS,
    InfoLayout,
    warning_bits,
    warning_names,
)
from ns_pz.envs.mujoco_knobs import Knob, ModelWriter, params_class

from ns_pz.checks import flag
from ns_pz.family import EnvFamily
from ns_pz.params import Params

if TYPE_CHECKING:
    from ns_pz.rendering import Painter

_INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION
_tail = struct.Struct("=dd")
"""The last two float64 of a state: its status and Gymnasium's reward of an unstable step."""
_pack_tail = _tail.pack


@dataclass(frozen=True)
class StateLayout:
    """Where each part of a state lies in its ``bytes`` (float64 offsets and counts).

    Attributes:
        integration: Size of the ``mjSTATE_INTEGRATION`` state.
        carried: ``(MjData field, shape)`` of each field restored before a step.
        observation: Size of the observation.
        info: Size of Gymnasium's info values (then come the status and a reward).
    """

    integration: int
    carried: tuple[tuple[str, tuple[int, ...]], ...]
    observation: int
    info: int

    @property
    def observation_offset(self) -> int:
        """Offset of the observation, in float64 entries."""
        return self.integration + sum(math.prod(shape) for _, shape in self.carried)

    @property
    def info_offset(self) -> int:
        """Offset of the info values, in float64 entries."""
        return self.observation_offset + self.observation

    @property
    def size(self) -> int:
        """Number of float64 entries in a state."""
        return self.info_offset + self.info + 2


class MujocoFamily(EnvFamily):
    """A Gymnasium v5 MuJoCo task stepped on its own model, with :attr:`knobs` as θ.

    Subclasses set :attr:`gymnasium_env` (``"module:Class"``), :attr:`knobs`,
    :attr:`params_cls` (from :func:`~ns_pz.envs.mujoco_knobs.params_class`) and, if the task's
    ``step`` reads kinematics before simulating, :attr:`carried`. The action space is
    Gymnasium's; finite actions outside it are passed on as given (MuJoCo clamps the controls,
    the control cost sees the action), as Gymnasium does.

    A step in which MuJoCo finds the physics unstable (a bad position, velocity or acceleration,
    after which it resets the simulation to the rest pose by itself) is terminal, with reward
    0.0, and its observation is that of the rest pose: what follows it is not a continuation of
    the episode, and its reward (computed from a diverged state or across the reset) is not a
    reward of the task. Its ``info`` says ``"unstable": True`` and names the warnings in
    ``"mujoco_warnings"``; Gymnasium's reward of that step is ``info["unstable_reward"]``.
    Terminated rather than truncated, so that a learner does not bootstrap from the rest pose as
    if the episode went on from there. The check costs one ``mj_checkVel`` (MuJoCo checks a
    substep's velocities at the start of the next, so the last one's are checked here) and three
    integer reads per step.

    Args:
        scale_inertia: A mass knob scales its body's inertia by the same factor (the same shape,
            denser or lighter; the default). ``False`` changes ``body_mass`` alone, as NS-Gym
            does, which leaves a body with the inertia of another mass.
    """

    gymnasium_env: ClassVar[str]
    knobs: ClassVar[tuple[Knob, ...]]
    carried: ClassVar[tuple[str, ...]] = ()
    """``MjData`` fields Gymnasium's ``step`` reads before it simulates."""
    render_modes: ClassVar[tuple[str, ...]] = ("human", "rgb_array")
    has_info = True

    def __init__(self, scale_inertia: bool = True) -> None:
        self.scale_inertia = flag("scale_inertia", scale_inertia)
        module, _, name = self.gymnasium_env.partition(":")
        self._env = getattr(importlib.import_module(module), name)()
        model, data = self._env.model, self._env.data
        self._model, self._data = model, data
        self.observation_space = self._env.observation_space
        self.action_space = self._env.action_space
        # the task's own frame rate (1 / its step's duration), known once the model is built
        self.render_fps = int(self._env.metadata["render_fps"])  # type: ignore[misc]
        self._writer = ModelWriter(model, self.knobs, scale_inertia)
        self._read_theta = operator.attrgetter(*(knob.name for knob in self.knobs))
        self._theta: Params = self.default_params()
        self._values: tuple[float, ...] = self._as_tuple(self._theta)
        self._buffer = np.empty(mujoco.mj_stateSize(model, _INTEGRATION))
        self._info = self._probe_info()
        carried = tuple((field, getattr(data, field).shape) for field in self.carried)
        self.layout = StateLayout(
            self._buffer.size, carried, self._env.observation_space.shape[0], self._info.size
        )
        self._carried_views = [getattr(data, field) for field in self.carried]
        layout = self.layout  # byte offsets, read at every step
        self._observation_at = layout.observation_offset * 8
        self._info_at = layout.info_offset * 8
        self._tail_at = (layout.info_offset + layout.info) * 8
        warnings = data.warning.number  # a view into MjData: reading it is reading MuJoCo's
        self._warnings = warnings
        self._warning_slots = tuple(int(w) for w in UNSTABLE_WARNINGS)
        self._planner: MujocoFamily | None = None

    @property
    def model(self) -> Any:
        """The ``MjModel`` stepped, with θ written in: what Gymnasium's ``env.unwrapped.model`` is.

        To read (``env.unwrapped.family.model.body_mass``), not to write: θ is the family's, and
        an edit by hand is overwritten at the next change of θ and never reaches planning
        copies, which step models of their own.
        """
        return self._model

    @property
    def data(self) -> Any:
        """The ``MjData`` of the state last loaded or stepped (to read, as :attr:`model`)."""
        return self._data

    def _probe_info(self) -> InfoLayout:
        """The keys and shapes of Gymnasium's reset and step info (one step from the rest pose)."""
        env = self._env
        mujoco.mj_resetData(self._model, self._data)
        reset_info = env._get_reset_info()
        step_info = env.step(np.zeros(self._model.nu, np.float32))[-1]
        mujoco.mj_resetData(self._model, self._data)
        return InfoLayout.of(reset_info, step_info)

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
        """Write ``theta`` into the model, then ``mj_setConst`` after a mass or gear change.

        ``mj_setConst`` moves ``MjData``: callers restore the state afterwards.
        """
        values = self._as_tuple(theta)
        writer = self._writer
        constants = False
        for index, (value, old) in enumerate(zip(values, self._values, strict=True)):
            if value != old:
                writer.write(index, value)
                constants = constants or writer.needs_constants[index]
        if constants:
            mujoco.mj_setConst(self._model, self._data)
        self._theta, self._values = theta, values

    def params_of_model(self, model: Any) -> Params:
        """The θ another (hand-edited) model of this task holds (what ``ns_pz.compat`` reads).

        Raises:
            ValueError: The model holds something θ cannot express (see
                :meth:`~ns_pz.envs.mujoco_knobs.ModelWriter.read`), or a value out of bounds.
        """
        return self.params_cls.from_mapping(self._writer.read(model))

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
        info = self._info.pack(env._get_reset_info(), step=False)
        return self._pack(observation, info, START)

    def _pack(
        self, observation: np.ndarray, info: bytes, status: float, raw_reward: float = 0.0
    ) -> bytes:
        mujoco.mj_getState(self._model, self._data, self._buffer, _INTEGRATION)
        parts = [self._buffer.tobytes()]
        parts.extend(view.tobytes() for view in self._carried_views)
        parts.append(np.asarray(observation, dtype=np.float64).tobytes())
        parts.append(info)
        parts.append(_pack_tail(status, raw_reward))
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
        """One Gymnasium step (``frame_skip`` MuJoCo steps) from ``state`` under ``theta``.

        An unstable step is terminal with reward 0.0 (see the class docstring).
        """
        if theta is not self._theta:
            self._write(theta)  # load() below restores what mj_setConst moved
        self.load(state)
        env = self._env
        observation, reward, terminated, _, info = env.step(action)
        # MuJoCo checks velocities at the start of a substep: check the last one's here
        mujoco.mj_checkVel(self._model, self._data)
        warnings, (qpos, qvel, qacc) = self._warnings, self._warning_slots
        if warnings[qpos] or warnings[qvel] or warnings[qacc]:
            return self._unstable(float(reward)), 0.0, True
        packed = self._pack(observation, self._info.pack(info, step=True), STEPPED)
        return packed, float(reward), bool(terminated)

    def _unstable(self, reward: float) -> bytes:
        """The state after an unstable step: MuJoCo's rest pose, seen as such, and the warnings.

        Gymnasium's observation and info of that step were computed across MuJoCo's reset (or
        from the diverged state) and mean nothing: the observation is that of the rest pose and
        the info values are left out (zeros in the state).
        """
        warnings = self._warnings
        status = UNSTABLE + warning_bits(warnings)
        warnings[:] = 0  # counted again from zero at the next step
        mujoco.mj_forward(self._model, self._data)
        observation = self._env._get_obs()
        return self._pack(observation, bytes(8 * self._info.size), status, reward)

    def observe(self, state: bytes) -> np.ndarray:
        """Gymnasium's observation of ``state`` (float64), as stored in it."""
        return np.frombuffer(
            state, count=self.layout.observation, offset=self._observation_at
        ).copy()

    def info(self, state: bytes) -> dict[str, Any]:
        """Gymnasium's ``info`` of ``state`` (reset info for a start state, else step info).

        Every state's info has ``"unstable"`` (a bool). After an unstable step the info is
        ``"unstable": True``, ``"mujoco_warnings"`` (the names of MuJoCo's warnings) and
        ``"unstable_reward"`` (Gymnasium's reward of that step, which the family replaced by
        0.0; possibly huge or NaN), without Gymnasium's terms.
        """
        status, reward = _tail.unpack_from(state, self._tail_at)
        if status >= UNSTABLE:
            return {
                "unstable": True,
                "mujoco_warnings": warning_names(status),
                "unstable_reward": reward,
            }
        info = self._info.unpack(state, self._info_at, step=status != START)
        info["unstable"] = False
        return info

    def painter(self) -> Painter:
        """Gymnasium's MuJoCo renderer for this task (see :mod:`ns_pz.envs.mujoco_rendering`)."""
        from ns_pz.envs.mujoco_rendering import MujocoPainter

        return MujocoPainter(self)

    def check_state(self, state: Any) -> bytes:
        """``state`` if it is a state of this family: ``bytes`` of the right size, all finite.

        Raises:
            ValueError: Another type, another size, NaN / infinity inside, or an unknown status.
        """
        size = self.layout.size
        if not isinstance(state, bytes) or len(state) != size * 8:
            raise ValueError(
                f"state={state!r:.80} is not a state of {self!r}; allowed: bytes of {size} "
                "float64 values, as get_state() returns"
            )
        values = np.frombuffer(state, count=size - 1)  # Gymnasium's unstable reward may be NaN
        if not np.isfinite(values).all():
            raise ValueError(f"state of {self!r} holds NaN or infinity; allowed: finite values")
        status = float(values[-1])
        if status not in (START, STEPPED) and not (
            status == int(status) and UNSTABLE < status < UNSTABLE + (1 << len(UNSTABLE_WARNINGS))
        ):
            raise ValueError(
                f"state of {self!r} has status {status!r}; allowed: {START:g} (start), {STEPPED:g} "
                f"(stepped), {UNSTABLE + 1:g} to {UNSTABLE + 7:g} (unstable), as step() makes them"
            )
        return state

    def planning_model(self, theta: Params, state: bytes, rng: np.random.Generator) -> Any:
        """A stationary model under ``theta`` at ``state``, on a simulator of its own.

        Every planning model of this family shares one second simulator, so planning under
        another θ does not re-apply θ to the environment's simulator at each step.
        """
        from ns_pz.planning import PlanningModel

        if self._planner is None:
            self._planner = type(self)(self.scale_inertia)
        return PlanningModel(self._planner, theta, state, rng)

    def __deepcopy__(self, memo: dict[int, Any]) -> MujocoFamily:
        """A new family with a simulator of its own (states and θ are values, never shared)."""
        return type(self)(self.scale_inertia)

    def __reduce__(self) -> tuple[type, tuple[bool]]:
        return type(self), (self.scale_inertia,)

    def __repr__(self) -> str:
        inertia = "" if self.scale_inertia else "scale_inertia=False"
        return f"{type(self).__name__}({inertia})"


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
