# One interface target carries the project's warning flags (and sanitizers); every project
# target links it PRIVATE. -Werror only with COSIM_WERROR (the dev/ci presets).
add_library(cosim_warnings INTERFACE)
target_compile_options(cosim_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Wunused -Woverloaded-virtual -Wconversion -Wno-sign-conversion -Wnull-dereference
  -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
# GCC 12's -Wrestrict reports impossible memcpy overlaps inside std::string concatenation
# (GCC bug 105651), on code as plain as "a" + std::to_string(i) + "b": silenced for GCC 12 only.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_GREATER_EQUAL 12
   AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  target_compile_options(cosim_warnings INTERFACE -Wno-restrict)
endif()
if(COSIM_WERROR)
  target_compile_options(cosim_warnings INTERFACE -Werror)
endif()
if(COSIM_SANITIZE)
  target_compile_options(cosim_warnings INTERFACE -fsanitize=address,undefined -fno-omit-frame-pointer
                                                  -fno-sanitize-recover=undefined)
  target_link_options(cosim_warnings INTERFACE -fsanitize=address,undefined)
endif()
