"""The native vector env equals N single views bit for bit, in both engines."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces
from ns_pz.envs.registry import make_gym, make_vec, registered_envs

from ns_pz.errors import ParamOutOfRange, ResetNeeded
from ns_pz.monitor.monitors import Monitor
from ns_pz.nature import (
    ContinuousScheduler,
    CyclicUpdate,
    DistributionDecrementUpdate,
    IncrementUpdate,
    PeriodicScheduler,
    RandomNature,
    ScriptedNature,
    StepWiseUpdate,
)
from ns_pz.vector import NSVectorEnv

CARTPOLE = ScriptedNature({"masspole": IncrementUpdate(ContinuousScheduler(start=1), 0.01)})
SLIP = ScriptedNature({"slip": DistributionDecrementUpdate(ContinuousScheduler(start=0), 0.05)})
CASES = [
    ("ns_pz/CartPole-v0", CARTPOLE, "arrays"),
    ("ns_pz/CartPole-v0", RandomNature(0.05), "processes"),
    ("ns_pz/FrozenLake-v0", SLIP, "arrays"),
    ("ns_pz/FrozenLake-v0", RandomNature(0.05), "processes"),
    ("ns_pz/CliffWalking-v0", SLIP, "arrays"),
    ("ns_pz/Bridge-v0", SLIP, "arrays"),
    (
        "ns_pz/BridgeSplit-v0",
        ScriptedNature(
            {"slip_left": DistributionDecrementUpdate(PeriodicScheduler(3, start=1), 0.2)}
        ),
        "arrays",
    ),
    (
        "ns_pz/MountainCar-v0",
        ScriptedNature(
            {
                "gravity": StepWiseUpdate(PeriodicScheduler(5, start=1), [0.002, 0.004]),
                "force": CyclicUpdate(PeriodicScheduler(2, start=0), [0.001, 0.0015]),
            }
        ),
        "arrays",
    ),
    ("ns_pz/MountainCarContinuous-v0", RandomNature(0.05), "processes"),
    (
        "ns_pz/MountainCarContinuous-v0",
        ScriptedNature(
            {
                "power": IncrementUpdate(ContinuousScheduler(start=1), 0.0005),
                "gravity": StepWiseUpdate(PeriodicScheduler(9, start=2), [0.002, 0.0035]),
            }
        ),
        "arrays",
    ),
    ("ns_pz/Acrobot-v0", None, "arrays"),
    (
        "ns_pz/Acrobot-v0",
        ScriptedNature({"link_mass_2": IncrementUpdate(ContinuousScheduler(start=1), 0.05)}),
        "arrays",
    ),
    ("ns_pz/Acrobot-v0", RandomNature(0.05), "processes"),
    ("ns_pz/Pendulum-v0", RandomNature(0.05), "processes"),
    (
        "ns_pz/Pendulum-v0",
        ScriptedNature(
            {
                "mass": IncrementUpdate(ContinuousScheduler(start=1), 0.01),
                "dt": StepWiseUpdate(PeriodicScheduler(7, start=3), [0.04, 0.06]),
            }
        ),
        "arrays",
    ),
]


def _actions(space: spaces.Space[Any], rng: np.random.Generator, n: int) -> np.ndarray:
    if isinstance(space, spaces.Discrete):
        return rng.integers(0, space.n, n)
    return rng.uniform(space.low, space.high, (n, *space.shape)).astype(space.dtype)


def _same(batch: dict[str, np.ndarray], singles: list[dict[str, Any]]) -> None:
    for key, values in batch.items():
        for i, single in enumerate(singles):
            assert np.array_equal(values[i], np.asarray(single[key])), (key, i)
            if key != "state":
                assert values[i].dtype == single[key].dtype, key


@pytest.mark.parametrize("level", ["none", "basic", "detailed"])
@pytest.mark.parametrize(("env_id", "nature", "engine"), CASES)
def test_vector_equals_single_views(env_id: str, nature: Any, engine: str, level: str) -> None:
    """Same seeds, same actions: same observations, rewards and ends (NEXT_STEP autoreset)."""
    n, seed = 4, 11
    vec = make_vec(env_id, n, nature=nature, notification=level, max_episode_steps=40)
    assert vec.engine == engine
    views = [
        make_gym(env_id, nature=nature, notification=level, max_episode_steps=40) for _ in range(n)
    ]
    obs, _ = vec.reset(seed=seed)
    singles = [view.reset(seed=seed + i)[0] for i, view in enumerate(views)]
    _same(obs, singles)
    rng = np.random.default_rng(0)
    ended = [False] * n
    notified = 0
    for _ in range(120):
        actions = _actions(vec.single_action_space, rng, n)
        obs, rewards, terminated, truncated, _ = vec.step(actions)
        for i, view in enumerate(views):
            if ended[i]:  # NEXT_STEP: the sub-env resets instead of stepping
                singles[i], _ = view.reset()
                expected: tuple = (0.0, False, False)
                ended[i] = False
            else:
                singles[i], reward, term, trunc, _ = view.step(actions[i])
                expected = (reward, term, trunc)
                ended[i] = term or trunc
            assert (rewards[i], terminated[i], truncated[i]) == expected
        _same(obs, singles)
        notified += int(obs["env_change"].any())
    if level != "none" and nature is not None:
        assert notified > 0  # the comparison covered notifications


def test_same_step_autoreset_matches_single_views() -> None:
    """SAME_STEP: the final observation in the info, the next episode's first in the batch."""
    n = 3
    vec = make_vec("ns_pz/FrozenLake-v0", n, nature=SLIP, autoreset_mode="SameStep")
    views = [make_gym("ns_pz/FrozenLake-v0", nature=SLIP) for _ in range(n)]
    obs, _ = vec.reset(seed=[5, 6, 7])
    for i, view in enumerate(views):
        view.reset(seed=5 + i)
    rng = np.random.default_rng(1)
    finals = 0
    for _ in range(60):
        actions = rng.integers(0, 4, n)
        obs, _, terminated, truncated, infos = vec.step(actions)
        for i, view in enumerate(views):
            single, _, term, trunc, _ = view.step(int(actions[i]))
            if term or trunc:
                finals += 1
                assert infos["_final_obs"][i]
                assert infos["final_obs"][i]["state"] == single["state"]
                single, _ = view.reset()
            assert obs["state"][i] == single["state"]
    assert finals > 0


def test_engine_falls_back_to_processes_for_other_monitors() -> None:
    """A monitor other than the oracle runs per sub-env, and is obeyed."""

    class Quiet(Monitor):
        needs_observation = False

        def notify(self, observation: Any, truth: Any, memory: Any, rng: Any) -> Any:
            return (0,), (0.0,)

    vec = make_vec("ns_pz/FrozenLake-v0", 2, nature=SLIP, monitor=Quiet(), notification="basic")
    assert vec.engine == "processes"
    obs, _ = vec.reset(seed=0)
    obs, *_ = vec.step(np.array([0, 1]))
    assert not obs["env_change"].any()


def test_bad_arguments_are_refused() -> None:
    """Each bad argument gets an error naming it."""
    with pytest.raises(ValueError, match="num_envs=0 must be >= 1"):
        make_vec("ns_pz/CartPole-v0", 0)
    with pytest.raises(TypeError, match="num_envs=2.0 must be an int"):
        make_vec("ns_pz/CartPole-v0", 2.0)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="autoreset_mode='Disabled' is not supported"):
        make_vec("ns_pz/CartPole-v0", 2, autoreset_mode="Disabled")
    with pytest.raises(ValueError, match="nature has 1 entries; num_envs=2"):
        make_vec("ns_pz/CartPole-v0", 2, nature=[CARTPOLE])
    vec = make_vec("ns_pz/CartPole-v0", 2)
    with pytest.raises(ResetNeeded, match="before reset"):
        vec.step(np.array([0, 1]))
    with pytest.raises(ValueError, match="seed has 3 entries; num_envs=2"):
        vec.reset(seed=[1, 2, 3])
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions=.* must be 2 ints in \[0, 2\)"):
        vec.step(np.array([0, 2]))


def test_observations_are_fresh_and_in_the_space() -> None:
    """Observations lie in the batched space and are the caller's to modify."""
    vec = make_vec("ns_pz/CartPole-v0", 3, nature=CARTPOLE, notification="detailed")
    obs, _ = vec.reset(seed=3)
    obs, *_ = vec.step(np.array([1, 0, 1]))
    obs, *_ = vec.step(np.array([1, 0, 1]))
    assert vec.observation_space.contains(obs)
    obs["env_change"][:] = 7
    again = vec._observation()
    assert again["env_change"].max() <= 1
    assert isinstance(vec, NSVectorEnv)
    assert vec.thetas()[:, 2] == pytest.approx(0.1 + 2 * 0.01)  # nature moved at t=1 and t=2


def test_sb3_adapter_steps_without_a_loop() -> None:
    """SB3VecEnv needs SAME_STEP and reports terminal observations SB3's way."""
    pytest.importorskip("stable_baselines3")
    from ns_pz.sb3_vec import SB3VecEnv

    with pytest.raises(ValueError, match="SAME_STEP"):
        SB3VecEnv(make_vec("ns_pz/CartPole-v0", 2))
    env = SB3VecEnv(make_vec("ns_pz/CartPole-v0", 4, autoreset_mode="SameStep"))
    env.seed(3)
    obs = env.reset()
    assert obs["state"].shape == (4, 4)
    done_seen = False
    for _ in range(100):
        obs, rewards, dones, infos = env.step(np.ones(4, np.int64))
        for i in np.flatnonzero(dones):
            done_seen = True
            assert infos[i]["terminal_observation"]["state"].shape == (4,)
    assert done_seen


def test_sb3_adapter_resets_with_the_options_sb3_set() -> None:
    """set_options reaches the next reset (once); options differing per sub-env are refused."""
    pytest.importorskip("stable_baselines3")
    from ns_pz.sb3_vec import SB3VecEnv

    env = SB3VecEnv(make_vec("ns_pz/CartPole-v0", 2, autoreset_mode="SameStep"))
    env.set_options({"params": {"masspole": 0.5}})
    env.seed(0)
    env.reset()
    assert env.env.thetas()[:, 2].tolist() == [0.5, 0.5]
    env.reset()  # options hold for one reset, as in SB3's own VecEnvs
    assert env.env.thetas()[:, 2].tolist() == [0.1, 0.1]
    env.set_options([{"params": {"masspole": 0.5}}, {}])
    with pytest.raises(ValueError, match="different options"):
        env.reset()


def test_grid_kernel_takes_the_last_positive_outcome_when_rounding_leaves_u_above_the_sum() -> None:
    """θ summing a hair below 1 and u above the sum: the scalar step's choice, not index K."""
    from ns_pz.envs.batched import SlipGridKernel
    from ns_pz.envs.frozen_lake import FrozenLakeFamily, FrozenLakeParams

    family = FrozenLakeFamily()
    theta = FrozenLakeParams(slip=(1.0 - 5e-9, 0.0, 0.0))
    u = 1.0 - 1e-9

    class Fixed:
        def random(self) -> float:
            return u

    expected = family.step(6, 2, theta, Fixed())  # type: ignore[arg-type]
    states, rewards, terminals = SlipGridKernel(family).step(
        np.array([6]), np.array([2]), np.array([theta.flat_values()]), np.array([u])
    )
    assert (int(states[0]), float(rewards[0]), bool(terminals[0])) == expected


@pytest.mark.parametrize("nature", [CARTPOLE, RandomNature(0.05)])
def test_reset_options_set_theta0_as_in_the_single_view(nature: Any) -> None:
    """``reset(options={"params": ...})`` starts every sub-env from that θ_0, in both engines."""
    import ns_pz

    options = {"params": {"masspole": 0.5}}
    vec = ns_pz.make_vec("ns_pz/CartPole-v0", 2, nature=nature, notification="detailed")
    views = [make_gym("ns_pz/CartPole-v0", nature=nature, notification="detailed") for _ in "ab"]
    obs, _ = vec.reset(seed=1, options=options)
    singles = [view.reset(seed=1 + i, options=options)[0] for i, view in enumerate(views)]
    _same(obs, singles)
    for _ in range(5):
        obs, *_ = vec.step(np.array([0, 1]))
        singles = [view.step(a)[0] for view, a in zip(views, (0, 1), strict=True)]
        _same(obs, singles)
    expected = [view.unwrapped.process.theta.flat_values() for view in views]
    assert vec.thetas().tolist() == expected


@pytest.mark.parametrize("env_id", registered_envs())
def test_every_registered_id_batches(env_id: str) -> None:
    """make_vec builds every registered id; observations stay in the batched space."""
    vec = make_vec(env_id, 3, notification="detailed")
    obs, _ = vec.reset(seed=0)
    assert vec.observation_space.contains(obs)
    vec.action_space.seed(0)
    for _ in range(5):
        obs, rewards, terminated, truncated, _ = vec.step(vec.action_space.sample())
        assert vec.observation_space.contains(obs)
        assert rewards.shape == terminated.shape == truncated.shape == (3,)


def test_pendulum_kernel_squares_as_the_scalar_step_does() -> None:
    """The kernel's squares equal Python's ``x ** 2`` and NumPy's scalar float32 power.

    Bit for bit, where NumPy's array arithmetic differs from both.
    """
    from ns_pz.envs.batched import _pow2, _powf2

    rng = np.random.default_rng(5)
    x = rng.uniform(-8.0, 8.0, 100_000)
    assert _pow2(x).tolist() == [v**2 for v in x.tolist()]
    assert (x * x).tolist() != [v**2 for v in x.tolist()]
    torques = rng.uniform(-2.0, 2.0, 100_000).astype(np.float32)
    ties = np.array([1 + 2**-12, 1.5 + 2**-12, 2**-70, 1e-30, 0.0, -0.0], np.float32)
    torques = np.concatenate([torques, ties, -ties]).astype(np.float64)
    expected = [float(np.float32(t) ** 2) for t in torques.tolist()]
    assert _powf2(torques).tolist() == expected
    plain = (torques * torques).astype(np.float32).astype(np.float64)
    assert plain.tolist() != expected  # the kernel cannot square with array arithmetic


def test_acrobot_kernel_draws_torque_noise_as_the_single_views() -> None:
    """With ``torque_noise_max`` each transition draws one uniform from its sub-env's stream."""
    n, seed = 3, 4
    vec = make_vec("ns_pz/Acrobot-v0", n, torque_noise_max=0.5, max_episode_steps=30)
    assert vec.engine == "arrays" and vec.kernel.step_uniforms == 1
    views = [
        make_gym("ns_pz/Acrobot-v0", torque_noise_max=0.5, max_episode_steps=30) for _ in range(n)
    ]
    obs, _ = vec.reset(seed=seed)
    singles = [view.reset(seed=seed + i)[0] for i, view in enumerate(views)]
    _same(obs, singles)
    for step in range(25):
        actions = np.array([(step + i) % 3 for i in range(n)])
        obs, *_ = vec.step(actions)
        singles = [view.step(int(a))[0] for view, a in zip(views, actions, strict=True)]
        _same(obs, singles)
    quiet = make_gym("ns_pz/Acrobot-v0", max_episode_steps=30)
    quiet.reset(seed=seed)
    for step in range(25):
        last = quiet.step(step % 3)[0]
    assert not np.array_equal(last["state"], singles[0]["state"])  # the noise mattered


def test_mountain_car_continuous_kernel_at_the_walls_the_goal_and_out_of_range_pushes() -> None:
    """MountainCarContinuous's kernel at the walls, the goal and pushes beyond ±1.

    A strong engine reaches the left wall and the goal; pushes beyond ±1 take Gymnasium's
    clipped branch. The batch still equals the single views, ends and rewards included.
    """
    n, seed = 4, 3
    kwargs = {"params": {"power": 0.05}, "max_episode_steps": 60}
    vec = make_vec("ns_pz/MountainCarContinuous-v0", n, **kwargs)
    assert vec.engine == "arrays"
    views = [make_gym("ns_pz/MountainCarContinuous-v0", **kwargs) for _ in range(n)]
    obs, _ = vec.reset(seed=seed)
    singles = [view.reset(seed=seed + i)[0] for i, view in enumerate(views)]
    rng = np.random.default_rng(1)
    ended, goals, walls = [False] * n, 0, 0
    for step in range(150):
        # Ram the left wall, then pump energy (push along the velocity) up to the goal.
        direction = np.where(obs["state"][:, 1:] >= 0.0, 1.0, -1.0) if step % 40 > 10 else -1.0
        actions = (direction * rng.uniform(0.5, 3.0, (n, 1))).astype(np.float32)
        obs, rewards, terminated, truncated, _ = vec.step(actions)
        for i, view in enumerate(views):
            if ended[i]:
                singles[i], _ = view.reset()
                ended[i] = False
                continue
            singles[i], reward, term, trunc, _ = view.step(actions[i])
            assert (rewards[i], terminated[i], truncated[i]) == (reward, term, trunc)
            ended[i] = term or trunc
            goals += term
            walls += float(singles[i]["state"][0]) == np.float32(-1.2)
        _same(obs, singles)
    assert goals > 0 and walls > 0


def test_continuous_actions_are_checked_and_kept_as_arrays_per_sub_env() -> None:
    """NaN, a wrong shape or a missing row are refused, as by the view; arrays are kept.

    With a detector (processes engine) each sub-env keeps its own float32 array as the last
    action.
    """
    from ns_pz.monitor import PredictionErrorMonitor

    vec = make_vec(
        "ns_pz/Pendulum-v0", 2, monitor=PredictionErrorMonitor(), notification="detailed"
    )
    vec.reset(seed=0)
    actions = np.array([[0.5], [-0.25]], np.float32)
    vec.step(actions)
    actions[:] = 9.0  # the caller's buffer, reused: nothing of ours may change
    last = [process.last_action for process in vec._processes]
    assert [a.tolist() for a in last] == [[0.5], [-0.25]] and last[0].dtype == np.float32
    for bad in (
        np.array([[np.nan], [0.0]], np.float32),
        np.array([[0.5]], np.float32),
        np.array([0.5, 0.5], np.float32),
        np.array([["a"], ["b"]]),
    ):
        with pytest.raises(ValueError, match=r"shape \(2, 1\)"):
            vec.step(bad)
    plain = make_vec("ns_pz/MountainCarContinuous-v0", 2)
    plain.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(2, 1\)"):
        plain.step(np.zeros((2, 3), np.float32))


def test_the_array_engine_checks_reset_options_as_the_view_does() -> None:
    """Unknown keys warn (they were ignored silently), a list is refused."""
    vec = make_vec("ns_pz/CartPole-v0", 2)
    vec.reset(seed=0)
    with pytest.warns(UserWarning, match="'speed'") as caught:
        vec.reset(options={"speed": 2})
    assert len(caught) == 1
    processes = make_vec("ns_pz/CartPole-v0", 3, nature=RandomNature(0.05))
    assert processes.engine == "processes"
    with pytest.warns(UserWarning, match="'speed'") as caught:  # once, not once per sub-env
        processes.reset(seed=0, options={"speed": 2})
    assert len(caught) == 1
    with pytest.raises(TypeError, match="options=\\[1\\]"):
        vec.reset(options=[1])


@pytest.mark.parametrize(("env_id", "nature", "engine"), CASES[:3])
def test_a_refused_reset_changes_nothing(env_id: str, nature: Any, engine: str) -> None:
    """Bad options are refused before any generator is reseeded or state drawn (they were not)."""
    vec, twin = (make_vec(env_id, 3, nature=nature, notification="detailed") for _ in "ab")
    assert vec.engine == engine
    actions = np.zeros(3, np.int64)
    for env in (vec, twin):
        env.reset(seed=1)
        for _ in range(2):
            env.step(actions)
    first = vec.family.params_cls.names()[0]
    with pytest.raises(ParamOutOfRange):
        vec.reset(seed=5, options={"params": {first: -1.0}})
    for _ in range(30):
        _same_batches(vec.step(actions)[0], twin.step(actions)[0])


@pytest.mark.parametrize(("env_id", "nature", "engine"), CASES[:4])
def test_reset_mask_resets_the_selected_sub_envs_as_sync_vector_env_does(
    env_id: str, nature: Any, engine: str
) -> None:
    """Gymnasium's ``options={"reset_mask": mask}`` (it was ignored with a warning)."""
    n = 3
    vec = make_vec(env_id, n, nature=nature, notification="detailed", max_episode_steps=25)
    assert vec.engine == engine
    sync = gym.vector.SyncVectorEnv(
        [
            lambda: make_gym(env_id, nature=nature, notification="detailed", max_episode_steps=25)
            for _ in range(n)
        ]
    )
    rng = np.random.default_rng(3)
    _same_batches(vec.reset(seed=7)[0], sync.reset(seed=7)[0])
    for step in range(60):
        if step % 9 == 4:
            mask = rng.random(n) < 0.5
            mask[step % n] = True
            seed = [int(s) for s in rng.integers(0, 99, n)] if step % 2 else None
            options = {"reset_mask": mask, "params": {}}
            obs, _ = vec.reset(seed=seed, options=options)
            assert options["reset_mask"] is mask  # the caller's dict is left as it was
            expected, _ = sync.reset(seed=seed, options=dict(options))
        else:
            actions = _actions(vec.single_action_space, rng, n)
            obs, *rest = vec.step(actions)
            expected, *sync_rest = sync.step(actions)
            for mine, theirs in zip(rest[:3], sync_rest[:3], strict=True):
                assert np.array_equal(mine, theirs)
        _same_batches(obs, expected)


def _same_batches(batch: dict[str, np.ndarray], expected: dict[str, np.ndarray]) -> None:
    assert batch.keys() == expected.keys()
    for key, values in batch.items():
        assert np.array_equal(values, expected[key]), key


def test_bad_seeds_and_reset_masks_are_refused_by_name() -> None:
    """A float, bool or str seed (it failed with "not iterable") and bad masks, named."""
    vec = make_vec("ns_pz/CartPole-v0", 2)
    with pytest.raises(ValueError, match="every sub-env at the first reset"):
        vec.reset(options={"reset_mask": np.array([True, False])})
    for seed in (3.0, True, "ab"):
        with pytest.raises(TypeError, match=f"seed={seed!r} must be None"):
            vec.reset(seed=seed)  # type: ignore[arg-type]
    vec.reset(seed=0)
    for mask, error, match in [
        ([True, False], TypeError, "numpy array of dtype bool"),
        (np.array([1, 0]), TypeError, "numpy array of dtype bool"),
        (np.array([True]), ValueError, "shape \\(1,\\); num_envs=2 needs \\(2,\\)"),
        (np.array([False, False]), ValueError, "selects no sub-env"),
    ]:
        with pytest.raises(error, match=match):
            vec.reset(options={"reset_mask": mask})


def test_the_vector_envs_own_generator_follows_the_seed() -> None:
    """``reset(seed=s)`` seeds ``np_random`` too (it drew from fresh entropy)."""
    draws = []
    for _ in range(2):
        vec = make_vec("ns_pz/CartPole-v0", 2)
        vec.reset(seed=4)
        assert vec.np_random_seed == 4
        draws.append(vec.np_random.random())
    assert draws[0] == draws[1]


@pytest.mark.parametrize("nature", [None, RandomNature(0.05)], ids=["arrays", "processes"])
def test_a_vector_env_larger_than_memory_is_refused_at_once(
    nature: Any, monkeypatch: pytest.MonkeyPatch
) -> None:
    """make_vec(id, 10**7) on the per-env engine built 10**7 processes for hours first."""
    import time

    import ns_pz.vector as vector

    monkeypatch.setattr(vector, "physical_memory", lambda: 2**33)  # 8 GiB, whatever the machine
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"num_envs=10000000 on the \w+ engine needs about"):
        make_vec("ns_pz/CartPole-v0", 10**7, nature=nature)
    assert time.perf_counter() - start < 30.0


def test_a_large_vector_env_warns_with_its_size_and_builds_no_process_per_sub_env(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The arrays engine built (then dropped) one process per sub-env; a large one now warns."""
    import ns_pz.vector as vector

    monkeypatch.setattr(vector, "LARGE", 1000 * vector.BYTES_PER_ENV["arrays"])
    built = []
    original = vector.NSProcess.__init__

    def counting(self: Any, *args: Any, **kwargs: Any) -> None:
        built.append(1)
        original(self, *args, **kwargs)

    monkeypatch.setattr(vector.NSProcess, "__init__", counting)
    with pytest.warns(UserWarning, match=r"num_envs=2000 on the arrays engine needs about") as seen:
        env = make_vec("ns_pz/CartPole-v0", 2000)
    assert seen[0].filename == __file__  # the user's line, not ns_pz's
    assert env.engine == "arrays" and len(built) == 1
    env.reset(seed=0)
    built.clear()
    processes = make_vec("ns_pz/CartPole-v0", 5, nature=RandomNature(0.05))
    assert processes.engine == "processes" and len(built) == 5
