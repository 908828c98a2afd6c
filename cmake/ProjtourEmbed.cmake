# projtour_embed_file(TARGET FUNCTION NAME FILE PATH [INLINES PATH ...])
# Adds to TARGET a source generated at build time that defines
# `std::string_view projtour::assets::NAME()`: the bytes of FILE (relative to the calling
# folder), NUL-terminated so that data() is also a C string. Each of INLINES (beside FILE) is put
# in FILE in place of the tag naming it, `<link rel="stylesheet" href="X.css">` or
# `<script src="X.js"></script>` on a line of its own, as `<style>`/`<script>` with the file's
# text: a page kept as files, served as one document. The source is made again when any of these
# files changes. CMake itself reads and writes the bytes (projtour_embed_file.cmake), so the
# build needs no xxd.
set(_projtour_embed_script ${CMAKE_CURRENT_LIST_DIR}/projtour_embed_file.cmake)

function(projtour_embed_file target)
  cmake_parse_arguments(E "" "FUNCTION;FILE" "INLINES" ${ARGN})
  if(NOT E_FUNCTION OR NOT E_FILE)
    message(FATAL_ERROR "projtour_embed_file(${target}): FUNCTION and FILE are required")
  endif()
  get_filename_component(input ${E_FILE} ABSOLUTE)
  set(inlines)
  foreach(file ${E_INLINES})
    get_filename_component(absolute ${file} ABSOLUTE)
    list(APPEND inlines ${absolute})
  endforeach()
  # A list would be split into separate arguments on the command line: joined with | instead.
  string(REPLACE ";" "|" inline_arg "${inlines}")
  set(output ${CMAKE_CURRENT_BINARY_DIR}/assets/${E_FUNCTION}.cpp)
  add_custom_command(OUTPUT ${output}
    COMMAND ${CMAKE_COMMAND} -DINPUT=${input} -DINLINES=${inline_arg} -DOUTPUT=${output}
            -DFUNCTION=${E_FUNCTION} -P ${_projtour_embed_script}
    DEPENDS ${input} ${inlines} ${_projtour_embed_script}
    COMMENT "Embedding ${E_FILE} as projtour::assets::${E_FUNCTION}()"
    VERBATIM)
  target_sources(${target} PRIVATE ${output})
endfunction()
