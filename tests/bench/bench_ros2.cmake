# ROS 2 over DDS: the round trip of a tick through projtour-sim-ros2, and the ros2 drivers' CPU
# cost at the tour's rates against a peer in a child process (tests/bench/bench_ros2.cpp).
if(TARGET projtour_ros2_driver_impl AND TARGET projtour-sim-ros2 AND TARGET projtour_sim_world)
  projtour_add_bench(bench_ros2 SOURCES ${CMAKE_CURRENT_LIST_DIR}/bench_ros2.cpp
    LIBS projtour_ros2_driver_impl projtour_sim_world)
  target_compile_definitions(bench_ros2 PRIVATE
    PROJTOUR_SIM_ROS2="$<TARGET_FILE:projtour-sim-ros2>")
  add_dependencies(bench_ros2 projtour-sim-ros2)
endif()
