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
    task_family,
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

InvertedPendulumFamily = task_family(
    "InvertedPendulum", _GYM + "inverted_pendulum_v5:InvertedPendulumEnv", _INVERTEDPENDULUM_KNOBS
)
InvertedPendulumParams = InvertedPendulumFamily.params_cls

InvertedDoublePendulumFamily = task_family(
    "InvertedDoublePendulum",
    _GYM + "inverted_double_pendulum_v5:InvertedDoublePendulumEnv",
    _INVERTEDDOUBLEPENDULUM_KNOBS,
)
InvertedDoublePendulumParams = InvertedDoublePendulumFamily.params_cls

ReacherFamily = task_family("Reacher", _GYM + "reacher_v5:ReacherEnv", _REACHER_KNOBS)
ReacherParams = ReacherFamily.params_cls

SwimmerFamily = task_family("Swimmer", _GYM + "swimmer_v5:SwimmerEnv", _SWIMMER_KNOBS)
SwimmerParams = SwimmerFamily.params_cls

PusherFamily = task_family("Pusher", _GYM + "pusher_v5:PusherEnv", _PUSHER_KNOBS)
PusherParams = PusherFamily.params_cls

HopperFamily = task_family("Hopper", _GYM + "hopper_v5:HopperEnv", _HOPPER_KNOBS)
HopperParams = HopperFamily.params_cls

Walker2dFamily = task_family("Walker2d", _GYM + "walker2d_v5:Walker2dEnv", _WALKER2D_KNOBS)
Walker2dParams = Walker2dFamily.params_cls

HalfCheetahFamily = task_family(
    "HalfCheetah", _GYM + "half_cheetah_v5:HalfCheetahEnv", _HALFCHEETAH_KNOBS
)
HalfCheetahParams = HalfCheetahFamily.params_cls

AntFamily = task_family("Ant", _GYM + "ant_v5:AntEnv", _ANT_KNOBS, carried=("xpos",))
AntParams = AntFamily.params_cls

HumanoidFamily = task_family(
    "Humanoid", _GYM + "humanoid_v5:HumanoidEnv", _HUMANOID_KNOBS, carried=("xipos",)
)
HumanoidParams = HumanoidFamily.params_cls

HumanoidStandupFamily = task_family(
    "HumanoidStandup", _GYM + "humanoidstandup_v5:HumanoidStandupEnv", _HUMANOID_KNOBS
)
HumanoidStandupParams = HumanoidStandupFamily.params_cls
