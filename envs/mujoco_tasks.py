"""The eleven Gymnasium v5 MuJoCo tasks as ns_pz families, θ named as in NS-Gym.

Each family is one table of knobs (θ field, kind, model element, Gymnasium's value) over
:class:`~ns_pz.envs.mujoco_family.MujocoFamily`. Names follow NS-Gym's MuJoCo wrapper where it
has the task (its ``ffeet_*`` are the ``ffoot`` body and joint, its InvertedDoublePendulum
``floor_friction`` is the rail's, ``pole1_*`` / ``hinge1_*`` the first pole's); Walker2d, which
NS-Gym lacks, and Swimmer's extra knobs are named after their bodies and joints the same way.
Defaults are the compiled models' exact values (``tests/test_mujoco.py`` checks them), so
default θ leaves each model as Gymnasium builds it.
"""

from __future__ import annotations

from ns_pz.envs.mujoco_family import (
    DAMPING,
    FRICTION,
    GRAVITY,
    MASS,
    Knob,
    MujocoFamily,
    params_class,
)
from ns_pz.envs.registry import MUJOCO_TASKS

_GYM = "gymnasium.envs.mujoco."

TASKS = tuple(name for name, _, _ in MUJOCO_TASKS)
"""The task names; the family of ``name`` is ``{name}Family``, its θ ``{name}Params``."""

_INVERTEDPENDULUM_KNOBS = (
    Knob("gravity", GRAVITY, "", -9.81),
    Knob("pole_mass", MASS, "pole", 5.018591641363306),
    Knob("cart_mass", MASS, "cart", 10.47197551196598),
    Knob("rail_friction", FRICTION, "rail", 1.0),
)

_INVERTEDDOUBLEPENDULUM_KNOBS = (
    Knob("gravity", GRAVITY, "", -9.81),
    Knob("cart_mass", MASS, "cart", 10.47197551196598),
    Knob("pole1_mass", MASS, "pole", 4.1987385815227585),
    Knob("pole2_mass", MASS, "pole2", 4.1987385815227585),
    Knob("floor_friction", FRICTION, "rail", 1.0),
    Knob("slider_damping", DAMPING, "slider", 0.05),
    Knob("hinge1_damping", DAMPING, "hinge", 0.05),
    Knob("hinge2_damping", DAMPING, "hinge2", 0.05),
)

_REACHER_KNOBS = (
    Knob("body0_mass", MASS, "body0", 0.03560471674068432),
    Knob("body1_mass", MASS, "body1", 0.03560471674068432),
    Knob("joint0_damping", DAMPING, "joint0", 1.0),
    Knob("joint1_damping", DAMPING, "joint1", 1.0),
)

_SWIMMER_KNOBS = (
    Knob("torso_mass", MASS, "torso", 35.604716740684324),
    Knob("body_mid_mass", MASS, "mid", 35.604716740684324),
    Knob("body_back_mass", MASS, "back", 35.604716740684324),
    Knob("motor1_rot_damping", DAMPING, "motor1_rot", 0.0),
    Knob("motor2_rot_damping", DAMPING, "motor2_rot", 0.0),
)

_PUSHER_KNOBS = (
    Knob("gravity", GRAVITY, "", 0.0),
    Knob("r_shoulder_pan_link_mass", MASS, "r_shoulder_pan_link", 7.293521504574065),
    Knob("r_shoulder_lift_link_mass", MASS, "r_shoulder_lift_link", 3.141592653589794),
    Knob("r_upper_arm_link_mass", MASS, "r_upper_arm_link", 1.6286016316209488),
    Knob("r_forearm_link_mass", MASS, "r_forearm_link", 0.8427322293254622),
    Knob("r_shoulder_pan_joint_damping", DAMPING, "r_shoulder_pan_joint", 1.0),
    Knob("r_shoulder_lift_joint_damping", DAMPING, "r_shoulder_lift_joint", 1.0),
    Knob("r_elbow_flex_joint_damping", DAMPING, "r_elbow_flex_joint", 0.1),
)

_HOPPER_KNOBS = (
    Knob("gravity", GRAVITY, "", -9.81),
    Knob("torso_mass", MASS, "torso", 3.6651914291880923),
    Knob("thigh_mass", MASS, "thigh", 4.057890510886818),
    Knob("leg_mass", MASS, "leg", 2.7813566959781637),
    Knob("foot_mass", MASS, "foot", 5.315574769873931),
    Knob("floor_friction", FRICTION, "floor", 1.0),
    Knob("thigh_joint_damping", DAMPING, "thigh_joint", 1.0),
    Knob("leg_joint_damping", DAMPING, "leg_joint", 1.0),
    Knob("foot_joint_damping", DAMPING, "foot_joint", 1.0),
)

_WALKER2D_KNOBS = (
    Knob("gravity", GRAVITY, "", -9.81),
    Knob("torso_mass", MASS, "torso", 3.6651914291880923),
    Knob("thigh_mass", MASS, "thigh", 4.057890510886818),
    Knob("leg_mass", MASS, "leg", 2.7813566959781637),
    Knob("foot_mass", MASS, "foot", 3.1667253948185117),
    Knob("thigh_left_mass", MASS, "thigh_left", 4.057890510886818),
    Knob("leg_left_mass", MASS, "leg_left", 2.7813566959781637),
    Knob("foot_left_mass", MASS, "foot_left", 3.1667253948185117),
    Knob("floor_friction", FRICTION, "floor", 0.7),
    Knob("thigh_joint_damping", DAMPING, "thigh_joint", 0.1),
    Knob("leg_joint_damping", DAMPING, "leg_joint", 0.1),
    Knob("foot_joint_damping", DAMPING, "foot_joint", 0.1),
    Knob("thigh_left_joint_damping", DAMPING, "thigh_left_joint", 0.1),
    Knob("leg_left_joint_damping", DAMPING, "leg_left_joint", 0.1),
    Knob("foot_left_joint_damping", DAMPING, "foot_left_joint", 0.1),
)

_HALFCHEETAH_KNOBS = (
    Knob("gravity", GRAVITY, "", -9.81),
    Knob("torso_mass", MASS, "torso", 6.25020920502092),
    Knob("bthigh_mass", MASS, "bthigh", 1.5435146443514645),
    Knob("bshin_mass", MASS, "bshin", 1.5874476987447697),
    Knob("bfoot_mass", MASS, "bfoot", 1.0953974895397491),
    Knob("fthigh_mass", MASS, "fthigh", 1.4380753138075317),
    Knob("fshin_mass", MASS, "fshin", 1.200836820083682),
    Knob("ffeet_mass", MASS, "ffoot", 0.8845188284518829),
    Knob("floor_friction", FRICTION, "floor", 0.4),
    Knob("bthigh_damping", DAMPING, "bthigh", 6.0),
    Knob("bshin_damping", DAMPING, "bshin", 4.5),
    Knob("bfoot_damping", DAMPING, "bfoot", 3.0),
    Knob("fthigh_damping", DAMPING, "fthigh", 4.5),
    Knob("fshin_damping", DAMPING, "fshin", 3.0),
    Knob("ffeet_damping", DAMPING, "ffoot", 1.5),
)

_ANT_KNOBS = (
    Knob("gravity", GRAVITY, "", -9.81),
    Knob("torso_mass", MASS, "torso", 0.32724923474893675),
    Knob("floor_friction", FRICTION, "floor", 1.0),
)

_HUMANOID_KNOBS = (
    Knob("gravity", GRAVITY, "", -9.81),
    Knob("torso_mass", MASS, "torso", 8.907462370478262),
    Knob("lwaist_mass", MASS, "lwaist", 2.261946710584651),
    Knob("pelvis_mass", MASS, "pelvis", 6.616194128460103),
    Knob("right_thigh_mass", MASS, "right_thigh", 4.751750928806242),
    Knob("left_thigh_mass", MASS, "left_thigh", 4.751750928806242),
    Knob("right_shin_mass", MASS, "right_shin", 2.7556961671836424),
    Knob("left_shin_mass", MASS, "left_shin", 2.7556961671836424),
    Knob("right_foot_mass", MASS, "right_foot", 1.7671458676442586),
    Knob("left_foot_mass", MASS, "left_foot", 1.7671458676442586),
    Knob("right_upper_arm_mass", MASS, "right_upper_arm", 1.6610804848382084),
    Knob("left_upper_arm_mass", MASS, "left_upper_arm", 1.6610804848382084),
    Knob("right_lower_arm_mass", MASS, "right_lower_arm", 1.2295401928310803),
    Knob("left_lower_arm_mass", MASS, "left_lower_arm", 1.2295401928310803),
    Knob("floor_friction", FRICTION, "floor", 1.0),
    Knob("right_knee_damping", DAMPING, "right_knee", 1.0),
    Knob("left_knee_damping", DAMPING, "left_knee", 1.0),
    Knob("right_elbow_damping", DAMPING, "right_elbow", 1.0),
    Knob("left_elbow_damping", DAMPING, "left_elbow", 1.0),
)

InvertedPendulumParams = params_class(
    "InvertedPendulumParams",
    _INVERTEDPENDULUM_KNOBS,
    "θ of InvertedPendulum-v5: {}.".format(", ".join(k.name for k in _INVERTEDPENDULUM_KNOBS)),
)


class InvertedPendulumFamily(MujocoFamily):
    """Gymnasium's InvertedPendulum-v5 with :class:`InvertedPendulumParams` as θ."""

    gymnasium_env = _GYM + "inverted_pendulum_v5:InvertedPendulumEnv"
    knobs = _INVERTEDPENDULUM_KNOBS
    params_cls = InvertedPendulumParams


InvertedDoublePendulumParams = params_class(
    "InvertedDoublePendulumParams",
    _INVERTEDDOUBLEPENDULUM_KNOBS,
    "θ of InvertedDoublePendulum-v5: {}.".format(
        ", ".join(k.name for k in _INVERTEDDOUBLEPENDULUM_KNOBS)
    ),
)


class InvertedDoublePendulumFamily(MujocoFamily):
    """Gymnasium's InvertedDoublePendulum-v5 with :class:`InvertedDoublePendulumParams` as θ."""

    gymnasium_env = _GYM + "inverted_double_pendulum_v5:InvertedDoublePendulumEnv"
    knobs = _INVERTEDDOUBLEPENDULUM_KNOBS
    params_cls = InvertedDoublePendulumParams


ReacherParams = params_class(
    "ReacherParams",
    _REACHER_KNOBS,
    "θ of Reacher-v5: {}.".format(", ".join(k.name for k in _REACHER_KNOBS)),
)


class ReacherFamily(MujocoFamily):
    """Gymnasium's Reacher-v5 with :class:`ReacherParams` as θ."""

    gymnasium_env = _GYM + "reacher_v5:ReacherEnv"
    knobs = _REACHER_KNOBS
    params_cls = ReacherParams


SwimmerParams = params_class(
    "SwimmerParams",
    _SWIMMER_KNOBS,
    "θ of Swimmer-v5: {}.".format(", ".join(k.name for k in _SWIMMER_KNOBS)),
)


class SwimmerFamily(MujocoFamily):
    """Gymnasium's Swimmer-v5 with :class:`SwimmerParams` as θ."""

    gymnasium_env = _GYM + "swimmer_v5:SwimmerEnv"
    knobs = _SWIMMER_KNOBS
    params_cls = SwimmerParams


PusherParams = params_class(
    "PusherParams",
    _PUSHER_KNOBS,
    "θ of Pusher-v5: {}.".format(", ".join(k.name for k in _PUSHER_KNOBS)),
)


class PusherFamily(MujocoFamily):
    """Gymnasium's Pusher-v5 with :class:`PusherParams` as θ."""

    gymnasium_env = _GYM + "pusher_v5:PusherEnv"
    knobs = _PUSHER_KNOBS
    params_cls = PusherParams


HopperParams = params_class(
    "HopperParams",
    _HOPPER_KNOBS,
    "θ of Hopper-v5: {}.".format(", ".join(k.name for k in _HOPPER_KNOBS)),
)


class HopperFamily(MujocoFamily):
    """Gymnasium's Hopper-v5 with :class:`HopperParams` as θ."""

    gymnasium_env = _GYM + "hopper_v5:HopperEnv"
    knobs = _HOPPER_KNOBS
    params_cls = HopperParams


Walker2dParams = params_class(
    "Walker2dParams",
    _WALKER2D_KNOBS,
    "θ of Walker2d-v5: {}.".format(", ".join(k.name for k in _WALKER2D_KNOBS)),
)


class Walker2dFamily(MujocoFamily):
    """Gymnasium's Walker2d-v5 with :class:`Walker2dParams` as θ."""

    gymnasium_env = _GYM + "walker2d_v5:Walker2dEnv"
    knobs = _WALKER2D_KNOBS
    params_cls = Walker2dParams


HalfCheetahParams = params_class(
    "HalfCheetahParams",
    _HALFCHEETAH_KNOBS,
    "θ of HalfCheetah-v5: {}.".format(", ".join(k.name for k in _HALFCHEETAH_KNOBS)),
)


class HalfCheetahFamily(MujocoFamily):
    """Gymnasium's HalfCheetah-v5 with :class:`HalfCheetahParams` as θ."""

    gymnasium_env = _GYM + "half_cheetah_v5:HalfCheetahEnv"
    knobs = _HALFCHEETAH_KNOBS
    params_cls = HalfCheetahParams


AntParams = params_class(
    "AntParams", _ANT_KNOBS, "θ of Ant-v5: {}.".format(", ".join(k.name for k in _ANT_KNOBS))
)


class AntFamily(MujocoFamily):
    """Gymnasium's Ant-v5 with :class:`AntParams` as θ."""

    gymnasium_env = _GYM + "ant_v5:AntEnv"
    knobs = _ANT_KNOBS
    params_cls = AntParams
    carried = ("xpos",)


HumanoidParams = params_class(
    "HumanoidParams",
    _HUMANOID_KNOBS,
    "θ of Humanoid-v5: {}.".format(", ".join(k.name for k in _HUMANOID_KNOBS)),
)


class HumanoidFamily(MujocoFamily):
    """Gymnasium's Humanoid-v5 with :class:`HumanoidParams` as θ."""

    gymnasium_env = _GYM + "humanoid_v5:HumanoidEnv"
    knobs = _HUMANOID_KNOBS
    params_cls = HumanoidParams
    carried = ("xipos",)


HumanoidStandupParams = params_class(
    "HumanoidStandupParams",
    _HUMANOID_KNOBS,
    "θ of HumanoidStandup-v5: {}.".format(", ".join(k.name for k in _HUMANOID_KNOBS)),
)


class HumanoidStandupFamily(MujocoFamily):
    """Gymnasium's HumanoidStandup-v5 with :class:`HumanoidStandupParams` as θ."""

    gymnasium_env = _GYM + "humanoidstandup_v5:HumanoidStandupEnv"
    knobs = _HUMANOID_KNOBS
    params_cls = HumanoidStandupParams
