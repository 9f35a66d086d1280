#!/usr/bin/python3
"""Print the README table (markdown) of a node's parameter table.

    source devel/setup.bash && /usr/bin/python3 tools/params_doc.py velocity_filter.node [PARAMS]

Every package README carries the rendered table of each ParamTable its nodes define
(tests/test_packages.py checks that the README and the code agree).
"""

import argparse
import importlib


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("module", help="the module that defines the table, e.g. velocity_filter.node")
    parser.add_argument("name", nargs="?", default="PARAMS", help="the table's name in the module (PARAMS)")
    args = parser.parse_args()
    print(getattr(importlib.import_module(args.module), args.name).markdown())


if __name__ == "__main__":
    main()
