# The two commands: `make demo` and `make test`. Both need only python3 (>= 3.10) and make.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
PIP    := $(BIN)/python -m pip --disable-pip-version-check -q

.PHONY: demo test test-slow test-lowest interop fuzz lint bench clean screenshots

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --upgrade pip

# Reinstall when the project's metadata changes.
$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(PIP) install -e .
	@touch $@

$(VENV)/.installed-test: pyproject.toml | $(BIN)/python
	$(PIP) install -e '.[test]'
	@touch $@ $(VENV)/.installed

$(VENV)/.installed-lint: pyproject.toml | $(BIN)/python
	$(PIP) install -e '.[test,lint]'
	@touch $@ $(VENV)/.installed $(VENV)/.installed-test

demo: $(VENV)/.installed
	$(BIN)/tfrec record robots/mbot.xacro --traj sine
	@echo
	@echo "The .mcap is a ROS 2 bag (ros2 bag info/play, Foxglove, rosbags); the .rrd opens in Rerun:"
	@echo "  $(BIN)/rerun <file>.rrd          (the viewer comes with the pinned rerun-sdk)"
	@echo "  $(BIN)/tfrec info <file>.mcap    (topics, rates, joints, frames)"
	@echo "Or activate the environment first ('. $(BIN)/activate') and type tfrec and rerun."

# The default tier: every test but those marked `slow` (Ray clusters, many subprocesses, pictures) or `interop`
# (Debian's ROS 1), a few minutes on 2 cores. CI runs every tier, with the newest and the lowest allowed versions
# (docs/ci.md).
test: $(VENV)/.installed-test
	$(BIN)/python -m pytest -q -m "not slow and not interop"

test-slow: $(VENV)/.installed-test
	$(BIN)/python -m pytest -q -m "slow and not interop"

# The interop tier: tfrec against Debian's ROS 1 (check_urdf, roscore, robot_state_publisher, joint_state_publisher,
# rosbag, view_frames, roslaunch), installed by .ci/install-ros1 when missing (apt-get, as root; elsewhere the tests
# skip and say why). The figures it measures (docs/ros-parity.md) are printed at the end and kept in
# $(VENV)/interop-figures.json.
interop: $(VENV)/.installed-test
	.ci/install-ros1
	TFREC_INTEROP_FIGURES=$(VENV)/interop-figures.json $(BIN)/python -m pytest -q -m interop tests/interop

# The default tier again in .venv-lowest, with every dependency at the lowest version pyproject.toml allows
# (.ci/lowest.txt): a lower bound that no longer works fails here, not on a user's machine.
LOWEST := .venv-lowest
$(LOWEST)/.installed: pyproject.toml .ci/lowest.txt
	rm -rf $(LOWEST)
	$(PYTHON) -m venv $(LOWEST)
	$(LOWEST)/bin/python -m pip --disable-pip-version-check -q install --upgrade pip
	$(LOWEST)/bin/python -m pip --disable-pip-version-check -q install -c .ci/lowest.txt -e '.[test]'
	@touch $@

test-lowest: $(LOWEST)/.installed
	$(LOWEST)/bin/python -m pytest -q -p no:cacheprovider -m "not slow and not interop"

# The long fuzz run (docs/security.md): tests/fuzz with TFREC_FUZZ_EXAMPLES random mutations per target (default
# 300), each run of tfrec in its own process under a 1 GiB address-space limit and a timeout. `make test` runs a
# short fixed-seed slice of the same targets. Inputs that break the contract are saved in .fuzz-failures/.
fuzz: $(VENV)/.installed-test
	TFREC_FUZZ=long $(BIN)/python -m pytest -q -p no:cacheprovider tests/fuzz

# ruff (with the layout's import bans), mypy --strict, and import-linter's layer and cycle contracts
lint: $(VENV)/.installed-lint
	$(BIN)/ruff check tfrec tests benchmarks scripts
	$(BIN)/mypy tfrec
	$(BIN)/lint-imports

# the baselines (yourdfpy, mcap_ros2, rosbags' writers) come with the test extra
bench: $(VENV)/.installed-test
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) $(LOWEST) .pytest_cache .hypothesis build dist

# docs/images/*.png from the current code, in a headless Rerun viewer (needs Mesa's Vulkan driver:
# apt-get install mesa-vulkan-drivers), and live-foxglove.png in Foxglove Studio's web build under headless Chromium
# (needs node, npm and chromium; skipped, with the reason, without them); not part of `make test`. The test extra
# brings what the pictures use (foxglove-sdk for `tfrec serve`, gymnasium's MuJoCo humanoid).
screenshots: $(VENV)/.installed-test
	$(BIN)/python scripts/screenshots.py
