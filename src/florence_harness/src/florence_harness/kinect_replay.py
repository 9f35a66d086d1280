"""The Kinect drivers' tests on fakenect: a dump of a florence_sim scene, its truth, the topics.

    dump = record_dump(tmp / "scene", people=PEOPLE, tilt=8, frames=3, repeat=100)
    truth = Truth(dump)                  # rendered depth, poses, people (truth/ of the recorder)
    proc = start_driver(ros_master, "openni_camera", "openni_camera_node", dump, "__ns:=/camera")
    probe = Probe(rospy, {"/camera/depth/image": Image})
    probe.wait_for("/camera/depth/image", 1, 60)

The recorder runs as a process (florence_sim's record_fakenect), so a test imports nothing of
florence_sim. Nothing here is product code: only tests read the truth.
"""

import json
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import yaml

from florence_common.processes import ManagedProcess, wait_for

FAKENECT_DIR = "/usr/lib/x86_64-linux-gnu/fakenect"
FAKENECT_LIBRARY = f"{FAKENECT_DIR}/libfreenect.so.0.5"
OPTICAL_IN_FRAME = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # optical axes in camera_*_frame


def record_dump(folder, people=None, x=1.0, y=2.5, yaw=0.0, tilt=0.0, frames=3, repeat=1, noise=False,
                timeout=180.0):
    """Record a dump of the apartment with ``people`` (a list of people-file entries, or None) into
    ``folder`` with its truth; returns the folder (a Path)."""
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    argv = [sys.executable, "-m", "florence_sim.fakenect_record", str(folder), "--x", str(x), "--y", str(y),
            "--yaw", str(yaw), "--tilt", str(tilt), "--frames", str(frames), "--repeat", str(repeat), "--truth"]
    if people:
        people_file = folder.parent / f"{folder.name}.people.yaml"
        people_file.write_text(yaml.safe_dump({"people": people}))
        argv += ["--people", str(people_file)]
    if not noise:
        argv.append("--no-noise")
    done = subprocess.run(argv, capture_output=True, text=True, timeout=timeout, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"record_fakenect failed ({done.returncode}):\n{done.stderr[-3000:]}")
    return folder


class Truth:
    """What the recorder rendered (truth/frames.npz, truth/scene.json)."""

    def __init__(self, dump):
        dump = Path(dump)
        with np.load(dump / "truth" / "frames.npz") as data:
            self.frames = {k: data[k] for k in data.files}
        self.scene = json.loads((dump / "truth" / "scene.json").read_text())
        self.people = self.scene["people"][0]

    def depth(self, k=0):
        return self.frames["depth"][k]

    def rgb_points_in_map(self, rgb_info, k=0):
        """(H, W, 3) points [m] in the map of the colour camera's noiseless depth (NaN: none)."""
        z = self.frames["rgb_depth"][k].astype(np.float64)
        h, w = z.shape
        u, v = np.meshgrid(np.arange(w), np.arange(h))
        xyz = np.stack([(u - rgb_info[2]) / rgb_info[0] * z, (v - rgb_info[5]) / rgb_info[4] * z, z], axis=-1)
        pose = self.frames["rgb_pose"][k]
        return xyz @ pose[:3, :3].T + pose[:3, 3]

    def frame_pose(self, which, k=0):
        """4x4 pose in the map of camera_depth_frame / camera_rgb_frame (the optical frame's parent)."""
        optical = self.frames[f"{which}_pose"][k]
        pose = np.eye(4)
        pose[:3, :3] = optical[:3, :3] @ OPTICAL_IN_FRAME.T
        pose[:3, 3] = optical[:3, 3]
        return pose


def start_driver(ros_master, package, executable, dump, *args, name=None, fakenect_env=True, env=None):
    """A driver node process against ``ros_master`` replaying ``dump`` (FAKENECT_PATH)."""
    import rospkg

    path = Path(rospkg.RosPack().get_path(package)) / "nodes" / executable
    extra = {"FAKENECT_PATH": str(dump)} if fakenect_env and dump is not None else {}
    extra.update(env or {})
    environ = ros_master.env(**extra)
    if not fakenect_env:
        environ.pop("FAKENECT_PATH", None)
    return ManagedProcess(["/usr/bin/python3", str(path), *args], env=environ, name=name or executable)


class Probe:
    """Subscribers keeping every topic's last message and count, and /diagnostics by status name."""

    def __init__(self, rospy, topics, diagnostics_prefix=None):
        from diagnostic_msgs.msg import DiagnosticArray

        self.lock = threading.Lock()
        self.last, self.count, self.diags = {}, dict.fromkeys(topics, 0), {}
        self.prefix = diagnostics_prefix
        self.subs = [rospy.Subscriber(t, cls, self._on, callback_args=t, queue_size=2, buff_size=1 << 24)
                     for t, cls in topics.items()]
        if diagnostics_prefix is not None:
            self.subs.append(rospy.Subscriber("/diagnostics", DiagnosticArray, self._on_diag, queue_size=50))

    def _on(self, msg, topic):
        with self.lock:
            self.last[topic] = msg
            self.count[topic] += 1

    def _on_diag(self, msg):
        for status in msg.status:
            if status.name.startswith(self.prefix):
                with self.lock:
                    self.diags[status.name[len(self.prefix):]] = (status.level, status.message,
                                                                   {v.key: v.value for v in status.values})

    def n(self, topic):
        with self.lock:
            return self.count[topic]

    def get(self, topic):
        with self.lock:
            return self.last.get(topic)

    def diag(self, name):
        with self.lock:
            return self.diags.get(name, (None, "", {}))

    def wait_for(self, topic, more=1, timeout=60.0):
        """The first message of ``topic`` after ``more`` new ones arrived."""
        start = self.n(topic)
        wait_for(lambda: self.n(topic) >= start + more, timeout, what=f"{more} messages on {topic}")
        return self.get(topic)

    def close(self):
        for sub in self.subs:
            sub.unregister()


def cloud_xyz_rgb(msg):
    """(H, W, 3) float32 points and (H, W, 3) uint8 colours of a PointCloud2 (x, y, z, rgb at 0, 4, 8, 12)."""
    offsets = {f.name: f.offset for f in msg.fields}
    assert offsets == {"x": 0, "y": 4, "z": 8, "rgb": 12}, offsets
    data = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.width, msg.point_step)
    xyz = data[..., :12].copy().view(np.float32).reshape(msg.height, msg.width, 3)
    packed = data[..., 12:16].copy().view(np.uint32).reshape(msg.height, msg.width)
    rgb = np.stack([(packed >> 16) & 255, (packed >> 8) & 255, packed & 255], axis=-1).astype(np.uint8)
    return xyz, rgb


def stop_together(procs):
    """Stop processes all at once (each by its process group, as ManagedProcess.stop does): a node's
    orderly shutdown takes seconds on a loaded machine, and one after the other they add up.
    Prints the output of any that had ended before."""
    procs = list(procs)
    for proc in procs:
        if not proc.running():
            print(f"----- {proc.name} exited early -----\n{proc.output()}")
    threads = [threading.Thread(target=proc.stop, daemon=True) for proc in procs]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60.0)
