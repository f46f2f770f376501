# The version every program reports (`vgrd --version`, vgr_build_info): `git describe
# --tags --always --dirty` of the source tree, or the project version outside a git
# checkout (a source tarball). Regenerated at every build by a tiny custom target, but the
# file is rewritten only when the description changes, so a build without a new commit
# recompiles nothing. core/version.hpp declares the function; the tiny library vgr_version
# defines it and only the programs that report it link it (vgrd, vgr), so a new commit
# relinks two programs, not every test.
set(VGR_VERSION_CPP ${CMAKE_BINARY_DIR}/generated/vgr_version.cpp)
add_custom_target(vgr_version_gen
  COMMAND ${CMAKE_COMMAND} -DSRC=${PROJECT_SOURCE_DIR} -DOUT=${VGR_VERSION_CPP} -DFALLBACK=${PROJECT_VERSION}
          -P ${PROJECT_SOURCE_DIR}/cmake/VgrVersionGen.cmake
  BYPRODUCTS ${VGR_VERSION_CPP}
  COMMENT "vgr version (git describe)"
  VERBATIM)
# At configure time too, so the file exists before the first build.
execute_process(COMMAND ${CMAKE_COMMAND} -DSRC=${PROJECT_SOURCE_DIR} -DOUT=${VGR_VERSION_CPP} -DFALLBACK=${PROJECT_VERSION}
                -P ${PROJECT_SOURCE_DIR}/cmake/VgrVersionGen.cmake)
add_library(vgr_version STATIC ${VGR_VERSION_CPP})
target_include_directories(vgr_version PRIVATE ${PROJECT_SOURCE_DIR})
add_dependencies(vgr_version vgr_version_gen)
# vgr_daemon's plant.cpp calls buildVersion(): everything that links the daemon library (vgrd,
# vgr through vgr_tools, the tests) gets it after it on the link line. A new version relinks
# those, it recompiles nothing.
target_link_libraries(vgr_daemon INTERFACE vgr_version)
target_link_libraries(vgrd PRIVATE vgr_version)
target_link_libraries(vgr PRIVATE vgr_version)
