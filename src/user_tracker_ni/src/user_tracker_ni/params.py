"""The parameters of user_tracker_ni_node, one table (no ROS): the detectors' and the tracker's
settings under ``~kinect/``, ``~laser/`` and ``~tracker/``, the node's own at the top level."""

from florence_common.params import FRAME, Param, ParamTable
from user_tracker_ni.depth_people import DepthParams
from user_tracker_ni.laser_legs import LegParams
from user_tracker_ni.tracker import TrackerParams

NODE = ParamTable(
    Param("fixed_frame", FRAME, "odom", "frame the tracks live in (odom: smooth; map: needs amcl)"),
    Param("base_frame", FRAME, "base_footprint", "the robot's frame on the floor (z up from the floor)"),
    Param("publish_tf", bool, True, "broadcast a frame user_<user_id> per tracked user, child of fixed_frame"),
    Param("frame_prefix", str, "user_", "prefix of the users' tf frames"),
    Param("start_tracking", bool, True, "track from start-up (false: wait for ~Start)"),
    Param("tf_timeout", float, 0.1, "how long a reading waits for its transforms before it is skipped", unit="s",
          ge=0, le=2),
    Param("publish_on_scans_after", float, 0.5, "with no depth frame for this long, publish after each scan instead",
          unit="s", gt=0),
)

KINECT = ParamTable(
    Param("kinect/target_width", int, DepthParams.target_width, "the depth image is decimated to about this width",
          unit="px", ge=16, le=640),
    Param("kinect/min_range", float, DepthParams.min_range, "nearer depth readings are ignored", unit="m", gt=0),
    Param("kinect/max_range", float, DepthParams.max_range, "farther depth readings are ignored", unit="m", gt=0),
    Param("kinect/upper_min", float, DepthParams.upper_min, "lowest point of the upper-body band (above furniture)",
          unit="m", gt=0),
    Param("kinect/max_height", float, DepthParams.max_height, "highest point considered", unit="m", gt=0),
    Param("kinect/cell", float, DepthParams.cell, "floor grid cell of the clustering", unit="m", gt=0, le=0.3),
    Param("kinect/min_points", int, DepthParams.min_points, "upper-body points of a person (decimated image)", ge=3),
    Param("kinect/min_width", float, DepthParams.min_width, "narrowest upper body across the line of sight",
          unit="m", gt=0),
    Param("kinect/max_width", float, DepthParams.max_width, "widest upper body", unit="m", gt=0),
    Param("kinect/min_roundness", float, DepthParams.min_roundness,
          "least spread of a torso's points across their best vertical plane (flat walls have none)", unit="m", ge=0),
    Param("kinect/noise_at_1m", float, DepthParams.noise_at_1m, "depth noise at 1 m (it grows with the square)",
          unit="m", ge=0),
    Param("kinect/hips_min", float, DepthParams.hips_min, "bottom of the body band below the upper body", unit="m",
          gt=0),
    Param("kinect/hips_max", float, DepthParams.hips_max, "top of the body band", unit="m", gt=0),
    Param("kinect/min_hips_width", float, DepthParams.min_hips_width,
          "least width of the body band (poles of lamps and coat stands have less)", unit="m", gt=0),
    Param("kinect/body_reach", float, DepthParams.body_reach, "how far around the upper body the body band counts",
          unit="m", gt=0),
    Param("kinect/sitting_top", float, DepthParams.sitting_top, "a person whose top is seen below this is sitting",
          unit="m", gt=0),
)

LASER = ParamTable(
    Param("laser/cluster_distance", float, LegParams.cluster_distance,
          "largest gap between neighbouring returns of one cluster", unit="m", gt=0),
    Param("laser/min_points", int, LegParams.min_points, "returns in a leg", ge=2),
    Param("laser/min_width", float, LegParams.min_width, "narrowest leg", unit="m", gt=0),
    Param("laser/max_width", float, LegParams.max_width, "widest leg (two legs seen as one included)", unit="m",
          gt=0),
    Param("laser/edge_jump", float, LegParams.edge_jump, "a leg stands this much in front of its neighbours",
          unit="m", gt=0),
    Param("laser/max_pair_distance", float, LegParams.max_pair_distance, "two legs of one person are nearer",
          unit="m", gt=0),
    Param("laser/max_range", float, LegParams.max_range, "returns beyond are not used", unit="m", gt=0),
)

TRACKER = ParamTable(
    Param("tracker/kinect_gate", float, TrackerParams.kinect_gate,
          "largest distance of a Kinect detection to the track it updates", unit="m", gt=0),
    Param("tracker/laser_gate", float, TrackerParams.laser_gate, "the same for the laser's leg pairs", unit="m", gt=0),
    Param("tracker/confirm_hits", int, TrackerParams.confirm_hits, "Kinect detections that confirm a track ...", ge=1),
    Param("tracker/confirm_window", int, TrackerParams.confirm_window, "... within its first this many Kinect frames",
          ge=1),
    Param("tracker/laser_confirm_distance", float, TrackerParams.laser_confirm_distance,
          "travel that confirms a track the laser started (walking legs)", unit="m", gt=0),
    Param("tracker/timeout", float, TrackerParams.timeout, "a confirmed track no sensor saw for this long is dropped",
          unit="s", gt=0),
    Param("tracker/tentative_timeout", float, TrackerParams.tentative_timeout, "the same for a tentative track",
          unit="s", gt=0),
    Param("tracker/id_wait", float, TrackerParams.id_wait,
          "a confirmed track waits this long for its colour before it gets a new persistent id", unit="s", ge=0),
    Param("tracker/process_noise", float, TrackerParams.process_noise,
          "white acceleration density of the constant-velocity filter", unit="m^2/s^3", gt=0),
    Param("tracker/reid_threshold", float, TrackerParams.reid_threshold,
          "largest colour-signature distance (Bhattacharyya) of a re-identification", gt=0, le=1),
    Param("tracker/max_tracks", int, TrackerParams.max_tracks, "tentative tracks beyond this are not started", ge=1),
)

PARAMS = NODE + KINECT + LASER + TRACKER


def split(values):
    """(node values, DepthParams, LegParams, TrackerParams) of validated PARAMS values."""

    def sub(prefix, cls):
        return cls(**{k[len(prefix) + 1:]: v for k, v in values.items() if k.startswith(prefix + "_")}).validate()

    return values, sub("kinect", DepthParams), sub("laser", LegParams), sub("tracker", TrackerParams)
