# `cmake --install` into a temporary prefix, then the out-of-tree template plugin built against
# that installation with find_package(projtour COMPONENTS contract) (a behaviour and a driver
# plugin), then loaded by the installed host.

option(PROJTOUR_INSTALL_TEST_CLI
  "The install test also runs the installed `projtour plugins` (needs that subcommand)" ON)

# Not a discovered test: it only makes sense after the install step, which passes it the prefix.
add_executable(test_template_plugin test_template_plugin.cpp)
target_link_libraries(test_template_plugin PRIVATE projtour_contract projtour_host
  projtour_test_support projtour_fixture_support GTest::gtest GTest::gtest_main)
target_compile_definitions(test_template_plugin PRIVATE ${fixture_definitions})
projtour_target_options(test_template_plugin)

add_test(NAME plugins_install_template
  COMMAND ${CMAKE_COMMAND}
    -DBUILD_DIR=${PROJECT_BINARY_DIR}
    -DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/install_check
    -DLIBDIR=${CMAKE_INSTALL_LIBDIR}
    -DTEMPLATE_DIR=${PROJECT_SOURCE_DIR}/examples/plugin_template
    -DGENERATOR=${CMAKE_GENERATOR}
    -DCXX_COMPILER=${CMAKE_CXX_COMPILER}
    -DCHECK_PROGRAM=$<TARGET_FILE:test_template_plugin>
    -DCHECK_CLI=${PROJTOUR_INSTALL_TEST_CLI}
    -DREADELF=${CMAKE_READELF}
    -DCONTRACT_SOVERSION=${PROJTOUR_CONTRACT_SOVERSION}
    -P ${CMAKE_CURRENT_SOURCE_DIR}/install_check_run.cmake)
set_tests_properties(plugins_install_template PROPERTIES LABELS install TIMEOUT 180)
