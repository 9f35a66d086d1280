"""The parameters of the amcl node, with ROS amcl's names and defaults (no ROS).

FILTER holds what the filter itself uses (read by :func:`amcl.localizer.config_from_params`,
also from a launch file's values by the offline evaluation); NODE what only the node uses.
"""

import math

from amcl.motion import MODELS
from amcl.sensor import LASER_MODELS
from florence_common.params import FRAME, Param, ParamTable

FILTER = ParamTable(
    Param("min_particles", int, 100, "fewest particles", ge=1),
    Param("max_particles", int, 5000, "most particles (at least min_particles)", ge=1),
    Param("kld_err", float, 0.01, "KLD-sampling error bound", gt=0, lt=1),
    Param("kld_z", float, 0.99, "KLD-sampling normal quantile (used as given, like ROS)", gt=0),
    Param("update_min_d", float, 0.2, "translation in x or y before a filter update", unit="m", ge=0),
    Param("update_min_a", float, math.pi / 6.0, "rotation before a filter update", unit="rad", ge=0),
    Param("resample_interval", int, 2, "filter updates per resampling", ge=1),
    Param("selective_resampling", bool, False, "resample only when N_eff < N/2"),
    Param("recovery_alpha_slow", float, 0.0, "slow average decay (0 disables random poses)", ge=0, le=1),
    Param("recovery_alpha_fast", float, 0.0, "fast average decay", ge=0, le=1),
    Param("recovery_mean_likelihood", bool, False, "Florence addition: the recovery averages follow the set's mean "
          "sensor likelihood (Probabilistic Robotics) instead of ROS's mean divided by the particle count, which "
          "KLD-sampling's shrinking set inflates so that random poses are never injected (false: ROS)"),
    Param("recovery_wait_converged", bool, False, "Florence addition: after an initialisation the recovery averages "
          "start once the set has converged (all particles within 0.5 m of the mean), not from a set spread by "
          "global_localization"),
    Param("laser_min_range", float, -1.0, "overrides the scan's range_min when > 0", unit="m"),
    Param("laser_max_range", float, -1.0, "overrides the scan's range_max when > 0", unit="m"),
    Param("laser_max_beams", int, 30, "beams used per scan (evenly spaced)", ge=2),
    Param("laser_z_hit", float, 0.95, "mixture weight of the hit term", ge=0),
    Param("laser_z_short", float, 0.1, "mixture weight of the short term", ge=0),
    Param("laser_z_max", float, 0.05, "mixture weight of the max-range term", ge=0),
    Param("laser_z_rand", float, 0.05, "mixture weight of the random term", ge=0),
    Param("laser_sigma_hit", float, 0.2, "standard deviation of the hit term", unit="m", gt=0),
    Param("laser_lambda_short", float, 0.1, "exponential rate of the short term (beam model)", unit="1/m", gt=0),
    Param("laser_likelihood_max_dist", float, 2.0, "cap of the likelihood field's distance", unit="m", gt=0),
    Param("laser_model_type", str, "likelihood_field", '"likelihood_field", "likelihood_field_prob" (ROS\'s product '
          'of the beams\' pz, without beam skipping) or "beam"', choices=LASER_MODELS),
    Param("laser_likelihood_interpolate", bool, False, "Florence addition: the likelihood field's distance is "
          "interpolated between cell centres and signed (false: ROS's cell lookup, 0 inside)"),
    Param("odom_model_type", str, "diff", '"diff" (ROS\'s original) or "diff-corrected"', choices=MODELS),
    Param("odom_alpha1", float, 0.2, "rotation noise from rotation", ge=0),
    Param("odom_alpha2", float, 0.2, "rotation noise from translation", ge=0),
    Param("odom_alpha3", float, 0.2, "translation noise from translation", ge=0),
    Param("odom_alpha4", float, 0.2, "translation noise from rotation", ge=0),
    Param("odom_alpha5", float, 0.2, "unused (omni models only)", ge=0),
    Param("off_free_weight", float, 1.0, "Florence addition: factor on the sensor likelihood of particles not on a "
          "free map cell (inside furniture, walls, unknown space or off the map); 1.0 is ROS amcl", ge=0, le=1),
)

NODE = ParamTable(
    Param("transform_tolerance", float, 0.1, "map -> odom is post-dated by this much", unit="s", ge=0),
    Param("initial_pose_x", float, 0.0, "initial mean x", unit="m"),
    Param("initial_pose_y", float, 0.0, "initial mean y", unit="m"),
    Param("initial_pose_a", float, 0.0, "initial mean yaw", unit="rad"),
    Param("initial_cov_xx", float, 0.25, "initial variance of x", unit="m^2", ge=0),
    Param("initial_cov_yy", float, 0.25, "initial variance of y", unit="m^2", ge=0),
    Param("initial_cov_aa", float, (math.pi / 12.0) ** 2, "initial variance of yaw", unit="rad^2", ge=0),
    Param("gui_publish_rate", float, -1.0, "accepted and unused, as in ROS noetic amcl (particlecloud goes out with "
          "every filter update)", unit="Hz"),
    Param("save_pose_rate", float, 0.5, "how often the robot's pose (the published map -> odom applied to the "
          "latest odometry, as ROS's amcl) is stored in ~initial_pose_* and ~initial_cov_* (<= 0 disables)",
          unit="Hz"),
    Param("use_map_topic", bool, False, "take the map from the map topic instead of the static_map service"),
    Param("first_map_only", bool, False, "ignore maps after the first"),
    Param("odom_frame_id", FRAME, "odom", "the odometry frame"),
    Param("base_frame_id", FRAME, "base_link", "the robot's frame"),
    Param("global_frame_id", FRAME, "map", "the map frame"),
    Param("tf_broadcast", bool, True, "publish map -> odom"),
)

