# Warnings for our own targets only; imported targets keep their includes SYSTEM.
add_library(vgr_warnings INTERFACE)
target_compile_options(vgr_warnings INTERFACE
  -Wall -Wextra -Wshadow -Wnon-virtual-dtor -Wpedantic
  $<$<BOOL:${VGR_WERROR}>:-Werror>)

if(VGR_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

# vgr_add_library(name SOURCES ... DEPS ...) : one library per folder, vgr::name alias.
function(vgr_add_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(vgr_${name} STATIC ${ARG_SOURCES})
  add_library(vgr::${name} ALIAS vgr_${name})
  target_include_directories(vgr_${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(vgr_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE vgr_warnings ${ARG_PRIVATE_DEPS})
endfunction()
