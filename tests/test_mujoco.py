"""MuJoCo families: Gymnasium v5 bit for bit at default θ, θ changes exact, planning by state."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
gym = pytest.importorskip("gymnasium")

from ns_pz.envs import mujoco_tasks  # noqa: E402
from ns_pz.envs.mujoco_family import MujocoFamily  # noqa: E402
from ns_pz.envs.mujoco_knobs import (  # noqa: E402
    DAMPING,
    FRICTION,
    FRICTIONLOSS,
    GEAR,
    GRAVITY,
    MASS,
    TILT,
)

import ns_pz  # noqa: E402

TASKS = mujoco_tasks.TASKS
INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION


def family_of(name: str, scale_inertia: bool = True) -> MujocoFamily:
    """A new family of task ``name``."""
    return getattr(mujoco_tasks, f"{name}Family")(scale_inertia)


def gymnasium_env(name: str):
    """Gymnasium's own v5 env, unwrapped."""
    return gym.make(f"{name}-v5").unwrapped


def actions(family: MujocoFamily, count: int, seed: int = 7) -> list[np.ndarray]:
    """``count`` random float32 actions, somewhat beyond the bounds (Gymnasium passes them on)."""
    rng = np.random.default_rng(seed)
    space = family.action_space
    return [(rng.uniform(space.low, space.high) * 1.2).astype(np.float32) for _ in range(count)]


def write_theta(model, family: MujocoFamily, theta, scale_inertia: bool = True) -> None:
    """Write θ into a freshly built (compiled) model by hand, and fix its constants.

    Written from the knobs' definitions, independently of the family's writer.
    """
    friction0 = model.geom_friction[:, 0].copy()
    gear0 = model.actuator_gear[:, 0].copy()
    x0 = model.opt.gravity[0]
    size = getattr(theta, "gravity", model.opt.gravity[2])
    angle = getattr(theta, "gravity_tilt", 0.0)
    model.opt.gravity[0] = x0 * np.cos(angle) - size * np.sin(angle)
    model.opt.gravity[2] = x0 * np.sin(angle) + size * np.cos(angle)
    for knob in family.knobs:
        value = getattr(theta, knob.name)
        if knob.kind == MASS:
            body = model.body(knob.element).id
            if scale_inertia:
                model.body_inertia[body] *= value / model.body_mass[body]
            model.body_mass[body] = value
        elif knob.kind == DAMPING:
            model.dof_damping[model.jnt_dofadr[model.joint(knob.element).id]] = value
        elif knob.kind == FRICTIONLOSS:
            model.dof_frictionloss[model.jnt_dofadr[model.joint(knob.element).id]] = value
        elif knob.kind == FRICTION:
            model.geom_friction[:, 0] = friction0 * (value / knob.default)
        elif knob.kind == GEAR:
            model.actuator_gear[:, 0] = gear0 * value
    mujoco.mj_setConst(model, mujoco.MjData(model))


def changed_theta(family: MujocoFamily):
    """Every knob moved inside its bounds (masses x1.3, damping +0.4, friction x1.5, ...)."""
    theta = family.default_params()
    changes = {}
    for knob in family.knobs:
        value = getattr(theta, knob.name)
        changes[knob.name] = {
            GRAVITY: value - 1.0,
            TILT: 0.1,
            MASS: value * 1.3,
            DAMPING: value + 0.4,
            FRICTION: value * 1.5,
            FRICTIONLOSS: 5.0,
            GEAR: 1.3,
        }[knob.kind]
    return theta.replace(**changes)


@pytest.mark.parametrize("name", TASKS)
def test_defaults_are_the_compiled_models_values(name):
    """Default θ is exactly what Gymnasium's model holds, so default θ changes nothing."""
    family = family_of(name)
    assert family.params_of_model(gymnasium_env(name).model) == family.default_params()


def as_gymnasium_info(info: dict) -> dict:
    """Gymnasium's info as the family keeps it: numbers as float, arrays as float64."""
    return {
        key: np.asarray(value, np.float64) if np.ndim(value) else float(value)
        for key, value in info.items()
    }


def assert_same_info(ours: dict, gymnasium: dict) -> None:
    """Our info is Gymnasium's (as floats), plus ``"unstable": False``."""
    assert ours.pop("unstable") is False
    expected = as_gymnasium_info(gymnasium)
    assert list(ours) == list(expected)
    for key, value in expected.items():
        np.testing.assert_array_equal(ours[key], value, err_msg=key)
        assert type(ours[key]) is type(value), key


@pytest.mark.parametrize("name", TASKS)
def test_default_theta_matches_gymnasium_bit_for_bit(name):
    """Reset and 200 steps (stepping on past termination) equal Gymnasium's v5 env's, info too.

    Between two steps the family's simulator steps another state, as a planner would, so
    anything a step reads that the state does not restore shows up.
    """
    family, env = family_of(name), gymnasium_env(name)
    theta = family.default_params()
    for seed in (0, 3):
        observation, info = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        state = family.initial_state_under(theta, rng)
        other = family.initial_state_under(theta, np.random.default_rng(seed + 1))
        np.testing.assert_array_equal(family.observe(state), observation)
        assert_same_info(family.info(state), info)
        for action in actions(family, 200, seed):
            other = family.step(other, -action, theta, rng)[0]
            observation, reward, terminated, _, info = env.step(action)
            state, our_reward, our_terminated = family.step(state, action, theta, rng)
            np.testing.assert_array_equal(family.observe(state), observation)
            assert (our_reward, our_terminated) == (reward, terminated)
            assert_same_info(family.info(state), info)


@pytest.mark.parametrize(
    ("name", "scale_inertia"),
    [(name, True) for name in TASKS] + [("Hopper", False), ("HalfCheetah", False)],
)
def test_theta_changed_mid_episode_equals_a_model_built_with_it(name, scale_inertia):
    """θ changed at step 10 gives, for 1,000 steps, exactly the trajectory of a fresh model.

    The fresh model is Gymnasium's env with θ written before it ever stepped (by hand, from
    the knobs' definitions); it continues from the family's integration state at the change. A
    change of every knob also moves the trajectory (so the comparison can fail).
    """
    family = family_of(name, scale_inertia)
    theta0, theta1 = family.default_params(), changed_theta(family)
    plan = actions(family, 1010)
    rng = np.random.default_rng(0)
    state = family.initial_state_under(theta0, rng)
    for action in plan[:10]:
        state, _, _ = family.step(state, action, theta0, rng)
    fresh = gymnasium_env(name)
    write_theta(fresh.model, family, theta1, scale_inertia)
    fresh.reset(seed=0)
    family.load(state)  # the carried kinematics into the family's data, copied below
    mujoco.mj_setState(
        fresh.model, fresh.data, np.frombuffer(state, count=family.layout.integration), INTEGRATION
    )
    for field, _ in family.layout.carried:
        getattr(fresh.data, field)[...] = getattr(family._data, field)
    unchanged = state
    differs = False
    for action in plan[10:]:
        observation, reward, terminated, _, _ = fresh.step(action)
        state, our_reward, our_terminated = family.step(state, action, theta1, rng)
        np.testing.assert_array_equal(family.observe(state), observation)
        assert (our_reward, our_terminated) == (reward, terminated)
        unchanged, _, _ = family.step(unchanged, action, theta0, rng)
        differs = differs or unchanged != state
    assert differs, "changing every knob did not move the trajectory"


LIVE = 1e-3
"""The least change of some observation entry that counts as a knob acting."""


def observations_under(family: MujocoFamily, theta, steps: int = 100) -> np.ndarray:
    """Observations of ``steps`` seeded random steps under ``theta`` from a seeded start."""
    rng = np.random.default_rng(1)
    state = family.initial_state_under(family.default_params(), rng)
    out = []
    for action in actions(family, steps):
        state, _, _ = family.step(state, action, theta, rng)
        out.append(family.observe(state))
    return np.array(out)


@pytest.mark.parametrize("name", TASKS)
def test_every_knob_acts_at_both_ends_of_its_range(name):
    """Each θ field alone, at its lower and at its upper bound, moves the trajectory.

    Same start, same actions, 100 steps: some observation entry differs from the default θ's
    by more than :data:`LIVE` (bit-level noise does not count). An end that is the default
    (no damping, no dry friction, no tilt is Gymnasium's own) is not a change.
    """
    family = family_of(name)
    theta0 = family.default_params()
    base = observations_under(family, theta0)
    dead = []
    for spec in family.params_cls.specs():
        for end in (spec.low, spec.high):
            if end != spec.default:
                moved = observations_under(family, theta0.replace(**{spec.name: end})) - base
                if np.max(np.abs(moved)) <= LIVE:
                    dead.append(f"{spec.name}={end}")
    assert not dead, f"{name}: these knob values change nothing: {dead}"


def test_returning_to_default_theta_is_gymnasium_again():
    """After a mass change and back, the model's derived constants are the compiled ones."""
    family = family_of("HalfCheetah")
    env = gymnasium_env("HalfCheetah")
    theta0 = family.default_params()
    family.apply(theta0.replace(torso_mass=9.0))
    family.apply(theta0)
    for field in ("body_subtreemass", "dof_invweight0", "body_invweight0", "actuator_acc0"):
        np.testing.assert_array_equal(getattr(family._model, field), getattr(env.model, field))


def test_first_observation_reads_theta0():
    """Humanoid's first observation (cinert) is that of the θ_0 the episode starts under."""
    family = family_of("Humanoid")
    heavy = family.default_params().replace(torso_mass=20.0)
    light = family.initial_state_under(family.default_params(), np.random.default_rng(0))
    assert family.initial_state_under(heavy, np.random.default_rng(0)) != light
    env = ns_pz.make_gym("ns_pz/Humanoid-v0", params=heavy)
    observation, _ = env.reset(seed=0)
    again, _ = env.reset(seed=0)
    np.testing.assert_array_equal(observation["state"], again["state"])


def test_planning_model_restores_states_exactly():
    """Save and restore by value: a replay from a saved state repeats itself bit for bit."""
    env = ns_pz.make_gym("ns_pz/HalfCheetah-v0", notification="detailed")
    env.reset(seed=0)
    model = env.unwrapped.planning_model()
    saved = model.get_state()
    plan = actions(model.family, 20)
    first = [model.step(action) for action in plan]
    model.set_state(saved)
    assert [model.step(action) for action in plan] == first
    assert model.family is not env.unwrapped.family  # a simulator of its own


def test_bad_states_and_actions_are_refused():
    """set_state and step name what is wrong."""
    family = family_of("Hopper")
    model = family.planning_model(family.default_params(), b"", np.random.default_rng(0))
    with pytest.raises(ValueError, match="bytes of"):
        model.set_state(b"\x00" * 8)
    good = family.initial_state(np.random.default_rng(0))
    bad = np.frombuffer(good).copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="NaN or infinity"):
        model.set_state(bad.tobytes())
    model.set_state(good)
    with pytest.raises(ValueError, match="shape"):
        model.step(np.zeros(2, dtype=np.float32))
    with pytest.raises(ValueError, match="not finite"):
        model.step(np.array([np.inf, 0, 0], dtype=np.float32))


def test_out_of_range_theta_is_refused():
    """Bounds: a mass of zero or gravity pointing up is refused, naming the field."""
    theta = mujoco_tasks.HalfCheetahParams()
    with pytest.raises(ns_pz.ParamOutOfRange, match="torso_mass=0.0"):
        theta.replace(torso_mass=0.0)
    with pytest.raises(ns_pz.ParamOutOfRange, match="gravity=5.0"):
        theta.replace(gravity=5.0)


def test_families_copy_and_pickle_with_a_simulator_of_their_own():
    """Copies and pickles build a new simulator; a state stepped on either agrees."""
    family = family_of("Ant")
    state = family.initial_state(np.random.default_rng(0))
    action = actions(family, 1)[0]
    theta = family.default_params()
    for twin in (copy.deepcopy(family), pickle.loads(pickle.dumps(family))):
        assert twin._model is not family._model
        ours = family.step(state, action, theta, None)[0]
        assert twin.step(state, action, theta, None)[0] == ours


def test_gymnasium_make_builds_the_view():
    """gymnasium.make reaches the family through the lazy registry entry."""
    env = gym.make("ns_pz/InvertedPendulum-v0")
    observation, _ = env.reset(seed=0)
    assert observation["state"].shape == (4,)
    assert env.spec.max_episode_steps == 1000


# -- ns_pz.compat's MujocoWrapper ----------------------------------------------------------------
def test_mujoco_wrapper_runs_nsgym_code():
    """NS-Gym's constructor and names: a drifting torso mass, notified with its size."""
    from ns_pz.compat.base import TUNABLE_PARAMS
    from ns_pz.compat.schedulers import ContinuousScheduler
    from ns_pz.compat.update_functions import IncrementUpdate
    from ns_pz.compat.wrappers import MujocoWrapper

    update = IncrementUpdate(ContinuousScheduler(), k=0.5)
    wrapper = MujocoWrapper(
        gym.make("HalfCheetah-v5"),
        {"torso_mass": update},
        change_notification=True,
        delta_change_notification=True,
    )
    wrapper.reset(seed=0)
    observation, _, _, _, info = wrapper.step(np.zeros(6, dtype=np.float32))
    assert observation["env_change"] == {"torso_mass": 1}
    assert observation["delta_change"]["torso_mass"] == pytest.approx(0.5)
    default = mujoco_tasks.HalfCheetahParams().torso_mass
    assert wrapper.get_params()["torso_mass"] == pytest.approx(default + 0.5)
    assert TUNABLE_PARAMS["HalfCheetahEnv"]["torso_mass"] == default
    assert wrapper.get_planning_env().get_params()["torso_mass"] == pytest.approx(default + 0.5)


def test_mujoco_wrapper_reads_theta0_from_the_model_and_steps_as_gymnasium():
    """A mass set on the model before wrapping is θ_0; without changes, Gymnasium's trajectory."""
    from ns_pz.compat.wrappers import MujocoWrapper

    env = gym.make("Hopper-v5")
    model = env.unwrapped.model
    model.body_mass[model.body("torso").id] = 5.0
    mujoco.mj_setConst(model, env.unwrapped.data)
    wrapper = MujocoWrapper(env, {})
    observation, _ = wrapper.reset(seed=1)
    assert wrapper.get_params()["torso_mass"] == 5.0
    reference = gym.make("Hopper-v5").unwrapped
    reference.model.body_mass[reference.model.body("torso").id] = 5.0
    mujoco.mj_setConst(reference.model, reference.data)
    np.testing.assert_array_equal(reference.reset(seed=1)[0], observation["state"])
    for action in actions(family_of("Hopper"), 30):
        expected, reward, terminated, _, _ = reference.step(action)
        observation, our_reward, our_terminated, _, _ = wrapper.step(action)
        np.testing.assert_array_equal(observation["state"], expected)
        assert (our_reward, our_terminated) == (reward, terminated)
        if terminated:
            break


def test_mujoco_wrapper_refuses_what_it_cannot_run():
    """An unknown parameter, a non-MuJoCo env, a changed task setting: ValueError naming it."""
    from ns_pz.compat.schedulers import ContinuousScheduler
    from ns_pz.compat.update_functions import IncrementUpdate
    from ns_pz.compat.wrappers import MujocoWrapper

    update = IncrementUpdate(ContinuousScheduler(), k=0.1)
    with pytest.raises(ValueError, match="'leg_mass', which AntEnv does not have"):
        MujocoWrapper(gym.make("Ant-v5"), {"leg_mass": update})
    with pytest.raises(ValueError, match="got an env of class CartPoleEnv"):
        MujocoWrapper(gym.make("CartPole-v1"), {})
    with pytest.raises(ValueError, match="ctrl_cost_weight"):
        MujocoWrapper(gym.make("HalfCheetah-v5", ctrl_cost_weight=0.5), {})
    # named by the setting itself, not by EzPickle's copy of every argument
    with pytest.raises(ValueError, match="built with frame_skip=10 "):
        MujocoWrapper(gym.make("HalfCheetah-v5", frame_skip=10), {})
    with pytest.raises(ValueError, match="built with reset_noise_scale=0.5 "):
        MujocoWrapper(gym.make("HalfCheetah-v5", reset_noise_scale=0.5), {})
