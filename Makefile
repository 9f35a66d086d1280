# Florence robot middleware workspace.
#   make demo   - set up, build, run the whole system headless through a scripted day, write a report
#   make test   - set up, build, lint and run every test (what CI runs)
# Both install what they need (Debian packages, pinned PyPI tools) idempotently.

SHELL := /bin/bash
# No -u: devel/setup.bash and Debian's ROS profile hooks read unset variables.
.SHELLFLAGS := -e -o pipefail -c
.DEFAULT_GOAL := help

WS := $(CURDIR)
# Debian's python everywhere: the pyenv python3 on some machines cannot see the
# ROS modules. /usr/local/bin holds the pinned PyPI tools (xacro, ruff).
export PATH := /usr/local/bin:/usr/bin:/bin:/usr/sbin:/sbin:$(PATH)
export ROS_PYTHON_VERSION := 3
# Only Python and C++ message bindings are wanted.
export ROS_LANG_DISABLE := genlisp
SOURCE := source $(WS)/devel/setup.bash
PYTEST_ARGS ?=

.PHONY: help setup build demo test lint bench clean

help:
	@echo "make demo   run the whole Florence system headless through a scripted day, with a report"
	@echo "make test   lint and run every test (CI runs this)"
	@echo "make setup  install Debian and PyPI dependencies only"
	@echo "make build  catkin build only"
	@echo "make bench  run the benchmarks under bench/ (JSON in bench/results/)"

setup:
	$(WS)/tools/setup.sh

build: setup
	catkin_make -C $(WS) -DPYTHON_EXECUTABLE=/usr/bin/python3 -DCATKIN_ENABLE_TESTING=OFF \
	  -DCMAKE_BUILD_TYPE=Release > $(WS)/build.log 2>&1 \
	  || { tail -n 60 $(WS)/build.log; echo "catkin_make failed: see build.log"; exit 1; }
	@echo "build: ok (log in build.log)"

demo: build
	$(SOURCE) && /usr/bin/python3 -m florence_scenarios.demo --output $(WS)/demo_output

lint: setup
	ruff check $(WS)

# One pytest process (one private rosmaster) per ROS test module: see florence_harness/isolated.py.
test: build lint
	$(SOURCE) && /usr/bin/python3 -m florence_harness.isolated $(PYTEST_ARGS)

bench: build
	$(SOURCE) && for b in $(WS)/bench/*.py; do /usr/bin/python3 "$$b" || exit 1; done

clean:
	rm -rf $(WS)/build $(WS)/devel $(WS)/build.log $(WS)/demo_output
