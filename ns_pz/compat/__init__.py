"""NS-Gym 1.0.12's public API over the ns_pz core: switch by changing the package name.

Modules: :mod:`ns_pz.compat.base` (``Scheduler``, ``UpdateFn``, ``UpdateDistributionFn``,
``Reward``, ``TUNABLE_PARAMS``), :mod:`ns_pz.compat.schedulers`,
:mod:`ns_pz.compat.update_functions` (``single_param`` and ``distribution``),
:mod:`ns_pz.compat.wrappers` and :mod:`ns_pz.compat.envs` (the Bridge, registered as
``ns_pz_compat/Bridge-v0``). The classes keep NS-Gym's names, constructor arguments, defaults
and calling conventions (``start=0``; ``sched(t)``; ``fn(param, t) -> (value, flag, delta)``;
periodic schedules on absolute ``t``), and compute through the native ns_pz classes: there is
one implementation of every rule and of every environment's dynamics.

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
   ``seed=`` on a scheduler or update function seeds only its standalone calls.
3. ``flag`` is 1 only when the value actually changed: ``NoUpdate``, a used-up ``StepWiseUpdate``
   or a change projected back onto the value it had report 0 (NS-Gym reports every firing).
   ``StepWiseUpdate`` does not consume the list you pass.
4. The size of a slip-vector change (``delta`` and ``delta_change``) is the total-variation
   distance (W1 under the discrete metric), which does not depend on the order in which the
   outcomes are listed; NS-Gym's W1 over positions 0..n-1 counts ``[1,0,0]→[0,0,1]`` twice
   ``[1,0,0]→[0,1,0]``. Scalar deltas are NS-Gym's signed ``new - old``.
5. ``info`` holds no ground truth unless ``ground_truth_info=True`` is passed (then NS-Gym's two
   keys); the current parameters, the true change times and sizes are available through
   ``wrapper.get_params()`` and ``wrapper.ground_truth()``. ``info`` has no ``prob`` or
   ``transition_prob`` either.
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
    ns_pz's families, and ``wrapper.unwrapped`` is the ns_pz env. Observations use floats for
    ``delta_change`` at reset too (NS-Gym: int 0). CliffWalking's ``modified_rewards`` must give
    ``"S"`` and ``"F"`` the same reward; the Bridge's ``modified_rewards`` must be ``None``.
"""

# NS-Gym's ``ns_gym/Bridge-v0``; registered with Gymnasium by ``import ns_pz`` (envs/registry.py).
from ns_pz.envs.registry import COMPAT_BRIDGE_ID as BRIDGE_ID  # noqa: F401
