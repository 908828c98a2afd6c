# cmake -DINPUT=FILE -DINLINES=A|B -DOUTPUT=X.cpp -DFUNCTION=NAME -P projtour_embed_file.cmake
# Writes X.cpp defining `std::string_view projtour::assets::NAME()` with FILE's bytes, each of
# INLINES put in place of the tag naming it (ProjtourEmbed.cmake says which tags).
foreach(variable INPUT OUTPUT FUNCTION)
  if(NOT DEFINED ${variable})
    message(FATAL_ERROR "projtour_embed_file.cmake: -D${variable}=... is required")
  endif()
endforeach()

if(INLINES STREQUAL "")
  # Read as bytes, not text: a file embedded whole is copied whatever it holds.
  file(READ "${INPUT}" hex HEX)
else()
  file(READ "${INPUT}" text)
  string(REPLACE "|" ";" inlines "${INLINES}")
  foreach(file IN LISTS inlines)
    get_filename_component(name "${file}" NAME)
    get_filename_component(extension "${file}" LAST_EXT)
    if(extension STREQUAL ".css")
      set(tag "<link rel=\"stylesheet\" href=\"${name}\">\n")
      set(open "<style>\n")
      set(close "</style>\n")
    elseif(extension STREQUAL ".js")
      set(tag "<script src=\"${name}\"></script>\n")
      set(open "<script>\n")
      set(close "</script>\n")
    else()
      message(FATAL_ERROR "${file}: only .css and .js files are inlined")
    endif()
    string(FIND "${text}" "${tag}" first)
    string(FIND "${text}" "${tag}" last REVERSE)
    if(first EQUAL -1 OR NOT first EQUAL last)
      message(FATAL_ERROR "${INPUT}: expected one line ${tag}")
    endif()
    file(READ "${file}" content)
    string(REPLACE "${tag}" "${open}${content}${close}" text "${text}")
  endforeach()
  # A tag no INLINES names would be served as a reference to a file the server does not have.
  if(text MATCHES "<link rel=\"stylesheet\"|<script src=")
    message(FATAL_ERROR "${INPUT}: a stylesheet or script that INLINES does not name")
  endif()
  string(HEX "${text}" hex)
endif()

# Twenty bytes a line, each as 0xNN, and the terminating NUL.
string(REGEX REPLACE "([0-9a-f][0-9a-f])" "0x\\1," bytes "${hex}")
string(REPEAT "0x[0-9a-f][0-9a-f]," 20 line)
string(REGEX REPLACE "(${line})" "\\1\n" bytes "${bytes}")
file(RELATIVE_PATH shown "${CMAKE_CURRENT_LIST_DIR}/.." "${INPUT}")
file(WRITE "${OUTPUT}" "// Generated from ${shown} by cmake/projtour_embed_file.cmake: edit that
// file, not this one.
#include <string_view>

namespace projtour::assets {

std::string_view ${FUNCTION}();

namespace {
// unsigned: a UTF-8 byte above 0x7f does not fit a signed char's initializer.
constexpr unsigned char kBytes[] = {
${bytes}0x00};
}  // namespace

std::string_view ${FUNCTION}() {
  return {reinterpret_cast<const char*>(kBytes), sizeof kBytes - 1};
}

}  // namespace projtour::assets
")
