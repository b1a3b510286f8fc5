"""Sweep each MuJoCo knob over candidate values: is the physics stable there, and does it act?

For every task and knob, each candidate value is written into a fresh family's model (values
outside the declared bounds too: that is the point), and the task is stepped with random actions
(uniform in the action space) from two seeded starts, never reset, counting the steps in which
MuJoCo reported an unstable state (``info["unstable"]``). "Acts" is the largest difference of
any observation entry from the default θ's trajectory over the first 200 steps of the first run
(same start, same actions). Every mass at once is swept too, and with ``--mass-only`` the
masses change without their inertia. The declared bounds in ``envs/mujoco_tasks.py`` are set
where every value was stable and acted; ``--declared`` checks exactly the bounds declared now.

Run: ``python benchmarks/mujoco_stability.py [--tasks Hopper ...] [--steps 1000] [--declared]
[--mass-only] 2>/dev/null`` (MuJoCo prints each instability to stderr).
"""

from __future__ import annotations

import argparse
import math

import mujoco
import numpy as np
from ns_pz.envs import mujoco_tasks
from ns_pz.envs.mujoco_family import MujocoFamily
from ns_pz.envs.mujoco_knobs import (
    DAMPING,
    FRICTION,
    FRICTIONLOSS,
    GEAR,
    GRAVITY,
    MASS,
    TILT,
    Knob,
)

SEEDS = (0, 1)
LIVE_STEPS = 200


def candidates(knob: Knob) -> list[float]:
    """Values to try: wide ones beyond the usual ranges, for each kind."""
    d = knob.default
    return {
        GRAVITY: [-50.0, -30.0, -20.0, 0.0],
        TILT: [-0.5, -0.3, 0.3, 0.5],
        MASS: [d * f for f in (0.1, 0.15, 0.2, 5.0, 10.0)],
        DAMPING: [0.0, max(10 * d, 1.0), max(50 * d, 5.0)],
        FRICTION: [d * f for f in (0.0, 0.1, 3.0, 10.0)],
        FRICTIONLOSS: [10.0, 50.0, 100.0],
        GEAR: [0.25, 0.5, 2.0, 3.0],
    }[knob.kind]


def family_with(task: str, values: dict[int, float], scale_inertia: bool) -> MujocoFamily:
    """A fresh family whose model holds ``values`` (knob index to value; bounds not checked)."""
    family: MujocoFamily = getattr(mujoco_tasks, f"{task}Family")(scale_inertia)
    for index, value in values.items():
        family._writer.write(index, value)  # noqa: SLF001 - a sweep goes past the bounds
    mujoco.mj_setConst(family._model, family._data)  # noqa: SLF001
    return family


def run(family: MujocoFamily, seed: int, steps: int) -> tuple[int, np.ndarray]:
    """Unstable steps in ``steps`` random steps, and the first :data:`LIVE_STEPS` observations.

    The start is drawn with ``seed``, and so are the actions.
    """
    rng = np.random.default_rng(seed)
    space = family.action_space
    theta = family._theta  # noqa: SLF001 - the model already holds the swept value
    state = family.initial_state_under(theta, rng)
    unstable, observations = 0, []
    for t in range(steps):
        action = rng.uniform(space.low, space.high).astype(space.dtype)
        state, _, _ = family.step(state, action, theta, rng)
        unstable += family.info(state)["unstable"]
        if t < LIVE_STEPS:
            observations.append(family.observe(state))
    return unstable, np.array(observations)


def cases(knobs: tuple[Knob, ...], declared: bool) -> list[tuple[str, dict[int, float]]]:
    """The ``(label, values)`` to run.

    Each knob alone at each value, then every mass at once (scaled by one factor), then with
    ``declared`` every knob at its lower and at its upper bound.
    """
    out = []
    for index, knob in enumerate(knobs):
        for value in [knob.low, knob.high] if declared else candidates(knob):
            if value != knob.default:
                out.append((f"{knob.name}={value:.5g}", {index: value}))
    masses = [i for i, knob in enumerate(knobs) if knob.kind == MASS]
    factors = (
        sorted(
            {
                knobs[masses[0]].low / knobs[masses[0]].default,
                knobs[masses[0]].high / knobs[masses[0]].default,
            }
        )
        if declared
        else (0.1, 0.15, 0.2, 5.0, 10.0)
    )
    if len(masses) > 1:
        for factor in factors:
            out.append((f"all masses x{factor:g}", {i: knobs[i].default * factor for i in masses}))
    if declared:
        out.append(("every knob at its low", {i: k.low for i, k in enumerate(knobs)}))
        out.append(("every knob at its high", {i: k.high for i, k in enumerate(knobs)}))
    return out


def sweep(task: str, steps: int, declared: bool, scale_inertia: bool) -> None:
    """Print one line per case: unstable steps, and the largest observation change."""
    base = run(family_with(task, {}, scale_inertia), SEEDS[0], steps)[1]
    knobs = getattr(mujoco_tasks, f"{task}Family").knobs
    for label, values in cases(knobs, declared):
        family = family_with(task, values, scale_inertia)
        unstable, moved = 0, math.nan
        for seed in SEEDS:
            count, observations = run(family, seed, steps)
            unstable += count
            if seed == SEEDS[0]:
                moved = float(np.max(np.abs(observations - base)))
        print(f"{task:22s} {label:42s} unstable={unstable:5d} acts={moved:.3g}", flush=True)


def main() -> None:
    """Parse the arguments and sweep."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=list(mujoco_tasks.TASKS))
    parser.add_argument("--steps", type=int, default=1000, help="steps per run (two runs)")
    parser.add_argument("--declared", action="store_true", help="only the declared bounds")
    parser.add_argument("--mass-only", action="store_true", help="scale_inertia=False")
    args = parser.parse_args()
    for task in args.tasks:
        sweep(task, args.steps, args.declared, not args.mass_only)


if __name__ == "__main__":
    main()
