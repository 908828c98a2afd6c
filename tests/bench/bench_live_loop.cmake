# The live loop of project with track: true (tests/bench/bench_live_loop.cpp): align from the
# last pose, the beam watch, the warp maps and the remap; builds plugins/steps/project's tracker in.
if(TARGET projtour_sim_render AND TARGET projtour_project)
  projtour_add_bench(bench_live_loop SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_live_loop.cpp
    ${PROJECT_SOURCE_DIR}/plugins/steps/project/tracker.cpp LIBS projtour_sim_render)
  target_include_directories(bench_live_loop PRIVATE ${PROJECT_SOURCE_DIR}/plugins/steps/project)
endif()
