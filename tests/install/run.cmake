# ctest "install: find_package consumer": install a glintlab build into a fresh prefix, build the
# outside project tests/install/consumer against it (find_package + glintlab::core) and run it.
# Every step that fails stops the script with FATAL_ERROR (non-zero exit). All files go to WORK_DIR
# (in the build tree), none to the source tree.
#
#   cmake -DBUILD_DIR=<glintlab build> -DWORK_DIR=<scratch> -DCONSUMER_DIR=<tests/install/consumer>
#         [-DBUILD_CONFIG=Release] [-DGENERATOR=...] [-DMAKE_PROGRAM=...] [-DCXX_COMPILER=...]
#         [-DCONSUMER_FLAGS=...] -P run.cmake
cmake_minimum_required(VERSION 3.24)
foreach(var BUILD_DIR WORK_DIR CONSUMER_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "install test: ${var} is not set")
  endif()
endforeach()

function(step title)
  message(STATUS "install test: ${title}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message("${out}")
    message(FATAL_ERROR "install test: FAILED at '${title}' (exit ${rc}): ${ARGN}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

set(prefix "${WORK_DIR}/prefix")
set(consumer_build "${WORK_DIR}/consumer-build")
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}")
set(config_args "")
if(BUILD_CONFIG)
  set(config_args --config "${BUILD_CONFIG}")
endif()

# The archive must be current: a no-op after `make test`'s full build, a rebuild of the core (only)
# when the test is run alone after an edit.
step("build glintlab_core" "${CMAKE_COMMAND}" --build "${BUILD_DIR}" --target glintlab_core ${config_args})
step("install into ${prefix}" "${CMAKE_COMMAND}" --install "${BUILD_DIR}" --prefix "${prefix}" ${config_args})

file(GLOB_RECURSE config_file "${prefix}/*/glintlabConfig.cmake")
file(GLOB_RECURSE version_file "${prefix}/*/glintlabConfigVersion.cmake")
file(GLOB_RECURSE archive "${prefix}/*/libglintlab_core.a" "${prefix}/*/glintlab_core.lib")
foreach(needed config_file version_file archive)
  if(NOT ${needed})
    message(FATAL_ERROR "install test: the install has no ${needed}")
  endif()
endforeach()
foreach(header glintlab/counting/law.hpp glintlab/base/rng.hpp glintlab/stats/normal.hpp glintlab/plugin.h)
  if(NOT EXISTS "${prefix}/include/${header}")
    message(FATAL_ERROR "install test: the install has no include/${header}")
  endif()
endforeach()

# Relocatable: the exported targets name no absolute path (a library of the building machine, such as
# libsleef, is an imported target that glintlabConfig.cmake finds again), and the package still works
# after the prefix is moved.
file(GLOB_RECURSE targets_files "${prefix}/*/glintlabTargets*.cmake")
foreach(f IN LISTS targets_files)
  file(STRINGS "${f}" absolute REGEX "(^|[\";(:])/[A-Za-z]")
  if(absolute)
    message(FATAL_ERROR "install test: ${f} names absolute paths (not relocatable):\n${absolute}")
  endif()
endforeach()
set(moved "${WORK_DIR}/moved-prefix")
file(RENAME "${prefix}" "${moved}")
set(prefix "${moved}")

set(configure_args -S "${CONSUMER_DIR}" -B "${consumer_build}"
    "-DCMAKE_PREFIX_PATH=${prefix}"
    # No user package registry entry (the glintlab_DIR check below catches any other stray one).
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF)
if(GENERATOR)
  list(APPEND configure_args -G "${GENERATOR}")
endif()
if(MAKE_PROGRAM)
  list(APPEND configure_args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
endif()
if(CXX_COMPILER)
  list(APPEND configure_args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
if(BUILD_CONFIG)
  list(APPEND configure_args "-DCMAKE_BUILD_TYPE=${BUILD_CONFIG}")
endif()
if(CONSUMER_FLAGS)
  list(APPEND configure_args "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_FLAGS}")
endif()
step("configure the consumer" "${CMAKE_COMMAND}" ${configure_args})

# find_package must have used the package just installed.
file(STRINGS "${consumer_build}/CMakeCache.txt" found_dir REGEX "^glintlab_DIR:")
string(REGEX REPLACE "^[^=]*=" "" found_dir "${found_dir}")
get_filename_component(found_dir "${found_dir}" REALPATH)
get_filename_component(real_prefix "${prefix}" REALPATH)
string(FIND "${found_dir}/" "${real_prefix}/" at)
if(NOT at EQUAL 0)
  message(FATAL_ERROR "install test: find_package(glintlab) used ${found_dir}, not the install in ${prefix}")
endif()

step("build the consumer" "${CMAKE_COMMAND}" --build "${consumer_build}" ${config_args})
file(GLOB_RECURSE exe LIST_DIRECTORIES false "${consumer_build}/glintlab_consumer" "${consumer_build}/glintlab_consumer.exe")
if(NOT exe)
  message(FATAL_ERROR "install test: no glintlab_consumer executable in ${consumer_build}")
endif()
list(GET exe 0 exe)
step("run the consumer" "${exe}")
message("${step_output}")
if(NOT step_output MATCHES "consumer: OK")
  message(FATAL_ERROR "install test: the consumer did not report OK")
endif()
message(STATUS "install test: passed (found ${found_dir})")
