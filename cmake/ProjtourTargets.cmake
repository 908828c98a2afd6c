# Shared build settings and helpers for every projtour target.

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

if(PROJTOUR_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

# projtour_add_plugin(NAME SOURCES a.cpp ... [LIBS lib ...])
# Builds a dlopen-able shared object into the common plugin directory.
function(projtour_add_plugin name)
  cmake_parse_arguments(P "" "" "SOURCES;LIBS" ${ARGN})
  add_library(${name} MODULE ${P_SOURCES})
  target_link_libraries(${name} PRIVATE projtour_core ${P_LIBS})
  projtour_target_options(${name})
  set_target_properties(${name} PROPERTIES
    PREFIX "lib"
    LIBRARY_OUTPUT_DIRECTORY ${PROJTOUR_PLUGIN_BUILD_DIR}
    CXX_VISIBILITY_PRESET hidden
    VISIBILITY_INLINES_HIDDEN ON)
  install(TARGETS ${name} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/projtour/plugins)
endfunction()

# projtour_add_test(NAME SOURCES a.cpp ... [LIBS lib ...] [LABELS l] [TIMEOUT s])
function(projtour_add_test name)
  cmake_parse_arguments(T "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE projtour_core GTest::gtest GTest::gtest_main ${T_LIBS})
  projtour_target_options(${name})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 300)
  endif()
  target_compile_definitions(${name} PRIVATE
    PROJTOUR_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    PROJTOUR_BINARY_DIR="${PROJECT_BINARY_DIR}"
    PROJTOUR_PLUGIN_BUILD_DIR="${PROJTOUR_PLUGIN_BUILD_DIR}")
  # The folder's label comes from tests/CMakeLists.txt; LABELS adds at most one more (unit,
  # long, plugins), since gtest_discover_tests in CMake 3.25 turns "a;b" into two properties.
  list(LENGTH T_LABELS label_count)
  if(label_count GREATER 1)
    message(FATAL_ERROR "projtour_add_test(${name}): one label beyond the folder's, got ${T_LABELS}")
  endif()
  set(label_property)
  if(T_LABELS)
    set(label_property LABELS ${T_LABELS})
  endif()
  gtest_discover_tests(${name}
    DISCOVERY_TIMEOUT 60
    PROPERTIES TIMEOUT ${T_TIMEOUT} ${label_property})
endfunction()

# projtour_add_bench(NAME SOURCES a.cpp ... [LIBS lib ...])
function(projtour_add_bench name)
  cmake_parse_arguments(B "" "" "SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${B_SOURCES})
  target_link_libraries(${name} PRIVATE projtour_core benchmark::benchmark ${B_LIBS})
  projtour_target_options(${name})
  target_compile_definitions(${name} PRIVATE
    PROJTOUR_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    PROJTOUR_PLUGIN_BUILD_DIR="${PROJTOUR_PLUGIN_BUILD_DIR}")
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/bench)
endfunction()
