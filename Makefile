# gpr_kinematics: the two commands of the README are `make demo` and `make test`.
#
# `make setup` (idempotent, stamp files) creates .venv with the pinned core requirements and the pinned
# ROS 2 Jazzy wheels (requirements-ros.txt; pip compiles their bytecode, and compileall the package's: where
# PYTHONDONTWRITEBYTECODE is set, as on the machines the tests were timed on, nothing else would, and every node a ROS
# test starts compiled what it imports again: 0.2 s more a node for the package, a quarter more CPU time for the ROS
# runs without pip's), repairs the wheels' exported CMake files (ros_env fix-wheels)
# and runs `colcon build` at the root (colcon_defaults.yaml: gpr_kinematics and gpr_interfaces, symlink install,
# so the nodes run the working tree's code; plus fallback/tf2_msgs where no tf2_msgs is installed) into
# install/. Commands that need ROS run through `python -m gpr_kinematics.ros.env exec --`, which sets the
# environment `source install/setup.bash` would (no system ROS needed); the tests activate it themselves
# (test/conftest.py).
#
# `make test` runs the two setups side by side, then every test (lint, mypy and the ROS tests included; as three
# runs, the ROS tests and the rest in two halves) and the tests not marked slow once more on the versions of a stock ROS 2 Jazzy install (Python 3.12, numpy 1.26.4, scipy 1.11.4,
# matplotlib 3.7.3, PyYAML 6.0.1: requirements-stock.txt) in .venv-stock with its own colcon build.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.setup-stamp
COLCON_STAMP := install/.colcon-stamp
ROSENV := $(PY) -m gpr_kinematics.ros.env exec --
# The stock-install check: Python 3.12 from pyenv, its own venv, build and install trees.
STOCK_PYTHON ?= env PYENV_VERSION=3.12.1 python
STOCK_VENV := .venv-stock
STOCK_PY := $(STOCK_VENV)/bin/python
STOCK_STAMP := $(STOCK_VENV)/.setup-stamp
STOCK_INSTALL := install-stock
STOCK_COLCON_STAMP := $(STOCK_INSTALL)/.colcon-stamp
# The ROS domains of `make test`'s five runs: GPR_TEST_ROS_DOMAIN_ID (or one from the shell's pid) and the next four.
TEST_DOMAIN := $(or $(GPR_TEST_ROS_DOMAIN_ID),$(shell expr 10 + $$$$ % 200))
DOMAIN_OF = GPR_TEST_ROS_DOMAIN_ID=$(shell expr \( $(TEST_DOMAIN) + $(1) \) % 233)
# Inputs of the colcon build: a change to any of them rebuilds (colcon itself is incremental).
COLCON_INPUTS := $(shell find gpr_interfaces fallback $(addprefix gpr_kinematics/,config resource launch rviz urdf) -type f \
	-not -path '*/__pycache__/*' -not -name '*.pyc' 2>/dev/null) $(addprefix gpr_kinematics/,setup.py setup.cfg package.xml) \
	colcon_defaults.yaml
# colcon build, with the interpreter and prefix of the venv given as $(1) (python) and $(2) (venv folder),
# into build $(3) and install $(4).
define COLCON_BUILD
	PATH="$(CURDIR)/$(2)/bin:$$PATH" AMENT_PREFIX_PATH="$(CURDIR)/$(2)" CMAKE_PREFIX_PATH="$(CURDIR)/$(2)" \
	$(2)/bin/colcon build --build-base $(3) --install-base $(4) \
		--base-paths $$($(1) -m gpr_kinematics.ros.env base-paths) \
		--cmake-args -DPython3_EXECUTABLE="$(CURDIR)/$(1)" -DPYTHON_EXECUTABLE="$(CURDIR)/$(1)" -DBUILD_TESTING=OFF
endef

.PHONY: setup setup-stock test test-pinned test-pinned-ros test-pinned-rest-1 test-pinned-rest-2 test-quick test-core test-ros test-stock test-stock-run test-stock-ros test-stock-rest demo lint clean

$(STAMP): requirements.txt requirements-ros.txt requirements-test.txt gpr_kinematics/setup.py
	@command -v cmake >/dev/null || { echo 'make setup: cmake not found (apt-get install cmake)' >&2; exit 1; }
	@command -v cc >/dev/null || { echo 'make setup: no C compiler (apt-get install gcc)' >&2; exit 1; }
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt -r requirements-ros.txt
	$(PY) -m pip install --quiet --no-deps -r requirements-test.txt
	$(PY) -m pip install --quiet --no-deps --no-build-isolation --config-settings editable_mode=compat -e gpr_kinematics
	$(PY) -m compileall -q gpr_kinematics/gpr_kinematics
	$(PY) -m gpr_kinematics.ros.env fix-wheels
	touch $(STAMP)

$(COLCON_STAMP): $(STAMP) $(COLCON_INPUTS)
	$(call COLCON_BUILD,$(PY),$(VENV),build,install)
	$(PY) -m gpr_kinematics.ros.env check
	touch $(COLCON_STAMP)

setup: $(COLCON_STAMP)

# The stock ROS 2 Jazzy versions (Ubuntu 24.04): Python 3.12 and the pins of requirements-stock.txt, the same ROS
# wheels (built for 3.12), the package installed from the working tree.
$(STOCK_STAMP): requirements.txt requirements-stock.txt requirements-ros.txt requirements-test.txt gpr_kinematics/setup.py
	test -x $(STOCK_PY) || $(STOCK_PYTHON) -m venv $(STOCK_VENV)
	$(STOCK_PY) -m pip install --quiet --upgrade pip
	awk -F'==' 'NR == FNR { if (NF == 2 && $$0 !~ /^#/) pin[tolower($$1)] = $$0; next } \
		{ name = tolower($$1); print ((name in pin) ? pin[name] : $$0) }' \
		requirements-stock.txt requirements.txt > $(STOCK_VENV)/requirements.txt
	awk -F'==' 'NR == FNR { if (NF == 2 && $$0 !~ /^#/) pin[tolower($$1)] = $$0; next } \
		{ name = tolower($$1); print ((name in pin) ? pin[name] : $$0) }' \
		requirements-stock.txt requirements-ros.txt > $(STOCK_VENV)/requirements-ros.txt
	$(STOCK_PY) -m pip install --quiet -r $(STOCK_VENV)/requirements.txt -r $(STOCK_VENV)/requirements-ros.txt
	$(STOCK_PY) -m pip install --quiet --no-deps -r requirements-test.txt
	$(STOCK_PY) -m pip install --quiet --no-deps --no-build-isolation --config-settings editable_mode=compat -e gpr_kinematics
	$(STOCK_PY) -m compileall -q gpr_kinematics/gpr_kinematics
	$(STOCK_PY) -m gpr_kinematics.ros.env fix-wheels
	touch $(STOCK_STAMP)

$(STOCK_COLCON_STAMP): $(STOCK_STAMP) $(COLCON_INPUTS)
	$(call COLCON_BUILD,$(STOCK_PY),$(STOCK_VENV),build-stock,$(STOCK_INSTALL))
	GPR_INSTALL_DIR=$(CURDIR)/$(STOCK_INSTALL) $(STOCK_PY) -m gpr_kinematics.ros.env check
	touch $(STOCK_COLCON_STAMP)

setup-stock: $(STOCK_COLCON_STAMP)

# The pinned suite and the stock one run side by side, each run in its own ROS domain (DOMAIN_OF 0 to 4): five runs,
# three at a time. The ROS tests wait on DDS and timers (about 57 % of a core in a run alone: 432 s of wall time on
# 251 s of CPU for the stock ROS tests, measured 2026-12-06), so the two ROS runs start first, beside the stock run's
# rest, and the pinned rest's two parts take each core a ROS run leaves: the whole is about the CPU time of all five
# runs over two cores (two at a time, the stock run whole, left a core idle while its ROS tests waited). The first
# part of the pinned rest (calibration, bags, safety, lint and types) starts when the stock ROS tests end, the second
# (the rest, with the slip bound's 100 kHz scans: ~85 s) when the next run ends; measured in a fresh-clone run of
# 2026-12-08 on an idle machine (wall and CPU seconds): setup 221 and 406, the stock ROS tests 401 and 215, the stock
# rest 491 and 387, the pinned ROS tests 771 and 361, the parts 491 and 398, 462 and 361 (the second ending 28 s
# before the first), 1,174 s in all: 2,128 CPU-s over two cores, 91 % of them busy (the same commit took 1,391 s in the run
# before on this kind of machine: the wall time follows the machine's speed and load).
PINNED_HALF := $(filter-out test/test_calibration_fit.py test/test_safety_slip_bound.py,$(wildcard test/test_calibration_*.py test/test_ros_*.py \
	test/test_bag_*.py test/test_safety_*.py test/test_lint.py test/test_types.py test/test_layout.py))
PINNED_NOT_ROS = $(call DOMAIN_OF,$(1)) $(PY) -m pytest -q -p no:cacheprovider --durations=10 -m 'not ros'
# The stock run (Python 3.12 and a stock install's versions) with pytest's marker expression $(2), in domain $(1).
STOCK_RUN = GPR_INSTALL_DIR=$(CURDIR)/$(STOCK_INSTALL) $(call DOMAIN_OF,$(1)) $(STOCK_PY) -m pytest -q -p no:cacheprovider \
	--durations=10 test -m $(2) --ignore test/test_lint.py --ignore test/test_types.py --ignore test/test_layout.py

# The runs share two cores: the threads of numpy's and scipy's OpenBLAS, waiting for work by spinning, took CPU time the
# other runs needed (four test modules alone: 82 CPU-s with them, 47 with one thread, the same wall time), so each
# run of `make test` has one BLAS thread.
test: export OPENBLAS_NUM_THREADS = 1
test:
	$(MAKE) --no-print-directory -j2 setup setup-stock
	$(MAKE) --no-print-directory --output-sync=target -j3 test-pinned-ros test-stock-ros test-stock-rest \
		test-pinned-rest-1 test-pinned-rest-2

test-pinned:
	$(PY) -m pytest -q test

test-pinned-ros:
	$(call DOMAIN_OF,0) $(PY) -m pytest -q --durations=10 -m ros test

test-pinned-rest-1:
	$(call PINNED_NOT_ROS,1) $(PINNED_HALF)

test-pinned-rest-2:
	$(call PINNED_NOT_ROS,3) test $(addprefix --ignore ,$(PINNED_HALF))

# The quick loop while working on the core (docs/ros.md#tests): the kinematics core, its command line, the robot and
# the mechanisms, the layout and the types, without the tests marked slow and the two hardening suites that start
# isolated interpreters or parse hostile inputs (test_core_standalone, test_core_safe_yaml); the venv only, no ROS.
QUICK_TESTS = $(filter-out test/test_core_standalone.py test/test_core_safe_yaml.py,$(wildcard test/test_core_*.py)) \
	$(wildcard test/test_robot_*.py test/test_mech_*.py) test/test_layout.py test/test_types.py

test-quick: $(STAMP)
	$(PY) -m pytest -q -m 'not ros and not slow' $(QUICK_TESTS)

test-core: $(STAMP)
	$(PY) -m pytest -q -m 'not ros' test

test-ros: setup
	$(PY) -m pytest -q -m ros test

# Core, CLI, bag and node tests on the stock versions, without the tests marked slow (each a long scenario whose code
# the others also run on these versions: the pinned run has them) and the static checks (lint, types, layout).
test-stock: setup-stock
	$(MAKE) --no-print-directory test-stock-run

test-stock-run:
	$(call STOCK_RUN,2,'not slow')

test-stock-ros:
	$(call STOCK_RUN,2,'ros and not slow')

test-stock-rest:
	$(call STOCK_RUN,4,'not ros and not slow')

# The demo: the example robot programmed through tilted stations with the naive model's wafer error
# (robot.demo), a calibration from the shipped synthetic measurements (calibration.demo), then the
# offline-programming loop: the services called once from a client (nodes.demo), then the paper's sweep streamed
# by trajectory_node, recorded by recorder_node and checked by `gpr verify` (offline_loop).
demo: setup
	$(PY) -m gpr_kinematics.robot.demo
	$(PY) -m gpr_kinematics.calibration.demo
	$(ROSENV) $(PY) -m gpr_kinematics.nodes.demo
	$(ROSENV) $(PY) -m gpr_kinematics.ros.offline_loop

# Lint needs the venv only (no colcon build, no ROS).
lint: $(STAMP)
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) $(STOCK_VENV) build build-stock install $(STOCK_INSTALL) log
