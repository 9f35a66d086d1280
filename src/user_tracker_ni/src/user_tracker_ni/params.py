"""The parameters of user_tracker_ni_node, one table (no ROS): the detectors', the free-space
memory's, the map check's and the tracker's settings under ``~kinect/``, ``~laser/``, ``~free/``,
``~map/`` and ``~tracker/`` (the fields of their dataclasses), the node's own at the top level."""

import dataclasses

from florence_common.params import FRAME, Param, ParamTable
from user_tracker_ni.depth_people import DepthParams
from user_tracker_ni.free_space import FreeSpaceParams
from user_tracker_ni.laser_legs import LegParams
from user_tracker_ni.pipeline import PipelineParams
from user_tracker_ni.static_map import StaticMapParams
from user_tracker_ni.tracker import TrackerParams

NODE = ParamTable(
    Param("fixed_frame", FRAME, "odom", "frame the tracks live in (odom: smooth; map: needs amcl)"),
    Param("base_frame", FRAME, "base_footprint", "the robot's frame on the floor (z up from the floor)"),
    Param("publish_tf", bool, True, "broadcast a frame user_<user_id> per tracked user, child of fixed_frame"),
    Param("frame_prefix", str, "user_", "prefix of the users' tf frames"),
    Param("start_tracking", bool, True, "track from start-up (false: wait for ~Start)"),
    Param("tf_timeout", float, 0.1, "how long a reading waits for its transforms before it is skipped", unit="s",
          ge=0, le=2),
    Param("mount_tolerance", float, 0.25, "a sensor's mount on the robot (base_frame -> sensor) not yet on tf "
          "at a reading's stamp is taken from the latest transform up to this much older (the Kinect's tilt "
          "joint comes at 10 Hz, its frames at 15-30 Hz; the robot's own motion is always looked up at the "
          "stamp); 0: never", unit="s", ge=0, le=2),
    Param("publish_on_scans_after", float, 0.5, "with no depth frame for this long, publish after each scan instead",
          unit="s", gt=0),
    Param("use_map", bool, True, "judge detections against the robot's map (topic map, placed through tf "
          "map_frame -> fixed_frame): none on thin static structure starts a track; without a map or that "
          "transform, tracking goes on without the check"),
    Param("map_frame", FRAME, "map", "the map's frame"),
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
    Param("kinect/max_depth", float, DepthParams.max_depth,
          "largest extent of a person's points along the line of sight (walls seen at a grazing angle run on)",
          unit="m", gt=0),
    Param("kinect/min_roundness", float, DepthParams.min_roundness,
          "least spread of a torso's points across their best vertical plane (flat walls have none)", unit="m", ge=0),
    Param("kinect/noise_at_1m", float, DepthParams.noise_at_1m, "depth noise at 1 m (it grows with the square)",
          unit="m", ge=0),
    Param("kinect/hips_min", float, DepthParams.hips_min,
          "bottom of the band below the upper body whose colours count as the shirt's (a near person)", unit="m",
          gt=0),
    Param("kinect/hips_max", float, DepthParams.hips_max, "top of that band", unit="m", gt=0),
    Param("kinect/body_reach", float, DepthParams.body_reach, "how far around the upper body that band counts",
          unit="m", gt=0),
    Param("kinect/fill_min", float, DepthParams.fill_min,
          "bottom of the heights below the upper body where a person shows a body (lamp poles do not)", unit="m",
          ge=0),
    Param("kinect/fill_max", float, DepthParams.fill_max, "top of those heights", unit="m", gt=0),
    Param("kinect/min_fill", float, DepthParams.min_fill,
          "least share of the judged pixels there that show something at the person's distance", ge=0, le=1),
    Param("kinect/fill_tolerance", float, DepthParams.fill_tolerance,
          "a pixel within this of the person's distance shows the body", unit="m", gt=0),
    Param("kinect/min_judged", float, DepthParams.min_judged,
          "share of those pixels that must be judgeable (not occluded, in the image) for the test", ge=0, le=1),
    Param("kinect/sitting_top", float, DepthParams.sitting_top, "a person whose top is seen below this is sitting",
          unit="m", gt=0),
    Param("kinect/border", int, DepthParams.border,
          "clusters touching the image's left or right border within this are not judged", unit="px", ge=0),
    Param("kinect/legs_min", float, DepthParams.legs_min, "heights of a seated person's shins, the facing cue ...",
          unit="m", ge=0),
    Param("kinect/legs_max", float, DepthParams.legs_max, "... (to this height)", unit="m", gt=0),
    Param("kinect/facing_reach", float, DepthParams.facing_reach,
          "... looked for this near the upper body's centre ...", unit="m", gt=0),
    Param("kinect/facing_gap", float, DepthParams.facing_gap, "... in patches (connected on a 5 cm grid) that come "
          "this near it: not the legs of a chair or a table beside her", unit="m", gt=0),
    Param("kinect/facing_min_offset", float, DepthParams.facing_min_offset,
          "shins whose centre is this far from the torso's tell which way a seated person faces", unit="m", gt=0),
    Param("kinect/close_range", float, DepthParams.close_range,
          "a tracked person this near the camera and not detected is looked for close up, below the upper-body "
          "band, and kept when the colours there are theirs (0: never)", unit="m", ge=0),
    Param("kinect/close_min", float, DepthParams.close_min, "lowest point of a body seen close up", unit="m", gt=0),
    Param("kinect/close_radius", float, DepthParams.close_radius,
          "how near the person's expected place the points seen close up lie", unit="m", gt=0),
    Param("kinect/close_depth", float, DepthParams.close_depth,
          "how far behind the nearest of them along the line of sight (not the wall behind)", unit="m", gt=0),
    Param("kinect/close_gate", float, DepthParams.close_gate,
          "largest colour difference (Bhattacharyya) of what is seen close up and the person", gt=0, le=1),
    Param("kinect/occluder_margin", float, DepthParams.occluder_margin,
          "something this much nearer than a person just beside them in the image ...", unit="m", gt=0),
    Param("kinect/occluder_reach", int, DepthParams.occluder_reach,
          "... within this many pixels of their outline (decimated image; the Kinect leaves gaps at edges) ...",
          unit="px", ge=1),
    Param("kinect/occluded_share", float, DepthParams.occluded_share,
          "... along at least this share of their rows on one side hides part of them: their detection is "
          "trusted less (its centroid is the side in view)", gt=0, le=1),
)

LASER = ParamTable(
    Param("laser/cluster_distance", float, LegParams.cluster_distance,
          "largest gap between neighbouring returns of one cluster", unit="m", gt=0),
    Param("laser/min_points", int, LegParams.min_points, "returns in a leg", ge=2),
    Param("laser/max_gap_beams", int, LegParams.max_gap_beams,
          "beams in a row without a return that do not split a cluster", ge=0),
    Param("laser/min_width", float, LegParams.min_width, "narrowest leg (chair legs and lamp poles are thinner)",
          unit="m", gt=0),
    Param("laser/max_width", float, LegParams.max_width, "widest leg (two legs seen as one included)", unit="m",
          gt=0),
    Param("laser/edge_jump", float, LegParams.edge_jump, "a leg stands this much in front of its neighbours",
          unit="m", gt=0),
    Param("laser/max_pair_distance", float, LegParams.max_pair_distance, "two legs of one person are nearer",
          unit="m", gt=0),
    Param("laser/max_range", float, LegParams.max_range, "returns beyond are not used", unit="m", gt=0),
    Param("laser/hidden_margin", float, LegParams.hidden_margin,
          "a lone leg with something this much nearer beside it (within max_pair_distance across the line of "
          "sight) may have its partner hidden: the tracker trusts its side less", unit="m", gt=0),
    Param("laser/lone_shift", float, LegParams.lone_shift,
          "a lone leg whose partner nothing else hides has it in its shadow: the person's centre this much farther "
          "along the line of sight (half a stance; 0: at the leg) ...", unit="m", ge=0, lt=0.5),
    Param("laser/lone_width", float, LegParams.lone_width,
          "... when the leg is no wider than this (wider: both legs seen as one)", unit="m", gt=0),
)

TRACKER = ParamTable(
    Param("tracker/kinect_gate", float, TrackerParams.kinect_gate,
          "largest distance of a Kinect detection to the track it updates", unit="m", gt=0),
    Param("tracker/laser_gate", float, TrackerParams.laser_gate, "the same for the laser's leg pairs", unit="m", gt=0),
    Param("tracker/confirm_hits", int, TrackerParams.confirm_hits, "Kinect detections that confirm a track ...", ge=1),
    Param("tracker/confirm_window", int, TrackerParams.confirm_window, "... within its first this many Kinect frames",
          ge=1),
    Param("tracker/laser_confirm_distance", float, TrackerParams.laser_confirm_distance,
          "travel that confirms a track the laser started (walking legs) ...", unit="m", gt=0),
    Param("tracker/laser_free_hits", int, TrackerParams.laser_free_hits,
          "... with at least this many of its detections in floor the laser saw free before ...", ge=0),
    Param("tracker/laser_free_share", float, TrackerParams.laser_free_share,
          "... and at least this share of them (of its latest laser_free_window) ...", ge=0, le=1),
    Param("tracker/laser_free_window", int, TrackerParams.laser_free_window,
          "... laser detections: the walk, not what the legs did before it (a seated person's, under her chair) ...",
          ge=1),
    Param("tracker/laser_hit_share", float, TrackerParams.laser_hit_share,
          "... seen in at least this share of the scans since it started", ge=0, le=1),
    Param("tracker/laser_dwell_hits", int, TrackerParams.laser_dwell_hits,
          "detections in free floor that confirm a track the laser started that stays put (somebody stopped) ...",
          ge=1),
    Param("tracker/laser_dwell_free_share", float, TrackerParams.laser_dwell_free_share,
          "... when at least this share of its detections lay in free floor", ge=0, le=1),
    Param("tracker/laser_stitch_time", float, TrackerParams.laser_stitch_time,
          "a track the laser started where a tentative one lost a walker's legs carries on that one's walk toward the "
          "rules above, that one dropped at most this long before (0: off)", unit="s", ge=0),
    Param("tracker/max_speed", float, TrackerParams.max_speed,
          "a tentative track takes no detection farther than this speed allows (no hopping between chair legs)",
          unit="m/s", gt=0),
    Param("tracker/unseen_timeout", float, TrackerParams.unseen_timeout,
          "a track in the Kinect's clear view that it did not detect for this long is dropped", unit="s", gt=0),
    Param("tracker/coast_limit", float, TrackerParams.coast_limit,
          "a published position extrapolates at most this long past the track's last update", unit="s", gt=0),
    Param("tracker/timeout", float, TrackerParams.timeout,
          "a confirmed track no sensor saw for this long (in the laser's view) is dropped", unit="s", gt=0),
    Param("tracker/hidden_timeout", float, TrackerParams.hidden_timeout,
          "a confirmed track out of the laser's view (behind the robot) is kept this long without an update, "
          "standing where it was last going (0: off, no longer than timeout; 10 s locked the robot in place with a "
          "person held behind it, see the README)", unit="s", ge=0),
    Param("tracker/tentative_timeout", float, TrackerParams.tentative_timeout, "the same for a tentative track",
          unit="s", gt=0),
    Param("tracker/merge_distance", float, TrackerParams.merge_distance,
          "two confirmed tracks nearer than this are one person's (a leg each): the junior one goes (0: off)",
          unit="m", ge=0, le=0.5),
    Param("tracker/id_wait", float, TrackerParams.id_wait,
          "a confirmed track waits this long out of the Kinect's view for its colour before it gets a provisional "
          "persistent id ...", unit="s", ge=0),
    Param("tracker/id_wait_max", float, TrackerParams.id_wait_max,
          "... and in front of the Kinect (too near for it to show the upper body yet), this long at most", unit="s",
          ge=0),
    Param("tracker/process_noise", float, TrackerParams.process_noise,
          "white acceleration density of the constant-velocity filter", unit="m^2/s^3", gt=0),
    Param("tracker/appearance_weight", float, TrackerParams.appearance_weight,
          "assignment cost of a colour difference of 1 (Bhattacharyya)", unit="m", ge=0),
    Param("tracker/appearance_gate", float, TrackerParams.appearance_gate,
          "largest colour difference of a Kinect detection and a track ...", gt=0, le=1),
    Param("tracker/appearance_after", int, TrackerParams.appearance_after,
          "... once the track has averaged this many signatures", ge=1),
    Param("tracker/signature_clearance", float, TrackerParams.signature_clearance,
          "a track learns a detection's colours only with no other track this near (one blob for two people)",
          unit="m", ge=0),
    Param("tracker/reid_threshold", float, TrackerParams.reid_threshold,
          "largest colour-signature distance (Bhattacharyya) of a re-identification", gt=0, le=1),
    Param("tracker/max_tracks", int, TrackerParams.max_tracks, "tentative tracks beyond this are not started", ge=1),
    Param("tracker/facing_walk_speed", float, TrackerParams.facing_walk_speed,
          "a user this fast faces the way they walk", unit="m/s", gt=0),
    Param("tracker/facing_frames", int, TrackerParams.facing_frames,
          "Kinect frames that told a still user's facing before it is published ...", ge=1),
    Param("tracker/facing_agreement", float, TrackerParams.facing_agreement,
          "... and the length of the mean of their unit vectors (1: all agree)", ge=0, le=1),
    Param("tracker/seated_frames", int, TrackerParams.seated_frames,
          "Kinect detections in a row of a person sitting that make her place her seat ...", ge=1),
    Param("tracker/seated_reach", float, TrackerParams.seated_reach,
          "... and the laser's detections (her shins) or close sightings within this of the seat keep her "
          "track there without moving it (0: off; less than tracker/laser_gate)", unit="m", ge=0),
    Param("tracker/seat_hold", float, TrackerParams.seat_hold,
          "a seated user's track the Kinect updated within this long is kept while the laser shows something "
          "within tracker/seated_reach of her seat (close up her legs are no pair of legs; 0: off)", unit="s", ge=0),
)

FREE = ParamTable(
    Param("free/resolution", float, FreeSpaceParams.resolution, "cell of the laser's free-space memory", unit="m",
          gt=0),
    Param("free/size", float, FreeSpaceParams.size, "side of that memory's window around the robot", unit="m", gt=0),
    Param("free/fade", float, FreeSpaceParams.fade, "time constant of what it remembers", unit="s", gt=0),
    Param("free/min_free", float, FreeSpaceParams.min_free, "beams through a cell (faded) before it counts as free",
          gt=0),
    Param("free/max_occupied_ratio", float, FreeSpaceParams.max_occupied_ratio,
          "... and the largest share of beams that ended in it", ge=0, lt=1),
    Param("free/margin", float, FreeSpaceParams.margin, "a beam marks free space up to this short of its end",
          unit="m", gt=0),
    Param("free/max_range", float, FreeSpaceParams.max_range, "returns beyond are not used for it", unit="m", gt=0),
    Param("free/neighbourhood", int, FreeSpaceParams.neighbourhood,
          "cells: a point is not free when a cell this near ended beams steadily ...", ge=0),
    Param("free/steady_scans", float, FreeSpaceParams.steady_scans,
          "... in at least this many scans (faded; a still person, not a walker's step)", gt=0),
)

MAP = ParamTable(
    Param("map/clearance", float, StaticMapParams.clearance,
          "a detection this near thin static structure of the map is on it", unit="m", ge=0),
    Param("map/thin", float, StaticMapParams.thin,
          "occupied map cells at most this far from free space are thin structure (walls, poles; not sofas)",
          unit="m", gt=0),
    Param("map/occupied", int, StaticMapParams.occupied, "occupancy from which a map cell is occupied", gt=0, le=100),
)

PARAMS = NODE + KINECT + LASER + FREE + MAP + TRACKER
GROUPS = {"kinect": DepthParams, "laser": LegParams, "free": FreeSpaceParams, "map": StaticMapParams,
          "tracker": TrackerParams}


def split(values):
    """(node values, PipelineParams, StaticMapParams) of validated PARAMS values."""

    def sub(prefix, cls):
        keys = {f.name: f"{prefix}_{f.name}" for f in dataclasses.fields(cls)}
        return cls(**{name: values[key] for name, key in keys.items() if key in values}).validate()

    pipeline = PipelineParams(sub("kinect", DepthParams), sub("laser", LegParams), sub("free", FreeSpaceParams),
                              sub("tracker", TrackerParams))
    return values, pipeline, sub("map", StaticMapParams)
