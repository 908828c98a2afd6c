# Loading a plugin: dlopen + descriptor checks (the fixture plugins of tests/core/host).
if(NOT PROJTOUR_SUBDIRS_ONLY OR "host" IN_LIST PROJTOUR_SUBDIRS_ONLY)
  projtour_add_bench(bench_plugin_load SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_plugin_load.cpp)
  target_compile_definitions(bench_plugin_load PRIVATE
    PROJTOUR_FIXTURE_DIR="${PROJECT_BINARY_DIR}/tests/core/host/fixtures")
  add_dependencies(bench_plugin_load pt_fixture_good)
endif()
