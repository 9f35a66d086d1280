"""pytest fixtures for tests that need ROS (loaded by the workspace's conftest.py).

Fixtures:
    ros_master (session): a private rosmaster on a free port. The test process's
        environment points at it, so rospy in the test process uses it too. `make test`
        runs each ROS test module in its own process (florence_harness.isolated), so a
        session here is one module.
    rospy_node (session): this test process as a rospy node (initialised once;
        rospy cannot re-initialise in one process).
    tf_buffer (session): a tf2_ros.Buffer fed by a TransformListener.
    publisher (session): ``publisher(topic, msg_class, latch=False)`` returns this
        process's one rospy.Publisher for ``topic``. Tests must not unregister a
        publisher and create another on the same topic: a long-lived subscriber that
        still holds the old connection (same caller URI) skips the new one for good
        (rospy's RegManager checks ``has_connection``), and the test waits forever.
    wall_time (function): the test runs on wall time: a /use_sim_time that an earlier test's
        simulator left on the session's master is deleted (nodes would wait for a /clock).
    launch (function): ``launch(package, file, *args)`` starts a roslaunch against
        the private master; every launch is stopped when the test ends, and its
        output is printed if the test failed.
"""

import os

import pytest

from florence_common.processes import RosMaster, roslaunch, wait_for

__all__ = ["wait_for"]


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    setattr(item, f"rep_{report.when}", report)


@pytest.fixture(scope="session")
def ros_master():
    saved = {k: os.environ.get(k) for k in ("ROS_MASTER_URI", "ROS_HOSTNAME", "ROS_HOME", "ROS_LOG_DIR", "ROS_IP")}
    master = RosMaster().start()
    for key, value in master.env().items():
        if key.startswith("ROS_"):
            os.environ[key] = value
    os.environ.pop("ROS_IP", None)
    try:
        yield master
    finally:
        master.stop()
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


@pytest.fixture(scope="session")
def rospy_node(ros_master):
    import rospy

    rospy.init_node("pytest", anonymous=True, disable_signals=True)
    yield rospy
    rospy.signal_shutdown("test session over")


@pytest.fixture(scope="session")
def tf_buffer(rospy_node):
    import tf2_ros

    buffer = tf2_ros.Buffer()
    listener = tf2_ros.TransformListener(buffer)
    yield buffer
    del listener


@pytest.fixture(scope="session")
def publisher(rospy_node):
    cache = {}

    def get(topic, msg_class, latch=False, queue_size=10):
        name = rospy_node.resolve_name(topic)
        pub = cache.get(name)
        if pub is None:
            pub = cache[name] = rospy_node.Publisher(name, msg_class, queue_size=queue_size, latch=latch)
        elif pub.data_class is not msg_class or pub.impl.is_latch != latch:
            raise ValueError(f"{name} is already published as {pub.data_class._type} (latch={pub.impl.is_latch})")
        return pub

    return get


@pytest.fixture
def wall_time(rospy_node):
    if rospy_node.has_param("/use_sim_time"):
        rospy_node.delete_param("/use_sim_time")


@pytest.fixture
def launch(request, ros_master):
    started = []

    def start(package, launch_file, *args):
        proc = roslaunch(ros_master, package, launch_file, *args)
        started.append(proc)
        return proc

    yield start
    failed = getattr(request.node, "rep_call", None) is not None and request.node.rep_call.failed
    for proc in reversed(started):
        if failed:
            print(f"----- output of {proc.name} -----\n{proc.output()}")
        proc.stop()
