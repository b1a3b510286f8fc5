"""A native Gymnasium vector env: N independent NS-MDPs stepped as numpy arrays.

:class:`NSVectorEnv` is what ``gymnasium.make_vec("ns_pz/<id>", num_envs=N)`` should return
(see :func:`ns_pz.envs.registry.make_vec`). Each sub-environment is the Gymnasium view
(:class:`ns_pz.views.NSGymEnv`) of its own NS-MDP: its own θ, its own nature and monitor memory,
its own generators. Under the same seeds and actions it yields exactly what N single views
yield, bit for bit (``tests/test_vector.py`` checks it), with Gymnasium's seeding convention
(``reset(seed=s)`` seeds sub-env ``i`` with ``s + i``, as ``SyncVectorEnv`` does) and its
autoreset modes ``NEXT_STEP`` (the default) and ``SAME_STEP``.

Two engines, chosen at construction, give the same results:

* **arrays** (:attr:`NSVectorEnv.engine` ``"arrays"``): θ is an ``(N, D)`` array; the
  dynamics, the scripted schedule, the projection onto the bounds and the oracle's notification
  are numpy operations over all sub-envs at once. Used when the family has an
  :class:`ArrayKernel` (CartPole, MountainCar, the grid worlds; see :mod:`ns_pz.envs.batched`),
  the monitor is the :class:`~ns_pz.monitor.OracleMonitor`, nature has no constraints beyond
  the bounds and is a :class:`~ns_pz.nature.StaticNature` or a
  :class:`~ns_pz.nature.ScriptedNature` built from deterministic schedulers
  (:data:`ARRAY_SCHEDULERS`) and the rules in :data:`ARRAY_RULES`.
* **processes** (``"processes"``): one :class:`~ns_pz.process.NSProcess` per sub-env plays
  nature and the monitor through the one cycle, so any nature and monitor (learned, random,
  stateful, constrained) behaves exactly as in the single view. The dynamics are still batched
  when the family has an array kernel; the per-sub-env turns cost a few microseconds each.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from ns_pz.family import EnvFamily, State
from ns_pz.monitor.monitors import Monitor, OracleMonitor
from ns_pz.monitor.notification import NotificationLevel
from ns_pz.nature.constraints import NatureConstraints
from ns_pz.nature.distribution_updates import (
    DistributionDecrementUpdate,
    DistributionIncrementUpdate,
)
from ns_pz.nature.policies import Nature, ScriptedNature, StaticNature
from ns_pz.nature.scalar_updates import (
    CyclicUpdate,
    DecrementUpdate,
    IncrementUpdate,
    StepWiseUpdate,
)
from ns_pz.nature.schedulers import (
    ContinuousScheduler,
    DiscreteScheduler,
    PeriodicScheduler,
    WindowScheduler,
)
from ns_pz.observations import agent_observation_space
from ns_pz.params import SIMPLEX, SIMPLEX_ATOL, Params
from ns_pz.process import DECISION, RESET_OPTIONS, NSProcess, check_seed
from ns_pz.process import _caller_outside_libraries as stacklevel

ARRAY_SCHEDULERS = (ContinuousScheduler, PeriodicScheduler, DiscreteScheduler, WindowScheduler)
"""Schedulers the array engine evaluates (they draw nothing from nature's generator)."""
ARRAY_RULES = (
    IncrementUpdate,
    DecrementUpdate,
    StepWiseUpdate,
    CyclicUpdate,
    DistributionIncrementUpdate,
    DistributionDecrementUpdate,
)
"""Update rules the array engine applies as array operations."""
_BUFFER = 256  # uniforms drawn ahead per sub-env generator


# --- batched dynamics ------------------------------------------------------------------------
class BatchKernel:
    """A family's dynamics for a batch of sub-environments.

    Attributes:
        family: The family whose scalar dynamics this kernel reproduces.
        step_uniforms: Uniform doubles a transition consumes from its sub-env's generator.
        reset_uniforms: Uniform doubles a start state consumes (0: the family's
            ``initial_state`` draws it from the generator itself).
    """

    step_uniforms = 0
    reset_uniforms = 0

    def __init__(self, family: EnvFamily) -> None:
        self.family = family


class LoopKernel(BatchKernel):
    """No batched dynamics: each sub-env's process calls the family's scalar ``step``."""


class ArrayKernel(BatchKernel):
    """Dynamics as array functions: ``step(states, actions, theta, uniforms)``.

    Args:
        family: The family.
        state_shape: Shape of one state's row in the batch array (``()`` for an index).
        state_dtype: Its dtype.
    """

    def __init__(self, family: EnvFamily, state_shape: tuple[int, ...], state_dtype: type) -> None:
        super().__init__(family)
        self.state_shape = state_shape
        self.state_dtype = state_dtype

    def step(
        self, states: np.ndarray, actions: np.ndarray, theta: np.ndarray, uniforms: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Next states, rewards (float64) and terminal flags of every row."""
        raise NotImplementedError

    def observe(self, states: np.ndarray) -> np.ndarray:
        """The batch of observations (a fresh array)."""
        raise NotImplementedError

    def initial_from_uniforms(self, uniforms: np.ndarray) -> np.ndarray:
        """Start states from ``(N, reset_uniforms)`` uniforms (kernels that declare them)."""
        raise NotImplementedError

    def pack(self, state: State) -> Any:
        """One family state as a row of the batch array."""
        return state

    def unpack(self, row: np.ndarray) -> State:
        """A row of the batch array as the family's state value (tuple of floats or int)."""
        return row.item() if self.state_shape == () else tuple(row.tolist())


# --- the vector env ---------------------------------------------------------------------------
class NSVectorEnv(gym.vector.VectorEnv[dict[str, Any], Any, Any]):
    """N sub-environments, each the Gymnasium view of its own NS-MDP, stepped together.

    Args:
        family: The environment family.
        num_envs: Number of sub-environments (>= 1).
        kernel: The family's batched dynamics (default: a loop over its scalar step).
        params: θ_0 of every sub-env.
        nature: One nature policy for all sub-envs (each keeps its own memory and generator),
            or a sequence of ``num_envs`` natures, one per sub-env.
        monitor: The monitor policy of every sub-env (default: the oracle).
        notification: ``"none"``, ``"basic"`` or ``"detailed"``.
        constraints: Lipschitz bound and budgets on nature.
        max_episode_steps: Transitions after which a sub-env's episode is truncated.
        autoreset_mode: ``AutoresetMode.NEXT_STEP`` (default) or ``SAME_STEP``.

    Raises:
        TypeError / ValueError: An argument of the wrong type or value (named in the message).
    """

    def __init__(
        self,
        family: EnvFamily,
        num_envs: int,
        *,
        kernel: BatchKernel | None = None,
        params: Params | Mapping[str, Any] | None = None,
        nature: Nature | Sequence[Nature] | None = None,
        monitor: Monitor | None = None,
        notification: str | NotificationLevel = "none",
        constraints: NatureConstraints | None = None,
        max_episode_steps: int | None = 500,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)):
            raise TypeError(f"num_envs={num_envs!r} must be an int >= 1")
        if num_envs < 1:
            raise ValueError(f"num_envs={num_envs!r} must be >= 1")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            mode = None
        if mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(
                f"autoreset_mode={autoreset_mode!r} is not supported; allowed: "
                "AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP"
            )
        self.num_envs = int(num_envs)
        self.autoreset_mode = mode
        self.metadata = {"autoreset_mode": mode, "render_modes": []}
        self.render_mode = None
        natures = _natures(nature, self.num_envs)

        def process(one: Nature | None) -> NSProcess:
            return NSProcess(
                family,
                params=params,
                nature=one,
                monitor=monitor,
                notification=notification,
                constraints=constraints,
                max_episode_steps=max_episode_steps,
            )

        first = process(natures[0])  # it holds θ_0 and the checked settings
        self.family = family
        self.kernel = LoopKernel(family) if kernel is None else kernel
        if self.kernel.family is not family:
            raise ValueError(f"kernel={kernel!r} was built for another family than {family!r}")
        self.level = first.level
        self.max_episode_steps = max_episode_steps
        self._schedule = (
            _ArraySchedule.of(natures, first) if _arrays_fit(self.kernel, first) else None
        )
        self.engine = "processes" if self._schedule is None else "arrays"
        """``"arrays"`` or ``"processes"`` (see the module docstring)."""
        check_size(self.num_envs, self.engine)
        self._processes = [first]
        if self.engine == "processes":
            self._processes += [process(one) for one in natures[1:]]

        self.single_observation_space = agent_observation_space(family)
        self.single_action_space = family.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)

        n = self.num_envs
        count = len(first.param_names)
        self._theta0_row = np.array(first.base_theta0.flat_values(), np.float64)
        self._layout = first.family.params_cls.flat_layout()
        self._all_scalar = all(spec.kind != SIMPLEX for spec, _, _ in self._layout)
        self._theta = np.tile(self._theta0_row, (n, 1))
        self._last_theta = self._theta.copy()
        self._theta_objects: list[Params | None] = [None] * n
        self._t = np.zeros(n, np.int64)
        self._flags = np.zeros((n, count), np.int8)
        self._sizes = np.zeros((n, count), np.float32)
        self._autoreset = np.zeros(n, np.bool_)
        self._started = False
        self._states: np.ndarray = np.zeros(0)
        if isinstance(self.kernel, ArrayKernel):
            self._states = np.zeros((n, *self.kernel.state_shape), self.kernel.state_dtype)
        self._rngs: list[np.random.Generator | None] = [None] * n
        self._uniforms = np.zeros((n, _BUFFER))
        self._cursor = np.zeros(n, np.int64)
        self._scratch = np.random.Generator(np.random.PCG64(0))
        self._buffered = bool(self.kernel.step_uniforms or self.kernel.reset_uniforms)

    # -- Gymnasium API ------------------------------------------------------------------------
    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Reset every sub-env, or those ``options["reset_mask"]`` selects.

        ``seed=s`` seeds sub-env ``i`` with ``s + i``, as ``SyncVectorEnv`` does.

        Args:
            seed: ``None`` (keep the generators; fresh entropy on the first reset), an int, or
                a list of ``num_envs`` ints or ``None``.
            options: ``{"params": θ_0}`` for the sub-envs reset, as the single view, and
                Gymnasium's ``{"reset_mask": mask}``: a bool array of shape ``(num_envs,)``
                selecting the sub-envs to reset (the others go on with their episodes; seeds
                apply to the selected ones only). A refused reset changes nothing.

        Raises:
            TypeError / ValueError: A bad seed, a seed list of the wrong length, bad options.
        """
        seeds = self._seeds(seed)
        rows = np.ones(self.num_envs, np.bool_)
        if isinstance(options, Mapping) and "reset_mask" in options:
            rows = self._reset_mask(options["reset_mask"])
            options = {key: value for key, value in options.items() if key != "reset_mask"}
        # Checked before any generator is seeded or drawn from: a refused reset changes nothing.
        start = self._processes[0].prepare_episode(options)
        if options is not None:  # unknown keys were warned of once, just now
            options = {key: value for key, value in options.items() if key in RESET_OPTIONS}
        if isinstance(seed, (int, np.integer)):  # the vector env's own np_random, as Gymnasium's
            self._np_random, self._np_random_seed = gym.utils.seeding.np_random(int(seed))
        for i, one in enumerate(seeds):
            if rows[i] and (one is not None or self._rngs[i] is None):
                self._seed(i, one)
        self._reset_rows(rows, options, theta0=start.theta0)
        self._autoreset[rows] = False
        self._started = True
        return self._observation(), {}

    def _seeds(self, seed: Any) -> list[int | None]:
        """One seed (or ``None``) per sub-env from ``reset``'s ``seed``."""
        n = self.num_envs
        if seed is None:
            return [None] * n
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            check_seed(seed)
            return [int(seed) + i for i in range(n)]
        if not isinstance(seed, (Sequence, np.ndarray)) or isinstance(seed, (str, bytes)):
            raise TypeError(
                f"seed={seed!r} must be None, a non-negative int or a list of {n} such ints or None"
            )
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"seed has {len(seeds)} entries; num_envs={n} needs {n}")
        for one in seeds:
            check_seed(one)
        return seeds

    def _reset_mask(self, mask: Any) -> np.ndarray:
        """The sub-envs ``options["reset_mask"]`` selects (checked as ``SyncVectorEnv`` does)."""
        n = self.num_envs
        if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_:
            raise TypeError(f"options['reset_mask']={mask!r} must be a numpy array of dtype bool")
        if mask.shape != (n,):
            raise ValueError(
                f"options['reset_mask'] has shape {mask.shape}; num_envs={n} needs ({n},)"
            )
        if not mask.any():
            raise ValueError("options['reset_mask'] selects no sub-env; select at least one")
        if not self._started and not mask.all():
            raise ValueError(
                "options['reset_mask'] must select every sub-env at the first reset (the others "
                "would have no episode to go on with)"
            )
        return mask.copy()

    def step(
        self, actions: Any
    ) -> tuple[dict[str, Any], np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One transition per sub-env (``NEXT_STEP``: a sub-env that ended is reset instead).

        Raises:
            ResetNeeded: Called before :meth:`reset`.
            ValueError: ``actions`` is not a batch of valid actions.
        """
        if not self._started:
            from ns_pz.errors import ResetNeeded

            raise ResetNeeded("step() called before reset(); call reset() first")
        actions = self._check_actions(actions)
        n = self.num_envs
        infos: dict[str, Any] = {}
        if self.autoreset_mode is AutoresetMode.NEXT_STEP:
            resetting = self._autoreset  # replaced, never written in place, below
            stepping = ~resetting
        else:
            resetting = np.zeros(n, np.bool_)
            stepping = np.ones(n, np.bool_)
        rewards = np.zeros(n)
        terminated = np.zeros(n, np.bool_)
        truncated = np.zeros(n, np.bool_)
        arrays = self.engine == "arrays"
        restart = arrays and resetting.any()
        if restart:  # independent of the stepping rows; nature then acts once for both
            self._reset_rows(resetting, None, act=False)
        if stepping.any():
            self._transition(stepping, actions, rewards, terminated, truncated, resetting)
        elif restart:  # every row restarts: no transition writes their notifications
            self._flags.fill(0)
            self._sizes.fill(0.0)
            assert self._schedule is not None
            self._schedule.act(self, resetting)
        ended = terminated | truncated
        if self.autoreset_mode is AutoresetMode.SAME_STEP:
            if ended.any():
                final = self._observation()
                objects = np.full(n, None, dtype=object)
                for i in np.flatnonzero(ended):
                    objects[i] = {key: value[i] for key, value in final.items()}
                infos = {
                    "final_obs": objects,
                    "_final_obs": ended.copy(),
                    "final_info": {},
                    "_final_info": ended.copy(),
                }
                self._reset_rows(ended, None)
        else:
            if not arrays and resetting.any():
                self._reset_rows(resetting, None)
            self._autoreset = ended
        return self._observation(), rewards, terminated, truncated, infos

    # -- ns_pz extras -------------------------------------------------------------------------
    def thetas(self) -> np.ndarray:
        """θ in force in every sub-env (for evaluation only).

        Returns:
            An ``(N, D)`` copy, each row laid out as :meth:`ns_pz.params.Params.flat`.
        """
        if self.engine == "processes":
            return np.array([p.theta.flat_values() for p in self._processes], np.float64)
        return self._theta.copy()

    # -- internals ----------------------------------------------------------------------------
    def _seed(self, i: int, seed: int | None) -> None:
        sequence = np.random.SeedSequence(seed)
        if self.engine == "processes":
            process = self._processes[i]
            process.seed(sequence)
            rng = process.env_rng
            if self._buffered:
                process.env_rng = self._scratch  # its draws come from our buffer instead
        else:
            rng = np.random.Generator(np.random.PCG64(sequence))  # as NSProcess.seed
        assert rng is not None
        self._rngs[i] = rng
        if self._buffered:
            self._uniforms[i] = rng.random(_BUFFER)
            self._cursor[i] = 0

    def _draw(self, rows: np.ndarray, count: int) -> np.ndarray:
        """``count`` uniforms for each selected sub-env, each from its own stream in order.

        ``rows`` are sorted indices; the result is a ``(len(rows), count)`` array.
        """
        cursor = self._cursor
        at = cursor[rows]
        if len(at) and at.max() > _BUFFER - count:  # some buffers are short (rarely)
            for i in rows[at + count > _BUFFER]:  # keep what is left, then draw on
                left = self._uniforms[i, cursor[i] :].copy()
                self._uniforms[i, : len(left)] = left
                self._uniforms[i, len(left) :] = self._rngs[i].random(_BUFFER - len(left))  # type: ignore[union-attr]
                cursor[i] = 0
            at = cursor[rows]
        if count == 1:
            values = self._uniforms[rows, at][:, None]
        else:
            values = self._uniforms[rows[:, None], at[:, None] + np.arange(count)]
        cursor[rows] = at + count
        return values

    def _check_actions(self, actions: Any) -> np.ndarray:
        space = self.single_action_space
        array = np.asarray(actions)
        if isinstance(space, gym.spaces.Discrete):
            if (
                array.shape != (self.num_envs,)
                or array.dtype.kind not in "iu"
                or array.min() < space.start
                or array.max() >= space.start + space.n
            ):
                raise ValueError(
                    f"actions={actions!r} must be {self.num_envs} ints in "
                    f"[{space.start}, {space.start + space.n})"
                )
            return array.astype(np.int64, copy=False)
        shape = (self.num_envs, *space.shape)  # type: ignore[misc]
        if array.shape != shape or array.dtype.kind not in "fiu" or not np.isfinite(array).all():
            raise ValueError(
                f"actions={actions!r} must be finite numbers of shape {shape} (one action of "
                f"{space} per sub-env; values outside its bounds are clipped by the dynamics, "
                "as in Gymnasium)"
            )
        return np.array(array, dtype=space.dtype)  # our own copy: rows become last actions

    def _transition(
        self,
        stepping: np.ndarray,
        actions: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        restarted: np.ndarray,
    ) -> None:
        kernel = self.kernel
        outcome = None
        if isinstance(kernel, ArrayKernel):
            count = kernel.step_uniforms
            uniforms = None
            if count:
                uniforms = np.zeros(self.num_envs)
                moving = np.flatnonzero(stepping)
                uniforms[moving] = self._draw(moving, count)[:, 0]
            outcome = kernel.step(self._states, actions, self._theta, uniforms)
        if self.engine == "processes":
            self._processes_transition(stepping, actions, outcome, rewards, terminated, truncated)
            return
        assert outcome is not None
        states, reward, terminal = outcome
        # In NEXT_STEP the rows not stepping are reset after this, so whole-array updates
        # (np.copyto with a mask, fill) are exact and cheaper than boolean indexing.
        np.copyto(self._states, states, where=stepping.reshape(-1, *[1] * (states.ndim - 1)))
        np.copyto(rewards, reward, where=stepping)
        theta, last = self._theta, self._last_theta
        changed = (theta != last).any(axis=1)
        changed &= stepping
        self._t += stepping
        np.logical_and(stepping, terminal, out=terminated)
        limit = self.max_episode_steps
        if limit is not None:
            np.logical_and(stepping, self._t >= limit, out=truncated)
        running = ~(terminated | truncated)
        notify = changed & running
        if self.level.shows_flags and notify.any():  # every row is written
            sizes = self._change_sizes(last, theta)
            sizes *= notify[:, None]
            np.greater(sizes, 0.0, out=self._flags)
            if self.level.shows_sizes:
                self._sizes[:] = sizes
            else:
                self._sizes.fill(0.0)
        else:
            self._flags.fill(0)
            self._sizes.fill(0.0)
        np.copyto(last, theta, where=changed[:, None])
        acting = stepping & running
        acting |= restarted
        assert self._schedule is not None
        self._schedule.act(self, acting)

    def _processes_transition(
        self,
        stepping: np.ndarray,
        actions: np.ndarray,
        outcome: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
        rewards: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
    ) -> None:
        check = self.family.check_action
        kernel = self.kernel
        discrete = isinstance(self.single_action_space, gym.spaces.Discrete)
        for i in np.flatnonzero(stepping):
            process = self._processes[i]
            if outcome is None:
                reward, term, trunc = process.transition(check(actions[i]))
            else:
                assert isinstance(kernel, ArrayKernel)
                states, all_rewards, terminals = outcome
                self._states[i] = states[i]
                result = (kernel.unpack(states[i]), float(all_rewards[i]), bool(terminals[i]))
                action = actions[i].item() if discrete else actions[i].copy()
                reward, term, trunc = process.transition(action, result)
            rewards[i] = reward
            terminated[i] = term
            truncated[i] = trunc
            if not process.done:
                process.play_until(DECISION)
            self._sync(i)

    def _sync(self, i: int | np.integer) -> None:
        """Copy process ``i``'s clock, notification and θ into the arrays."""
        process = self._processes[i]
        self._t[i] = process.t
        flags, sizes = process.notice
        self._flags[i] = flags
        self._sizes[i] = sizes
        if process.theta is not self._theta_objects[i]:
            self._theta_objects[i] = process.theta
            self._theta[i] = process.theta.flat_values()

    def _reset_rows(
        self,
        rows: np.ndarray,
        options: Mapping[str, Any] | None,
        act: bool = True,
        theta0: Params | None = None,
    ) -> None:
        """Start new episodes in the selected sub-envs (a bool mask).

        ``options`` were checked by :meth:`reset`, which passes the θ_0 they start as
        ``theta0`` (``None``: the env's own). ``act=False`` leaves nature's first turn and the
        rows' notifications to the caller (array engine only): the transition that follows in
        :meth:`step` writes every row of both.
        """
        kernel = self.kernel
        starts = None
        indices = np.flatnonzero(rows)
        if kernel.reset_uniforms:
            assert isinstance(kernel, ArrayKernel)
            starts = kernel.initial_from_uniforms(self._draw(indices, kernel.reset_uniforms))
        if self.engine == "processes":
            for j, i in enumerate(indices):
                process = self._processes[i]
                process.reset(options)
                if starts is not None:
                    assert isinstance(kernel, ArrayKernel)
                    self._states[i] = starts[j]
                    state = kernel.unpack(starts[j])
                    process.state = process.initial_state = process.last_state = state
                elif isinstance(kernel, ArrayKernel):
                    self._states[i] = kernel.pack(process.state)
                process.play_until(DECISION)
                self._sync(i)
            return
        assert isinstance(kernel, ArrayKernel)
        if starts is not None:
            self._states[indices] = starts
        else:
            initial = self.family.initial_state
            for i in indices:
                self._states[i] = kernel.pack(initial(self._rngs[i]))  # type: ignore[arg-type]
        row = self._theta0_row
        if theta0 is not None:
            row = np.array(theta0.flat_values(), np.float64)
        # Index arrays: a few rows restart per step, and fancy indexing by them is cheaper
        # than a boolean mask over every sub-env.
        self._theta[indices] = row
        self._last_theta[indices] = row
        self._t[indices] = 0
        assert self._schedule is not None
        self._schedule.restart(indices, self.num_envs)
        if act:
            self._flags[indices] = 0
            self._sizes[indices] = 0.0
            self._schedule.act(self, rows)

    def _change_sizes(self, before: np.ndarray, after: np.ndarray) -> np.ndarray:
        """Per-parameter change sizes of rows, as :meth:`Params.change_sizes` computes them.

        ``|after - before|`` for a scalar, half the sum of the elements' (left to right) for a
        probability vector.
        """
        difference = np.abs(after - before)
        if self._all_scalar:
            return difference
        sizes = np.empty((len(before), len(self._layout)))
        for j, (spec, start, stop) in enumerate(self._layout):
            total = difference[:, start]
            if spec.kind == SIMPLEX:
                for k in range(start + 1, stop):
                    total = total + difference[:, k]
                total = 0.5 * total
            sizes[:, j] = total
        return sizes

    def _observation(self) -> dict[str, Any]:
        if isinstance(self.kernel, ArrayKernel):
            state = self.kernel.observe(self._states)
        else:
            observe = self.family.observe
            state = np.array([observe(p.state) for p in self._processes])
        return {
            "state": state,
            "env_change": self._flags.copy(),
            "delta_change": self._sizes.copy(),
            "relative_time": self._t.astype(np.float32)[:, None],
        }

    def __repr__(self) -> str:
        return (
            f"NSVectorEnv({self.family!r}, num_envs={self.num_envs}, engine={self.engine!r}, "
            f"notification={self.level.value!r})"
        )


BYTES_PER_ENV = {"arrays": 8 * _BUFFER + 512, "processes": 8 * _BUFFER + 512 + 8_000}
"""Memory one sub-env takes, roughly, by engine: the uniforms drawn ahead and the batch rows;
the processes engine adds one process (about 5 KB for CartPole, more with a learned nature or a
detector)."""
LARGE = 2**30
"""Above this estimate (bytes), building a vector env warns with its size."""


def check_size(num_envs: int, engine: str) -> None:
    """Refuse a vector env larger than this machine's memory; warn above :data:`LARGE`.

    Raises:
        ValueError: The estimate exceeds the physical memory; the message names ``num_envs``,
            the engine and the estimate.
    """
    estimate = num_envs * BYTES_PER_ENV[engine]
    memory = physical_memory()
    what = (
        f"num_envs={num_envs} on the {engine} engine needs about {estimate / 2**30:.1f} GiB "
        f"({BYTES_PER_ENV[engine]} bytes per sub-env)"
    )
    if memory is not None and estimate > memory:
        raise ValueError(f"{what}, more than this machine's {memory / 2**30:.1f} GiB of memory")
    if estimate > LARGE:
        warnings.warn(f"{what}; building it may take a while", stacklevel=stacklevel())


def physical_memory() -> int | None:
    """This machine's memory in bytes (``None`` where the system does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return None


def _natures(nature: Nature | Sequence[Nature] | None, count: int) -> list[Nature | None]:
    if nature is None or isinstance(nature, Nature):
        return [nature] * count
    if isinstance(nature, Sequence) and not isinstance(nature, (str, bytes)):
        if len(nature) != count:
            raise ValueError(f"nature has {len(nature)} entries; num_envs={count} needs {count}")
        return list(nature)
    raise TypeError(f"nature={nature!r} must be a Nature, a list of num_envs Natures, or None")


def _arrays_fit(kernel: BatchKernel, process: NSProcess) -> bool:
    return (
        isinstance(kernel, ArrayKernel)
        and type(process.monitor) is OracleMonitor
        and process.constraints.unconstrained
    )


class _ArraySchedule:
    """A scripted nature's schedule as array operations over the θ rows of many sub-envs."""

    def __init__(self, entries: list[tuple[Any, Any, int, int]], owner: str) -> None:
        self._entries = entries  # (spec, rule, start, stop)
        self._owner = owner
        self._counts: list[np.ndarray] = []

    @classmethod
    def of(cls, natures: list[Nature | None], process: NSProcess) -> _ArraySchedule | None:
        """The array form of the sub-envs' nature, or ``None`` if it has none."""
        nature = natures[0]
        if any(other is not nature for other in natures):
            return None
        params_cls = process.family.params_cls
        owner = params_cls.__name__
        if nature is None or type(nature) is StaticNature:
            return cls([], owner)
        if type(nature) is not ScriptedNature:
            return None
        slices = {spec.name: (spec, start, stop) for spec, start, stop in params_cls.flat_layout()}
        entries = []
        for name, rule in nature.updates.items():
            if type(rule) not in ARRAY_RULES or type(rule.scheduler) not in ARRAY_SCHEDULERS:
                return None
            spec, start, stop = slices[name]
            entries.append((spec, rule, start, stop))
        return cls(entries, owner)

    def restart(self, rows: np.ndarray, num_envs: int) -> None:
        """Zero the firing counts of the sub-envs starting an episode (a mask or indices)."""
        if not self._counts:
            self._counts = [np.zeros(num_envs, np.int64) for _ in self._entries]
        for counts in self._counts:
            counts[rows] = 0

    def act(self, env: NSVectorEnv, rows: np.ndarray) -> None:
        """Nature's turn in the selected sub-envs (a bool mask), each at its own step.

        Rules are applied to whole columns (cheaper than gathering rows) and kept where the
        scheduler fired and the value moved.
        """
        theta = env._theta
        steps = env._t
        for (spec, rule, start, stop), counts in zip(self._entries, self._counts, strict=True):
            fires = _fires(rule.scheduler, steps, rows)
            if not fires.any():
                continue
            old = theta[:, start:stop]
            new = self._propose(spec, rule, old, counts, fires)
            counts += fires
            moved = new[:, 0] != old[:, 0] if stop - start == 1 else (new != old).any(axis=1)
            moved &= fires
            np.copyto(old, new, where=moved[:, None])

    def _propose(
        self, spec: Any, rule: Any, old: np.ndarray, n: np.ndarray, fires: np.ndarray
    ) -> np.ndarray:
        """The rule's values, projected onto the spec exactly as ``ParamSpec.project`` does."""
        kind = type(rule)
        if spec.kind == SIMPLEX:
            k = rule.k if kind is DistributionIncrementUpdate else -rule.k
            first = np.minimum(np.maximum(old[:, 0] + k, 0.0), 1.0)
            rest = (1.0 - first) / (old.shape[1] - 1)
            new = np.repeat(rest[:, None], old.shape[1], axis=1)
            new[:, 0] = first
            total = new[:, 0] + 0.0
            for j in range(1, new.shape[1]):
                total = total + new[:, j]
            odd = (np.abs(total - 1.0) > SIMPLEX_ATOL) & fires
            for i in np.flatnonzero(odd):  # rare: let the spec project it
                new[i] = spec.project(self._owner, tuple(new[i].tolist()))
            return new
        value = old[:, 0]
        if kind is IncrementUpdate:
            new_value = value + rule.k
        elif kind is DecrementUpdate:
            new_value = value - rule.k
        else:
            listed = np.array(rule.param_list if kind is StepWiseUpdate else rule.value_list)
            if kind is CyclicUpdate:
                new_value = listed[n % len(listed)]
            else:
                new_value = np.where(n < len(listed), listed[np.minimum(n, len(listed) - 1)], value)
        # ParamSpec.project: inside stays as is; at or beyond a bound, the nearest allowed value.
        low = math.nextafter(spec.low, math.inf) if spec.low_open else spec.low
        high = math.nextafter(spec.high, -math.inf) if spec.high_open else spec.high
        inside = np.where(
            new_value <= spec.low, low, np.where(new_value >= spec.high, high, new_value)
        )
        return inside[:, None]


def _fires(scheduler: Any, steps: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Where a deterministic scheduler fires, for the selected rows at their own steps."""
    kind = type(scheduler)
    if kind is ContinuousScheduler or kind is PeriodicScheduler:
        active = steps >= scheduler.start
        if scheduler.end is not None:
            active &= steps <= scheduler.end
        if kind is PeriodicScheduler:
            active &= (steps - scheduler.start) % scheduler.period == 0
        return active & rows
    if kind is DiscreteScheduler:
        return np.isin(steps, list(scheduler.event_list)) & rows
    fired = np.array([scheduler(int(t), None) for t in steps], np.bool_)
    return fired & rows
