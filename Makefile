# The two commands that matter: `make book` and `make test`. Every target sets up
# .venv from requirements.txt first when it is missing or older than requirements.txt.

PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
ISOLATED := $(BIN)/python -m rosbook.runtime.isolation --

LAB ?= lab01_nodes_topics
SUBMISSIONS ?= submissions
OUT ?= grading

.PHONY: book test test-fast stress lab hub axe check labs grade bench lint clean

# The course's own interface packages (rosbook/ros_packages: tf2_msgs) are built into the
# venv by colcon from the wheels, as its other ROS packages are installed there.
COURSE_PACKAGES := $(shell find rosbook/ros_packages -type f) rosbook/launch/wheel_prefix.cmake

$(STAMP): requirements.txt pyproject.toml $(COURSE_PACKAGES)
	@$(PYTHON) -c 'import platform, sys; ok = sys.platform == "linux" and platform.machine() == "x86_64" and (3, 10) <= sys.version_info[:2] <= (3, 13); ok or sys.exit("ROS 2 Jazzy wheels exist for Linux x86_64 with Python 3.10-3.13 only; this is %s %s with Python %d.%d (see README: Mac and Windows)" % (sys.platform, platform.machine(), *sys.version_info[:2]))'
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -r requirements.txt
	$(BIN)/python -m rosbook.launch.interfaces_build install
	touch $(STAMP)

## book: build the HTML book into _build/html, every cell executed (cached)
book: $(STAMP)
	$(ISOLATED) $(BIN)/jupyter-book build --all -W -n --keep-going .

## test: the whole test suite (library, labs round trip, grader, book build); in
## TEST_WORKERS parallel workers (logical: one per CPU; 0: in this process; tests/conftest.py
## groups them)
TEST_WORKERS ?= 4
PARALLEL := -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder
test: $(STAMP)
	$(ISOLATED) $(BIN)/python -m pytest $(PARALLEL)

## test-fast: the edit loop: library units and one lab round trip, no book build
test-fast: $(STAMP)
	$(ISOLATED) $(BIN)/python -m pytest $(PARALLEL) -m "not slow"

## stress: the book build and the whole test suite with the CPU oversubscribed by
## STRESS_PER_CORE busy processes per core; every chapter is executed again
STRESS_PER_CORE ?= 2
stress: $(STAMP)
	ROSBOOK_BOOK_CACHE=fresh $(BIN)/python -m rosbook.runtime.stress --per-core $(STRESS_PER_CORE) -- \
		$(ISOLATED) $(BIN)/python -m pytest $(PARALLEL)

## lab: JupyterLab on the student labs, in a ROS domain of its own; its terminals have
## the venv's ros2 and colcon in the kernel's domain (LAB_DIR, LAB_ARGS: other folder, flags)
LAB_DIR ?= labs
LAB_ARGS ?=
lab: $(STAMP)
	$(BIN)/python -m autograder preflight --unsandboxed
	$(ISOLATED) $(BIN)/jupyter lab --config=rosbook/jupyterlab_config.py $(LAB_ARGS) $(LAB_DIR)

## hub: the course server: JupyterHub at HUB_URL, each student's JupyterLab sandboxed on a
## network of its own (coursehub/hub.py); its proxy comes from npm into .hub/ (not global).
## People: `.venv/bin/python -m coursehub.hub add NAME [--instructor]` prints a password.
## Ctrl-C, or SIGTERM to make or to the hub, stops the proxy and every student's sandbox
## (exec: the hub is make's child itself, and stops when make ends).
HUB_URL ?= http://127.0.0.1:8000
CHP := .hub/node_modules/.bin/configurable-http-proxy
$(CHP):
	npm install --prefix .hub --no-save --no-package-lock configurable-http-proxy@4.6.3
hub: $(STAMP) $(CHP)
	ROSBOOK_HUB_URL=$(HUB_URL) ROSBOOK_HUB_PARENT=$$PPID exec $(BIN)/jupyterhub -f coursehub/jupyterhub_config.py

## axe: axe-core, the accessibility rules the browser tests run over every page of the
## built book; from npm into .axe/ (not global; needs npm), a pinned version
AXE := .axe/node_modules/axe-core/axe.min.js
axe: $(AXE)
$(AXE):
	npm install --prefix .axe --no-save --no-package-lock axe-core@4.10.3

## check: a student's self-check of LAB before submitting
check: $(STAMP)
	$(BIN)/python -m autograder check $(LAB)

## labs: regenerate labs/ from solutions/
labs: $(STAMP)
	$(BIN)/python -m autograder labs

## grade: grade SUBMISSIONS/<student>/<lab>/<lab>.ipynb into OUT/
grade: $(STAMP)
	$(BIN)/python -m autograder grade $(SUBMISSIONS) --out $(OUT)

## bench: performance figures, printed and written to _build/bench.json
bench: $(STAMP)
	$(BIN)/python -m benchmarks

lint: $(STAMP)
	$(BIN)/ruff check rosbook autograder coursehub tests benchmarks solutions
	$(BIN)/ruff format --check rosbook autograder coursehub tests benchmarks

clean:
	rm -rf _build grading
