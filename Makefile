# gpr_kinematics: the two commands of the README are `make demo` and `make test`.
#
# `make setup` (idempotent, stamp files) creates .venv with the pinned core requirements and the pinned
# ROS 2 Jazzy wheels (requirements-ros.txt), repairs the wheels' exported CMake files (ros_env fix-wheels)
# and runs `colcon build` at the root (colcon_defaults.yaml: gpr_kinematics and gpr_interfaces) into
# install/. Commands that need ROS run through `python -m gpr_kinematics.ros_env exec --`, which sets the
# environment `source install/setup.bash` would (no system ROS needed).
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.setup-stamp
COLCON_STAMP := install/.colcon-stamp
ROSENV := $(PY) -m gpr_kinematics.ros_env exec --
# Inputs of the colcon build: a change to any of them rebuilds (colcon itself is incremental).
COLCON_INPUTS := $(shell find gpr_interfaces gpr_kinematics config resource -type f \
	-not -path '*/__pycache__/*' -not -name '*.pyc' 2>/dev/null) setup.py setup.cfg package.xml colcon_defaults.yaml

.PHONY: setup test test-ros demo lint clean

$(STAMP): requirements.txt requirements-ros.txt setup.py
	@command -v cmake >/dev/null || { echo 'make setup: cmake not found (apt-get install cmake)' >&2; exit 1; }
	@command -v cc >/dev/null || { echo 'make setup: no C compiler (apt-get install gcc)' >&2; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt -r requirements-ros.txt
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	$(PY) -m gpr_kinematics.ros_env fix-wheels
	touch $(STAMP)

$(COLCON_STAMP): $(STAMP) $(COLCON_INPUTS)
	PATH="$(CURDIR)/$(VENV)/bin:$$PATH" AMENT_PREFIX_PATH="$(CURDIR)/$(VENV)" \
	CMAKE_PREFIX_PATH="$(CURDIR)/$(VENV)" $(VENV)/bin/colcon build \
		--cmake-args -DPython3_EXECUTABLE="$(CURDIR)/$(PY)" -DPYTHON_EXECUTABLE="$(CURDIR)/$(PY)" \
		-DBUILD_TESTING=OFF
	$(PY) -m gpr_kinematics.ros_env check
	touch $(COLCON_STAMP)

setup: $(COLCON_STAMP)

test: setup
	$(ROSENV) $(PY) -m pytest -q test

test-ros: setup
	$(ROSENV) $(PY) -m pytest -q test/test_ros_*.py

# The offline-programming loop: the services called once from a client (nodes.demo), then the paper's sweep
# streamed by trajectory_node, recorded by recorder_node and checked by `gpr verify` (offline_loop).
demo: setup
	$(ROSENV) $(PY) -m gpr_kinematics.nodes.demo
	$(ROSENV) $(PY) -m gpr_kinematics.offline_loop

lint: setup
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) build install log
