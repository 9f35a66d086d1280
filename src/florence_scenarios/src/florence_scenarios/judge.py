"""The scripted day's judgement against the simulator's ground truth, ROS-free.

Logs as florence_eval.locator_session records them, in simulated time [s]: the robot's true track,
rows (t, x, y, yaw, v, w) [s, m, m, rad, m/s, rad/s]; the people's log, [(t, {id: (x, y, yaw,
posture)})]. The shared measures (how the robot stands to a user, the nearest person, when it
stopped) are florence_eval.locator_metrics'; this module adds what the day reads over its steps.
"""

import math

import numpy as np

PERSONAL_SPACE = 0.45  # [m] centre to centre: the edge of Hall's personal zone


def person_rows(people_log, pid):
    """(N, 3) rows (t, x, y) of person ``pid`` in ``people_log``."""
    rows = [(t, *people[pid][:2]) for t, people in people_log if pid in people]
    return np.array(rows, dtype=float).reshape(-1, 3)


def distance_series(track, person):
    """Centre distance [m] from the robot to a person over the robot's samples: (times, distances);
    the person's position interpolated at each robot stamp within their log's span."""
    track = np.asarray(track, dtype=float)
    person = np.asarray(person, dtype=float).reshape(-1, 3)
    if track.ndim != 2 or len(track) == 0 or len(person) < 2:
        return np.zeros(0), np.zeros(0)
    t = track[:, 0]
    inside = (t >= person[0, 0]) & (t <= person[-1, 0])
    t = t[inside]
    px = np.interp(t, person[:, 0], person[:, 1])
    py = np.interp(t, person[:, 0], person[:, 2])
    return t, np.hypot(px - track[inside, 1], py - track[inside, 2])


def least_distances(track, people_log, windows, excused=()):
    """The robot's least centre distance [m] to each person in each window.

    ``windows``: [(name, since, until)] [s]; ``excused``: {(window name, person id)} whose distance the
    day asked to be small (an approach's end), reported but not held to personal space. Returns
    [{"window", "person", "least_m", "at_s", "excused"}] for every window and person seen in it."""
    out = []
    ids = sorted({pid for _, people in people_log for pid in people})
    for name, since, until in windows:
        rows = track[(track[:, 0] >= since) & (track[:, 0] <= until)] if len(track) else track
        for pid in ids:
            t, d = distance_series(rows, person_rows(people_log, pid))
            if len(d) == 0:
                continue
            k = int(np.argmin(d))
            out.append({"window": name, "person": pid, "least_m": float(d[k]), "at_s": float(t[k]),
                        "excused": (name, pid) in excused})
    return out


def personal_space_kept(least, limit=PERSONAL_SPACE):
    """(kept, the least of the distances that count, its row): every unexcused least distance >= ``limit``."""
    counted = [row for row in least if not row["excused"]]
    if not counted:
        return True, math.inf, None
    worst = min(counted, key=lambda row: row["least_m"])
    return worst["least_m"] >= limit, worst["least_m"], worst


def moved(track, since, until):
    """(distance [m] between the robot's first and last true positions, net turn [rad]) over [since, until]."""
    rows = track[(track[:, 0] >= since) & (track[:, 0] <= until)]
    if len(rows) < 2:
        return 0.0, 0.0
    turn = np.sum(np.angle(np.exp(1j * np.diff(rows[:, 3]))))
    return float(math.hypot(rows[-1, 1] - rows[0, 1], rows[-1, 2] - rows[0, 2])), float(turn)


def cpu_per_node(first, last, sim_seconds):
    """Cores each node used at real time: CPU seconds over the day / simulated seconds.

    ``first``, ``last``: {node: {pid: CPU s}} sampled at the day's start and end (a node restarted in
    between has two pids; one that was gone at the end keeps its last sample). Returns
    ({node: cores}, total cores)."""
    cores = {}
    for node, pids in last.items():
        used = sum(cpu - first.get(node, {}).get(pid, 0.0) for pid, cpu in pids.items())
        cores[node] = used / sim_seconds if sim_seconds > 0 else math.nan
    return cores, float(sum(cores.values()))
