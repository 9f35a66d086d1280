"""florence_eval: evaluation of the Florence stack against florence_sim's ground truth.

Not product code: the benches (bench/*.py), the scenario tests and the demo import it; no
product node does. Modules: tour (scripted tours, waypoint follower, estimate errors),
amcl_offline (amcl's core against the simulator's core in one process), amcl_recorder
(ground truth and amcl_pose over ROS), nav_session (move_base goals and what the robot did).
"""
