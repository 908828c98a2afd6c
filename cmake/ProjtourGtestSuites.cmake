# cmake -D EXE=... -D OUT=... -D WORKDIR=... -D TIMEOUT=... [-D LABEL=...] -P ProjtourGtestSuites.cmake
# Run after a test program is built (projtour_add_test): lists its GoogleTest cases and writes
# OUT, a ctest file adding one test per suite, "program/Suite.*", which runs that suite's cases
# in one process (--gtest_filter=Suite.*). A test program links the robot's few hundred shared
# libraries, and loading them (~0.4 s of CPU) costs a case that runs in its own process more
# than many cases themselves take. Every case still runs, and GoogleTest's output names each
# one that fails.
#
# TIMEOUT is per case: a suite gets it times its number of cases, the same budget as before, but
# at most the 900 s `make test` gives a test without one (unless one case has more), so that a
# hung case is still stopped within minutes.
# A skipped case (GTEST_SKIP) marks a suite skipped only when it is the suite's only case: in a
# larger suite the others' verdict counts, and "[  SKIPPED ]" stays in the output.

execute_process(COMMAND "${EXE}" --gtest_list_tests
  WORKING_DIRECTORY "${WORKDIR}"
  TIMEOUT 60
  OUTPUT_VARIABLE output
  RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "${EXE} --gtest_list_tests failed (${result}):\n${output}")
endif()

# Only the suite lines (unindented) matter, and how many case lines follow each; a case line
# may hold a parameter's printed value, whose ';' or brackets would split a CMake list.
string(REGEX REPLACE "[][;]" "_" output "${output}")
string(REPLACE "\n" ";" lines "${output}")

set(suites)
foreach(line IN LISTS lines)
  if(line STREQUAL "" OR line MATCHES "gtest_main\\.cc")
    continue()
  endif()
  if(NOT line MATCHES "^ ")
    # "Suite." or "Prefix/Suite/0.  # TypeParam = int"
    string(REGEX REPLACE "\\.( +#.*)?$" "" suite "${line}")
    list(APPEND suites "${suite}")
    set(cases_${suite} 0)
  elseif(DEFINED suite)
    string(STRIP "${line}" case)
    if(NOT case MATCHES "^DISABLED_")
      math(EXPR cases_${suite} "${cases_${suite}} + 1")
    endif()
  endif()
endforeach()

# A suite's name may recur in another program (SimFaults, DepletionGuard): the program's name
# before it keeps each test's name unique and says where its cases are.
get_filename_component(program "${EXE}" NAME)
set(script "")
foreach(suite IN LISTS suites)
  if(suite MATCHES "^DISABLED_" OR cases_${suite} EQUAL 0)
    continue()
  endif()
  math(EXPR timeout "${TIMEOUT} * ${cases_${suite}}")
  if(timeout GREATER 900 AND TIMEOUT LESS 900)
    set(timeout 900)
  endif()
  set(name "${program}/${suite}.*")
  string(APPEND script
    "add_test([==[${name}]==] [==[${EXE}]==] [==[--gtest_filter=${suite}.*]==])\n")
  set(properties "WORKING_DIRECTORY [==[${WORKDIR}]==] TIMEOUT ${timeout}")
  if(LABEL)
    string(APPEND properties " LABELS ${LABEL}")
  endif()
  if(cases_${suite} EQUAL 1)
    string(APPEND properties " SKIP_REGULAR_EXPRESSION [==[\\[  SKIPPED \\]]==]")
  endif()
  string(APPEND script "set_tests_properties([==[${name}]==] PROPERTIES ${properties})\n")
endforeach()
file(WRITE "${OUT}" "${script}")
