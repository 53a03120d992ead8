# Install rules: `cmake --install <build> [--prefix P]` puts the C++ core, its headers (plugin.h
# included) and a CMake package in P, so that a renderer's build does
#
#   find_package(glintlab 0.1 REQUIRED)
#   target_link_libraries(app PRIVATE glintlab::core)
#
# and gets every registered law. Included at the end of the top-level CMakeLists.txt.
#
# Whole-archive: laws, blends and grid schemes register themselves from static initializers in
# object files nothing else refers to, so a plain static link drops them (make_law("gated") would
# fail in the consumer). The installed package therefore exports two targets:
#   glintlab::core_static  the archive itself (libglintlab_core.a) with its usage requirements;
#   glintlab::core         an INTERFACE target linking $<LINK_LIBRARY:WHOLE_ARCHIVE,glintlab::core_static>,
#                          which is what consumers link: the whole-archive requirement travels with it.
# Chosen over an installed shared library because (1) it installs the very archive the tests,
# benchmarks and the Python module link (no second compile of the core, no second library
# flavour to keep in step), (2) the build already relies on the same CMake >= 3.24 feature, and
# (3) a shared library would bring SONAME/ABI versioning, RPATH and symbol-visibility questions
# that this project has not settled. The cost: consumers need CMake >= 3.24 (glintlabConfig.cmake
# says so instead of failing obscurely), and a consumer must not also link glintlab::core_static
# plainly (CMake refuses mixing features for one library). Non-CMake builds must wrap the archive
# in -Wl,--whole-archive ... -Wl,--no-whole-archive themselves.

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(GLINTLAB_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/glintlab"
    CACHE STRING "Where glintlabConfig.cmake is installed (relative to the prefix)")

# glintlab_core's include directories are source-tree and system paths; an exported target may
# carry neither. Keep them for the build tree only, and use the installed include dir plus
# imported targets that glintlabConfig.cmake finds (Boost::headers for <boost/math/...> in
# normal.hpp, glintlab::random123 for <Random123/philox.h> in rng.hpp) in the install tree.
function(_glintlab_build_interface_only target property)
  get_target_property(dirs ${target} ${property})
  set(wrapped "")
  if(dirs)
    foreach(dir IN LISTS dirs)
      list(APPEND wrapped "$<BUILD_INTERFACE:${dir}>")
    endforeach()
  endif()
  set_property(TARGET ${target} PROPERTY ${property} ${wrapped})
endfunction()
_glintlab_build_interface_only(glintlab_core INTERFACE_INCLUDE_DIRECTORIES)
_glintlab_build_interface_only(glintlab_core INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
set_property(TARGET glintlab_core APPEND PROPERTY INTERFACE_INCLUDE_DIRECTORIES
             "$<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>")
set_property(TARGET glintlab_core APPEND PROPERTY INTERFACE_LINK_LIBRARIES
             "$<INSTALL_INTERFACE:Boost::headers>" "$<INSTALL_INTERFACE:glintlab::random123>")
set_target_properties(glintlab_core PROPERTIES EXPORT_NAME core_static)

# CMake 3.25's export does not rename targets inside $<LINK_LIBRARY:...> (it would write the
# build-tree name glintlab_core), so the installed form names the exported target itself.
add_library(glintlab_core_whole INTERFACE)
target_link_libraries(glintlab_core_whole INTERFACE
                      "$<BUILD_INTERFACE:$<LINK_LIBRARY:WHOLE_ARCHIVE,glintlab_core>>"
                      "$<INSTALL_INTERFACE:$<LINK_LIBRARY:WHOLE_ARCHIVE,glintlab::core_static>>")
set_target_properties(glintlab_core_whole PROPERTIES EXPORT_NAME core)

install(TARGETS glintlab_core glintlab_core_whole EXPORT glintlabTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT glintlab_development)
# Every public header, the C plugin ABI core/include/glintlab/plugin.h among them.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/include/glintlab
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT glintlab_development
        FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")

install(EXPORT glintlabTargets NAMESPACE glintlab:: FILE glintlabTargets.cmake
        DESTINATION ${GLINTLAB_INSTALL_CMAKEDIR} COMPONENT glintlab_development)
# Recorded as a hint only (the Random123 headers of the machine that built the package).
set(GLINTLAB_RANDOM123_HINT "${RANDOM123_INCLUDE_DIR}")
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/glintlabConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/glintlabConfig.cmake
                              INSTALL_DESTINATION ${GLINTLAB_INSTALL_CMAKEDIR})
# 0.x: a minor release may break the API, so 0.1 accepts 0.1.* only.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/glintlabConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/glintlabConfig.cmake ${PROJECT_BINARY_DIR}/glintlabConfigVersion.cmake
        DESTINATION ${GLINTLAB_INSTALL_CMAKEDIR} COMPONENT glintlab_development)
