# Depth rendering of the simulated world (tests/bench/bench_render.cpp); needs plugins/sim.
if(TARGET projtour_sim_render)
  projtour_add_bench(bench_render SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_render.cpp
    LIBS projtour_sim_render)
endif()
