"""Every message, service and action of the seed is generated with the seed's fields.

Table-driven: each row names a generated class and the (field, type) pairs it
must have, in order. Messages whose definition may grow (TrackedUsers) are
checked for the seed's fields as a prefix.
"""

import importlib

import pytest

pytestmark = pytest.mark.unit

F32 = "float32"
XYPHI = [("x", F32), ("y", F32), ("phi", F32)]
STATUS = [("success", "bool"), ("message", "string")]
ROOM = [("room", "string")]

# (module, class, request-or-message fields, response fields or None, prefix_only)
MESSAGES = [
    ("detect_users.msg", "DetectedUser",
     [("command", "bool"), ("user_position_x", F32), ("user_position_y", F32)], None, False),
    ("user_tracker_ni.msg", "TrackedUsers",
     [("user_ids", "int32[]"), ("user_ids_ni", "int32[]"), ("num_users_tracked", "int32")], None, True),
    ("follow_me.msg", "FollowMeGoal",
     [("x", F32), ("y", F32), ("max_lin_speed", F32), ("max_ang_speed", F32), ("desired_follow_distance", F32)],
     None, False),
    ("follow_me.msg", "FollowMeResult", [("x", F32), ("y", F32)], None, False),
    ("follow_me.msg", "FollowMeFeedback", [("x", F32), ("y", F32)], None, False),
    ("approach_me.msg", "ApproachMeGoal",
     [("x", F32), ("y", F32), ("desired_distance", F32), ("desired_p2r_orientation", F32),
      ("desired_r2p_orientation", F32), ("max_lin_speed", F32), ("max_ang_speed", F32)], None, False),
    ("approach_me.msg", "ApproachMeResult", [("x", F32), ("y", F32)], None, False),
    ("approach_me.msg", "ApproachMeFeedback", [("x", F32), ("y", F32)], None, False),
]

SERVICES = [
    ("user_tracker_ni.srv", "Start", [], STATUS),
    ("user_tracker_ni.srv", "Stop", [], STATUS),
    ("florence_locator.srv", "GetUserPosRoom", [], [*ROOM, *STATUS]),
    ("florence_locator.srv", "GetUserPosXYPhi", [], [*XYPHI, *STATUS]),
    ("florence_locator.srv", "GetRobotPosRoom", [], [*ROOM, *STATUS]),
    ("florence_locator.srv", "GetRobotPosXYPhi", [], [*XYPHI, *STATUS]),
    ("florence_locator.srv", "GetGoalPosRoom", [], [*ROOM, *STATUS]),
    ("florence_locator.srv", "GetGoalPosXYPhi", [], [*XYPHI, *STATUS]),
    ("florence_locator.srv", "GetHotspot", ROOM, [*XYPHI, *STATUS]),
    ("florence_locator.srv", "SetHotspot", [*ROOM, *XYPHI], STATUS),
    ("florence_locator.srv", "GetStatus", [], [("status", "string"), *STATUS]),
    ("florence_locator.srv", "GotoUser", [], STATUS),
    ("florence_locator.srv", "GotoRoom", ROOM, STATUS),
    ("florence_locator.srv", "GotoXYPhi", XYPHI, STATUS),
    ("florence_locator.srv", "SetUserPosRoom", ROOM, STATUS),
    ("florence_locator.srv", "SetUserPosXYPhi", XYPHI, STATUS),
    ("turtlebot_node.srv", "SetDigitalOutputs",
     [("digital_out_0", "uint8"), ("digital_out_1", "uint8"), ("digital_out_2", "uint8")], [("done", "bool")]),
    ("turtlebot_node.srv", "SetTurtlebotMode", [("mode", "uint8")], [("valid_mode", "bool")]),
]

SENSOR_STATE = [
    ("header", "std_msgs/Header"), ("bumps_wheeldrops", "uint8"), ("wall", "bool"), ("cliff_left", "bool"),
    ("cliff_front_left", "bool"), ("cliff_front_right", "bool"), ("cliff_right", "bool"),
    ("virtual_wall", "bool"), ("motor_overcurrents", "uint8"), ("dirt_detector_left", "uint8"),
    ("dirt_detector_right", "uint8"), ("remote_opcode", "uint8"), ("buttons", "uint8"),
    ("distance", "float64"), ("angle", "float64"), ("charging_state", "uint8"), ("voltage", "uint16"),
    ("current", "int16"), ("temperature", "int8"), ("charge", "uint16"), ("capacity", "uint16"),
    ("wall_signal", "uint16"), ("cliff_left_signal", "uint16"), ("cliff_front_left_signal", "uint16"),
    ("cliff_front_right_signal", "uint16"), ("cliff_right_signal", "uint16"),
    ("user_digital_outputs", "uint8"), ("user_digital_inputs", "uint8"), ("user_analog_input", "uint16"),
    ("charging_sources_available", "uint8"), ("oi_mode", "uint8"), ("song_number", "uint8"),
    ("song_playing", "bool"), ("number_of_stream_packets", "uint8"), ("requested_velocity", "int32"),
    ("requested_radius", "int32"), ("requested_right_velocity", "int32"), ("requested_left_velocity", "int32"),
]


def fields(cls):
    return list(zip(cls.__slots__, cls._slot_types, strict=True))


def load(module, name):
    return getattr(importlib.import_module(module), name)


@pytest.mark.parametrize(("module", "name", "expected", "_unused", "prefix_only"), MESSAGES,
                         ids=[f"{m}.{n}" for m, n, *_ in MESSAGES])
def test_message_fields(module, name, expected, _unused, prefix_only):
    actual = fields(load(module, name))
    if prefix_only:
        assert actual[: len(expected)] == expected
    else:
        assert actual == expected


@pytest.mark.parametrize(("module", "name", "request_fields", "response_fields"), SERVICES,
                         ids=[f"{m}.{n}" for m, n, *_ in SERVICES])
def test_service_fields(module, name, request_fields, response_fields):
    srv = load(module, name)
    assert fields(srv._request_class) == request_fields
    assert fields(srv._response_class) == response_fields


def test_tracked_users_appended_positions_line_up_with_ids():
    from geometry_msgs.msg import Point

    from user_tracker_ni.msg import TrackedUsers

    extra = fields(TrackedUsers)[3:]
    # appended in issue 3 (where), then issue 18 (how fast, when last seen, by which sensors, which way they face),
    # then issue 20 (who sits)
    assert extra == [("stamp", "time"), ("frame_id", "string"), ("positions", "geometry_msgs/Point[]"),
                     ("velocities", "geometry_msgs/Vector3[]"), ("last_seen", "time[]"), ("sensors", "uint8[]"),
                     ("facings", "float32[]"), ("seated", "bool[]")]
    msg = TrackedUsers(user_ids=[7], user_ids_ni=[1], num_users_tracked=1, positions=[Point(1.0, 0.5, 0.9)])
    assert msg.positions[0].x == 1.0


@pytest.mark.parametrize("package,action", [("follow_me", "FollowMe"), ("approach_me", "ApproachMe")])
def test_actions_have_actionlib_wrappers(package, action):
    mod = importlib.import_module(f"{package}.msg")
    for suffix in ("Action", "ActionGoal", "ActionResult", "ActionFeedback"):
        assert hasattr(mod, action + suffix), action + suffix
    wrapper = fields(getattr(mod, action + "Action"))
    assert wrapper == [
        ("action_goal", f"{package}/{action}ActionGoal"),
        ("action_result", f"{package}/{action}ActionResult"),
        ("action_feedback", f"{package}/{action}ActionFeedback"),
    ]


def test_turtlebot_sensor_state_fields_and_constants():
    from turtlebot_node.msg import TurtlebotSensorState as S

    assert fields(S) == SENSOR_STATE
    assert (S.OI_MODE_OFF, S.OI_MODE_PASSIVE, S.OI_MODE_SAFE, S.OI_MODE_FULL) == (0, 1, 2, 3)
    assert (S.CHARGING_NOT_CHARGING, S.CHARGING_CHARGING_ERROR) == (0, 5)
    assert (S.REMOTE_LEFT, S.REMOTE_NONE) == (129, 255)


def test_messages_round_trip_through_serialisation():
    """The generated classes serialise: what a subscriber would receive equals what was sent."""
    import io

    from florence_locator.srv import SetHotspotRequest
    from turtlebot_node.msg import TurtlebotSensorState

    sent = TurtlebotSensorState(voltage=15800, current=-1200, temperature=31, distance=0.012, oi_mode=2)
    buf = io.BytesIO()
    sent.serialize(buf)
    received = TurtlebotSensorState().deserialize(buf.getvalue())
    assert (received.voltage, received.current, received.temperature, received.oi_mode) == (15800, -1200, 31, 2)
    assert received.distance == pytest.approx(0.012)

    request = SetHotspotRequest(room="kitchen", x=1.5, y=-2.25, phi=3.0)
    buf = io.BytesIO()
    request.serialize(buf)
    back = SetHotspotRequest().deserialize(buf.getvalue())
    assert (back.room, back.x, back.y, back.phi) == ("kitchen", 1.5, -2.25, 3.0)
