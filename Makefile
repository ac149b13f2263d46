# Entry points named in README.md. `make test` and `make demo` do all the set-up on a fresh Debian 12.
VENV      ?= .venv
PYTHON    := $(VENV)/bin/python
BUILD_DIR := build/py
export CMAKE_BUILD_PARALLEL_LEVEL ?= 2

APT_PACKAGES := g++ cmake ninja-build python3-dev python3-venv libeigen3-dev libompl-dev \
                libfcl-dev liborocos-kdl-dev liburdfdom-dev libgtest-dev \
                libegl1 libegl-mesa0 libgl1-mesa-dri
# The last three: Mesa's software EGL, for MuJoCo's headless renderer (the perception tests' scenes).
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps install test test-cpp test-python demo bench clean

all: install

deps:
	@missing=$$(for p in $(APT_PACKAGES); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q 'ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages:" $$missing; \
	  $(SUDO) apt-get update -qq && DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi

$(PYTHON):
	python3 -m venv $(VENV)
	$(PYTHON) -m pip install -q --upgrade pip

# Builds the extension and the C++ tests in one CMake tree (build/py), installs the package.
install: deps $(PYTHON)
	$(PYTHON) -m pip install -q scikit-build-core pybind11
	$(PYTHON) -m pip install -q --no-build-isolation -C build-dir=$(BUILD_DIR) \
	  -C cmake.define.SLIDEPLAN_BUILD_TESTS=ON ".[experiments,perception,test]"

test-cpp: install
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j2

test-python: install
	$(PYTHON) -m pytest -q tests/python

test: test-cpp test-python

demo: install
	$(VENV)/bin/slideplan demo --out out

bench: install
	$(BUILD_DIR)/bench_core
	$(PYTHON) benchmarks/plan_bench.py
	$(PYTHON) benchmarks/perceive_bench.py

clean:
	rm -rf build out $(VENV)
