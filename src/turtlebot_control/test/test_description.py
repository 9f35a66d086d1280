"""The Florence TurtleBot description: xacro expansion, the frame tree, and the live tf
that robot_state_publisher publishes from it (seed 3.2.1)."""

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

from turtlebot_control import xacro_yaml

PKG = Path(__file__).resolve().parents[1]
MODEL = PKG / "urdf" / "florence_turtlebot.urdf.xacro"
DIMS = yaml.safe_load((PKG / "config" / "robot_dimensions.yaml").read_text())

REQUIRED = [
    "base_footprint", "base_link", "plate_0_link", "plate_1_link", "plate_2_link", "plate_3_link",
    "base_laser_link", "base_laser_round_link", "camera_link", "camera_depth_frame",
    "camera_depth_optical_frame", "camera_rgb_frame", "camera_rgb_optical_frame", "gyro_link",
    "left_wheel_link", "right_wheel_link",
]


@pytest.fixture(scope="module")
def urdf():
    return ET.fromstring(xacro_yaml.expand(str(MODEL)))


def joints(urdf):
    return {j.get("name"): j for j in urdf.iter("joint")}


def origin(joint):
    o = joint.find("origin")
    return [float(v) for v in o.get("xyz").split()], [float(v) for v in o.get("rpy").split()]


@pytest.mark.unit
def test_every_required_frame_is_a_link(urdf):
    links = {link.get("name") for link in urdf.iter("link")}
    assert sorted(set(REQUIRED) - links) == []


@pytest.mark.unit
def test_links_form_one_tree_rooted_at_base_footprint(urdf):
    links = {link.get("name") for link in urdf.iter("link")}
    children = [j.find("child").get("link") for j in urdf.iter("joint")]
    assert len(children) == len(set(children)), "a link with two parents"
    roots = links - set(children)
    assert roots == {"base_footprint"}


@pytest.mark.unit
def test_standoffs_are_10_25_50_cm(urdf):
    j = joints(urdf)
    heights = [origin(j[f"plate_{n}_joint"])[0][2] for n in (1, 2, 3)]
    assert heights == pytest.approx([0.10, 0.25, 0.50])
    for plate, length in (("plate_0", 0.10), ("plate_1", 0.25), ("plate_2", 0.50)):
        for i in range(4):
            link = next(link for link in urdf.iter("link") if link.get("name") == f"{plate}_standoff_{i}_link")
            assert float(link.find("visual/geometry/cylinder").get("length")) == pytest.approx(length)


@pytest.mark.unit
def test_inverted_laser_joint_is_the_seeds(urdf):
    j = joints(urdf)
    laser = j["base_laser_joint"]
    assert laser.find("parent").get("link") == "plate_1_link"
    xyz, rpy = origin(laser)
    assert xyz == pytest.approx([0.06, 0.0, -0.02])
    assert rpy == pytest.approx([math.pi, 0.0, 0.0], abs=1e-6)
    xyz, rpy = origin(j["base_laser_round_joint"])
    assert j["base_laser_round_joint"].find("parent").get("link") == "base_laser_link"
    assert xyz == pytest.approx([0.0, 0.0, 0.035])


@pytest.mark.unit
def test_every_link_with_geometry_has_visual_and_collision(urdf):
    for link in urdf.iter("link"):
        if link.find("visual") is not None:
            assert link.find("collision") is not None, link.get("name")


@pytest.mark.unit
def test_dimensions_file_drives_the_model(tmp_path):
    """Changing the YAML changes the URDF: nothing is hard-coded in the xacro."""
    dims = yaml.safe_load((PKG / "config" / "robot_dimensions.yaml").read_text())
    dims["plates"]["plate_2"]["xyz"][2] = 0.30
    path = tmp_path / "dims.yaml"
    path.write_text(yaml.safe_dump(dims))
    urdf = ET.fromstring(xacro_yaml.expand(str(MODEL), {"dimensions": str(path)}))
    assert origin(joints(urdf)["plate_2_joint"])[0][2] == pytest.approx(0.30)


@pytest.mark.unit
def test_missing_dimensions_file_is_a_clear_error(tmp_path):
    import xacro

    with pytest.raises(xacro.XacroException, match=r"no_such\.yaml"):
        xacro_yaml.expand(str(MODEL), {"dimensions": str(tmp_path / "no_such.yaml")})


def expected_laser_in_base_link():
    """base_link -> base_laser_link from the YAML: plate_0, plate_1 and the laser offsets."""
    p0 = np.array(DIMS["plates"]["plate_0"]["xyz"])
    p1 = np.array(DIMS["plates"]["plate_1"]["xyz"])
    laser = np.array(DIMS["laser"]["xyz"])
    return p0 + p1 + laser


@pytest.mark.ros
def test_tf_base_link_to_laser_is_offset_and_upside_down(launch, tf_buffer, rospy_node):
    rospy = rospy_node
    launch("turtlebot_control", "description.launch")
    t = tf_buffer.lookup_transform("base_link", "base_laser_link", rospy.Time(0), rospy.Duration(30.0)).transform
    translation = [t.translation.x, t.translation.y, t.translation.z]
    assert translation == pytest.approx(expected_laser_in_base_link().tolist(), abs=1e-6)
    assert translation == pytest.approx([-0.04334 + 0.04068 + 0.06, 0.0, 0.06775704 + 0.10 - 0.02], abs=1e-6)
    # Rolled by pi: quaternion (1, 0, 0, 0) up to sign; the laser's z axis points at the floor.
    q = np.array([t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w])
    assert abs(q[0]) == pytest.approx(1.0, abs=1e-6)
    from florence_common.pose import transform_matrix

    rot = transform_matrix((0, 0, 0), q)[:3, :3]
    assert rot @ [0, 0, 1] == pytest.approx([0, 0, -1], abs=1e-6)
    assert rot @ [0, 1, 0] == pytest.approx([0, -1, 0], abs=1e-6)  # the laser's left is the robot's right
    # The optical window hangs 0.035 m below the laser body.
    r = tf_buffer.lookup_transform("base_link", "base_laser_round_link", rospy.Time(0), rospy.Duration(5.0))
    assert r.transform.translation.z == pytest.approx(translation[2] - 0.035, abs=1e-6)


@pytest.mark.ros
def test_kinect_tilt_joint_state_moves_the_camera(launch, tf_buffer, rospy_node):
    """kinect_aux reports the tilt on kinect_aux/joint_states; positive tilt looks up."""
    rospy = rospy_node
    from sensor_msgs.msg import JointState

    from florence_common.processes import wait_for

    launch("turtlebot_control", "description.launch")
    pub = rospy.Publisher("kinect_aux/joint_states", JointState, queue_size=1)
    tilt = math.radians(20.0)

    def optical_axis_pitch():
        msg = JointState(name=["camera_tilt_joint"], position=[tilt])
        msg.header.stamp = rospy.Time.now()
        pub.publish(msg)
        t = tf_buffer.lookup_transform("base_link", "camera_depth_optical_frame", rospy.Time(0)).transform
        from florence_common.pose import transform_matrix

        axis = transform_matrix((0, 0, 0), (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w))[:3, :3] @ [0, 0, 1]
        pitch_up = math.atan2(axis[2], axis[0])
        return pitch_up if abs(pitch_up - tilt) < 1e-3 else None

    assert wait_for(optical_axis_pitch, 30.0, interval=0.1, what="camera tilted by 20 degrees") == pytest.approx(
        tilt, abs=1e-3)
