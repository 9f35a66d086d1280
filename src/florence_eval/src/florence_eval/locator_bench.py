"""bench/locator.py's runs: gotoUser over random placements of the user and the robot in
florence_sim, judged by ground truth (issue 20's targets).

Each run: the user somewhere free in a random room (standing or sitting, facing anywhere), the robot
somewhere free in another room (carried there; amcl told, as a user does in rviz), the locator told
the user's room as a home sensor would (setUserPosRoom), then gotoUser. With ``user_xy`` the
locator is told the user's true pose instead (help from ground truth, reported apart).
"""

import math
import time

import numpy as np

from florence_eval import locator_metrics

TARGETS = {"success_rate": 0.95, "distance_m": (0.35, 0.65), "facing_error_deg": 20.0,
           "nearest_person_m": locator_metrics.PERSONAL_SPACE, "collisions": 0}
SHIRTS = [[0.85, 0.1, 0.1], [0.1, 0.3, 0.85], [0.1, 0.6, 0.2], [0.9, 0.7, 0.1]]


def free_points(grid, clearance):
    """(N, 2) centres [m] of the cells of ``grid`` (map_server GridMap) at least ``clearance`` [m] from any
    cell that is not free."""
    from scipy.ndimage import distance_transform_edt

    dist = distance_transform_edt(grid.data == 0) * grid.resolution
    rows, cols = np.nonzero(dist >= clearance)
    return np.column_stack([grid.origin[0] + (cols + 0.5) * grid.resolution,
                            grid.origin[1] + (rows + 0.5) * grid.resolution])


def placements(rooms, grid, count, rng, user_clearance=0.55, robot_clearance=0.45, hotspot_gap=0.6):
    """``count`` placements: (room, user spec for florence_sim, robot pose (x, y, yaw)). The user stands
    ``user_clearance`` [m] clear of the keep-out map (a person and the robot beside them fit) and
    ``hotspot_gap`` [m] from the room's hotspot (where the robot arrives); the robot in another room."""
    users = free_points(grid, user_clearance)
    robots = free_points(grid, robot_clearance)
    user_rooms, robot_rooms = rooms.rooms_at(users), rooms.rooms_at(robots)
    labels = [r for r in rooms.labels() if np.any(user_rooms == r)]
    out = []
    while len(out) < count:
        room = labels[rng.integers(len(labels))]
        spot = rooms.hotspots.get(room)
        pool = users[user_rooms == room]
        if spot is not None:
            pool = pool[np.hypot(pool[:, 0] - spot.x, pool[:, 1] - spot.y) >= hotspot_gap]
        if not len(pool):
            continue
        ux, uy = pool[rng.integers(len(pool))]
        others = robots[(robot_rooms != room) & (robot_rooms != "unknown")]
        rx, ry = others[rng.integers(len(others))]
        user = {"pose": [round(float(ux), 2), round(float(uy), 2), round(float(rng.uniform(-math.pi, math.pi)), 2)],
                "posture": "sitting" if rng.random() < 0.5 else "standing",
                "shirt": SHIRTS[rng.integers(len(SHIRTS))]}
        out.append((room, user, (float(rx), float(ry), float(rng.uniform(-math.pi, math.pi)))))
    return out


def run_one(session, room, user, robot, user_xy=False, sim_timeout=300.0):
    """One gotoUser run; returns its record (ground truth judged)."""
    session.remove_people()
    session.place_robot(robot)
    session.set_person("user", **user)
    session.wait_sim(1.0)  # the tracker sees the scene
    told = session.call("setUserPosXYPhi", *user["pose"]) if user_xy else session.call("setUserPosRoom", room)
    collisions0 = session.collisions
    t0, wall0 = session.sim_now(), time.monotonic()
    res, done, took = session.goto_user(sim_timeout)
    session.wait_sim(0.5)
    state = done.status if done is not None else "REFUSED"
    text = done.message if done is not None else res.message
    truth = session.person("user")
    track = session.track(t0)
    record = {
        "room": room, "user": user, "robot_start": [round(v, 3) for v in robot], "told": told.message,
        "state": state, "text": text, "time_s": round(took, 2), "wall_s": round(time.monotonic() - wall0, 1),
        "collisions": session.collisions - collisions0,
        "track": np.round(track[::5, :4], 3).tolist(),
    }
    if truth is not None and len(track):
        result = locator_metrics.approach(session.robot(), truth)
        record.update(result.as_dict())
        nearest, when, _pid = locator_metrics.nearest_person(track, session.people_log(t0))
        record["nearest_person_m"] = round(nearest, 3)
        record["nearest_at_s"] = round(when - t0, 2) if math.isfinite(when) else None
        found = session.detected_since(t0)
        if found is not None:
            record["found_at_s"] = round(found - t0, 2)
            near_approach, _, _ = locator_metrics.nearest_person(track, session.people_log(t0), since=found)
            record["nearest_in_approach_m"] = round(near_approach, 3)
    return record


def summarise(runs):
    n = len(runs)
    ok = [r for r in runs if r["state"] == "SUCCEEDED"]
    lo, hi = TARGETS["distance_m"]
    dist = [r["distance_m"] for r in ok if "distance_m" in r]
    facing = [abs(r["facing_error_deg"]) for r in ok if "facing_error_deg" in r]
    nearest = [r["nearest_person_m"] for r in runs if "nearest_person_m" in r]
    nearest_approach = [r["nearest_in_approach_m"] for r in runs if "nearest_in_approach_m" in r]
    times = [r["time_s"] for r in ok]
    sides = {}
    for r in ok:
        key = f"{r.get('posture', '?')}: {r.get('side', '?')}"
        sides[key] = sides.get(key, 0) + 1
    return {
        "runs": n, "succeeded": len(ok), "success_rate": len(ok) / n if n else None,
        "outcomes": {s: sum(r["state"] == s for r in runs) for s in sorted({r["state"] for r in runs})},
        "distance_within_target": sum(lo <= d <= hi for d in dist), "distance_m_min": min(dist, default=None),
        "distance_m_median": locator_metrics.percentile(dist, 50), "distance_m_max": max(dist, default=None),
        "facing_error_deg_median": locator_metrics.percentile(facing, 50),
        "facing_error_deg_max": max(facing, default=None),
        "facing_within_target": sum(f <= TARGETS["facing_error_deg"] for f in facing),
        "nearest_person_m_min": min(nearest, default=None),
        "runs_nearer_than_personal_space": sum(d < TARGETS["nearest_person_m"] for d in nearest),
        "nearest_in_approach_m_min": min(nearest_approach, default=None),
        "runs_nearer_than_personal_space_in_approach": sum(d < TARGETS["nearest_person_m"] for d in nearest_approach),
        "collisions": sum(r["collisions"] for r in runs),
        "time_s_median": locator_metrics.percentile(times, 50), "time_s_p90": locator_metrics.percentile(times, 90),
        "sides": dict(sorted(sides.items())),
        "targets": TARGETS,
    }


def plot_runs(path, grid, runs, title):
    """One panel per run: the map, the robot's path from its start (blue; red when the run failed), the user
    (a dot and an arrow for the way they face; a square when sitting) and the final robot pose."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = 5
    rows = max(1, math.ceil(len(runs) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.0 * cols, 3.6 * rows), squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for k, (ax, run) in enumerate(zip(axes.ravel(), runs, strict=False)):
        ax.imshow(grid.shades(), cmap="gray", origin="lower", extent=grid.extent, vmin=0, vmax=1)
        track = np.asarray(run["track"]).reshape(-1, 4)
        color = "tab:blue" if run["state"] == "SUCCEEDED" else "tab:red"
        if len(track):
            ax.plot(track[:, 1], track[:, 2], "-", color=color, lw=1.0)
            ax.plot(track[0, 1], track[0, 2], "o", color=color, ms=3)
            x, y, yaw = track[-1, 1:4]
            ax.arrow(x, y, 0.35 * math.cos(yaw), 0.35 * math.sin(yaw), color=color, width=0.03)
        ux, uy, uyaw = run["user"]["pose"]
        ax.plot(ux, uy, "s" if run["user"]["posture"] == "sitting" else "o", color="tab:orange", ms=5)
        ax.arrow(ux, uy, 0.35 * math.cos(uyaw), 0.35 * math.sin(uyaw), color="tab:orange", width=0.03)
        label = f"{k + 1}: {run['state']} {run['time_s']:.0f} s"
        if "distance_m" in run:
            label += f"\n{run['distance_m']:.2f} m, {run['facing_error_deg']:+.0f} deg, {run.get('side', '')}"
        ax.set_title(label, fontsize=7)
        ax.axis("on")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
