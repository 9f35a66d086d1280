"""florence_harness.

Process harness for tests, the demo and benchmarks: private rosmaster on a free port,
roslaunch runs in their own process group, condition waits.
"""
