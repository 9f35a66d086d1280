"""Offline evaluation of the people tracker: florence_sim's core and user_tracker_ni's core in one
process, no ROS.

The simulator (the apartment, people walking their paths, the Create with its odometry errors,
the Kinect's depth with its noise and lost edges, the Hokuyo with its noise) runs in fixed 10 ms
steps. Every camera frame (15 Hz) goes to the depth detector with the colour image and the camera's
pose on the robot, every scan (10 Hz) to the leg detector through the laser's real mount (upside
down), both placed in the odometry frame through the odometry pose of the same instant, as the
node places them through tf; the tracker's output after each camera frame is what the node would
publish. It is what the node sees on a perfectly synchronised machine, and repeatable: the same
seed gives the same run. Judged like the ROS runs (people_metrics: in the robot's base frame, the
tracks through odometry, the people through the true pose).

Used by ``bench/people.py --offline`` and the regression tests. Imports the simulator's core only.
"""

import math
from dataclasses import dataclass

import numpy as np

from florence_common import pose
from florence_common.maps import map_file
from florence_eval import people_metrics
from florence_eval.people_scenarios import Scenario  # noqa: F401 - re-exported for callers

TILT_FRAME = "camera_depth_optical_frame"


@dataclass
class Run:
    """What the tracker published and what truly happened, stamped in simulated time."""

    tracks: list  # (t, {pid: (x, y) odom}, {pid: ni id})
    everyone: list  # (t, {ni id: (x, y) odom}, {ni id: ni id}): every confirmed person (tracked_people)
    people: list  # (t, {person: (x, y) map})
    truth: tuple  # (times [N], poses [N, 3]) map
    odom: tuple  # (times [N], poses [N, 3]) odom
    detections: dict  # sensor -> count of detections
    visible: object = None  # people_metrics.LineOfSight of the world


def _person(spec, pid):
    from florence_sim.people import person_from_spec
    from florence_sim.world import _Reader

    return person_from_spec({**spec, "id": pid}, _Reader("scenario"), pid)


def run(scenario, seed=1, camera=None, params=None, world=None, use_map=True, warmup=1.0, pipeline=None):
    """Play ``scenario``; ``params`` a user_tracker_ni.pipeline.PipelineParams (None: the defaults);
    ``camera`` a florence_sim CameraConfig (None: the simulator's default, 160x120). ``use_map``:
    the tracker has the apartment's map, placed through the true pose (perfect localization:
    the ROS runs use amcl's). For ``warmup`` [s] the people walk and the robot stands with its
    tracker stopped (its laser learns the free floor), as in the ROS runs, where the tracker is
    started a second after the scene is set; the scenario's clock starts after it. ``pipeline``:
    a user_tracker_ni Pipeline to go on with (reset first, as ~Stop and ~Start do: the persistent
    ids it knows are kept, as in the ROS runs, where one node plays every scenario)."""
    from florence_sim.sensors import CameraConfig
    from florence_sim.sim import TILT_JOINT, SimConfig, Simulator
    from user_tracker_ni.pipeline import Pipeline

    from florence_common.camera import Camera

    config = SimConfig(camera=camera or CameraConfig(), seed=seed)
    sim = Simulator.from_files(world or map_file("apartment", "apartment.world.yaml"), None, config=config,
                               start=tuple(scenario.robot))
    for pid, spec in scenario.people.items():
        sim.add_person(_person(spec, pid))
    cam = Camera.from_k(sim.camera.K, config.camera.width, config.camera.height)
    laser = sim.laser
    if pipeline is None:
        pipeline = Pipeline(params)
        if use_map:
            pipeline.set_map(apartment_map())
    else:
        pipeline.reset()
        pipeline.free.reset()  # another simulator: its odometry frame starts anew
    out = Run([], [], [], ([], []), ([], []), pipeline.counts, people_metrics.LineOfSight(sim.world.scene))
    plan = [(v, w, s) for v, w, s in scenario.drive]
    plan_end, command = warmup, (0.0, 0.0)
    while sim.time < scenario.seconds + warmup:
        if sim.time >= plan_end:
            command = (0.0, 0.0)
            if plan:
                v, w, s = plan.pop(0)
                command, plan_end = (v, w), sim.time + s
        sim.base.command(*command, sim.time)
        due = sim.step()
        t, b = sim.time - warmup, sim.base
        tracking = t >= 0
        odom = (b.ox, b.oy, b.oyaw)
        base_in_odom = pose.planar_matrix(*odom)
        odom_in_map = pose.planar_matrix(*b.odom_origin)  # the odometry frame where the robot started
        if "laser" in due:
            pipeline.on_scan(t, sim.scan(), laser.angle_min, laser.increment, laser.range_min, laser.range_max,
                             base_in_odom @ laser.mount, odom_in_map, track=tracking)
        if "camera" in due and tracking:
            depth, rgb = sim.render_camera(TILT_FRAME)
            pipeline.on_depth(t, depth, cam, sim.robot.pose(TILT_FRAME, {TILT_JOINT: sim.tilt}), base_in_odom, rgb,
                              odom_in_map)
            published = pipeline.published()
            limit = pipeline.tracker.params.coast_limit
            out.tracks.append((t, {tr.pid: tr.output(limit) for tr in published},
                               {tr.pid: tr.ni_id for tr in published}))
            everyone = pipeline.tracker.people()
            out.everyone.append((t, {tr.ni_id: tr.output(limit) for tr in everyone},
                                 {tr.ni_id: tr.ni_id for tr in everyone}))
            out.people.append((t, {p.id: (p.x, p.y) for p in sim.people.values()}))
            out.truth[0].append(t)
            out.truth[1].append((b.x, b.y, b.yaw))
            out.odom[0].append(t)
            out.odom[1].append(odom)
    return out


def apartment_map():
    """The shipped apartment map (maps/apartment/apartment.yaml) as the tracker's StaticMap."""
    from map_server.mapfile import load_map
    from user_tracker_ni.static_map import StaticMap

    grid = load_map(str(map_file("apartment", "apartment.yaml")))
    return StaticMap(np.asarray(grid.data).reshape(grid.height, grid.width), grid.resolution, grid.origin)


def frames(result, since=0.5, view=None, everyone=False):
    """people_metrics.Frame of a run's tracker outputs after ``since`` [s] (``everyone``: of every
    confirmed person, tracked_people, instead of the identified users, tracked_users)."""
    truth = (np.array(result.truth[0]), np.array(result.truth[1]).reshape(-1, 3))
    odom = (np.array(result.odom[0]), np.array(result.odom[1]).reshape(-1, 3))
    msgs = [m for m in (result.everyone if everyone else result.tracks) if m[0] >= since]
    return people_metrics.frames(msgs, result.people, truth, odom, view or people_metrics.KinectView(), result.visible)


LASER_VIEW = people_metrics.KinectView(x=0.06, y=0.0, near=0.3, far=4.0, hfov=math.radians(150))


def beside_share(frame_list, gate=0.5):
    """(frames with a person in the laser's view but not the Kinect's, share of them with a track
    within ``gate`` [m] of that person)."""
    beside = [f for f in frame_list if any(not f.care[p] and LASER_VIEW.sees([xy])[0] for p, xy in f.truth.items())]
    tracked = 0
    for f in beside:
        who = [xy for p, xy in f.truth.items() if not f.care[p] and LASER_VIEW.sees([xy])[0]]
        if f.tracks and all(min(math.hypot(hx - x, hy - y) for hx, hy in f.tracks.values()) < gate for x, y in who):
            tracked += 1
    return len(beside), (tracked / len(beside) if beside else None)


# where the laser (0.057 m ahead of the base, 180 deg) sees a person near the robot, the Kinect
# or not: whom move_base must keep its distance from
NEAR_VIEW = people_metrics.KinectView(x=0.057, y=0.0, near=0.3, far=1.5, hfov=math.radians(180),
                                      margin=math.radians(5))


def near_share(frame_list, gate=0.5):
    """(person-frames of people in NEAR_VIEW, share of them with a track within ``gate`` [m]);
    ``frame_list``: people_metrics.frames with ``view=NEAR_VIEW``."""
    seen = tracked = 0
    for f in frame_list:
        for pid, (x, y) in f.truth.items():
            if not f.care[pid]:
                continue
            seen += 1
            tracked += any(math.hypot(hx - x, hy - y) < gate for hx, hy in f.tracks.values())
    return seen, (tracked / seen if seen else None)


def evaluate(scenario, result):
    """people_metrics.evaluate of a run, with the beside-the-robot share and, in the clutter-only
    scenario, every persistent id ever published."""
    fl = frames(result)
    summary = people_metrics.evaluate(fl)
    if scenario.beside:
        summary["beside_frames"], summary["beside_tracked_share"] = beside_share(fl)
    if scenario.clutter:
        summary["tracks_seen"] = sorted({pid for f in fl for pid in f.tracks})
    if scenario.near:
        summary["near_frames"], summary["near_tracked_share"] = near_share(
            frames(result, view=NEAR_VIEW, everyone=True))
    summary["detections"] = dict(result.detections)
    return summary
