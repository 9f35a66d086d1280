#!/usr/bin/python3
from turtlebot_node.node import main; main()  # noqa: E702, I001 - the two-line executable
