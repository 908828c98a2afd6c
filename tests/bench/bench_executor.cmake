# The executor: state transitions per second with scripted behaviours (in-process), loading
# the testing plugin, and the live monitor's cost to the tick loop (tests/bench/bench_executor.cpp).
if(TARGET projtour_testing)
  projtour_add_bench(bench_executor
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_executor.cpp
            ${PROJECT_SOURCE_DIR}/plugins/testing/scripted_behaviour.cpp
    LIBS projtour_executor PkgConfig::CPP_HTTPLIB)
  # The monitor's tick-loop side (monitor_hookup.hpp) is the runner's, private to the executor.
  target_include_directories(bench_executor PRIVATE ${PROJECT_SOURCE_DIR}/plugins/testing
                                                    ${PROJECT_SOURCE_DIR}/executor/tour/src)
  add_dependencies(bench_executor projtour_testing)
endif()
