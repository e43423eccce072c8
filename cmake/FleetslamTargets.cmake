# Helpers shared by every module: warnings per target, sanitizers, and the library layout of DESIGN.md.

function(fleetslam_target_options target)
  if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
    target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor
                                             -Wold-style-cast -Wcast-align -Woverloaded-virtual
                                             -Wnull-dereference -Wdouble-promotion -Wformat=2)
    if(FLEETSLAM_WARNINGS_AS_ERRORS)
      target_compile_options(${target} PRIVATE -Werror)
    endif()
  endif()
  if(FLEETSLAM_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=address,undefined -fno-omit-frame-pointer
                                             -fno-sanitize-recover=undefined)
    target_link_options(${target} PRIVATE -fsanitize=address,undefined)
  endif()
endfunction()

# fleetslam_add_library(<module> SOURCES ... PUBLIC_DEPS ... PRIVATE_DEPS ...)
# Creates fleetslam_<module> with the alias fleetslam::<module>; headers in <module>/include.
function(fleetslam_add_library module)
  cmake_parse_arguments(ARG "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  set(target fleetslam_${module})
  add_library(${target} ${ARG_SOURCES})
  add_library(fleetslam::${module} ALIAS ${target})
  target_include_directories(${target} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>)
  target_link_libraries(${target} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  fleetslam_target_options(${target})
endfunction()
