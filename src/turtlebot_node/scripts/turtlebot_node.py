#!/usr/bin/python3
import sys; del sys.path[0]; from turtlebot_node.node import main; main()  # noqa: E402, E702, I001 - this file would shadow the package
