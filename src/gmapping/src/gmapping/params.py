"""The parameters of slam_gmapping, with its names and defaults (no ROS).

SLAM holds what the mapper itself uses (read by :func:`gmapping.slam.config_from_params`, also from a
launch file's values by the offline evaluation); NODE what only the node uses. Names, defaults and
meanings are slam_gmapping's (ros-perception/slam_gmapping, gmapping/src/slam_gmapping.cpp); the
Florence additions say so.
"""

from florence_common.params import FRAME, Param, ParamTable

SLAM = ParamTable(
    Param("particles", int, 30, "number of particles in the filter", ge=1),
    Param("maxRange", float, None, "maximum range of the laser: readings beyond it (and no-return readings) are "
          "left out (unset: the scan's range_max - 0.01)", unit="m", gt=0, optional=True),
    Param("maxUrange", float, None, "maximum usable range: beams are cut to it for matching and mapping, longer "
          "readings only clear the cells up to it (unset: maxRange)", unit="m", gt=0, optional=True),
    Param("sigma", float, 0.05, "spread of the greedy endpoint matching: a beam scores exp(-d^2 / sigma), d the "
          "distance of its end point to the nearest matching cell's mean hit point", unit="m^2", gt=0),
    Param("kernelSize", int, 1, "cells searched around each end point for a match (a (2k+1)^2 window)", ge=0),
    Param("lstep", float, 0.05, "initial translation step of the scan matcher's hill climb", unit="m", gt=0),
    Param("astep", float, 0.05, "initial rotation step of the scan matcher's hill climb", unit="rad", gt=0),
    Param("iterations", int, 5, "times the scan matcher halves its steps", ge=0),
    Param("lsigma", float, 0.075, "spread of a beam in the likelihood that weighs a particle: -d^2 / lsigma "
          "per matched beam, -0.5 / lsigma per unmatched one", unit="m^2", gt=0),
    Param("ogain", float, 3.0, "gain that smooths the likelihood before resampling: weights exp(l / (ogain N))",
          gt=0),
    Param("lskip", int, 0, "beams skipped between two used beams (0: every beam)", ge=0),
    Param("minimumScore", float, 0.0, "least scan matching score to accept the matched pose; below it the "
          "particle keeps its odometry pose (raise it against jumps in open space)", ge=0),
    Param("srr", float, 0.1, "odometry error in translation as a function of translation", ge=0),
    Param("srt", float, 0.2, "odometry error in rotation as a function of translation", ge=0),
    Param("str", float, 0.1, "odometry error in translation as a function of rotation", ge=0),
    Param("stt", float, 0.2, "odometry error in rotation as a function of rotation", ge=0),
    Param("linearUpdate", float, 1.0, "process a scan each time the robot translates this far", unit="m", ge=0),
    Param("angularUpdate", float, 0.5, "process a scan each time the robot rotates this much", unit="rad", ge=0),
    Param("temporalUpdate", float, -1.0, "process a scan if the last processed one is older than this; < 0 "
          "turns time-based updates off", unit="s"),
    Param("resampleThreshold", float, 0.5, "resample when the effective sample size falls below this fraction "
          "of the particles", ge=0),
    Param("xmin", float, -100.0, "initial map size: least x", unit="m"),
    Param("ymin", float, -100.0, "initial map size: least y", unit="m"),
    Param("xmax", float, 100.0, "initial map size: greatest x", unit="m"),
    Param("ymax", float, 100.0, "initial map size: greatest y", unit="m"),
    Param("delta", float, 0.05, "resolution of the map", unit="m/cell", gt=0),
    Param("occ_thresh", float, 0.25, "a cell hit in more than this fraction of the beams that reached it is "
          "occupied (100), otherwise free (0)", ge=0, le=1),
    Param("llsamplerange", float, 0.01, "accepted and unused, as in slam_gmapping (its likelihood sampling is "
          "never called)", unit="m"),
    Param("llsamplestep", float, 0.01, "accepted and unused, as in slam_gmapping", unit="m"),
    Param("lasamplerange", float, 0.005, "accepted and unused, as in slam_gmapping", unit="rad"),
    Param("lasamplestep", float, 0.005, "accepted and unused, as in slam_gmapping", unit="rad"),
)

NODE = ParamTable(
    Param("throttle_scans", int, 1, "process one scan in this many (the others are dropped)", ge=1),
    Param("base_frame", FRAME, "base_link", "the robot's frame"),
    Param("map_frame", FRAME, "map", "the map frame"),
    Param("odom_frame", FRAME, "odom", "the odometry frame"),
    Param("map_update_interval", float, 5.0, "time between two rebuilds of the published map (scan time)",
          unit="s", ge=0),
    Param("transform_publish_period", float, 0.05, "period of the map -> odom broadcast; 0 turns it off",
          unit="s", ge=0),
    Param("tf_delay", float, None, "map -> odom is stamped this far ahead of now (unset: "
          "transform_publish_period)", unit="s", ge=0, optional=True),
    Param("seed", int, -1, "Florence addition: seed of the particle filter's random numbers, for repeatable "
          "runs (-1: a fresh seed every start)", ge=-1),
)
