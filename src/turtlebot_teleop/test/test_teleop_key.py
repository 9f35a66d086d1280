"""turtlebot_teleop_key under a real pseudo-terminal: the keys typed on the pty's master side as a
terminal sends them (a key, a pause of the terminal's repeat delay, then 30 repeats a second).

ros tier: the node against a private master (commands on its cmd_vel, the terminal's modes, quit,
Ctrl-C, a terminal that closes, no terminal). scenario tier: florence_sim behind the velocity
multiplexer and velocity_filter, the robot judged by the simulator's ground truth: it drives
forward on "i" and stops after the key is released."""

import contextlib
import itertools
import math
import os
import signal
import termios
import threading
import time

import pytest

from florence_common.processes import ManagedProcess, wait_for
from florence_common.pty_device import PtyKeyboard

KEY_TIMEOUT = 0.3  # [s] the node's default ~key_timeout
REPEAT = 1 / 30  # [s]


class Keyboard(PtyKeyboard):
    """A pseudo-terminal: the node reads its slave side, the test types on its master side (and reads
    the terminal's modes the node set)."""

    def __init__(self):
        super().__init__(repeat=1 / REPEAT)
        self.before = termios.tcgetattr(self.slave)

    def modes(self):
        return termios.tcgetattr(self.slave)


def start_teleop(ros_master, keyboard, *args):
    proc = ManagedProcess(["rosrun", "turtlebot_teleop", "turtlebot_teleop_key", *args], env=ros_master.env(),
                          name="turtlebot_teleop_key", stdin=keyboard.slave if keyboard else None)
    if keyboard is not None:
        wait_for(lambda: "currently:" in proc.output() or not proc.running(), 60.0, what="the teleop's first screen")
    return proc


class Commands:
    """(wall time, linear.x, angular.z) of every Twist on ``topic``."""

    def __init__(self, rospy, topic):
        from geometry_msgs.msg import Twist

        self.items, self.lock = [], threading.Lock()
        self.sub = rospy.Subscriber(topic, Twist, self._cb, queue_size=100)

    def _cb(self, msg):
        with self.lock:
            self.items.append((time.monotonic(), msg.linear.x, msg.angular.z))

    def get(self):
        with self.lock:
            return list(self.items)


@pytest.mark.ros
def test_no_terminal_is_a_clear_message(ros_master, wall_time):
    proc = start_teleop(ros_master, None)
    try:
        wait_for(lambda: not proc.running(), 60.0, what="turtlebot_teleop_key to end")
    finally:
        status = proc.stop()
    out = proc.output()
    assert status == 1, out
    assert "standard input is not a terminal: it reads single keys from a terminal" in out
    assert "Traceback" not in out


@pytest.mark.ros
def test_keys_on_a_pty(ros_master, rospy_node, wall_time):
    """Hold i: 0.3 m/s at a steady 10 Hz; release: zero within key_timeout, then silence; the
    terminal without echo and line editing while it runs, as it was after Ctrl-C (typed as a character)."""
    keyboard = Keyboard()
    commands = Commands(rospy_node, "/teleop_test/cmd_vel")
    proc = start_teleop(ros_master, keyboard, "cmd_vel:=/teleop_test/cmd_vel")
    try:
        modes = keyboard.modes()
        assert not modes[3] & (termios.ICANON | termios.ECHO)  # cbreak
        assert modes[3] & termios.ISIG  # Ctrl-C still signals
        wait_for(lambda: commands.sub.get_num_connections() > 0, 30.0, what="the teleop's publisher")
        last = keyboard.hold("i", 2.0)
        wait_for(lambda: any(t > last and lin == 0.0 for t, lin, _ in commands.get()), 5.0, what="a stop")
        time.sleep(1.0)
        got = commands.get()
        moving = [t for t, lin, ang in got if lin == pytest.approx(0.3) and ang == 0.0]
        zeros = [t for t, lin, ang in got if lin == 0.0 and ang == 0.0 and t > last]
        assert len(moving) >= 15, got
        gaps = [b - a for a, b in itertools.pairwise(moving)]
        assert max(gaps) < 0.2, f"commands not steady while the key was held: {gaps}"
        assert zeros[0] - last < KEY_TIMEOUT + 0.15, f"stop {zeros[0] - last:.3f} s after the last key"
        assert len(zeros) == 3 and got[-1][0] == zeros[-1]  # three zeros, then silence
        keyboard.type("q")  # speeds +10 %, shown on screen
        wait_for(lambda: "speed 0.33 m/s\tturn 1.10 rad/s" in proc.output(), 10.0, what="the new speeds")
        keyboard.type("\x03")
        wait_for(lambda: not proc.running(), 20.0, what="quit on Ctrl-C")
    finally:
        status = proc.stop()
        commands.sub.unregister()
    assert status == 0, proc.output()
    assert keyboard.modes() == keyboard.before  # restored
    keyboard.close()


@contextlib.contextmanager
def driving(ros_master, rospy_node, topic, key):
    """turtlebot_teleop_key on a pty publishing on ``topic``, ``key`` typed and its first command
    received: (keyboard, commands, process); the process is stopped afterwards."""
    keyboard = Keyboard()
    commands = Commands(rospy_node, topic)
    proc = start_teleop(ros_master, keyboard, f"cmd_vel:={topic}")
    try:
        wait_for(lambda: commands.sub.get_num_connections() > 0, 30.0, what="the teleop's publisher")
        keyboard.type(key)
        wait_for(commands.get, 10.0, what="a command")
        yield keyboard, commands, proc
    finally:
        proc.stop()
        commands.sub.unregister()


@pytest.mark.ros
def test_sigint_restores_the_terminal_and_stops(ros_master, rospy_node, wall_time):
    with driving(ros_master, rospy_node, "/teleop_test2/cmd_vel", "u") as (keyboard, commands, proc):
        assert keyboard.modes() != keyboard.before
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C does under rosrun
        wait_for(lambda: not proc.running(), 20.0, what="the end on SIGINT")
    assert keyboard.modes() == keyboard.before
    assert commands.get()[-1][1:] == (0.0, 0.0)
    assert "Traceback" not in proc.output()
    keyboard.close()


@pytest.mark.ros
def test_terminal_that_closes(ros_master, rospy_node, wall_time):
    with driving(ros_master, rospy_node, "/teleop_test3/cmd_vel", "i") as (keyboard, commands, proc):
        keyboard.close()  # the window closes while the robot drives
        wait_for(lambda: not proc.running(), 20.0, what="the end when the terminal closed")
    out = proc.output()
    assert proc.proc.returncode == 1, out
    assert "the terminal closed" in out and "robot stopped" in out
    assert "Traceback" not in out
    assert commands.get()[-1][1:] == (0.0, 0.0)


SIM_LAUNCH = """<launch>
  <!-- florence_sim driving on velocity_filter's output behind the multiplexer, as on the robot -->
  <group>
    <remap from="cmd_vel" to="filtered_cmd_vel"/>
    <include file="$(find florence_sim)/launch/florence_sim.launch">
      <arg name="people" value="{people}"/>
      <arg name="x" value="1.0"/>
      <arg name="y" value="2.5"/>
      <arg name="yaw" value="0.0"/>
    </include>
  </group>
  <include file="$(find turtlebot_control)/launch/includes/filters.launch.xml"/>
</launch>
"""


class Truth:
    """Ground-truth poses (wall time of arrival, simulated time, x, y, yaw) of the simulated robot."""

    def __init__(self, rospy):
        from nav_msgs.msg import Odometry

        from florence_common_ros.convert import to_xyyaw

        self.to_xyyaw, self.items, self.lock = to_xyyaw, [], threading.Lock()
        self.sub = rospy.Subscriber("/base_pose_ground_truth", Odometry, self._cb, queue_size=100)

    def _cb(self, msg):
        with self.lock:
            self.items.append((time.monotonic(), msg.header.stamp.to_sec(), *self.to_xyyaw(msg)))

    def at(self, wall):
        """The sample that arrived nearest to ``wall`` (time.monotonic)."""
        with self.lock:
            return min(self.items, key=lambda item: abs(item[0] - wall))

    def since(self, sim_time):
        with self.lock:
            return [item for item in self.items if item[1] >= sim_time]

    def latest(self):
        with self.lock:
            return self.items[-1] if self.items else None


@pytest.mark.scenario
def test_i_drives_forward_and_release_stops_the_robot(ros_master, rospy_node, tmp_path):
    nobody = tmp_path / "nobody.yaml"
    nobody.write_text("people: []\n")
    launch_file = tmp_path / "teleop_sim.launch"
    launch_file.write_text(SIM_LAUNCH.format(people=nobody))
    sim = ManagedProcess(["roslaunch", "--disable-title", str(launch_file)], env=ros_master.env(), name="sim")
    truth = Truth(rospy_node)
    keyboard = Keyboard()
    teleop = None
    try:
        wait_for(lambda: truth.latest() is not None or not sim.running(), 120.0, what="ground truth")
        assert sim.running(), sim.output()
        teleop = start_teleop(ros_master, keyboard, "cmd_vel:=/cmd_vel_mux/input/teleop")
        commands = Commands(rospy_node, "/cmd_vel_mux/input/teleop")
        wait_for(lambda: commands.sub.get_num_connections() > 0, 30.0, what="the teleop's publisher")
        _, _, x0, y0, yaw0 = truth.latest()

        def forward(item):
            return (item[2] - x0) * math.cos(yaw0) + (item[3] - y0) * math.sin(yaw0)

        # hold "i" until the robot is 0.4 m on (judged in the simulation, whatever the machine's load)
        last = keyboard.hold("i", 30.0, until=lambda: forward(truth.latest()) > 0.4)
        at_release = truth.at(last)
        assert forward(at_release) > 0.3, f"only {forward(at_release):.2f} m forward after 30 s of 'i'"
        sideways = -(at_release[2] - x0) * math.sin(yaw0) + (at_release[3] - y0) * math.cos(yaw0)
        assert abs(sideways) < 0.02 and abs(at_release[4] - yaw0) < 0.02, "not straight ahead"
        # the teleop says stop within key_timeout of the last key (wall time: keys are typed in real time)
        wait_for(lambda: truth.latest()[1] > at_release[1] + 2.5, 60.0, what="2.5 simulated s after the release")
        zeros = [t for t, lin, _ in commands.get() if t > last and lin == 0.0]
        assert zeros and zeros[0] - last < KEY_TIMEOUT + 0.15, commands.get()[-5:]
        # the robot is at rest 1.2 simulated s after the release (the stop within key_timeout, then
        # velocity_filter's 0.3 s ramp from 0.3 m/s; the simulator runs at most in real time) and stays
        rest = truth.since(at_release[1] + 1.2)
        drift = max(math.hypot(item[2] - rest[0][2], item[3] - rest[0][3]) for item in rest)
        assert drift < 0.005, f"the robot moved {drift:.3f} m after it should have stopped"
        coast = forward(rest[0]) - forward(at_release)
        assert coast < 0.3 * (KEY_TIMEOUT + 0.4), f"coasted {coast:.2f} m after the last key"
        keyboard.type("\x03")
        wait_for(lambda: not teleop.running(), 20.0, what="quit")
    finally:
        if teleop is not None:
            teleop.stop()
        truth.sub.unregister()
        sim.stop()
        keyboard.close()
        if rospy_node.has_param("/use_sim_time"):
            rospy_node.delete_param("/use_sim_time")
