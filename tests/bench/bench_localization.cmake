projtour_add_bench(bench_localization SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_localization.cpp)
