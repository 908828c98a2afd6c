cmake_minimum_required(VERSION 3.16)
# Run by ctest (plugins_install_template): cmake -P with BUILD_DIR, WORK_DIR, LIBDIR,
# TEMPLATE_DIR, GENERATOR, CXX_COMPILER, CHECK_PROGRAM, CHECK_CLI.
set(prefix ${WORK_DIR}/prefix)
set(template_build ${WORK_DIR}/template-build)
file(REMOVE_RECURSE ${WORK_DIR})

function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(step_output "${out}${err}" PARENT_SCOPE)
endfunction()

# The shared libraries `binary` names (its NEEDED list), into `out`.
function(needed_libraries binary out)
  run_step("reading the NEEDED list of ${binary}" ${READELF} -d ${binary})
  string(REGEX MATCHALL "\\(NEEDED\\)[^\n]*\\[([^]]*)\\]" needed_lines "${step_output}")
  set(needed "")
  foreach(line ${needed_lines})
    string(REGEX REPLACE ".*\\[([^]]*)\\]" "\\1" lib "${line}")
    list(APPEND needed ${lib})
  endforeach()
  set(${out} ${needed} PARENT_SCOPE)
endfunction()

run_step("installing the build" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
set(components contract host head perception navigation light)
set(expected bin/projtour ${LIBDIR}/projtour/libprojtour_cli.so
             include/projtour/contract/plugin_author.hpp include/projtour/contract/plugin_abi.h
             include/projtour/contract/contract_version.h
             ${LIBDIR}/libprojtour_contract.so.${CONTRACT_SOVERSION}
             ${LIBDIR}/cmake/projtour/projtourConfig.cmake
             ${LIBDIR}/cmake/projtour/projtourConfigVersion.cmake)
foreach(c ${components})
  list(APPEND expected ${LIBDIR}/libprojtour_${c}.so ${LIBDIR}/cmake/projtour/projtour-${c}-targets.cmake)
endforeach()
foreach(file ${expected})
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "not installed: ${prefix}/${file}")
  endif()
endforeach()
file(GLOB fixtures ${prefix}/${LIBDIR}/projtour/plugins/libpt_fixture_*
                   ${prefix}/${LIBDIR}/projtour/plugins/libprojtour_testing.so)
if(fixtures)
  message(FATAL_ERROR "test doubles were installed: ${fixtures}")
endif()
# Nothing installed may point back into the tree it was built in: not its RUNPATH, not a
# string the code uses (.rodata; debug information may name the tree, it is never read).
file(GLOB_RECURSE installed_binaries ${prefix}/bin/* ${prefix}/${LIBDIR}/*.so*)
foreach(binary ${installed_binaries})
  if(IS_SYMLINK ${binary})
    continue()
  endif()
  execute_process(COMMAND ${READELF} -d -p .rodata ${binary} OUTPUT_VARIABLE sections
                  ERROR_QUIET)
  string(FIND "${sections}" "${BUILD_DIR}" at)
  if(NOT at EQUAL -1)
    message(FATAL_ERROR "${binary} names the build tree ${BUILD_DIR}")
  endif()
endforeach()

# The installed command runs from its prefix: its RPATH finds the installed core.
execute_process(COMMAND ${prefix}/bin/projtour RESULT_VARIABLE rc ERROR_VARIABLE err
                OUTPUT_QUIET)
if(err MATCHES "error while loading shared libraries" OR rc EQUAL 127)
  message(FATAL_ERROR "the installed projtour does not start:\n${err}")
endif()
# The launcher runs `projtour history` with none of the robot's libraries (cli_module.hpp): the
# rest is in the module it loads.
needed_libraries(${prefix}/bin/projtour launcher_needed)
foreach(lib ${launcher_needed})
  if(lib MATCHES "mrpt|pcl|opencv|yaml|vtk|boost|ddsc|projtour")
    message(FATAL_ERROR "the projtour launcher links ${lib} (NEEDED: ${launcher_needed})")
  endif()
endforeach()

run_step("configuring the template" ${CMAKE_COMMAND} -S ${TEMPLATE_DIR} -B ${template_build}
         -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=Release
         -DCMAKE_PREFIX_PATH=${prefix})
run_step("building the template" ${CMAKE_COMMAND} --build ${template_build})
run_step("installing the template" ${CMAKE_COMMAND} --install ${template_build} --prefix ${prefix})
set(plugin ${prefix}/${LIBDIR}/projtour/plugins/libprojtour_hello.so)
if(NOT EXISTS ${plugin})
  message(FATAL_ERROR "the template did not install ${plugin}")
endif()

# A behaviour plugin and a driver plugin built against the installed package link the contract
# and nothing of MRPT, PCL, OpenCV, yaml-cpp or the rest of projtour.
foreach(built ${plugin} ${prefix}/${LIBDIR}/projtour/plugins/libprojtour_hello_base.so)
  if(NOT EXISTS ${built})
    message(FATAL_ERROR "the template did not install ${built}")
  endif()
  needed_libraries(${built} needed)
  if(NOT "libprojtour_contract.so.${CONTRACT_SOVERSION}" IN_LIST needed)
    message(FATAL_ERROR "${built} does not link libprojtour_contract.so.${CONTRACT_SOVERSION}: ${needed}")
  endif()
  foreach(lib ${needed})
    if(lib MATCHES "mrpt|pcl|opencv|yaml|vtk|boost|projtour_(host|head|perception|navigation)")
      message(FATAL_ERROR "${built} links ${lib} (NEEDED: ${needed})")
    endif()
  endforeach()
  message(STATUS "${built} NEEDED: ${needed}")
endforeach()

# The check program loads the installed core first (LD_LIBRARY_PATH before its RUNPATH), so
# the search path it sees is the installed core's.
run_step("loading the template" ${CMAKE_COMMAND} -E env
         LD_LIBRARY_PATH=${prefix}/${LIBDIR}
         PROJTOUR_INSTALL_PREFIX=${prefix}
         PROJTOUR_TEMPLATE_PLUGIN=${plugin}
         ${CHECK_PROGRAM})
message(STATUS "${step_output}")

if(CHECK_CLI)
  foreach(args "plugins" "plugins;--plugin-path;${template_build}")
    run_step("projtour ${args}" ${prefix}/bin/projtour ${args})
    if(NOT step_output MATCHES "\nhello \\(behaviour\\)\n" OR
       NOT step_output MATCHES "\nhello_base \\(driver\\)\n")
      message(FATAL_ERROR "`projtour ${args}` does not list the template's kinds:\n${step_output}")
    endif()
  endforeach()
endif()
