# The version every program reports (`vgrd --version`, vgr_build_info): `git describe
# --tags --always --dirty` of the source tree, or the project version outside a git
# checkout (a source tarball). Regenerated at every build by a tiny custom target, but the
# file is rewritten only when the description changes, so a build without a new commit
# recompiles nothing. core/version.hpp declares the function; vgr_core compiles it.
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
target_sources(vgr_core PRIVATE ${VGR_VERSION_CPP})
add_dependencies(vgr_core vgr_version_gen)
