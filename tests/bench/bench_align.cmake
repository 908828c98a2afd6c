# Alignment: the default projective ICP against PCL's ICP and GICP on the same rendered frames
# (tests/bench/bench_align.cpp); needs plugins/steps/align and plugins/sim.
if(TARGET projtour_align_pcl AND TARGET projtour_sim_render)
  projtour_add_bench(bench_align SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_align.cpp
    LIBS projtour_align_pcl projtour_sim_render)
endif()
