"""The robot enablers judged against florence_sim's ground truth (ROS-free): following (distance to
the person, whether the right person was kept), approaching (the final pose against the pose the
goal asked for), and the collision monitor's added latency.

Logs are as florence_eval.enablers_session records them, in simulated time: the robot's true pose
rows (t, x, y, yaw), a person's true rows (t, x, y), the enabler's feedback rows (t, x, y) in the
robot frame, its state rows (t, text), commands (t, wall time, v, w).
"""

import math

import numpy as np

from approach_me import geometry
from florence_common import angles
from florence_common import pose as pose2d
from florence_eval.tour import travelled

PERSONAL_SPACE = 0.45  # [m] centre to centre: the edge of the intimate zone (Hall)
KEPT_RADIUS = 0.5  # [m] the followed position within this of the true person: the right person


def _at(rows, t):
    """The row of ``rows`` (time first, sorted) last at or before each ``t`` (index array; -1: none)."""
    return np.searchsorted(rows[:, 0], t, side="right") - 1


def following(robot, person, feedback, states, desired, since, until):
    """Following, judged over [since, until] [s] on the robot's true pose samples: the centre
    distance's error to ``desired`` [m] (RMS, largest), the least distance, and the share of the
    time the right person was kept (follow_me's state says "following" and its latest feedback,
    placed through the true pose, is within KEPT_RADIUS of the true person)."""
    robot = np.asarray(robot, dtype=float).reshape(-1, 4)
    robot = robot[(robot[:, 0] >= since) & (robot[:, 0] <= until)]
    person = np.asarray(person, dtype=float).reshape(-1, 3)
    if len(robot) < 2 or len(person) < 2:
        return {"samples": 0}
    t = robot[:, 0]
    px = np.interp(t, person[:, 0], person[:, 1])
    py = np.interp(t, person[:, 0], person[:, 2])
    d = np.hypot(px - robot[:, 1], py - robot[:, 2])
    err = d - desired
    kept = np.zeros(len(t), dtype=bool)
    fb = np.asarray(feedback, dtype=float).reshape(-1, 3)
    st_t = np.array([s[0] for s in states])
    if len(fb) and len(st_t):
        i_fb, i_st = _at(fb, t), np.searchsorted(st_t, t, side="right") - 1
        for k in np.flatnonzero((i_fb >= 0) & (i_st >= 0)):
            if not states[i_st[k]][1].startswith("following") or t[k] - fb[i_fb[k], 0] > 0.5:
                continue
            seen = pose2d.transform_points(robot[k, 1:4], [fb[i_fb[k], 1:3]])[0]
            kept[k] = math.hypot(seen[0] - px[k], seen[1] - py[k]) <= KEPT_RADIUS
    return {
        "samples": len(t),
        "seconds": float(t[-1] - t[0]),
        "rms_error_m": float(np.sqrt(np.mean(err ** 2))),
        "max_error_m": float(np.max(np.abs(err))),
        "mean_distance_m": float(np.mean(d)),
        "min_distance_m": float(np.min(d)),
        "kept_fraction": float(np.mean(kept)),
    }


def ideal_following(person, robot_xy, desired, since, until, max_speed=0.5, max_acc=1.0, delay=0.0, dt=0.02,
                    along_trail=False):
    """What a perfect follower would score on ``person``'s true rows (t, x, y) over [since, until] [s]:
    starting at rest at ``robot_xy`` (x, y) [m] at ``since``, it drives straight at the person (turning
    at once, through walls, seeing them without delay) at the speed that brings the distance to
    ``desired`` [m] soonest within ``max_speed`` [m/s] (forward or back) and ``max_acc`` [m/s^2] (the
    base's limits: follow_me's and velocity_filter's 1.0); with ``delay`` [s], it sees where the
    person was (and how fast they went) that long before. With no delay, a bound from below for the
    real robot, which must turn, go round the doorway's jambs and wait for the tracker. With
    ``along_trail``, it goes where the person went instead (as follow_me does, through the doorway they
    took): their walk straightened out (:func:`straightened`), so that no corner is cut and what it loses
    setting off at their speed is never made up. Returns RMS and largest error [m] as :func:`following`
    does, and the mean distance."""
    if along_trail:
        person, robot_xy = straightened(person, robot_xy, since), (0.0, 0.0)
    person = np.asarray(person, dtype=float).reshape(-1, 3)
    t = np.arange(since, until + 1e-9, dt)
    px, py = np.interp(t, person[:, 0], person[:, 1]), np.interp(t, person[:, 0], person[:, 2])
    seen_x, seen_y = np.interp(t - delay, person[:, 0], person[:, 1]), np.interp(t - delay, person[:, 0], person[:, 2])
    vx, vy = np.gradient(seen_x, dt), np.gradient(seen_y, dt)
    r, v = np.array(robot_xy, dtype=float), 0.0
    err = np.empty(len(t))
    for k in range(len(t)):
        err[k] = math.hypot(px[k] - r[0], py[k] - r[1]) - desired
        ux, uy = seen_x[k] - r[0], seen_y[k] - r[1]
        d = math.hypot(ux, uy)
        if d < 1e-9:
            continue
        ux, uy = ux / d, uy / d
        away = vx[k] * ux + vy[k] * uy  # the person's speed away from the robot
        # the speed that closes the gap soonest and arrives at the person's: braking at max_acc
        gap = d - desired
        wanted = away + math.copysign(math.sqrt(2.0 * max_acc * abs(gap)), gap)
        v = float(np.clip(np.clip(wanted, v - max_acc * dt, v + max_acc * dt), -max_speed, max_speed))
        r = r + v * dt * np.array([ux, uy])
    return {"rms_error_m": float(np.sqrt(np.mean(err ** 2))), "max_error_m": float(np.max(np.abs(err))),
            "mean_distance_m": float(np.mean(err) + desired)}


def straightened(person, robot_xy, since):
    """``person``'s rows (t, x, y) laid out along a straight line from a robot at the origin: at ``since``
    [s] as far from it as from ``robot_xy`` (x, y) [m], and on by the length of the way they walked since
    (back by what they walked before). A follower that keeps to their trail sees only this distance."""
    person = np.asarray(person, dtype=float).reshape(-1, 3)
    walked = travelled(person[:, 1:3])
    at = np.interp(since, person[:, 0], walked)
    start = math.hypot(np.interp(since, person[:, 0], person[:, 1]) - robot_xy[0],
                       np.interp(since, person[:, 0], person[:, 2]) - robot_xy[1])
    return np.column_stack([person[:, 0], start + walked - at, np.zeros(len(person))])


def approach_target(person, robot0, distance, p2r):
    """(x, y) of the position the goal asks for, from the person's and the robot's true positions at
    goal time (approach_me.geometry: the product's own definition)."""
    direction = geometry.approach_direction(person, robot0, p2r)
    return geometry.goal_position(person, direction, distance)


def approach_errors(final_pose, person, robot0, person_final, distance, p2r, r2p):
    """(position error [m], heading error [rad]) of the robot's true ``final_pose`` (x, y, yaw)
    against the goal, all true positions: the approach direction from the person's place ``person``
    and the robot's ``robot0`` at goal time, the position from the person's place at the end
    (``person_final``: the same for a person who stood), the heading relative to the line to them."""
    direction = geometry.approach_direction(person, robot0, p2r)
    gx, gy = geometry.goal_position(person_final, direction, distance)
    yaw = geometry.final_heading(final_pose[:2], person_final, r2p)
    return math.hypot(final_pose[0] - gx, final_pose[1] - gy), abs(angles.diff(yaw, final_pose[2]))


def latency(inputs, outputs, window=0.05):
    """The monitor's added latency [s wall]: for each command into it (``inputs``, rows (t, wall, v,
    w)), the first command out of it (``outputs``) within ``window`` s after it. Returns the delays."""
    out_wall = np.array([r[1] for r in outputs])
    delays = []
    for r in inputs:
        k = np.searchsorted(out_wall, r[1])
        if k < len(out_wall) and out_wall[k] - r[1] <= window:
            delays.append(out_wall[k] - r[1])
    return np.array(delays)


def percentiles(values, ps=(50, 90, 99)):
    values = np.asarray(values, dtype=float)
    return {f"p{p}": float(np.percentile(values, p)) if len(values) else None for p in ps}


# --- the approach bench's placements ---------------------------------------------------------------------
ROBOT_HEIGHT = 0.94  # [m] the robot's top (turtlebot_control's description): lower furniture stops it
PERSON_HEIGHT = 1.8  # [m]


def random_approach(scene, rng, tries=2000):
    """One random approach placement in the world ``scene`` (florence_sim's): the robot somewhere free,
    a person standing 1.5-2.2 m in front of it (within 20 degrees of its heading, in the Kinect's view,
    nothing between them), a request (distance 0.5-0.9 m, p2r within +-120 degrees: never from behind,
    r2p within +-0.5 rad) whose goal position and way (geometry.approach_path) keep the robot 0.30 m
    clear of everything up to its height. Returns {"robot": (x, y, yaw), "person": (x, y), "distance",
    "p2r", "r2p"}."""
    def clear(xy, margin, height=ROBOT_HEIGHT):
        dist, _ = scene.clearance(np.asarray(xy, dtype=float).reshape(-1, 2), z_max=height, z_min=0.0)
        return bool(np.all(dist >= margin))

    for _ in range(tries):
        robot = (rng.uniform(0.4, 7.6), rng.uniform(0.4, 9.6), rng.uniform(-math.pi, math.pi))
        rng_m = rng.uniform(1.5, 2.2)
        bearing = robot[2] + rng.uniform(-0.35, 0.35)
        person = (robot[0] + rng_m * math.cos(bearing), robot[1] + rng_m * math.sin(bearing))
        distance, p2r, r2p = rng.uniform(0.5, 0.9), rng.uniform(-2.1, 2.1), rng.uniform(-0.5, 0.5)
        goal = approach_target(person, robot[:2], distance, p2r)
        way = geometry.approach_path(robot[:2], person, goal, math.copysign(1.0, p2r))
        sight = np.linspace(robot[:2], person, 12)[1:-3]
        if (clear([robot[:2]], 0.35) and clear([person], 0.45, PERSON_HEIGHT) and clear([goal], 0.35)
                and clear(way, 0.30) and clear(sight, 0.15, PERSON_HEIGHT)):
            return {"robot": tuple(float(v) for v in robot), "person": tuple(float(v) for v in person),
                    "distance": float(distance), "p2r": float(p2r), "r2p": float(r2p)}
    raise RuntimeError(f"no free approach placement in {tries} tries")


def plot(path, grid, follows, approaches, title):
    """The following runs (robot and person paths) and the approaches (start, person, goal, end) over
    the map, written to ``path``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(13, 7.5))
    for ax in axes:
        ax.imshow(grid.shades(), cmap="gray", origin="lower", extent=grid.extent, vmin=0, vmax=1)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
    ax = axes[0]
    for k, run in enumerate(follows):
        robot, person = np.asarray(run["robot_track"]), np.asarray(run["person_track"])
        ax.plot(person[:, 1], person[:, 2], "-", color="tab:red", lw=1.2, label="person" if k == 0 else None)
        ax.plot(robot[:, 1], robot[:, 2], "-", color="tab:blue", lw=0.9, label="robot" if k == 0 else None)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title("follow_me: robot and person paths", fontsize=9)
    ax = axes[1]
    for run in approaches:
        colour = "tab:green" if run["state"] == "SUCCEEDED" else "tab:red"
        track = np.asarray(run["robot_track"])
        if len(track):
            ax.plot(track[:, 1], track[:, 2], "-", color=colour, lw=0.8, alpha=0.8)
        ax.plot(*run["person"], "o", color="tab:red", ms=4)
        ax.plot(*run["goal"], "x", color="k", ms=4)
    ax.set_title("approach_me: ways to the goal (x) beside the person (o); red: not reached", fontsize=9)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
