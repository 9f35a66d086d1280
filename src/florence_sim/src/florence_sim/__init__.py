"""florence_sim.

The 2.5D apartment simulator that stands in for the TurtleBot, the Hokuyo and the
Kinect.
"""
