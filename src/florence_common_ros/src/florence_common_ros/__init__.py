"""florence_common_ros: the thin rospy glue every Florence node shares.

Modules: node (``run`` start-up, parameter reading, the safe stop of motion nodes),
convert (messages <-> (x, y, yaw), 4x4 matrices, images through cv_bridge), diagnostics
(diagnostic_updater set-up), behaviour (the action-server base of the behaviours),
mock_move_base (a scriptable move_base action server for tests of behaviours).
"""
