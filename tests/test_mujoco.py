"""MuJoCo families: Gymnasium v5 bit for bit at default θ, θ changes exact, planning by state."""

from __future__ import annotations

import copy
import pickle
import re

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


# -- knobs: units, inertia, tilt, gear -----------------------------------------------------------
@pytest.mark.parametrize("name", TASKS)
def test_joint_knob_units_follow_the_joint_type(name):
    """Damping is N·s/m on a slide joint and N·m·s/rad on a hinge; dry friction N or N·m."""
    family = family_of(name)
    model = family._model
    for knob in family.knobs:
        if knob.kind not in (DAMPING, FRICTIONLOSS):
            continue
        slide = model.jnt_type[model.joint(knob.element).id] == mujoco.mjtJoint.mjJNT_SLIDE
        expected = {
            (DAMPING, True): "N s/m",
            (DAMPING, False): "N m s/rad",
            (FRICTIONLOSS, True): "N",
            (FRICTIONLOSS, False): "N m",
        }[knob.kind, bool(slide)]
        assert family.params_cls.spec(knob.name).unit == expected, knob.name


def test_a_mass_scales_its_inertia_unless_told_not_to():
    """scale_inertia=True (the default): inertia x factor; False: inertia as compiled."""
    heavy = mujoco_tasks.HalfCheetahParams().replace(torso_mass=6.25020920502092 * 2)
    compiled = gymnasium_env("HalfCheetah").model
    torso = compiled.body("torso").id
    trajectories = []
    for scale_inertia, factor in ((True, 2.0), (False, 1.0)):
        family = family_of("HalfCheetah", scale_inertia)
        family.apply(heavy)
        np.testing.assert_allclose(
            family._model.body_inertia[torso], compiled.body_inertia[torso] * factor, rtol=1e-15
        )
        trajectories.append(observations_under(family, heavy))
    assert np.max(np.abs(trajectories[0] - trajectories[1])) > LIVE
    assert repr(family_of("Hopper", False)) == "HopperFamily(scale_inertia=False)"


def test_the_model_a_view_steps_is_readable_as_gymnasiums_is():
    """``env.unwrapped.family.model``/``.data``: θ's change is there, as in ``env.model``."""
    env = ns_pz.make_gym("ns_pz/Hopper-v0")
    env.reset(seed=0)
    family = env.unwrapped.family
    torso = family.model.body("torso").id
    before = float(family.model.body_mass[torso])
    env.unwrapped.set_params(torso_mass=2 * before)  # as a nature's change would
    env.step(np.zeros(3, np.float32))
    assert float(family.model.body_mass[torso]) == pytest.approx(2 * before)
    assert family.data.qpos.shape == (family.model.nq,)


def test_gravity_tilt_turns_the_compiled_vector_about_y():
    """InvertedDoublePendulum's compiled gravity has x = 1e-5: the tilt turns the whole vector."""
    family = family_of("InvertedDoublePendulum")
    x0, g, angle = 1e-5, -12.0, 0.25
    family.apply(family.default_params().replace(gravity=g, gravity_tilt=angle))
    expected = [x0 * np.cos(angle) - g * np.sin(angle), 0.0, x0 * np.sin(angle) + g * np.cos(angle)]
    np.testing.assert_allclose(family._model.opt.gravity, expected, rtol=1e-15)
    assert family._model.opt.gravity[0] > 0  # a positive tilt pulls toward +x
    family.apply(family.default_params())
    assert family._model.opt.gravity.tolist() == [1e-5, 0.0, -9.81]


def test_actuator_gain_and_friction_scale_every_element():
    """actuator_gain scales every gear; floor_friction scales every geom's sliding friction."""
    family = family_of("Hopper")
    compiled = gymnasium_env("Hopper").model
    family.apply(family.default_params().replace(actuator_gain=1.5, floor_friction=0.5))
    np.testing.assert_array_equal(
        family._model.actuator_gear[:, 0], compiled.actuator_gear[:, 0] * 1.5
    )
    np.testing.assert_array_equal(
        family._model.geom_friction[:, 0], compiled.geom_friction[:, 0] * 0.5
    )
    np.testing.assert_array_equal(family._model.geom_friction[:, 1:], compiled.geom_friction[:, 1:])


def test_compat_reads_what_theta_can_express_and_refuses_the_rest():
    """A model whose floor alone was changed (NS-Gym's way) is not a θ of ours: say so."""
    family = family_of("Hopper")
    model = gymnasium_env("Hopper").model
    model.actuator_gear[:, 0] *= 2
    assert family.params_of_model(model).actuator_gain == 2.0
    model.geom_friction[model.geom("floor").id, 0] = 0.5
    with pytest.raises(ValueError, match="floor_friction: the model's values"):
        family.params_of_model(model)


# -- instability ---------------------------------------------------------------------------------
def fragile_swimmer() -> MujocoFamily:
    """Swimmer with masses allowed down to a tenth, masses without inertia: unstable there."""
    from ns_pz.envs.mujoco_family import task_family
    from ns_pz.envs.mujoco_knobs import mass

    knobs = tuple(
        mass(knob.name, knob.element, knob.default, low=0.1) if knob.kind == MASS else knob
        for knob in mujoco_tasks.SwimmerFamily.knobs
    )
    cls = task_family("FragileSwimmer", mujoco_tasks.SwimmerFamily.gymnasium_env, knobs)
    return cls(scale_inertia=False)


def test_an_unstable_step_is_terminal_reported_and_never_leaks_a_spike():
    """At a tenth of every mass (inertia kept) MuJoCo diverges: every such step is caught.

    Each episode runs until it terminates; a step MuJoCo finds unstable is terminal with
    reward 0, its info says so and keeps Gymnasium's reward aside, its observation is the rest
    pose; no step reports a diverged observation or reward as if it were stable.
    """
    family = fragile_swimmer()
    theta = family.params_cls.from_mapping(
        {k.name: k.low if k.kind == MASS else k.default for k in family.knobs}
    )
    rng = np.random.default_rng(0)
    rest = None
    unstable = 0
    for _ in range(20):
        state = family.initial_state_under(theta, rng)
        for action in actions(family, 300, int(rng.integers(1 << 30))):
            state, reward, terminated = family.step(state, action, theta, rng)
            info = family.info(state)
            observation = family.observe(state)
            if info["unstable"]:
                unstable += 1
                assert terminated and reward == 0.0
                assert info["mujoco_warnings"] and set(info) == {
                    "unstable",
                    "mujoco_warnings",
                    "unstable_reward",
                }
                rest = observation if rest is None else rest
                np.testing.assert_array_equal(observation, rest)  # the rest pose
                family.check_state(state)  # a state like any other
                break
            assert np.all(np.abs(observation) < 1e6) and abs(reward) < 1e3
    assert unstable >= 5


def test_a_diverged_state_is_caught_in_the_step_that_makes_it():
    """A velocity past MuJoCo's limit, set through a planning model: the very next step."""
    env = ns_pz.make_gym("ns_pz/Hopper-v0")
    env.reset(seed=0)
    model = env.unwrapped.planning_model()
    values = np.frombuffer(model.get_state()).copy()
    nq = model.family._model.nq
    values[1 + nq] = 1e11  # qvel[0]: after time and qpos
    model.set_state(values.tobytes())
    _, reward, terminated = model.step(np.zeros(3, np.float32))[:3]
    assert (reward, terminated) == (0.0, True)
    info = model.family.info(model.get_state())
    assert info["unstable"] and info["mujoco_warnings"] == ("mjWARN_BADQVEL",)


def test_the_view_ends_an_unstable_episode_and_says_why():
    """Through the Gymnasium view: terminated, info["unstable"], Gymnasium's terms gone."""
    env = ns_pz.make_gym("ns_pz/Hopper-v0")
    env.reset(seed=0)
    process = env.unwrapped.process
    values = np.frombuffer(process.state).copy()
    values[1 + process.family._model.nq] = 1e11
    process.state = values.tobytes()
    _, reward, terminated, truncated, info = env.step(np.zeros(3, np.float32))
    assert (reward, terminated, truncated) == (0.0, True, False)
    assert info["unstable"] is True and "x_velocity" not in info


def test_states_with_an_unknown_status_are_refused():
    """The status word of a state is checked like the rest."""
    family = family_of("Hopper")
    values = np.frombuffer(family.initial_state(np.random.default_rng(0))).copy()
    values[-2] = 1.5
    with pytest.raises(ValueError, match="status 1.5"):
        family.check_state(values.tobytes())


# -- Gymnasium's info, rendering, the missing extra ----------------------------------------------
def test_the_view_passes_gymnasiums_info_on():
    """Hopper's reward terms reach the view's info and add up to the reward; θ on request."""
    env = gym.make("ns_pz/Hopper-v0", ground_truth_info=True)
    _, info = env.reset(seed=0)
    assert set(info) == {"x_position", "z_distance_from_origin", "unstable", "theta"}
    _, reward, _, _, info = env.step(np.zeros(3, np.float32))
    assert {"x_velocity", "reward_forward", "reward_ctrl", "reward_survive"} <= set(info)
    assert reward == info["reward_forward"] + info["reward_ctrl"] + info["reward_survive"]
    assert info["theta"]["gravity"] == -9.81 and info["unstable"] is False


RENDER_SCRIPT = """
import numpy as np, gymnasium as gym, ns_pz
for env_id in ("ns_pz/InvertedPendulum-v0", "ns_pz/Hopper-v0"):
    env = gym.make(env_id, render_mode="rgb_array")
    env.reset(seed=0)
    first = env.render()
    for _ in range(5):
        env.step(np.zeros(env.action_space.shape, np.float32))
    frame = env.render()
    env.close()
    print(env_id, first.shape, first.dtype, int(np.abs(first.astype(int) - frame).sum() > 0))
env = gym.make("ns_pz/Hopper-v0", render_mode="human")  # pygame's dummy video driver
env.reset(seed=0)
env.step(np.zeros(3, np.float32))
print("human", env.render())
env.close()
"""


def test_rgb_array_frames_on_a_machine_without_a_display(tmp_path):
    """MUJOCO_GL=egl: 480 x 480 frames that change as the task moves, and a "human" window.

    Skipped where no EGL context can be made (Mesa's libEGL missing); "human" uses pygame's
    dummy video driver.
    """
    import os
    import subprocess
    import sys

    env = {**os.environ, "MUJOCO_GL": "egl", "SDL_VIDEODRIVER": "dummy", "SDL_AUDIODRIVER": "dummy"}
    result = subprocess.run(
        [sys.executable, "-c", RENDER_SCRIPT], capture_output=True, text=True, env=env, cwd=tmp_path
    )
    if result.returncode and re.search(r"OpenGL|EGL|glGetError", result.stderr):
        pytest.skip(
            "no EGL: apt-get install libegl1 libgl1-mesa-dri (" + result.stderr[-200:] + ")"
        )
    assert result.returncode == 0, result.stderr
    assert result.stdout.split("\n")[:3] == [
        "ns_pz/InvertedPendulum-v0 (480, 480, 3) uint8 1",
        "ns_pz/Hopper-v0 (480, 480, 3) uint8 1",
        "human None",
    ]


def test_without_mujoco_a_mujoco_id_names_the_extra(monkeypatch):
    """ns_pz and gymnasium.make both say to install ns_pz[mujoco]."""
    from ns_pz.envs import registry

    monkeypatch.delitem(registry._SPECS, "ns_pz/Hopper-v0")
    with pytest.raises(ns_pz.UnknownEnvironment, match=r'pip install "ns_pz\[mujoco\]"'):
        ns_pz.make_gym("ns_pz/Hopper-v0")
    with pytest.raises(ns_pz.UnknownEnvironment, match=r"Hopper-v0 needs MuJoCo"):
        gym.make("ns_pz/Hopper-v0")
