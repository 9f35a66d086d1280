"""Record a fakenect dump of the simulated Kinect, so a simulated scene replays through libfreenect.

    rosrun florence_sim record_fakenect /tmp/scene --people $FLORENCE_MAPS/apartment/people.yaml \\
        --x 1.0 --y 2.5 --yaw 0 --tilt 5 --frames 30 --repeat 10
    FAKENECT_PATH=/tmp/scene rosrun openni_camera openni_camera_node \\
        _library:=/usr/lib/x86_64-linux-gnu/fakenect/libfreenect.so.0.5 \\
        _depth_camera_info_url:=file:///tmp/scene/depth_camera_info.yaml \\
        _rgb_camera_info_url:=file:///tmp/scene/rgb_camera_info.yaml

The dump is what fakenect-record would write from a Kinect in that scene (openni_camera's
fakenect_dump): at each frame the depth rendered in camera_depth_optical_frame (640x480, with
the simulator's noise and edge dropouts unless turned off) as the 11-bit raw disparity the
depth model gives for the simulated camera's focal length (openni_camera.kinect; no return:
2047), the colour rendered in camera_rgb_optical_frame, and the tilt state (accelerometer
counts from the simulated gravity in camera_link, tilt in half degrees, motor status). The
simulated cameras' intrinsics go beside it as camera_calibration YAML files, since they are not
the Kinect's defaults (florence_sim's 58 degree field of view).

``--repeat N`` lists the recorded frames N times in the index (later passes are symbolic links
to the first pass's files): a long replay of a short recording. ``--truth`` also writes
``truth/``: the rendered depth before quantisation, the noiseless depth of the colour camera,
the optical frames' poses and the people (for tests and benchmarks; no product node reads it).
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from florence_sim.sim import TILT_MOVING, SimConfig, Simulator
from openni_camera import camera_info, fakenect_dump, kinect

DEPTH_FRAME, RGB_FRAME = "camera_depth_optical_frame", "camera_rgb_optical_frame"
TICKS_PER_SECOND = 1e6  # the timestamps written: microseconds (the Kinect's own clock rate is not documented)


def sim_camera_info(sim, name):
    cam = sim.camera
    return camera_info.pinhole(cam.cfg.width, cam.cfg.height, cam.fx, cam.cx, cam.cy, name)


def settle_tilt(sim, degrees, timeout=5.0):
    """Command the tilt [deg] and step the simulator until the motor stopped (at most ``timeout`` [s])."""
    sim.set_tilt_degrees(degrees)
    end = sim.time + timeout
    while sim.tilt_status == TILT_MOVING and sim.time < end:
        sim.step()


def record(sim, out_dir, frames, rate=kinect.RATE, repeat=1, truth=False, noise=True, start_time=None,
           progress=None):
    """Write ``frames`` frames at ``rate`` [Hz] of ``sim`` (a Simulator with a 640x480 camera) to the
    dump folder ``out_dir``; returns the list of index names."""
    cfg = sim.camera.cfg
    if (cfg.width, cfg.height) != (kinect.WIDTH, kinect.HEIGHT):
        raise ValueError(f"a fakenect dump is {kinect.WIDTH}x{kinect.HEIGHT}; the simulated camera is "
                         f"{cfg.width}x{cfg.height}")
    if frames < 1 or repeat < 1 or not rate > 0:
        raise ValueError("need frames >= 1, repeat >= 1 and rate > 0")
    writer = fakenect_dump.DumpWriter(out_dir)
    for name, frame in (("depth", DEPTH_FRAME), ("rgb", RGB_FRAME)):
        text = camera_info.to_yaml(sim_camera_info(sim, f"florence_sim_{name}"))
        with open(os.path.join(out_dir, f"{name}_camera_info.yaml"), "w") as f:
            f.write(f"# florence_sim's {frame} (58 deg horizontal field of view), for ~{name}_camera_info_url\n{text}")
    t0 = time.time() if start_time is None else float(start_time)
    sim_start = sim.time
    truths = {"depth": [], "rgb_depth": [], "depth_pose": [], "rgb_pose": [], "robot": [], "tilt": [], "accel": [],
              "times": []}
    people = []
    first_pass = []
    for k in range(frames):
        while sim.time - sim_start + 1e-9 < k / rate:
            sim.step()
        depth, _ = sim.render_camera(DEPTH_FRAME, noise=noise, color=False)
        rgb_depth, rgb = sim.render_camera(RGB_FRAME, noise=False, color=True)
        raw = kinect.metres_to_raw(depth, focal=sim.camera.fx)
        # the dump's clock runs at exactly ``rate`` (the scene is the one of the physics step at or after it)
        t = t0 + k / rate
        tick = round(k / rate * TICKS_PER_SECOND)
        accel = sim.accelerometer()
        tilt_deg = math.degrees(sim.tilt)
        first_pass.append(writer.depth(t, tick, raw))
        first_pass.append(writer.rgb(t + 0.001, tick, rgb))
        first_pass.append(writer.tilt_state(t + 0.002, tick, kinect.camera_link_to_accel(accel),
                                            kinect.tilt_raw(tilt_deg), sim.tilt_status))
        if truth:
            truths["depth"].append(depth.astype(np.float32))
            truths["rgb_depth"].append(rgb_depth.astype(np.float32))
            truths["depth_pose"].append(sim.frame_pose(DEPTH_FRAME))
            truths["rgb_pose"].append(sim.frame_pose(RGB_FRAME))
            truths["robot"].append((sim.base.x, sim.base.y, sim.base.yaw))
            truths["tilt"].append(sim.tilt)
            truths["accel"].append(accel)
            truths["times"].append(t)
            people.append([{"id": p.id, "x": p.x, "y": p.y, "yaw": p.yaw, "shirt": list(p.shirt),
                            "posture": p.posture, "height": p.height, "build": p.build}
                           for p in sim.people.values()])
        if progress:
            progress(k + 1, frames)
    period = frames / rate
    for r in range(1, repeat):
        for name in first_pass:
            match = fakenect_dump.NAME.match(name)
            time_ = float(match.group(2)) + r * period
            tick = int(match.group(3)) + round(r * period * TICKS_PER_SECOND)
            writer.again(name, time_, tick)
    writer.close()
    if truth:
        folder = os.path.join(out_dir, "truth")
        os.makedirs(folder, exist_ok=True)
        np.savez_compressed(os.path.join(folder, "frames.npz"), **{k: np.asarray(v) for k, v in truths.items()})
        with open(os.path.join(folder, "scene.json"), "w") as f:
            json.dump({"people": people, "frames": frames, "rate": rate, "repeat": repeat, "noise": noise,
                       "depth_focal": sim.camera.fx, "baseline": kinect.BASELINE,
                       "disparity_offset": kinect.DISPARITY_OFFSET}, f, indent=1)
    return writer.names


def main(argv=None):
    from florence_common.maps import map_file
    from florence_sim.sensors import CameraConfig

    parser = argparse.ArgumentParser(description="Record a fakenect dump (what fakenect-record writes) of "
                                     "florence_sim's Kinect")
    parser.add_argument("out_dir", help="folder of the dump (created; must not hold a recording)")
    parser.add_argument("--world", default=None, help="world file (default: the apartment)")
    parser.add_argument("--people", default=None, help="people file (default: nobody)")
    parser.add_argument("--x", type=float, default=1.0, help="robot x [m] in the map")
    parser.add_argument("--y", type=float, default=2.5, help="robot y [m] in the map")
    parser.add_argument("--yaw", type=float, default=0.0, help="robot heading [rad]")
    parser.add_argument("--tilt", type=float, default=0.0, help="Kinect tilt [deg], -31..31 (settled first)")
    parser.add_argument("--frames", type=int, default=30, help="frames rendered")
    parser.add_argument("--rate", type=float, default=kinect.RATE, help="frame rate [Hz]")
    parser.add_argument("--repeat", type=int, default=1, help="times the recorded frames are listed (links)")
    parser.add_argument("--seed", type=int, default=0, help="random seed of the simulator's noise")
    parser.add_argument("--no-noise", action="store_true", help="no depth noise (edge dropouts stay)")
    parser.add_argument("--truth", action="store_true", help="also write truth/ (rendered depth, poses, people)")
    args = parser.parse_args(argv)
    if not -kinect.TILT_LIMIT_DEG <= args.tilt <= kinect.TILT_LIMIT_DEG:
        parser.error(f"--tilt must be within +-{kinect.TILT_LIMIT_DEG:g} deg")
    camera = CameraConfig(width=kinect.WIDTH, height=kinect.HEIGHT)
    if args.no_noise:
        camera.depth_noise = 0.0
    try:
        sim = Simulator.from_files(args.world or map_file("apartment", "apartment.world.yaml"), args.people,
                                   config=SimConfig(camera=camera, seed=args.seed), start=(args.x, args.y, args.yaw))
        settle_tilt(sim, args.tilt)
        names = record(sim, args.out_dir, args.frames, args.rate, args.repeat, args.truth, not args.no_noise,
                       progress=lambda k, n: print(f"\rframe {k}/{n}", end="", file=sys.stderr, flush=True))
    except (OSError, ValueError) as exc:  # WorldError is a ValueError
        print(f"\nrecord_fakenect: {exc}", file=sys.stderr)
        return 2
    print(f"\nwrote {len(names)} records ({args.frames} frames x {args.repeat}) to {args.out_dir}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
