# Entry points named in README.md. `make test` and `make demo` do all the set-up on a fresh Debian 12.
VENV      ?= .venv
PYTHON    := $(VENV)/bin/python
BUILD_DIR := build/py
export CMAKE_BUILD_PARALLEL_LEVEL ?= 2

APT_PACKAGES := g++ cmake ninja-build python3-dev python3-venv libeigen3-dev libompl-dev \
                libfcl-dev liborocos-kdl-dev liburdfdom-dev libgtest-dev libassimp-dev libqhull-dev libnanoflann-dev chromium \
                libegl1 libegl-mesa0 libgl1-mesa-dri
# chromium: the 3D view's browser test; the last three: Mesa's software EGL, for MuJoCo's headless renderer.
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: all deps install install-lerobot test test-cpp test-python test-physics test-lerobot test-sanitize fuzz demo view bench clean

all: install

# The Debian packages of $(1) that are not installed yet. Another apt holding the dpkg lock (an unattended
# upgrade) is waited for, up to 10 minutes, as apt's own DPkg::Lock::Timeout does.
define apt_install
	@missing=$$(for p in $(1); do dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q 'ok installed' || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  echo "Installing Debian packages:" $$missing; \
	  $(SUDO) apt-get -o DPkg::Lock::Timeout=600 update -qq && \
	  DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get -o DPkg::Lock::Timeout=600 install -y -qq $$missing; \
	fi
endef

deps:
	$(call apt_install,$(APT_PACKAGES))

$(PYTHON):
	python3 -m venv $(VENV)
	$(PYTHON) -m pip install -q --upgrade pip

# Builds the extension and the C++ tests in one CMake tree (build/py), installs the package. setuptools
# >= 70.1 builds the ros extra's sdists (empy) without build isolation: older ones need the wheel package.
EXTRAS := experiments,robots,view,perception,execution,ros,test
install: deps $(PYTHON)
	$(PYTHON) -m pip install -q scikit-build-core pybind11 "setuptools>=70.1"
	$(PYTHON) -m pip install -q --no-build-isolation -C build-dir=$(BUILD_DIR) \
	  -C cmake.define.SLIDEPLAN_BUILD_TESTS=ON ".[$(EXTRAS)]"

# The lerobot extra too (torch: a download of several GB the first time): the demonstrations' tests need it.
# ffmpeg: the FFmpeg libraries lerobot's video decoder (torchcodec) loads.
install-lerobot: install
	$(call apt_install,ffmpeg)
	$(PYTHON) -m pip install -q --no-build-isolation -C build-dir=$(BUILD_DIR) \
	  -C cmake.define.SLIDEPLAN_BUILD_TESTS=ON ".[$(EXTRAS),lerobot]"

test-cpp: install
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j2

test-python: install
	$(PYTHON) -m pytest -q -m "not physics and not lerobot" tests/python

# The C++ tests and every Python test but the whole MuJoCo episodes, timed (set-up excluded).
test: install
	@start=$$(date +%s); \
	ctest --test-dir $(BUILD_DIR) --output-on-failure -j2 && $(PYTHON) -m pytest -q -m "not physics and not lerobot" tests/python; \
	status=$$?; echo "make test: $$(( $$(date +%s) - start )) s (set-up excluded)"; exit $$status

# The whole MuJoCo episodes (tests marked physics): executions, closed-loop runs, the calibrated facts.
test-physics: install
	@start=$$(date +%s); \
	$(PYTHON) -m pytest -q -m "physics and not lerobot" tests/python; \
	status=$$?; echo "make test-physics: $$(( $$(date +%s) - start )) s (set-up excluded)"; exit $$status

# The tests that write or load LeRobot datasets (marked lerobot), whole generations included: the lerobot
# extra (torch, several GB the first time) is installed for them alone.
test-lerobot: install-lerobot
	@start=$$(date +%s); \
	$(PYTHON) -m pytest -q -m lerobot tests/python; \
	status=$$?; echo "make test-lerobot: $$(( $$(date +%s) - start )) s (set-up excluded)"; exit $$status

# The core and the C++ tests under AddressSanitizer + UndefinedBehaviorSanitizer (no Python module:
# the sanitizer runtimes would have to be preloaded into Python).
SANITIZE_DIR := build/sanitize
test-sanitize: deps
	cmake -S . -B $(SANITIZE_DIR) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSLIDEPLAN_BUILD_PYTHON=OFF \
	  -DSLIDEPLAN_BUILD_TESTS=ON -DSLIDEPLAN_SANITIZE=ON > /dev/null
	cmake --build $(SANITIZE_DIR) --target slideplan_tests
	ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 ctest --test-dir $(SANITIZE_DIR) --output-on-failure -j2

# Many more fuzz examples than `make test` runs, with fresh random seeds.
fuzz: install
	HYPOTHESIS_PROFILE=fuzz $(PYTHON) -m pytest -q tests/python/test_fuzz.py

demo: install
	$(VENV)/bin/slideplan demo --out out

view: demo
	$(VENV)/bin/slideplan view out/demo-plan.json

bench: install
	$(BUILD_DIR)/bench_core "$$($(PYTHON) -c 'import slideplan.world.scenes as s; print(":".join(map(str, s.package_search_dirs())))')"
	$(PYTHON) benchmarks/plan_bench.py --time-limit 10 --scenes square round triangle long --dense \
	  --variants "slideplan dz*=2cm" "slideplan dz*=2cm, grasp map cold" "slideplan dz*=2cm, paired goals off" \
	  "Algorithm 1 as published"
	$(PYTHON) benchmarks/plan_bench.py --time-limit 10 --poses 4 --scenes square --peers --out docs/benchmarks/baselines.md \
	  --variants "slideplan dz*=2cm" "slideplan dz*=0.5cm" "slideplan dz*=0cm" "cbirrt as published" "cbirrt2 as published"
	$(PYTHON) benchmarks/plan_bench.py --time-limit 10 --poses 5 --scenes panda_square panda_round ur5_square ur5_round z1_square so101_square \
	  --variants "slideplan hand" --out docs/benchmarks/robots.md
	$(PYTHON) benchmarks/plan_bench.py --time-limit 10 --poses 10 --scenes clutter_can clutter_books clutter_boxed \
	  --variants "slideplan hand" --out docs/benchmarks/clutter.md
	$(PYTHON) benchmarks/support_bench.py
	$(PYTHON) benchmarks/thread_bench.py
	$(PYTHON) benchmarks/hands_sweep.py
	$(PYTHON) benchmarks/timing_bench.py
	$(PYTHON) benchmarks/cli_bench.py
	$(PYTHON) benchmarks/perceive_bench.py
	$(MAKE) install-lerobot && $(PYTHON) benchmarks/demos_bench.py
	$(PYTHON) benchmarks/execute_bench.py
	$(PYTHON) benchmarks/video_bench.py
	$(PYTHON) benchmarks/tracking_bench.py
	$(PYTHON) benchmarks/replan_bench.py
	$(PYTHON) benchmarks/ros_bench.py
	$(PYTHON) docs/results/make_tables.py  # the pages of rows a benchmark rewrote (hands_sweep.py's hands.parquet)

clean:
	rm -rf build out $(VENV)
