# The closed loop's calibration measurement: the Gray code decoded, lifted against the registered
# depth and fitted, on frames from the analytic renderer of tests/core/light
# (tests/bench/bench_closed_loop.cpp).
projtour_add_bench(bench_closed_loop SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_closed_loop.cpp
  ${PROJECT_SOURCE_DIR}/tests/core/light/light_scene.cpp)
