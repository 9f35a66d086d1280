"""hokuyo_node.

Hokuyo URG SCIP 2.0 laser driver over pyserial (seed 2.1): /scan, /diagnostics,
~self_test.
"""
