# Runs aoscan's module dependency check (cmake/aoscan_modules.cmake) on a made-up tree of modules,
# in script mode: cmake -DCASE=NAME -DMODULES=cmake/aoscan_modules.cmake -DWORK=DIR -P this-file.
# CASE allowed must pass; every other case must stop with the check's message (tests/CMakeLists.txt
# matches it).
cmake_minimum_required(VERSION 3.22)
set(root "${WORK}/${CASE}")
file(REMOVE_RECURSE "${root}")
set(AOSCAN_MODULE_ROOT "${root}")
include("${MODULES}")

# low <- mid_a, mid_b <- high; each file includes what CASE says.
function(write path text)
  file(WRITE "${root}/${path}" "${text}\n")
endfunction()
write(low/low.h "#pragma once\n#include <vector>")
write(low/low.cpp "#include \"low/low.h\"")
write(mid_a/a.h "#pragma once\n#include \"low/low.h\"")
write(mid_b/b.h "#pragma once\n#include \"low/low.h\"")
write(high/high.cpp "#include \"mid_a/a.h\"\n#include \"mid_b/b.h\"\n#include \"low/low.h\"\n#include \"not_a_module.h\"")
if(CASE STREQUAL "upward_include")
  write(low/low.cpp "#include \"low/low.h\"\n#include \"high/high.h\"")
  write(high/high.h "#pragma once")
elseif(CASE STREQUAL "sibling_include")
  write(mid_b/b.cpp "#include \"mid_b/b.h\"\n#include \"mid_a/a.h\"")
elseif(NOT CASE STREQUAL "allowed" AND NOT CASE STREQUAL "undeclared_dependency")
  message(FATAL_ERROR "unknown CASE '${CASE}'")
endif()

aoscan_declare_module(low low)
if(CASE STREQUAL "undeclared_dependency")
  aoscan_declare_module(high high aoscan::mid_a)
endif()
aoscan_declare_module(mid_a mid_a aoscan::low Threads::Threads)
aoscan_declare_module(mid_b mid_b aoscan::low)
aoscan_declare_module(high high aoscan::mid_a aoscan::mid_b)
message(STATUS "dependency check passed: ${CASE}")
