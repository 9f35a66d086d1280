"""cmd_vel_mux.

Priority multiplexer of velocity commands in front of velocity_filter: teleop above the
enablers (follow_me, approach_me) above move_base, each input with a timeout.
"""
