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
* ``nature seat`` / ``monitor seat``: the game from nature's or the monitor's seat as a
  learner trains it (``single_agent(id, learner)``, random actions; the decision agent plays
  the same actions as the other cases);
* with ``ns_gym`` importable, NS-Gym's wrappers on the same schedules.

Resets are not timed. Each round times every case once, in a row, each after a full garbage
collection (NS-Gym's cases leave tens of thousands of objects behind, which made whichever case
came next pay for slower collections: 1.5 or 1.9× for the same compat case); a ratio is taken
within each round and the median over rounds is reported, which keeps drifting machine load out
of the ratios. It also times the planning model's save + restore and ``get_planning_env()``.

Run: ``python benchmarks/bench_core.py`` (``--smoke`` for a seconds-long check that it runs).
"""

from __future__ import annotations

import argparse
import gc
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from ns_pz.envs.registry import make_vec

import ns_pz
import ns_pz.compat.schedulers as compat_schedulers
import ns_pz.compat.update_functions as compat_updates
import ns_pz.compat.wrappers as compat_wrappers
from ns_pz.learning.seats import single_agent
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


def time_game(
    game: ns_pz.NSGame, actions: list[int], seed: int, observe: bool, policies: bool = False
) -> float:
    """Seconds per AEC cycle (nature, monitor, agent turns), resets and dead steps excluded.

    Nature and monitor play a fixed tiny Δθ and a quiet notification, or with ``policies`` the
    game's own nature and monitor through ``policy_action`` (as users run the game).
    """
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
    step, obs, policy = game.step, game.observe, game.policy_action
    total = 0.0
    i = 0
    n = len(actions)
    while i < n:
        start = time.perf_counter()
        while i < n:
            if observe:
                obs(ns_pz.NATURE)
            step(policy(ns_pz.NATURE) if policies else nudge)
            if observe:
                obs(ns_pz.MONITOR)
            step(policy(ns_pz.MONITOR) if policies else quiet)
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


def scripted(bench: Bench, scheduler: object) -> ScriptedNature:
    """Nature moving ``bench.param`` by ``bench.k`` whenever ``scheduler`` fires."""
    return scripted_param(bench, bench.param, scheduler)


def scripted_param(bench: Bench, param: str, scheduler: object) -> ScriptedNature:
    """Nature moving ``param`` by ``bench.k`` whenever ``scheduler`` fires."""
    if param == "slip":
        return ScriptedNature({"slip": DistributionDecrementUpdate(scheduler, k=bench.k)})
    return ScriptedNature({param: IncrementUpdate(scheduler, k=bench.k)})


def cases(name: str) -> dict[str, Runner]:
    """Every timed variant for one environment of :data:`ENVS`."""
    bench = ENVS.get(name) or MUJOCO_ENVS[name]
    base_id, ns_id = bench.base_id, bench.ns_id

    every = scripted(bench, ContinuousScheduler(start=0))
    once = scripted(bench, DiscreteScheduler({1}))
    limit = {}
    if name in MUJOCO_ENVS:  # short episodes, raw started where the views start
        limit = {"max_episode_steps": MUJOCO_EPISODE}
        raw = SyncedMujoco(gym.make(base_id).unwrapped, gym.make(ns_id, **limit).unwrapped)
    elif base_id in gym.registry:
        raw = gym.make(base_id).unwrapped
    else:  # the Bridge without NS-Gym: the stationary ns_pz view stands in
        raw = gym.make(ns_id).unwrapped
    view_once = gym.make(ns_id, nature=once, **limit).unwrapped
    game = ns_pz.make(ns_id, **limit)
    runners: dict[str, Runner] = {"raw": lambda a: time_gym(raw, a, 0)}
    for level in LEVELS:
        view = gym.make(ns_id, nature=every, notification=level, **limit).unwrapped
        runners[f"view {level}, change every step"] = _timer(time_gym, view)
    runners["view, single change"] = lambda a: time_gym(view_once, a, 0)
    runners["AEC cycle, change every step"] = lambda a: time_game(game, a, 0, observe=False)
    runners["AEC cycle + observe, every step"] = lambda a: time_game(game, a, 0, observe=True)
    user_game = ns_pz.make(ns_id, nature=every, notification="detailed", **limit)
    runners["game: policy_action + observe, detailed"] = lambda a: time_game(
        user_game, a, 0, observe=True, policies=True
    )
    runners["nature seat: learner step, normalized"] = seat_runner(ns_id, ns_pz.NATURE, limit)
    runners["monitor seat: learner step, flags"] = seat_runner(ns_id, ns_pz.MONITOR, limit)
    if bench.mass:
        masses = scripted_param(bench, bench.mass, ContinuousScheduler(start=0))
        view_mass = gym.make(ns_id, nature=masses, **limit).unwrapped
        runners["view, mass every step"] = lambda a: time_gym(view_mass, a, 0)
    if name in ENVS:
        runners.update(
            wrapper_cases(
                name, "compat", compat_schedulers, compat_updates, compat_wrappers, levels=True
            )
        )
    if ng_wrappers is not None and name in ENVS:
        runners.update(nsgym_cases(name))
    return runners


LEVELS = ("none", "basic", "detailed")
NOTIFY = {"none": (False, False), "basic": (True, False), "detailed": (True, True)}
"""NS-Gym's (change_notification, delta_change_notification) for each level."""


def seat_runner(ns_id: str, learner: str, limit: dict) -> Runner:
    """Nature or the monitor as a learner sees the game (``single_agent(id, learner)``).

    Each step is the learner's turn with a random action (nature: ``Box(-1, 1)``, zero for about
    a third of the parameters, as a policy's output might be; monitor: random 0/1 flags, paid
    by the detection reward), then the other seats' turns (scripted nature or oracle monitor;
    the decision agent plays the same actions as the other cases, in order) and the learner's
    next observation.
    """
    decisions: list = []
    position = [0]

    def decide(observation: object) -> object:
        action = decisions[position[0] % len(decisions)]
        position[0] += 1
        return action

    reward = {"monitor_reward": "detection"} if learner == ns_pz.MONITOR else {}
    seat = single_agent(ns_id, learner=learner, policies={"agent": decide}, **reward, **limit)
    rng = np.random.default_rng(1)
    if learner == ns_pz.NATURE:
        shape = seat.action_space.shape
        draws = rng.uniform(-1.0, 1.0, (20_000, *shape)) * (rng.random((20_000, *shape)) > 1 / 3)
        moves = list(draws.astype(seat.action_space.dtype))
    else:
        moves = list(rng.integers(0, 2, (20_000, *seat.action_space.shape)))

    def run(actions: list) -> float:
        decisions[:] = actions
        position[0] = 0
        return time_gym(seat, (moves * (len(actions) // len(moves) + 1))[: len(actions)], 0)

    return run


def _timer(timer: Callable[..., float], env: object) -> Runner:
    return lambda a: timer(env, a, 0)


def wrapper_cases(
    name: str, label: str, schedulers: object, updates: object, wrappers: object, levels: bool
) -> dict[str, Runner]:
    """NS-Gym's wrapper API (NS-Gym itself or ``ns_pz.compat``) on the same schedules.

    With ``levels``, a change every step at each notification level; without, a change every
    step and a single change, detailed.
    """
    bench = ENVS[name]
    # NS-Gym's wrappers take its own base Bridge; ns_pz.compat's take ns_pz's NS-Gym-style one.
    base_id = "ns_pz_compat/Bridge-v0" if name == "Bridge" and label == "compat" else bench.base_id

    def build(scheduler_fn: Callable[[], object], level: str) -> gym.Env:
        change, delta = NOTIFY[level]
        flags = {"change_notification": change, "delta_change_notification": delta}
        if bench.slip is None:
            update = updates.IncrementUpdate(scheduler_fn(), k=bench.k)  # type: ignore[attr-defined]
            return wrappers.NSClassicControlWrapper(  # type: ignore[attr-defined]
                gym.make(base_id), {bench.nsgym_param: update}, **flags
            )
        update = updates.DistributionDecrementUpdate(scheduler_fn(), k=bench.k)  # type: ignore[attr-defined]
        wrapper = {
            "FrozenLake": "NSFrozenLakeWrapper",
            "CliffWalking": "NSCliffWalkingWrapper",
            "Bridge": "NSBridgeWrapper",
        }[name]
        return getattr(wrappers, wrapper)(
            gym.make(base_id), {"P": update}, initial_prob_dist=list(bench.slip), **flags
        )

    continuous = schedulers.ContinuousScheduler  # type: ignore[attr-defined]
    if levels:
        return {
            f"{label} wrapper {level}, every step": _timer(time_gym, build(continuous, level))
            for level in LEVELS
        }
    once = build(lambda: schedulers.DiscreteScheduler({1}), "detailed")  # type: ignore[attr-defined]
    return {
        f"{label} detailed, change every step": _timer(time_gym, build(continuous, "detailed")),
        f"{label} detailed, single change": _timer(time_gym, once),
    }


def nsgym_cases(name: str) -> dict[str, Runner]:
    """NS-Gym's wrappers on the same schedules (needs ``ns_gym`` importable)."""
    return wrapper_cases(name, "NS-Gym", ng_schedulers, ng_updates, ng_wrappers, levels=False)


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
            gc.collect()  # each case starts from a clean heap, whatever ran before it
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


def time_vector(env: gym.vector.VectorEnv, actions: list[np.ndarray]) -> float:
    """Seconds per env-step of a vector env over batches of actions (autoreset included)."""
    env.reset(seed=0)
    step = env.step
    start = time.perf_counter()
    for batch in actions:
        step(batch)
    return (time.perf_counter() - start) / (len(actions) * env.num_envs)


def measure_vector(name: str, num_envs: int, steps: int, rounds: int) -> None:
    """µs per env-step of the batched env against Gymnasium's vector envs, change every step."""
    from gymnasium.envs.classic_control.cartpole import CartPoleVectorEnv

    bench = ENVS[name]
    every = scripted(bench, ContinuousScheduler(start=0))
    envs: dict[str, gym.vector.VectorEnv] = {}
    if name == "CartPole":
        envs["Gymnasium CartPoleVectorEnv (raw)"] = CartPoleVectorEnv(num_envs=num_envs)
    if bench.base_id in gym.registry and not bench.base_id.startswith("ns_gym/"):
        # (NS-Gym's base Bridge puts lists into info, which Gymnasium's vector envs refuse.)
        envs["Gymnasium SyncVectorEnv (raw)"] = gym.make_vec(
            bench.base_id, num_envs, vectorization_mode="sync"
        )
    for level in LEVELS:
        batched = make_vec(bench.ns_id, num_envs, nature=every, notification=level)
        envs[f"ns_pz make_vec {level} ({batched.engine})"] = batched
    envs["SyncVectorEnv of the view, detailed"] = gym.make_vec(
        bench.ns_id, num_envs, vectorization_mode="sync", nature=every, notification="detailed"
    )
    space = envs[f"ns_pz make_vec detailed ({batched.engine})"].action_space
    space.seed(0)
    actions = [space.sample() for _ in range(steps)]
    seconds: dict[str, list[float]] = {case: [] for case in envs}
    for _ in range(rounds):
        for case, env in envs.items():
            gc.collect()
            seconds[case].append(time_vector(env, actions))
    first = next(iter(envs))
    print(f"\n{name}, N={num_envs}: {steps} batch steps x {rounds} rounds (median)")
    print(f"  {'case':40s} {'us/env-step':>11s} {'x first':>8s}")
    for case, times in seconds.items():
        ratio = statistics.median(t / r for t, r in zip(times, seconds[first], strict=True))
        print(f"  {case:40s} {statistics.median(times) * 1e6:11.3f} {ratio:8.2f}")


def measure_sb3(num_envs: int, timesteps: int) -> None:
    """SB3 PPO steps per second on a changing CartPole: the batched env vs ``make_vec_env``."""
    try:
        from stable_baselines3 import PPO
        from stable_baselines3.common.env_util import make_vec_env

        from ns_pz.learning.sb3_vec import SB3VecEnv
    except ImportError:
        print("\nSB3 PPO: stable-baselines3 not installed (skipped)")
        return
    every = scripted(ENVS["CartPole"], ContinuousScheduler(start=0))
    ns_id = "ns_pz/CartPole-v0"
    envs = {
        "SB3VecEnv(make_vec)": SB3VecEnv(
            make_vec(
                ns_id, num_envs, nature=every, notification="detailed", autoreset_mode="SameStep"
            )
        ),
        "make_vec_env of the view": make_vec_env(
            ns_id, n_envs=num_envs, env_kwargs={"nature": every, "notification": "detailed"}
        ),
    }
    print(
        f"\nSB3 PPO (MultiInputPolicy, cpu), changing CartPole, {num_envs} envs, {timesteps} steps"
    )
    for label, env in envs.items():
        model = PPO("MultiInputPolicy", env, n_steps=128, seed=0, device="cpu", verbose=0)
        start = time.perf_counter()
        model.learn(total_timesteps=timesteps)
        rate = timesteps / (time.perf_counter() - start)
        print(f"  {label:28s} {rate:9.0f} steps/s")


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
    parser.add_argument("--num-envs", type=int, default=256, help="sub-envs of vector envs")
    parser.add_argument("--vector-steps", type=int, default=200, help="batch steps per round")
    parser.add_argument("--sb3-steps", type=int, default=20_000, help="PPO steps (0: skip)")
    parser.add_argument(
        "--only", choices=("single", "vector", "sb3"), help="run one part of the benchmark"
    )
    args = parser.parse_args()
    steps, rounds = (300, 2) if args.smoke else (args.steps, args.rounds)
    num_envs = 8 if args.smoke else args.num_envs
    if args.only in (None, "vector"):
        for name in args.envs:  # every family has a batched kernel
            measure_vector(name, num_envs, 20 if args.smoke else args.vector_steps, rounds)
    if args.only in (None, "sb3") and args.sb3_steps and not args.smoke:
        measure_sb3(8, args.sb3_steps)
    if args.only not in (None, "single"):
        return
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
