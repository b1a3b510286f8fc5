"""NS-Gym 1.0.12's public API over the ns_pz core: switch by changing the package name.

Modules, under NS-Gym's paths: :mod:`ns_pz.compat.base` (``Scheduler``, ``UpdateFn``,
``UpdateDistributionFn``, ``Reward``, ``TUNABLE_PARAMS``, ``NSWrapper``),
:mod:`ns_pz.compat.schedulers`, :mod:`ns_pz.compat.update_functions` (``single_param`` and
``distribution``), :mod:`ns_pz.compat.wrappers` (``classic_control``, ``toy_text`` and, with the
``mujoco`` extra, ``MujocoWrapper``; NS-Gym's Box2D and pursuit-evasion wrappers raise
``ImportError``: ns_pz has no such family) and
:mod:`ns_pz.compat.envs` (``envs.Bridge``, registered as ``ns_pz_compat/Bridge-v0``). Not
provided: ``ns_gym.utils``, ``evaluate``, ``benchmark_algorithms``, ``context_switching``.

The classes keep NS-Gym's names, constructor arguments, defaults and calling conventions
(``start=0``; ``sched(t)``; ``fn(param, t) -> (value, flag, delta)``; periodic schedules on
absolute ``t``), and compute through the native ns_pz classes: there is one implementation of
every rule and of every environment's dynamics.

Differences from NS-Gym (each one a defect there, or a choice ns_pz makes everywhere):

1. Bad input is refused with ``ValueError``/``TypeError`` naming the argument and the value:
   a probability vector that does not sum to 1 (NS-Gym samples from ``[0.5, 0.2, 0.2]``), a
   ``rate``/``theta`` outside [0, 1], an unknown parameter name, an unknown keyword argument
   (NS-Gym ignores ``foo=3``), a scalar update on a slip vector. ``t`` may be a numpy integer.
2. Randomness follows the wrapper's ``reset(seed=...)``: every random scheduler and update
   function inside a wrapper draws from generators derived from that seed, so the same seed
   gives the same parameter trajectory, episodes without a seed differ from each other, and
   planning envs draw from seeded child generators. (NS-Gym's random schedulers replay one
   pattern every episode and ignore the seed; its planning envs reseed from OS entropy.)
   ``seed=`` on a scheduler or update function seeds its standalone calls, and the wrapper's
   first reset when that has no seed (so such runs repeat, as NS-Gym's do). A scheduler's
   ``seed=`` also seeds nature's draws together with a reset seed (the env's start state still
   follows the reset seed alone): as in NS-Gym, whose reset reseeds update functions but never
   schedulers, two scheduler seeds give two schedules under one reset seed. A user subclass
   (its own ``_check`` or ``_update``) runs as a per-episode copy, called as NS-Gym calls it,
   whose numpy generators, under any attribute name, are reseeded from the wrapper's.
3. ``flag`` is 1 only when the value actually changed: ``NoUpdate``, a used-up ``StepWiseUpdate``
   or a change projected back onto the value it had report 0 (NS-Gym reports every firing).
   ``StepWiseUpdate`` does not consume the list you pass.
4. The size of a slip-vector change (``delta`` and ``delta_change``) is the total-variation
   distance (W1 under the discrete metric), which does not depend on the order in which the
   outcomes are listed; NS-Gym's W1 over positions 0..n-1 counts ``[1,0,0]→[0,0,1]`` twice
   ``[1,0,0]→[0,1,0]``. Scalar deltas are NS-Gym's signed ``new - old``.
5. ``info`` holds NS-Gym's ``"Ground Truth Env Change"`` (int flags) and ``"Ground Truth Delta
   Change"`` (float sizes; int zeros at reset), as NS-Gym's, with the flags and sizes of
   points 3 and 4; grid wrappers add ``"transition_prob"``. ``ground_truth_info=False`` leaves
   the two keys out (the native view never puts ground truth in ``info`` unless asked).
   ``info`` has no ``prob``. ``wrapper.ground_truth()`` gives the whole θ trajectory.
6. The transition table is a function of the current slip vector, never stored: no stale table
   after ``reset`` and no table rebuilt per change (NS-Gym brings the previous episode's table
   back). Planning envs keep the map (NS-Gym's FrozenLake 8x8 copy comes back as 4x4), the time
   limit's step count and the episode's bookkeeping.
7. A change that would leave a parameter's physical range (a negative mass) is projected onto
   the range instead of being dropped with a warning.
8. ``MemorylessScheduler`` never stops firing when a step is skipped, and counts its waiting
   times from ``start``; ``DiscreteScheduler(set())`` is allowed (never fires).
9. ``LCBoundedDistrubutionUpdate`` (also spelled ``LCBoundedDistributionUpdate``) shortens a
   proposal that moves too far instead of redrawing it; ``BudgetBoundedIncrement`` works.
10. The wrappers pass ``gymnasium.utils.env_checker.check_env``; the Bridge draws its slips from
    its own seeded generator (NS-Gym's uses the global numpy generator).
11. The env you wrap is read (class, map, constants, time limit), not stepped: the dynamics are
    ns_pz's families, and ``wrapper.unwrapped`` is the ns_pz env (a ``CompatCore``, not
    ``env.unwrapped`` itself as in NS-Gym). It stands in for the base env: its class has the
    base env's name (``TUNABLE_PARAMS[type(ns_env.unwrapped).__name__]`` works), its
    ``observation_space`` is the base env's, and its own ``reset``/``step`` return the state
    alone, though a step of it is a step of the wrapper's episode. As in NS-Gym, reads of the
    parameters show the θ in force, on ``env.unwrapped`` and ``wrapper.unwrapped`` alike
    (``masspole``, ``total_mass``, ``LINK_LENGTH_1``, ``m``, ``force``, FrozenLake's and
    CliffWalking's table ``P``, the Bridge's ``P``; the grid wrappers' ``transition_prob`` and
    ``P``): at reset θ_0, after a step the θ that step's transition used. They are read-only
    (``ReadOnlyParam``, an ``AttributeError``, says to use an update function or
    ``wrapper.unwrapped.set_params``); NS-Gym lets a write through until the next reset. A copy
    of the env is a plain env with the values of the moment. Settings of the env are honoured
    (``goal_velocity``, ``kinematics_integrator``, ``torque_noise_max``, FrozenLake's map and
    ``reward_schedule``, which NS-Gym drops) or refused with ``ValueError`` naming them
    (``sutton_barto_reward``, ``x_threshold`` and any other changed constant, ``render_mode``
    for now, and any wrapper other than ``TimeLimit``/``OrderEnforcing``/``PassiveEnvChecker``,
    such as a ``TransformReward``, which belongs around the NS-Gym wrapper); NS-Gym runs the
    default task. The slip the env was built with (``is_slippery``) is replaced by
    ``initial_prob_dist``, as in NS-Gym. Observations use floats for ``delta_change`` at reset
    too (NS-Gym: int 0). CliffWalking's ``modified_rewards`` must give ``"S"`` and ``"F"`` the
    same reward; the Bridge's ``modified_rewards`` must be ``None``.
12. The Bridge's ``P`` (``P_left``, ``P_right`` when split, also read as ``left_side_prob``,
    ``right_side_prob``; ``get_loc_based_prob((row, col))`` gives a cell's, as in NS-Gym's
    current release, on the Bridge and on ``ns_env.unwrapped``) is validated when set, and
    changes its dynamics from the next step; ``NSBridgeWrapper`` starts from the Bridge's own slip
    unless ``initial_prob_dist`` is given (both default to ``[1, 0, 0]``; NS-Gym's wrapper
    overwrites a ``P`` you set with its default).
"""

# NS-Gym's ``ns_gym/Bridge-v0``; registered with Gymnasium by ``import ns_pz`` (envs/registry.py).
from ns_pz.envs.registry import COMPAT_BRIDGE_ID as BRIDGE_ID  # noqa: F401
