"""The shipped robot models: they parse, the UR5e matches its DH table, the gripper its datasheet."""

from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform
from pydrake.multibody.plant import MultibodyPlant

from tsad_drake.station_models import (
    FINGER_JOINTS,
    FINGER_OPEN,
    GRIPPER_URL,
    PACKAGE_XML,
    UR5E_JOINTS,
    UR5E_URL,
    make_parser,
)

MODELS = PACKAGE_XML.parent
# Universal Robots' published UR5e DH parameters (theta offsets 0)
DH_A = [0.0, -0.425, -0.3922, 0.0, 0.0, 0.0]
DH_D = [0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996]
DH_ALPHA = [np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0]


def dh_forward_kinematics(q: np.ndarray) -> np.ndarray:
    """4x4 pose of the DH flange frame in base_link (UR base = base_link rotated pi about z)."""
    X = np.diag([-1.0, -1.0, 1.0, 1.0])
    for theta, a, d, alpha in zip(q, DH_A, DH_D, DH_ALPHA, strict=True):
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        X = X @ np.array([[ct, -st * ca, st * sa, a * ct],
                          [st, ct * ca, -ct * sa, a * st],
                          [0.0, sa, ca, d],
                          [0.0, 0.0, 0.0, 1.0]])
    return X


def _plant_with(*urls: str) -> tuple[MultibodyPlant, list]:
    plant = MultibodyPlant(time_step=0.0)
    parser = make_parser(plant)
    instances = [parser.AddModelsFromUrl(url)[0] for url in urls]
    return plant, instances


def test_package_xml_names_the_package():
    assert "<name>tsad_drake</name>" in PACKAGE_XML.read_text()


@pytest.mark.parametrize("path", sorted(MODELS.rglob("*.urdf")), ids=lambda p: p.name)
def test_every_model_file_parses(path: Path):
    plant, _ = _plant_with("package://tsad_drake/" + str(path.relative_to(MODELS)))
    plant.Finalize()
    assert plant.num_bodies() > 1
    assert str(MODELS) not in path.read_text(), "model files must not hold absolute paths"


def test_ur5e_forward_kinematics_matches_dh_table():
    plant, (robot,) = _plant_with(UR5E_URL)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link", robot))
    plant.Finalize()
    assert [plant.GetJointByName(n).position_start() for n in UR5E_JOINTS] == list(range(6))
    context = plant.CreateDefaultContext()
    base, tool = plant.GetFrameByName("base_link"), plant.GetFrameByName("tool0")
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = rng.uniform(plant.GetPositionLowerLimits(), plant.GetPositionUpperLimits())
        plant.SetPositions(context, q)
        X = plant.CalcRelativeTransform(context, base, tool).GetAsMatrix4()
        expected = dh_forward_kinematics(q)
        np.testing.assert_allclose(X[:3, 3], expected[:3, 3], atol=1e-6)
        np.testing.assert_allclose(X[:3, :3], expected[:3, :3], atol=1e-6)
    plant.SetPositions(context, np.zeros(6))  # UR's published reach at q = 0
    p = plant.CalcRelativeTransform(context, base, tool).translation()
    np.testing.assert_allclose(p, [0.8172, 0.2329, 0.0628], atol=1e-4)


def test_ur5e_dynamics_and_limits_as_published():
    plant, (robot,) = _plant_with(UR5E_URL)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link", robot))
    plant.Finalize()
    masses = {"base_link": 4.0, "shoulder_link": 3.761, "upper_arm_link": 8.058,
              "forearm_link": 2.846, "wrist_1_link": 1.37, "wrist_2_link": 1.3,
              "wrist_3_link": 0.365}
    for name, mass in masses.items():
        assert plant.GetBodyByName(name).default_mass() == pytest.approx(mass)
    context = plant.CreateDefaultContext()
    # The published CoM of the upper arm is 0.2125 m along the link (DH frame 2: [0.2125, 0, 0.11336])
    com = plant.GetBodyByName("upper_arm_link").CalcCenterOfMassInBodyFrame(context)
    np.testing.assert_allclose(com, [0.0, 0.11336 - 0.138, 0.2125], atol=1e-9)
    np.testing.assert_allclose(plant.GetPositionUpperLimits(),
                               [2 * np.pi, 2 * np.pi, np.pi, 2 * np.pi, 2 * np.pi, 2 * np.pi])
    np.testing.assert_allclose(plant.GetVelocityUpperLimits(), np.full(6, np.pi))
    np.testing.assert_allclose(plant.GetEffortUpperLimits(), [150, 150, 150, 28, 28, 28])


def test_gripper_geometry_matches_the_2f85():
    plant, (robot, gripper) = _plant_with(UR5E_URL, GRIPPER_URL)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base_link", robot))
    plant.WeldFrames(plant.GetFrameByName("tool0", robot),
                     plant.GetFrameByName("tool_adapter", gripper), RigidTransform())
    plant.Finalize()
    assert plant.num_constraints() == 1, "the <mimic> finger must become a coupler constraint"
    for name in FINGER_JOINTS:
        joint = plant.GetJointByName(name, gripper)
        assert joint.position_lower_limits()[0] == 0.0
        assert joint.position_upper_limits()[0] == pytest.approx(FINGER_OPEN)
    context = plant.CreateDefaultContext()
    for name in FINGER_JOINTS:
        plant.GetJointByName(name, gripper).set_translation(context, FINGER_OPEN)
    G = plant.GetFrameByName("gripper_base", gripper)

    def p_G(frame_name):
        return plant.CalcRelativeTransform(context, G, plant.GetFrameByName(frame_name)).translation()

    np.testing.assert_allclose(p_G("tcp"), [0.0, 0.0, 0.145], atol=1e-12)
    # the gripper sits on its 0.10 m tool extension: the tcp is 0.245 m from the flange
    tool0 = plant.GetFrameByName("tool0", robot)
    np.testing.assert_allclose(plant.CalcRelativeTransform(
        context, tool0, plant.GetFrameByName("tcp", gripper)).translation(), [0.0, 0.0, 0.245],
        atol=1e-12)
    left, right = p_G("left_finger"), p_G("right_finger")
    assert left[1] - right[1] == pytest.approx(0.085)  # inner pad gap = stroke
    outer = left[1] + 0.0125 - (right[1] - 0.0125)
    assert outer == pytest.approx(2 * 0.055)  # GripperConfig.swept_half_width
    mass = sum(plant.get_body(i).default_mass() for i in plant.GetBodyIndices(gripper))
    adapter = plant.GetBodyByName("tool_adapter", gripper).default_mass()
    assert 0.8 < mass - adapter < 1.0 and 0.2 <= adapter <= 0.4  # the 2F-85 and its extension
    # camera optical axis: ahead along the approach axis, pitched up, image "down" is -x (bottom)
    R_GC = plant.CalcRelativeTransform(context, G, plant.GetFrameByName("camera_link"))
    R = R_GC.rotation().matrix()
    assert R[2, 2] > 0.9 and R[0, 2] > 0.0  # looks forward, slightly towards +x (top)
    np.testing.assert_allclose(R[:, 1] @ [-1.0, 0.0, 0.0], np.cos(np.radians(20)), atol=1e-9)
