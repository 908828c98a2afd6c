# projtour_add_fuzzer(NAME fuzz_x HARNESS h.cpp SOURCES core/host/src/a.cpp ...
#                     [HEADERS glob ...] [LINK_FILES file-or-genex ...] [CORPUS dir]
#                     GCC_FALLBACK_LINK target ...)
# A libFuzzer fuzzer: the harness (relative to the calling folder) and the project sources it
# needs (SOURCES and HEADERS, relative to the project root; HEADERS are globs, for rebuilding)
# are compiled by clang with libFuzzer + ASan + UBSan, as the main build is GCC: sanitized
# objects cannot come from it, so the sources are compiled again rather than linked. LINK_FILES
# are prebuilt libraries to link as files ($<TARGET_FILE:yaml-cpp>): their code is not fuzzed.
# The fuzzer is part of `all`: a minute of clang when its sources change, counted as build time,
# not as the suite's test time (it was a test, `build_NAME`, until the suite had to fit 12
# minutes). Without clang, the harness is built by GCC against GCC_FALLBACK_LINK and runs the
# seed corpus once (NAME_corpus).
find_program(PROJTOUR_CLANGXX NAMES clang++ clang++-14 clang++-15 clang++-16)

# The stand-in for libFuzzer's driver the GCC fallback links.
set(PROJTOUR_FUZZ_CORPUS_MAIN ${PROJECT_SOURCE_DIR}/tests/fuzz/run_corpus_main.cpp)

function(projtour_add_fuzzer)
  cmake_parse_arguments(F "" "NAME;HARNESS;CORPUS"
                        "SOURCES;GENERATED;HEADERS;LINK_FILES;GCC_FALLBACK_LINK" ${ARGN})
  if(NOT F_NAME OR NOT F_HARNESS OR NOT F_SOURCES OR NOT F_GCC_FALLBACK_LINK)
    message(FATAL_ERROR "projtour_add_fuzzer: NAME, HARNESS, SOURCES and GCC_FALLBACK_LINK "
                        "are required")
  endif()
  set(harness ${CMAKE_CURRENT_SOURCE_DIR}/${F_HARNESS})
  if(NOT F_CORPUS)
    set(F_CORPUS ${CMAKE_CURRENT_SOURCE_DIR}/corpus)
  endif()

  if(NOT PROJTOUR_CLANGXX)
    add_executable(${F_NAME}_corpus ${harness} ${PROJTOUR_FUZZ_CORPUS_MAIN})
    target_link_libraries(${F_NAME}_corpus PRIVATE ${F_GCC_FALLBACK_LINK})
    projtour_target_options(${F_NAME}_corpus)
    add_test(NAME ${F_NAME}_corpus COMMAND ${F_NAME}_corpus ${F_CORPUS})
    set_tests_properties(${F_NAME}_corpus PROPERTIES LABELS fuzz TIMEOUT 120)
    return()
  endif()

  list(TRANSFORM F_SOURCES PREPEND ${PROJECT_SOURCE_DIR}/)
  # GENERATED: TARGET=path pairs of sources another target generates (an embedded file), with
  # the path relative to the build tree; the fuzzer is built after TARGET.
  set(generated_targets)
  foreach(pair ${F_GENERATED})
    string(REPLACE "=" ";" pair_parts ${pair})
    list(GET pair_parts 0 generator)
    list(GET pair_parts 1 generated)
    list(APPEND F_SOURCES ${CMAKE_BINARY_DIR}/${generated})
    list(APPEND generated_targets ${generator})
  endforeach()
  list(TRANSFORM F_HEADERS PREPEND ${PROJECT_SOURCE_DIR}/)
  file(GLOB headers ${F_HEADERS})
  # libFuzzer writes new inputs into its first corpus directory: keep those in the build tree.
  set(work_corpus ${CMAKE_CURRENT_BINARY_DIR}/corpus)
  set(artifacts ${CMAKE_CURRENT_BINARY_DIR}/artifacts)
  file(MAKE_DIRECTORY ${work_corpus} ${artifacts})

  # Every fuzzer gets the project's include folders; those of the libraries with a target here
  # as system headers (their warnings are not ours). nlohmann_json's target is found in
  # executor/ and is not visible here: its headers are where the compiler looks anyway.
  set(include_flags -I${PROJECT_SOURCE_DIR}/core/contract/include
    -I${PROJECT_SOURCE_DIR}/core/host/include -I${PROJECT_SOURCE_DIR}/executor/formats/include -I${PROJECT_SOURCE_DIR}/executor/record/include -I${PROJECT_SOURCE_DIR}/executor/machine/include
    -I${CMAKE_BINARY_DIR}/core/contract/include)
  set(include_dirs ${OpenCV_INCLUDE_DIRS})
  foreach(dep Eigen3::Eigen yaml-cpp)
    get_target_property(dep_includes ${dep} INTERFACE_INCLUDE_DIRECTORIES)
    if(dep_includes)
      list(APPEND include_dirs ${dep_includes})
    endif()
  endforeach()
  # The compiler searches /usr/include anyway; naming it again breaks libstdc++'s #include_next.
  list(REMOVE_ITEM include_dirs /usr/include)
  list(REMOVE_DUPLICATES include_dirs)
  foreach(inc ${include_dirs})
    list(APPEND include_flags -isystem ${inc})
  endforeach()

  set(fuzzer ${CMAKE_CURRENT_BINARY_DIR}/${F_NAME})
  add_custom_command(OUTPUT ${fuzzer}
    COMMAND ${PROJTOUR_CLANGXX} -std=c++17 -g -O1 -fsanitize=fuzzer,address,undefined
            -fno-sanitize-recover=undefined -fno-omit-frame-pointer
            ${include_flags} ${harness} ${F_SOURCES} ${F_LINK_FILES} -o ${fuzzer}
    DEPENDS ${harness} ${F_SOURCES} ${headers}
    COMMENT "Building ${F_NAME} with clang (libFuzzer, ASan, UBSan)"
    COMMAND_EXPAND_LISTS VERBATIM)
  add_custom_target(${F_NAME} ALL DEPENDS ${fuzzer})
  if(generated_targets)
    add_dependencies(${F_NAME} ${generated_targets})
  endif()

  # `slow`: the minute of fuzzing runs after the fast suite (`make test`).
  # Any crash, sanitizer report, leak or timeout of one input makes libFuzzer exit non-zero.
  add_test(NAME ${F_NAME}_60s
    COMMAND ${fuzzer} -max_total_time=60 -timeout=10 -rss_limit_mb=2048 -print_final_stats=1
            -artifact_prefix=${artifacts}/ ${work_corpus} ${F_CORPUS})
  set_tests_properties(${F_NAME}_60s PROPERTIES LABELS slow TIMEOUT 180)
endfunction()
