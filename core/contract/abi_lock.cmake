# The contract's headers against the SOVERSION they were last recorded under (abi.lock).
#   cmake -DSOVERSION=N -P core/contract/abi_lock.cmake              check (the test contract_abi_lock)
#   cmake -DSOVERSION=N -DUPDATE=ON -P core/contract/abi_lock.cmake  record the current headers
# A change to any contract header fails the check until it is recorded: bump
# PROJTOUR_CONTRACT_SOVERSION in core/contract/CMakeLists.txt first unless the change leaves
# every plugin built against the recorded headers working (a comment, a new free function).
cmake_minimum_required(VERSION 3.16)
get_filename_component(dir ${CMAKE_CURRENT_LIST_FILE} DIRECTORY)
file(GLOB headers RELATIVE ${dir} ${dir}/include/projtour/contract/*.h ${dir}/include/projtour/contract/*.hpp
     ${dir}/contract_version.h.in)
list(SORT headers)
set(digest_input "")
foreach(h ${headers})
  file(SHA256 ${dir}/${h} h_sha)
  string(APPEND digest_input "${h} ${h_sha}\n")
endforeach()
string(SHA256 digest "${digest_input}")
set(recorded_text "soversion ${SOVERSION}\nheaders ${digest}\n")

if(UPDATE)
  file(WRITE ${dir}/abi.lock "${recorded_text}")
  message(STATUS "recorded the contract headers under SOVERSION ${SOVERSION}")
  return()
endif()
file(READ ${dir}/abi.lock lock_text)
if(NOT lock_text STREQUAL recorded_text)
  message(FATAL_ERROR
    "The contract's headers or SOVERSION differ from core/contract/abi.lock:\n"
    "recorded:\n${lock_text}now:\n${recorded_text}"
    "If plugins built against the old headers would break, bump PROJTOUR_CONTRACT_SOVERSION in "
    "core/contract/CMakeLists.txt. Then record: "
    "cmake -DSOVERSION=<N> -DUPDATE=ON -P core/contract/abi_lock.cmake")
endif()
