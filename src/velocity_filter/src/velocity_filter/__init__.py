"""velocity_filter.

Florence velocity filter (seed 3.6): acceleration- and speed-limited cmd_vel at a fixed
rate, ramping to zero when commands stop; the last node before the motors.
"""
