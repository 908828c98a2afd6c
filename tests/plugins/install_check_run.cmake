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

run_step("installing the build" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(file bin/projtour ${LIBDIR}/libprojtour_core.so include/projtour/plugin_author.hpp
             include/projtour/plugin_abi.h ${LIBDIR}/cmake/projtour/projtourConfig.cmake
             ${LIBDIR}/cmake/projtour/projtourConfigVersion.cmake
             ${LIBDIR}/cmake/projtour/projtourTargets.cmake)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "not installed: ${prefix}/${file}")
  endif()
endforeach()
file(GLOB fixtures ${prefix}/${LIBDIR}/projtour/plugins/libpt_fixture_*)
if(fixtures)
  message(FATAL_ERROR "test fixtures were installed: ${fixtures}")
endif()

# The installed command runs from its prefix: its RPATH finds the installed core.
execute_process(COMMAND ${prefix}/bin/projtour RESULT_VARIABLE rc ERROR_VARIABLE err
                OUTPUT_QUIET)
if(err MATCHES "error while loading shared libraries" OR rc EQUAL 127)
  message(FATAL_ERROR "the installed projtour does not start:\n${err}")
endif()

run_step("configuring the template" ${CMAKE_COMMAND} -S ${TEMPLATE_DIR} -B ${template_build}
         -G ${GENERATOR} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=Release
         -DCMAKE_PREFIX_PATH=${prefix})
run_step("building the template" ${CMAKE_COMMAND} --build ${template_build})
run_step("installing the template" ${CMAKE_COMMAND} --install ${template_build} --prefix ${prefix})
set(plugin ${prefix}/${LIBDIR}/projtour/plugins/libprojtour_hello.so)
if(NOT EXISTS ${plugin})
  message(FATAL_ERROR "the template did not install ${plugin}")
endif()

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
    if(NOT step_output MATCHES "\nhello \\(behaviour\\)\n")
      message(FATAL_ERROR "`projtour ${args}` does not list the template's kind:\n${step_output}")
    endif()
  endforeach()
endif()
