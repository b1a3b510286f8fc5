"""MuJoCo families: Gymnasium v5 bit for bit at default θ, θ changes exact, planning by state."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
gym = pytest.importorskip("gymnasium")

from ns_pz.envs import mujoco_tasks  # noqa: E402
from ns_pz.envs.mujoco_family import DAMPING, FRICTION, GRAVITY, MASS, MujocoFamily  # noqa: E402

import ns_pz  # noqa: E402

TASKS = mujoco_tasks.TASKS
INTEGRATION = mujoco.mjtState.mjSTATE_INTEGRATION


def family_of(name: str) -> MujocoFamily:
    """A new family of task ``name``."""
    return getattr(mujoco_tasks, f"{name}Family")()


def gymnasium_env(name: str):
    """Gymnasium's own v5 env, unwrapped."""
    return gym.make(f"{name}-v5").unwrapped


def actions(family: MujocoFamily, count: int, seed: int = 7) -> list[np.ndarray]:
    """``count`` random float32 actions, somewhat beyond the bounds (Gymnasium passes them on)."""
    rng = np.random.default_rng(seed)
    space = family.action_space
    return [(rng.uniform(space.low, space.high) * 1.2).astype(np.float32) for _ in range(count)]


def write_theta(model, family: MujocoFamily, theta) -> None:
    """Write θ into a freshly built model by hand, as NS-Gym would, and fix its constants."""
    for knob in family.knobs:
        value = getattr(theta, knob.name)
        if knob.kind == GRAVITY:
            model.opt.gravity[2] = value
        elif knob.kind == MASS:
            model.body_mass[model.body(knob.element).id] = value
        elif knob.kind == DAMPING:
            model.dof_damping[model.jnt_dofadr[model.joint(knob.element).id]] = value
        elif knob.kind == FRICTION:
            model.geom_friction[model.geom(knob.element).id, 0] = value
    mujoco.mj_setConst(model, mujoco.MjData(model))


def changed_theta(family: MujocoFamily):
    """Every knob moved inside its bounds: masses x1.3, damping +0.4, friction x1.5, gravity -1."""
    theta = family.default_params()
    changes = {}
    for knob in family.knobs:
        value = getattr(theta, knob.name)
        changes[knob.name] = {
            GRAVITY: value - 1.0,
            MASS: value * 1.3,
            DAMPING: value + 0.4,
            FRICTION: value * 1.5,
        }[knob.kind]
    return theta.replace(**changes)


@pytest.mark.parametrize("name", TASKS)
def test_defaults_are_the_compiled_models_values(name):
    """Default θ is exactly what Gymnasium's model holds, so default θ changes nothing."""
    family = family_of(name)
    model = gymnasium_env(name).model
    for knob in family.knobs:
        array, index = knob.slot(model)
        assert array[index] == getattr(family.default_params(), knob.name), knob.name


@pytest.mark.parametrize("name", TASKS)
def test_default_theta_matches_gymnasium_bit_for_bit(name):
    """Reset and 200 steps (stepping on past termination) equal Gymnasium's v5 env's.

    Between two steps the family's simulator steps another state, as a planner would, so
    anything a step reads that the state does not restore shows up.
    """
    family, env = family_of(name), gymnasium_env(name)
    theta = family.default_params()
    for seed in (0, 3):
        observation, _ = env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        state = family.initial_state_under(theta, rng)
        other = family.initial_state_under(theta, np.random.default_rng(seed + 1))
        np.testing.assert_array_equal(family.observe(state), observation)
        for action in actions(family, 200, seed):
            other = family.step(other, -action, theta, rng)[0]
            observation, reward, terminated, _, _ = env.step(action)
            state, our_reward, our_terminated = family.step(state, action, theta, rng)
            np.testing.assert_array_equal(family.observe(state), observation)
            assert (our_reward, our_terminated) == (reward, terminated)


@pytest.mark.parametrize("name", TASKS)
def test_theta_changed_mid_episode_equals_a_model_built_with_it(name):
    """θ changed at step 10 gives, for 1,000 steps, exactly the trajectory of a fresh model.

    The fresh model is Gymnasium's env with θ written before it ever stepped; it continues
    from the family's integration state at the change. A change of every knob also moves the
    trajectory (so the comparison can fail).
    """
    family = family_of(name)
    theta0, theta1 = family.default_params(), changed_theta(family)
    plan = actions(family, 1010)
    rng = np.random.default_rng(0)
    state = family.initial_state_under(theta0, rng)
    for action in plan[:10]:
        state, _, _ = family.step(state, action, theta0, rng)
    fresh = gymnasium_env(name)
    write_theta(fresh.model, family, theta1)
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


@pytest.mark.parametrize("name", ["InvertedPendulum", "HalfCheetah", "Hopper", "Ant", "Humanoid"])
def test_every_knob_moves_the_trajectory(name):
    """Each θ field alone, raised, changes the states within 100 steps (it reaches the model).

    Known exception: InvertedPendulum's rail geom takes part in no contact, so its
    ``rail_friction`` (NS-Gym's name, kept for compat) has no effect.
    """
    family = family_of(name)
    theta0 = family.default_params()
    plan = actions(family, 100)
    inert = {"rail_friction"}

    def run(theta):
        rng = np.random.default_rng(1)
        state = family.initial_state_under(theta0, rng)
        states = []
        for action in plan:
            state, _, _ = family.step(state, action, theta, rng)
            states.append(state)
        return states

    base = run(theta0)
    for knob in family.knobs:
        value = getattr(theta0, knob.name)
        raised = value - 2.0 if knob.kind == GRAVITY else max(value * 3, 0.5)
        moved = run(theta0.replace(**{knob.name: raised})) != base
        assert moved != (knob.name in inert), knob.name


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
