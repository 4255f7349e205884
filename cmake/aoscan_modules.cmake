# aoscan's modules and the check of their dependencies. Included by the top-level CMakeLists.txt;
# tests/cmake/dependency_check.cmake runs the check itself on made-up trees (the functions below
# that need no target work in script mode too).

# Every module is one library: add_aoscan_module(NAME [DIR FOLDER] DEPS...) compiles
# src/FOLDER/*.cpp (FOLDER defaults to NAME) into aoscan_NAME, alias aoscan::NAME. The allowed
# dependencies are the DEPS: a module may link only modules declared before it (no module links one
# above it), and every #include "..." of its files must name a header of its own module or of a
# module it depends on, directly or through them (aoscan_check_includes). The configure step stops
# on a violation, so a forbidden dependency cannot come back unnoticed. docs/ARCHITECTURE.md draws
# the graph.

# The folder that holds the modules' folders (a test points it at a made-up tree).
if(NOT AOSCAN_MODULE_ROOT)
  set(AOSCAN_MODULE_ROOT "${CMAKE_SOURCE_DIR}/src")
endif()

# Registers module NAME in folder DIR (relative to AOSCAN_MODULE_ROOT) with its dependencies DEPS
# (aoscan::X for modules; other names, such as imported targets, are not modules) and checks the
# includes of its files. Stops the configure step when a dependency is not declared yet.
function(aoscan_declare_module name dir)
  set(closure ${name})
  foreach(dep ${ARGN})
    if(dep MATCHES "^aoscan::(.+)$")
      set(dep_module "${CMAKE_MATCH_1}")
      get_property(dep_closure GLOBAL PROPERTY "aoscan_closure_${dep_module}")
      if(NOT dep_closure)
        message(FATAL_ERROR "module ${name}: depends on ${dep}, which is not declared before it "
                            "(modules are declared bottom-up in src/CMakeLists.txt)")
      endif()
      list(APPEND closure ${dep_closure})
    endif()
  endforeach()
  list(REMOVE_DUPLICATES closure)
  set_property(GLOBAL PROPERTY "aoscan_closure_${name}" "${closure}")
  set_property(GLOBAL PROPERTY "aoscan_module_dir_${name}" "${dir}")
  set_property(GLOBAL APPEND PROPERTY aoscan_modules "${name}")
  file(GLOB files "${AOSCAN_MODULE_ROOT}/${dir}/*.cpp" "${AOSCAN_MODULE_ROOT}/${dir}/*.h")
  aoscan_check_includes("module ${name}" "${closure}" ${files})
endfunction()

function(add_aoscan_module name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "DIR" "")
  set(dir "${name}")
  if(arg_DIR)
    set(dir "${arg_DIR}")
  endif()
  aoscan_declare_module(${name} ${dir} ${arg_UNPARSED_ARGUMENTS})
  # The glob re-runs the configure step (and so the include check) when a file is added.
  file(GLOB sources CONFIGURE_DEPENDS "${AOSCAN_MODULE_ROOT}/${dir}/*.cpp")
  file(GLOB headers CONFIGURE_DEPENDS "${AOSCAN_MODULE_ROOT}/${dir}/*.h")
  if(sources)
    add_library(aoscan_${name} STATIC ${sources})
    target_include_directories(aoscan_${name} PUBLIC "${AOSCAN_MODULE_ROOT}")
    target_link_libraries(aoscan_${name} PUBLIC ${arg_UNPARSED_ARGUMENTS})
  else()  # a module whose sources are all headers so far
    add_library(aoscan_${name} INTERFACE)
    target_include_directories(aoscan_${name} INTERFACE "${AOSCAN_MODULE_ROOT}")
    target_link_libraries(aoscan_${name} INTERFACE ${arg_UNPARSED_ARGUMENTS})
  endif()
  add_library(aoscan::${name} ALIAS aoscan_${name})
endfunction()

# The modules whose headers `modules` (aoscan::NAME or NAME) may include: each one's closure.
function(aoscan_closure_of out)
  set(result "")
  foreach(m ${ARGN})
    string(REGEX REPLACE "^aoscan::" "" m "${m}")
    get_property(c GLOBAL PROPERTY "aoscan_closure_${m}")
    list(APPEND result ${c})
  endforeach()
  list(REMOVE_DUPLICATES result)
  set(${out} "${result}" PARENT_SCOPE)
endfunction()

# Fails the configure step when one of `files` includes a header of a module outside `allowed`
# (a list of module names). A quoted include is a module header when it names a file under src/;
# its module is the one whose folder holds the file.
function(aoscan_check_includes what allowed)
  get_property(modules GLOBAL PROPERTY aoscan_modules)
  foreach(file ${ARGN})
    file(STRINGS "${file}" includes REGEX "^#include \"[^\"]+\"")
    foreach(line ${includes})
      string(REGEX REPLACE "^#include \"([^\"]+)\".*$" "\\1" header "${line}")
      if(NOT EXISTS "${AOSCAN_MODULE_ROOT}/${header}")
        continue()
      endif()
      get_filename_component(header_dir "${header}" DIRECTORY)
      set(owner "")
      foreach(m ${modules})
        get_property(d GLOBAL PROPERTY "aoscan_module_dir_${m}")
        if(d STREQUAL header_dir)
          set(owner "${m}")
        endif()
      endforeach()
      if(NOT owner)
        message(FATAL_ERROR "${what}: ${file} includes ${header}, which belongs to no module "
                            "declared so far")
      endif()
      list(FIND allowed "${owner}" found)
      if(found EQUAL -1)
        message(FATAL_ERROR "${what}: ${file} includes ${header} of module ${owner}, which it "
                            "does not depend on (allowed: ${allowed}); see docs/ARCHITECTURE.md")
      endif()
    endforeach()
  endforeach()
endfunction()
