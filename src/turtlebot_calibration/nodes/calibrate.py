#!/usr/bin/python3
from turtlebot_calibration.node import main

main()
