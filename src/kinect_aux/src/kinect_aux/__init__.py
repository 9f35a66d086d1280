"""kinect_aux.

Kinect tilt motor, LED and accelerometer interface (seed 2.2.2): /tilt_angle,
/led_options, /cur_tilt_angle, /cur_tilt_status, /imu.
"""
