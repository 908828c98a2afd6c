# The two commands a newcomer needs: `make run` (demo tour as a dry run) and `make test`.
# Both install missing Debian packages and build (Release) first.
BUILD_DIR ?= build
ASAN_BUILD_DIR ?= build-asan
TSAN_BUILD_DIR ?= build-tsan
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
RUN_DIR ?= runs/demo_tour
SEED ?= 1
# WORLD=busy: the demo tour's building on a busy day (missions/demo_world_busy.yaml).
WORLD ?=
WORLD_FILE = missions/demo_world$(if $(WORLD),_$(WORLD),).yaml

.PHONY: all deps configure build run test test-asan test-tsan bench format clean

all: build

deps:
	@./scripts/install-deps.sh

$(BUILD_DIR)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

configure: deps $(BUILD_DIR)/CMakeCache.txt

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

run: build
	$(BUILD_DIR)/projtour run missions/demo_tour.yaml --dry-run --world $(WORLD_FILE) --seed $(SEED) --out $(RUN_DIR)

# The monitor's browser tests drive Chromium with puppeteer-core, from the npm registry:
# installed from tests/executor/views/monitor/package-lock.json when node_modules is missing or older.
MONITOR_NODE_MODULES = tests/executor/views/monitor/node_modules/.package-lock.json
$(MONITOR_NODE_MODULES): tests/executor/views/monitor/package-lock.json
	@if command -v npm >/dev/null; then npm ci --prefix tests/executor/views/monitor --no-audit --no-fund; \
	else echo "no npm: the monitor's browser tests will be skipped"; fi

# test_foxglove_peer's ROS 2 node (@foxglove/ros2 under Node.js, not built on Cyclone): installed
# from tests/ros2_peer/package-lock.json the same way. Without it that test fails and says so.
ROS2_PEER_NODE_MODULES = tests/ros2_peer/node_modules/.package-lock.json
$(ROS2_PEER_NODE_MODULES): tests/ros2_peer/package-lock.json
	@if command -v npm >/dev/null; then npm ci --prefix tests/ros2_peer --no-audit --no-fund; \
	else echo "no npm: test_foxglove_peer will fail (it needs tests/ros2_peer/node_modules)"; fi

# The fast suite first, so its failures show within minutes; then the `slow` label (the minute
# of fuzzing, the interruption test).
test: build $(MONITOR_NODE_MODULES) $(ROS2_PEER_NODE_MODULES)
	cd $(BUILD_DIR) && ctest -LE slow --output-on-failure -j $(JOBS) --timeout 900
	cd $(BUILD_DIR) && ctest -L slow --output-on-failure -j $(JOBS) --timeout 900

test-asan: deps $(MONITOR_NODE_MODULES) $(ROS2_PEER_NODE_MODULES)
	cmake -S . -B $(ASAN_BUILD_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPROJTOUR_SANITIZE=ON $(CMAKE_FLAGS)
	cmake --build $(ASAN_BUILD_DIR) -j $(JOBS)
	cd $(ASAN_BUILD_DIR) && ASAN_OPTIONS=detect_leaks=0 ctest --output-on-failure -j $(JOBS) --timeout 1800

# The executor and the dry runs under ThreadSanitizer: the tick loop, its watchdog thread and
# the services. tests/tsan.supp silences reports inside uninstrumented third-party libraries
# only; the build needs it too, since gtest_discover_tests runs each test program at build time.
# history_size=7: with the default, the earlier access of a oneTBB worker is often lost and the
# report then names no libopencv_core frame for the suppression to match.
TSAN_RUN_OPTIONS = suppressions=$(CURDIR)/tests/tsan.supp second_deadlock_stack=1 history_size=7 $(TSAN_OPTIONS)
test-tsan: deps
	cmake -S . -B $(TSAN_BUILD_DIR) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DPROJTOUR_SANITIZE=thread $(CMAKE_FLAGS)
	TSAN_OPTIONS="$(TSAN_RUN_OPTIONS)" cmake --build $(TSAN_BUILD_DIR) -j $(JOBS)
	cd $(TSAN_BUILD_DIR) && TSAN_OPTIONS="$(TSAN_RUN_OPTIONS)" \
	  ctest --output-on-failure -j $(JOBS) --timeout 1800 -L "executor|integration"

bench: build
	@for b in $(BUILD_DIR)/bench/bench_*; do echo "== $$b"; $$b; done

format:
	find core executor plugins tests examples -name '*.cpp' -o -name '*.hpp' -o -name '*.h' | xargs clang-format -i

clean:
	rm -rf $(BUILD_DIR) $(ASAN_BUILD_DIR) $(TSAN_BUILD_DIR)
