"""The eleven Gymnasium v5 MuJoCo tasks as ns_pz families, θ named as in NS-Gym.

Each family is one table of knobs (θ field, kind, model element, Gymnasium's value, bounds; see
:mod:`ns_pz.envs.mujoco_knobs`) over :class:`~ns_pz.envs.mujoco_family.MujocoFamily`. Names
follow NS-Gym's MuJoCo wrapper where it has the knob (its ``ffeet_*`` are the ``ffoot`` body
and joint, ``pole1_*`` / ``hinge1_*`` the first pole's); Walker2d, which NS-Gym lacks, and
Swimmer's extra knobs are named after their bodies and joints the same way. Not as in NS-Gym:
the pendulums' ``rail_friction`` is the slider joint's dry friction (NS-Gym's, a friction of the
rail geom, acts on nothing: the cart touches no geom), so InvertedDoublePendulum's
``floor_friction`` (the same rail geom in NS-Gym) is gone; ``slider_damping``,
``gravity_tilt`` and ``actuator_gain`` are new. Defaults are the compiled models' exact values
(``tests/test_mujoco.py`` checks them), so default θ leaves each model as Gymnasium builds it.
Bounds are where each knob acts and the physics stays stable
(``benchmarks/mujoco_stability.py``).
"""

from __future__ import annotations

from ns_pz.envs.mujoco_family import task_family
from ns_pz.envs.mujoco_knobs import (
    damping,
    friction,
    frictionloss,
    gear,
    gravity,
    mass,
    tilt,
)
from ns_pz.envs.registry import MUJOCO_TASKS

_GYM = "gymnasium.envs.mujoco."

TASKS = tuple(name for name, _, _ in MUJOCO_TASKS)
"""The task names; the family of ``name`` is ``{name}Family``, its θ ``{name}Params``."""

_INVERTEDPENDULUM_KNOBS = (
    gravity(-9.81),
    mass("pole_mass", "pole", 5.018591641363306),
    mass("cart_mass", "cart", 10.47197551196598),
    frictionloss("rail_friction", "slider", 50.0),
    damping("slider_damping", "slider", 1.0, unit="N s/m"),
    tilt(),
    gear(),
)

_INVERTEDDOUBLEPENDULUM_KNOBS = (
    gravity(-9.81),
    mass("cart_mass", "cart", 10.47197551196598),
    mass("pole1_mass", "pole", 4.1987385815227585),
    mass("pole2_mass", "pole2", 4.1987385815227585),
    frictionloss("rail_friction", "slider", 50.0),
    damping("slider_damping", "slider", 0.05, unit="N s/m"),
    damping("hinge1_damping", "hinge", 0.05),
    damping("hinge2_damping", "hinge2", 0.05),
    tilt(),
    gear(),
)

_REACHER_KNOBS = (
    mass("body0_mass", "body0", 0.03560471674068432),
    mass("body1_mass", "body1", 0.03560471674068432),
    damping("joint0_damping", "joint0", 1.0),
    damping("joint1_damping", "joint1", 1.0),
    gear(),
)

_SWIMMER_KNOBS = (
    mass("torso_mass", "torso", 35.604716740684324),
    mass("body_mid_mass", "mid", 35.604716740684324),
    mass("body_back_mass", "back", 35.604716740684324),
    damping("motor1_rot_damping", "motor1_rot", 0.0),
    damping("motor2_rot_damping", "motor2_rot", 0.0),
    gear(),
)

_PUSHER_KNOBS = (
    gravity(0.0),
    mass("r_shoulder_pan_link_mass", "r_shoulder_pan_link", 7.293521504574065),
    mass("r_shoulder_lift_link_mass", "r_shoulder_lift_link", 3.141592653589794),
    mass("r_upper_arm_link_mass", "r_upper_arm_link", 1.6286016316209488),
    mass("r_forearm_link_mass", "r_forearm_link", 0.8427322293254622),
    damping("r_shoulder_pan_joint_damping", "r_shoulder_pan_joint", 1.0),
    damping("r_shoulder_lift_joint_damping", "r_shoulder_lift_joint", 1.0),
    damping("r_elbow_flex_joint_damping", "r_elbow_flex_joint", 0.1),
    gear(),
)

_HOPPER_KNOBS = (
    gravity(-9.81),
    mass("torso_mass", "torso", 3.6651914291880923),
    mass("thigh_mass", "thigh", 4.057890510886818),
    mass("leg_mass", "leg", 2.7813566959781637),
    mass("foot_mass", "foot", 5.315574769873931),
    friction("floor_friction", "floor", 1.0),
    damping("thigh_joint_damping", "thigh_joint", 1.0),
    damping("leg_joint_damping", "leg_joint", 1.0),
    damping("foot_joint_damping", "foot_joint", 1.0),
    tilt(),
    gear(),
)

_WALKER2D_KNOBS = (
    gravity(-9.81),
    mass("torso_mass", "torso", 3.6651914291880923),
    mass("thigh_mass", "thigh", 4.057890510886818),
    mass("leg_mass", "leg", 2.7813566959781637),
    mass("foot_mass", "foot", 3.1667253948185117),
    mass("thigh_left_mass", "thigh_left", 4.057890510886818),
    mass("leg_left_mass", "leg_left", 2.7813566959781637),
    mass("foot_left_mass", "foot_left", 3.1667253948185117),
    friction("floor_friction", "floor", 0.7),
    damping("thigh_joint_damping", "thigh_joint", 0.1),
    damping("leg_joint_damping", "leg_joint", 0.1),
    damping("foot_joint_damping", "foot_joint", 0.1),
    damping("thigh_left_joint_damping", "thigh_left_joint", 0.1),
    damping("leg_left_joint_damping", "leg_left_joint", 0.1),
    damping("foot_left_joint_damping", "foot_left_joint", 0.1),
    tilt(),
    gear(),
)

_HALFCHEETAH_KNOBS = (
    gravity(-9.81),
    mass("torso_mass", "torso", 6.25020920502092),
    mass("bthigh_mass", "bthigh", 1.5435146443514645),
    mass("bshin_mass", "bshin", 1.5874476987447697),
    mass("bfoot_mass", "bfoot", 1.0953974895397491),
    mass("fthigh_mass", "fthigh", 1.4380753138075317),
    mass("fshin_mass", "fshin", 1.200836820083682),
    mass("ffeet_mass", "ffoot", 0.8845188284518829),
    friction("floor_friction", "floor", 0.4),
    damping("bthigh_damping", "bthigh", 6.0),
    damping("bshin_damping", "bshin", 4.5),
    damping("bfoot_damping", "bfoot", 3.0),
    damping("fthigh_damping", "fthigh", 4.5),
    damping("fshin_damping", "fshin", 3.0),
    damping("ffeet_damping", "ffoot", 1.5),
    tilt(),
    gear(),
)

_ANT_KNOBS = (
    gravity(-9.81),
    mass("torso_mass", "torso", 0.32724923474893675),
    friction("floor_friction", "floor", 1.0),
    tilt(),
    gear(),
)

_HUMANOID_KNOBS = (
    gravity(-9.81),
    mass("torso_mass", "torso", 8.907462370478262),
    mass("lwaist_mass", "lwaist", 2.261946710584651),
    mass("pelvis_mass", "pelvis", 6.616194128460103),
    mass("right_thigh_mass", "right_thigh", 4.751750928806242),
    mass("left_thigh_mass", "left_thigh", 4.751750928806242),
    mass("right_shin_mass", "right_shin", 2.7556961671836424),
    mass("left_shin_mass", "left_shin", 2.7556961671836424),
    mass("right_foot_mass", "right_foot", 1.7671458676442586),
    mass("left_foot_mass", "left_foot", 1.7671458676442586),
    mass("right_upper_arm_mass", "right_upper_arm", 1.6610804848382084),
    mass("left_upper_arm_mass", "left_upper_arm", 1.6610804848382084),
    mass("right_lower_arm_mass", "right_lower_arm", 1.2295401928310803),
    mass("left_lower_arm_mass", "left_lower_arm", 1.2295401928310803),
    friction("floor_friction", "floor", 1.0),
    damping("right_knee_damping", "right_knee", 1.0),
    damping("left_knee_damping", "left_knee", 1.0),
    damping("right_elbow_damping", "right_elbow", 1.0),
    damping("left_elbow_damping", "left_elbow", 1.0),
    tilt(),
    gear(),
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
