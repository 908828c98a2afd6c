# The executor: state transitions per second with scripted behaviours (in-process) and loading
# the testing plugin (tests/bench/bench_executor.cpp).
if(TARGET projtour_testing)
  projtour_add_bench(bench_executor
    SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_executor.cpp
            ${PROJECT_SOURCE_DIR}/plugins/testing/scripted_behaviour.cpp
    LIBS projtour_executor)
  target_include_directories(bench_executor PRIVATE ${PROJECT_SOURCE_DIR}/plugins/testing)
  add_dependencies(bench_executor projtour_testing)
endif()
