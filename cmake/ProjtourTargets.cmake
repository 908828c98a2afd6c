# Shared build settings and helpers for every projtour target.

# This folder, for the scripts the functions below run (read where they are called).
set(_projtour_targets_dir ${CMAKE_CURRENT_LIST_DIR})

function(projtour_target_options target)
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # GCC 12 reports maybe-uninitialized falsely inside std::string and Eigen at -O2.
    target_compile_options(${target} PRIVATE -Wno-maybe-uninitialized)
  endif()
  if(PROJTOUR_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# PROJTOUR_SANITIZER is the normalised choice ("", address or thread) for the rest of the build
# to test: "thread" is a string, which if(PROJTOUR_SANITIZE) would read as a false variable name.
string(TOLOWER "${PROJTOUR_SANITIZE}" _projtour_sanitize)
if(_projtour_sanitize MATCHES "^(thread|tsan)$")
  set(PROJTOUR_SANITIZER thread)
elseif(_projtour_sanitize MATCHES "^(address|asan|on|yes|true|y|1)$")
  # The bool values: the option was a bool meaning this before thread was offered.
  set(PROJTOUR_SANITIZER address)
elseif(_projtour_sanitize MATCHES "^(off|no|false|n|0|)$")
  set(PROJTOUR_SANITIZER "")
else()
  message(FATAL_ERROR "PROJTOUR_SANITIZE=${PROJTOUR_SANITIZE}: use OFF, address (or ON) or thread")
endif()

if(PROJTOUR_SANITIZER STREQUAL "address")
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
elseif(PROJTOUR_SANITIZER STREQUAL "thread")
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
endif()

# projtour_add_library(COMPONENT SOURCES a.cpp ... [PUBLIC lib ...] [PRIVATE lib ...])
# One of core's libraries: target projtour_COMPONENT (alias projtour::COMPONENT), headers in
# the folder's include/, shared, into the build tree's lib/ (where the host looks for
# lib/projtour/plugins, as in an installation), exported as its own find_package component.
function(projtour_add_library component)
  cmake_parse_arguments(L "" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  set(target projtour_${component})
  add_library(${target} SHARED ${L_SOURCES})
  add_library(projtour::${component} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
  target_link_libraries(${target} PUBLIC ${L_PUBLIC} PRIVATE ${L_PRIVATE})
  projtour_target_options(${target})
  set_target_properties(${target} PROPERTIES
    EXPORT_NAME ${component}
    LIBRARY_OUTPUT_DIRECTORY ${PROJTOUR_LIBRARY_BUILD_DIR}
    INSTALL_RPATH "$ORIGIN")
  install(TARGETS ${target} EXPORT projtour-${component}-targets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(DIRECTORY include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(EXPORT projtour-${component}-targets NAMESPACE projtour::
    DESTINATION ${PROJTOUR_CMAKE_INSTALL_DIR})
endfunction()

# projtour_add_plugin(NAME SOURCES a.cpp ... [LIBS lib ...] [NO_INSTALL])
# Builds a dlopen-able shared object into the common plugin directory. A plugin links the
# contract and whichever of core's algorithm libraries it names in LIBS. NO_INSTALL: test
# doubles, which an installation must not offer.
function(projtour_add_plugin name)
  cmake_parse_arguments(P "NO_INSTALL" "" "SOURCES;LIBS" ${ARGN})
  add_library(${name} MODULE ${P_SOURCES})
  target_link_libraries(${name} PRIVATE projtour_contract ${P_LIBS})
  projtour_target_options(${name})
  set_target_properties(${name} PROPERTIES
    PREFIX "lib"
    LIBRARY_OUTPUT_DIRECTORY ${PROJTOUR_PLUGIN_BUILD_DIR}
    # <libdir>/projtour/plugins -> <libdir>, where core's libraries are installed.
    INSTALL_RPATH "$ORIGIN/../.."
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  if(NOT P_NO_INSTALL)
    install(TARGETS ${name} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/projtour/plugins)
  endif()
endfunction()

# Tests and benchmarks may use any of core's libraries, and the libraries those wrap. A macro, so
# OpenCV_LIBS is read where it is called (after find_package), not where this file is included.
macro(projtour_all_libraries out)
  set(${out} projtour_contract projtour_host projtour_head projtour_perception
      projtour_navigation projtour_light ${OpenCV_LIBS} mrpt::obs mrpt::poses)
endmacro()

# projtour_add_test(NAME SOURCES a.cpp ... [LIBS lib ...] [LABELS l] [TIMEOUT s])
function(projtour_add_test name)
  cmake_parse_arguments(T "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  projtour_all_libraries(all_libraries)
  target_link_libraries(${name} PRIVATE ${all_libraries} projtour_test_support GTest::gtest
    GTest::gtest_main ${T_LIBS})
  projtour_target_options(${name})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 300)
  endif()
  target_compile_definitions(${name} PRIVATE
    PROJTOUR_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    PROJTOUR_BINARY_DIR="${PROJECT_BINARY_DIR}"
    PROJTOUR_PLUGIN_BUILD_DIR="${PROJTOUR_PLUGIN_BUILD_DIR}")
  # The folder's label comes from tests/CMakeLists.txt; LABELS adds at most one more (unit,
  # plugins, slow): the folder's reaches the suites' tests as a directory property, and one
  # more is one word on their set_tests_properties line.
  # `slow`: what `make test` runs after the fast suite (ctest -LE slow, then -L slow).
  list(LENGTH T_LABELS label_count)
  if(label_count GREATER 1)
    message(FATAL_ERROR "projtour_add_test(${name}): one label beyond the folder's, got ${T_LABELS}")
  endif()
  # One ctest test per GoogleTest suite ("test_x/Suite.*", its cases in one process), listed after
  # each build as gtest_discover_tests would list cases: see ProjtourGtestSuites.cmake for why.
  set(suites_file ${CMAKE_CURRENT_BINARY_DIR}/${name}_suites.cmake)
  add_custom_command(TARGET ${name} POST_BUILD
    COMMAND ${CMAKE_COMMAND} -D EXE=$<TARGET_FILE:${name}> -D OUT=${suites_file}
            -D WORKDIR=${CMAKE_CURRENT_BINARY_DIR} -D TIMEOUT=${T_TIMEOUT} -D LABEL=${T_LABELS}
            -P ${_projtour_targets_dir}/ProjtourGtestSuites.cmake
    BYPRODUCTS ${suites_file}
    VERBATIM)
  set(include_file ${CMAKE_CURRENT_BINARY_DIR}/${name}_include.cmake)
  file(WRITE ${include_file}
    "if(EXISTS [==[${suites_file}]==])\n"
    "  include([==[${suites_file}]==])\n"
    "else()\n"
    "  add_test([==[${name}_NOT_BUILT]==] [==[${name}_NOT_BUILT]==])\n"
    "endif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${include_file})
endfunction()

# projtour_add_bench(NAME SOURCES a.cpp ... [LIBS lib ...])
function(projtour_add_bench name)
  cmake_parse_arguments(B "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${B_SOURCES})
  projtour_all_libraries(all_libraries)
  target_link_libraries(${name} PRIVATE ${all_libraries} projtour_test_support
    benchmark::benchmark ${B_LIBS})
  projtour_target_options(${name})
  target_compile_definitions(${name} PRIVATE
    PROJTOUR_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    PROJTOUR_PLUGIN_BUILD_DIR="${PROJTOUR_PLUGIN_BUILD_DIR}")
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bench)
endfunction()
