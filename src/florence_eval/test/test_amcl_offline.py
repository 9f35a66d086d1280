"""amcl against florence_sim's core in one process (florence_eval.amcl_offline): the launch file's values on one lap of
the apartment tour, and the launch-file reader. Needs the built workspace (xacro finds turtlebot_control)."""

import math

import numpy as np
import pytest
from florence_eval.amcl_offline import LAUNCH, global_starts, launch_params, make_config

pytestmark = pytest.mark.unit

pytest.importorskip("florence_sim")
pytest.importorskip("xacro")


def test_launch_params_are_typed_and_args_substituted(tmp_path):
    path = tmp_path / "x.launch"
    path.write_text('<launch><arg name="a" default="1.5"/><node pkg="amcl" type="amcl" name="amcl">'
                    '<param name="initial_pose_x" value="$(arg a)"/><param name="tf_broadcast" value="false"/>'
                    '<param name="laser_model_type" value="beam"/><param name="max_particles" value="7"/>'
                    '</node><node pkg="x" type="y" name="other"><param name="max_particles" value="9"/></node>'
                    '</launch>')
    assert launch_params(path) == {"initial_pose_x": 1.5, "tf_broadcast": False, "laser_model_type": "beam",
                                   "max_particles": 7}
    assert launch_params(path, args={"a": 2})["initial_pose_x"] == 2
    config = make_config(launch_params(LAUNCH), laser_sigma_hit=0.3)
    assert config.laser.sigma_hit == 0.3 and config.laser_max_beams == 60


def test_global_starts_head_along_the_loop():
    starts = global_starts()
    assert len(starts) == 8
    assert starts[0][:2] == (1.0, 2.5) and starts[0][2] == pytest.approx(math.atan2(2.3, 0.2))


@pytest.mark.timeout(300)
def test_tracking_one_lap_with_the_launch_values():
    """Regression (issue 5 follow-up): the interpolated likelihood field put obstacle surfaces on the cells'
    edges and scored endpoints inside walls like hits: a forward bias of about 3 cm along the heading and
    position RMS 4.1-5.0 cm on two laps (seeds 1-3). Measured after the fix: 3.5-4.3 cm, bias 2.4-2.6 cm,
    most of which is the simulated odometry's +1 % scale error."""
    from florence_eval.amcl_offline import run_tracking

    summary = run_tracking(launch_params(), length=18.0, sim_seed=1, amcl_seed=1).tracking_summary()
    assert summary["complete"] and summary["collisions"] == 0
    assert summary["position_rms_m"] <= 0.045, summary
    assert summary["yaw_rms_deg"] <= 1.0, summary
    assert abs(summary["along_mean_m"]) <= 0.03, summary
    assert np.isfinite(summary["update_p50_ms"])


def test_launch_motion_model_spreads_resampled_copies():
    """Regression (issue: global localization within 10 m): resampling duplicates particles and only the motion
    model spreads the copies. With ROS's legacy "diff" model and alphas 0.2 (the variance terms used as standard
    deviations) one 0.12 m update adds about 3 mm and 0.2 deg, so after global_localization the particles nearest
    the true pose (0.2-0.4 m and a few degrees away, where the likelihood field scores like a random pose) never
    reached it. The launch values must spread copies by at least the peak's width over 1 m of driving."""
    from amcl.motion import sample_motion

    config = make_config(launch_params(LAUNCH))
    rng = np.random.default_rng(4)
    particles = np.zeros((4000, 3))
    odom = np.zeros(3)
    for _ in range(8):  # 8 updates of 0.12 m (update_min_d 0.1 at 0.3 m/s and 10 Hz scans): about 1 m
        new = odom + np.array([0.12, 0.0, 0.0])
        particles = sample_motion(particles, odom, new, config.odom_alphas, config.odom_model_type, rng)
        odom = new
    assert np.std(particles[:, 0]) >= 0.05  # [m] along the path
    assert np.std(particles[:, 1]) >= 0.05  # [m] across it (from the heading noise)
    assert math.degrees(np.std(particles[:, 2])) >= 3.0


@pytest.mark.timeout(300)
@pytest.mark.parametrize(("seed", "start"), [(1, 6), (2, 2)])
def test_global_localization_converges_within_10_m(seed, start):
    """Regression (issue: "from global_localization, converged within 10 m of travel"): with the legacy "diff"
    model (alphas 0.2) these starts never converged in 15 m (bench/amcl.py --offline: 10/16 trials); the set
    shrank onto a wrong pose 1.3 m off (seed 1, start 6) while the particles near the true pose stayed 0.2-0.4 m
    away from it. Measured with diff-corrected 0.05: 1.5 m and 1.2 m."""
    from florence_eval.amcl_offline import run_global

    _, at = run_global(launch_params(), start, sim_seed=seed, amcl_seed=seed + 100, max_drive=12.0)
    assert at is not None and at <= 10.0, at
