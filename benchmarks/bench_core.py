"""Cost of the NS-MDP core relative to the raw Gymnasium step, measured in one run.

For each environment of :data:`ENVS` (CartPole, FrozenLake, CliffWalking, Bridge, MountainCar,
MountainCarContinuous, Acrobot, Pendulum; ``--envs`` picks some) and, with ``--mujoco``, for the
MuJoCo tasks of :data:`MUJOCO_ENVS` (gravity or a damping moved at every step, and a body mass
in an extra case), it times, per transition:

* ``raw``: ``gymnasium.make(base_id).unwrapped.step`` (the reference, 1.00x). Gymnasium has no
  Bridge: its reference is NS-Gym's base Bridge env (``ns_gym/Bridge-v0``, unwrapped) when NS-Gym
  is installed, else the ns_pz view without nature (then labelled ``raw (ns_pz, static)``);
* ``view, change every step`` / ``view, single change``: the ns_pz Gymnasium view
  (``gymnasium.make("ns_pz/...").unwrapped.step``) with θ changed at every step
  (``ContinuousScheduler`` + ``IncrementUpdate`` / ``DistributionDecrementUpdate``) or once
  (``DiscreteScheduler({1})``);
* ``AEC cycle``: the game's three turns (nature with a Δθ at every step, monitor, agent) given
  precomputed actions, and the same cycle with ``observe`` called for every agent before it acts,
  as a loop of learning agents would;
* with ``ns_gym`` importable, NS-Gym's wrappers on the same schedules.

Resets are not timed. Each round times every case once, in a row; a ratio is taken within each
round and the median over rounds is reported, which keeps drifting machine load out of the
ratios. It also times the planning model's save + restore and ``get_planning_env()``.

Run: ``python benchmarks/bench_core.py`` (``--smoke`` for a seconds-long check that it runs).
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

import ns_pz
from ns_pz.nature import (
    ContinuousScheduler,
    DiscreteScheduler,
    DistributionDecrementUpdate,
    IncrementUpdate,
    ScriptedNature,
)

try:  # NS-Gym, for a side-by-side measurement when it is installed
    import ns_gym.schedulers as ng_schedulers
    import ns_gym.update_functions as ng_updates
    import ns_gym.wrappers as ng_wrappers
except ImportError:
    ng_wrappers = None
try:  # the MuJoCo tasks (--mujoco), with the mujoco extra
    import mujoco
except ImportError:
    mujoco = None

Runner = Callable[[list], float]
SLIP = (1 / 3, 1 / 3, 1 / 3)


def time_gym(env: gym.Env, actions: list[int], seed: int) -> float:
    """Seconds per ``env.step`` over ``actions``, resets excluded."""
    env.reset(seed=seed)
    step = env.step
    total = 0.0
    i = 0
    n = len(actions)
    while i < n:
        start = time.perf_counter()
        while i < n:
            _, _, terminated, truncated, _ = step(actions[i])
            i += 1
            if terminated or truncated:
                break
        total += time.perf_counter() - start
        if i < n:
            env.reset()
    return total / n


def time_game(game: ns_pz.NSGame, actions: list[int], seed: int, observe: bool) -> float:
    """Seconds per AEC cycle (nature, monitor, agent turns), resets and dead steps excluded."""
    theta_size = game.action_space(ns_pz.NATURE).shape[0]
    # A tiny valid Δθ: off the first flat element, spread over the others for a vector.
    nudge = np.zeros(theta_size)
    nudge[0] = -1e-9
    if "slip" in game.family.params_cls.names():
        nudge[1:] = 1e-9 / (theta_size - 1)
    quiet = {
        "env_change": np.zeros(len(game.family.params_cls.names()), np.int8),
        "delta_change": np.zeros(len(game.family.params_cls.names()), np.float32),
    }
    game.reset(seed=seed)
    step, obs = game.step, game.observe
    total = 0.0
    i = 0
    n = len(actions)
    while i < n:
        start = time.perf_counter()
        while i < n:
            if observe:
                obs(ns_pz.NATURE)
            step(nudge)
            if observe:
                obs(ns_pz.MONITOR)
            step(quiet)
            if observe:
                obs(ns_pz.DECISION)
            step(actions[i])
            i += 1
            if game.terminations[ns_pz.NATURE] or game.truncations[ns_pz.NATURE]:
                break
        total += time.perf_counter() - start
        if i < n:
            game.reset()
    return total / n


@dataclass(frozen=True)
class Bench:
    """One timed environment: its Gymnasium and ns_pz ids and the θ field nature moves."""

    base_id: str
    ns_id: str
    param: str
    k: float = 1e-4
    """Change per step (the nudge of IncrementUpdate / DistributionDecrementUpdate)."""
    nsgym_param: str = ""
    """The Gymnasium attribute NS-Gym's wrapper sets (scalar θ)."""
    slip: tuple[float, ...] | None = None
    """NS-Gym's initial slip vector (grid worlds)."""
    mass: str = ""
    """A MuJoCo task's body mass, moved every step in an extra case."""


ENVS = {
    "CartPole": Bench("CartPole-v1", "ns_pz/CartPole-v0", "masspole", nsgym_param="masspole"),
    "FrozenLake": Bench("FrozenLake-v1", "ns_pz/FrozenLake-v0", "slip", slip=SLIP),
    "Bridge": Bench("ns_gym/Bridge-v0", "ns_pz/Bridge-v0", "slip", slip=SLIP),
    "CliffWalking": Bench(
        "CliffWalking-v1", "ns_pz/CliffWalking-v0", "slip", slip=(1.0, 0.0, 0.0, 0.0)
    ),
    "MountainCar": Bench(
        "MountainCar-v0", "ns_pz/MountainCar-v0", "gravity", k=1e-7, nsgym_param="gravity"
    ),
    "MountainCarContinuous": Bench(
        "MountainCarContinuous-v0",
        "ns_pz/MountainCarContinuous-v0",
        "power",
        k=1e-7,
        nsgym_param="power",
    ),
    "Acrobot": Bench("Acrobot-v1", "ns_pz/Acrobot-v0", "link_mass_2", nsgym_param="LINK_MASS_2"),
    "Pendulum": Bench("Pendulum-v1", "ns_pz/Pendulum-v0", "mass", nsgym_param="m"),
}
MUJOCO_ENVS = {  # timed with --mujoco (needs the mujoco extra)
    name: Bench(f"{name}-v5", f"ns_pz/{name}-v0", param, k=1e-6, mass=mass)
    for name, param, mass in (
        ("InvertedPendulum", "gravity", "pole_mass"),
        ("InvertedDoublePendulum", "gravity", "pole2_mass"),
        ("Reacher", "joint1_damping", "body1_mass"),
        ("Swimmer", "motor1_rot_damping", "body_mid_mass"),
        ("Pusher", "gravity", "r_forearm_link_mass"),
        ("Hopper", "gravity", "torso_mass"),
        ("Walker2d", "gravity", "torso_mass"),
        ("HalfCheetah", "gravity", "torso_mass"),
        ("Ant", "gravity", "torso_mass"),
        ("Humanoid", "gravity", "torso_mass"),
        ("HumanoidStandup", "gravity", "torso_mass"),
    )
}
"""MuJoCo tasks: ``param`` (gravity or a damping: written into the model, nothing recomputed)
moves at every step in the ``change every step`` cases; ``mass`` in the ``mass every step`` case,
which also pays ``mj_setConst`` (MuJoCo's derived constants) at every step."""


MUJOCO_EPISODE = 100
"""Steps per timed MuJoCo episode: the physics' cost depends on the state (contacts), so raw
and view run the same short episodes from the same start states."""


class SyncedMujoco(gym.Wrapper):
    """Gymnasium's MuJoCo env, reset to the start state of a static ns_pz view seeded alike.

    Every episode (``MUJOCO_EPISODE`` steps at most) then begins where the views' episodes
    begin, so ``raw`` and ``view`` time the same physics.
    """

    def __init__(self, env: gym.Env, view: ns_pz.NSGymEnv) -> None:
        super().__init__(env)
        self.view = view
        self.steps = 0

    def reset(self, **kwargs):  # noqa: ANN003, ANN201, D102
        self.env.reset(**kwargs)
        self.view.reset(**kwargs)
        state = self.view.planning_model().get_state()
        family, model, data = self.view.family, self.env.unwrapped.model, self.env.unwrapped.data
        integration = np.frombuffer(state, count=family.layout.integration)
        mujoco.mj_setState(model, data, integration, mujoco.mjtState.mjSTATE_INTEGRATION)
        mujoco.mj_forward(model, data)
        self.steps = 0
        return family.observe(state), {}

    def step(self, action):  # noqa: ANN001, ANN201, D102
        observation, reward, terminated, _, info = self.env.step(action)
        self.steps += 1
        return observation, reward, terminated, self.steps >= MUJOCO_EPISODE, info


def cases(name: str) -> dict[str, Runner]:
    """Every timed variant for one environment of :data:`ENVS`."""
    bench = ENVS.get(name) or MUJOCO_ENVS[name]
    base_id, ns_id, param = bench.base_id, bench.ns_id, bench.param

    def rule(scheduler):  # noqa: ANN001, ANN202
        if param == "slip":
            return DistributionDecrementUpdate(scheduler, k=bench.k)
        return IncrementUpdate(scheduler, k=bench.k)

    every = ScriptedNature({param: rule(ContinuousScheduler(start=0))})
    once = ScriptedNature({param: rule(DiscreteScheduler({1}))})
    limit = {}
    if name in MUJOCO_ENVS:  # short episodes, raw started where the views start
        limit = {"max_episode_steps": MUJOCO_EPISODE}
        raw = SyncedMujoco(gym.make(base_id).unwrapped, gym.make(ns_id, **limit).unwrapped)
    elif base_id in gym.registry:
        raw = gym.make(base_id).unwrapped
    else:  # the Bridge without NS-Gym: the stationary ns_pz view stands in
        raw = gym.make(ns_id).unwrapped
    view_every = gym.make(ns_id, nature=every, **limit).unwrapped
    view_once = gym.make(ns_id, nature=once, **limit).unwrapped
    game = ns_pz.make(ns_id, **limit)
    runners: dict[str, Runner] = {
        "raw": lambda a: time_gym(raw, a, 0),
        "view, change every step": lambda a: time_gym(view_every, a, 0),
        "view, single change": lambda a: time_gym(view_once, a, 0),
        "AEC cycle, change every step": lambda a: time_game(game, a, 0, observe=False),
        "AEC cycle + observe, every step": lambda a: time_game(game, a, 0, observe=True),
    }
    if bench.mass:
        masses = ScriptedNature({bench.mass: rule(ContinuousScheduler(start=0))})
        view_mass = gym.make(ns_id, nature=masses, **limit).unwrapped
        runners["view, mass every step"] = lambda a: time_gym(view_mass, a, 0)
    if ng_wrappers is not None and name in ENVS:
        runners.update(nsgym_cases(name))
    return runners


def nsgym_cases(name: str) -> dict[str, Runner]:
    """NS-Gym 1.0.12 wrappers on the same schedules."""
    bench = ENVS[name]
    base_id = bench.base_id

    def build(scheduler_fn: Callable[[], object]) -> gym.Env:
        if bench.slip is None:
            update = ng_updates.IncrementUpdate(scheduler_fn(), k=bench.k)
            return ng_wrappers.NSClassicControlWrapper(
                gym.make(base_id), {bench.nsgym_param: update}
            )
        update = ng_updates.DistributionDecrementUpdate(scheduler_fn(), k=bench.k)
        wrapper = {
            "FrozenLake": ng_wrappers.NSFrozenLakeWrapper,
            "CliffWalking": ng_wrappers.NSCliffWalkingWrapper,
            "Bridge": ng_wrappers.NSBridgeWrapper,
        }[name]
        return wrapper(gym.make(base_id), {"P": update}, initial_prob_dist=list(bench.slip))

    every = build(ng_schedulers.ContinuousScheduler)
    once = build(lambda: ng_schedulers.DiscreteScheduler({1}))
    return {
        "NS-Gym, change every step": lambda a: time_gym(every, a, 0),
        "NS-Gym, single change": lambda a: time_gym(once, a, 0),
    }


def random_actions(space: gym.Space, steps: int) -> list:
    """Seeded uniform actions: ints for a Discrete space, float32 arrays for a Box."""
    rng = np.random.default_rng(0)
    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(0, int(space.n), steps).tolist()
    draws = rng.uniform(space.low, space.high, (steps, *space.shape)).astype(space.dtype)
    return list(draws)


def measure(name: str, steps: int, rounds: int) -> None:
    """Print µs per step and the median ratio to ``raw`` for every case of one env."""
    runners = cases(name)
    bench = ENVS.get(name) or MUJOCO_ENVS[name]
    actions = random_actions(gym.make(bench.ns_id).unwrapped.family.action_space, steps)
    seconds: dict[str, list[float]] = {case: [] for case in runners}
    for _ in range(rounds):
        for case, run in runners.items():
            seconds[case].append(run(actions))
    reference = "" if bench.base_id in gym.registry else " [raw = ns_pz, static]"
    print(f"\n{name}: {steps} steps x {rounds} rounds (median){reference}")
    print(f"  {'case':36s} {'us/step':>9s} {'x raw':>7s}")
    for case, times in seconds.items():
        ratio = statistics.median(t / r for t, r in zip(times, seconds["raw"], strict=True))
        print(f"  {case:36s} {statistics.median(times) * 1e6:9.2f} {ratio:7.2f}")


def measure_planning(name: str, repeats: int) -> None:
    """Planning model save + restore and get_planning_env(), in µs."""
    ns_id = f"ns_pz/{name}-v0"
    env = gym.make(ns_id, notification="detailed").unwrapped
    env.reset(seed=0)
    model = env.planning_model()

    def save_restore() -> None:
        for _ in range(repeats):
            model.set_state(model.get_state())

    def planning_env() -> None:
        for _ in range(repeats // 100):
            env.get_planning_env()

    save = _best_of(save_restore) / repeats
    copy_env = _best_of(planning_env) / (repeats // 100)
    print(
        f"  {name} planning model save + restore: {save * 1e6:.3f} us;"
        f" get_planning_env(): {copy_env * 1e6:.1f} us"
    )
    if ng_wrappers is not None:
        if name not in ("CartPole", "FrozenLake"):
            return
        if name == "CartPole":
            update = ng_updates.IncrementUpdate(ng_schedulers.ContinuousScheduler(), k=1e-4)
            ng = ng_wrappers.NSClassicControlWrapper(
                gym.make("CartPole-v1"),
                {"masspole": update},
                change_notification=True,
                delta_change_notification=True,
            )
        else:
            update = ng_updates.DistributionDecrementUpdate(
                ng_schedulers.ContinuousScheduler(), k=1e-4
            )
            ng = ng_wrappers.NSFrozenLakeWrapper(
                gym.make("FrozenLake-v1"),
                {"P": update},
                change_notification=True,
                delta_change_notification=True,
                initial_prob_dist=list(SLIP),
            )
        ng.reset(seed=0)
        count = max(repeats // 1000, 5)
        ng_copy = _best_of(lambda: [ng.get_planning_env() for _ in range(count)]) / count
        print(f"  {name} NS-Gym get_planning_env(): {ng_copy * 1e6:.1f} us")


def _best_of(fn: Callable[[], object], rounds: int = 5) -> float:
    best = float("inf")
    for _ in range(rounds):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    """Run every measurement."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=20_000, help="steps per case and round")
    parser.add_argument("--rounds", type=int, default=9, help="rounds (ratios: median)")
    parser.add_argument("--smoke", action="store_true", help="tiny run that checks it works")
    parser.add_argument(
        "--envs", nargs="+", choices=sorted(ENVS), default=list(ENVS), help="environments to time"
    )
    parser.add_argument(
        "--mujoco",
        nargs="*",
        choices=sorted(MUJOCO_ENVS),
        help="also time these MuJoCo tasks (no name: all), at a tenth of --steps",
    )
    args = parser.parse_args()
    steps, rounds = (300, 2) if args.smoke else (args.steps, args.rounds)
    print(
        f"ns_pz {ns_pz.__version__}, gymnasium {gym.__version__}, "
        f"NS-Gym {'present' if ng_wrappers is not None else 'not installed (skipped)'}"
    )
    for name in args.envs:
        measure(name, steps, rounds)
    mujoco_tasks = [] if args.mujoco is None else args.mujoco or list(MUJOCO_ENVS)
    for name in mujoco_tasks:
        measure(name, max(steps // 10, 100), rounds)
    print("\nPlanning")
    for name in ("CartPole", "FrozenLake", *mujoco_tasks[:1]):
        measure_planning(name, 1000 if args.smoke else 100_000)


if __name__ == "__main__":
    main()
