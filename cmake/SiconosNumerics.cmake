# Imported target Siconos::numerics for Siconos Numerics built from Debian's source package
# by scripts/build_siconos.sh. The Debian binary -dev package's CMake config does not work
# with only the numerics component, and the source build's config unsets CMAKE_CXX_STANDARD,
# so the project makes its own target (see docs/reference/siconos-numerics.md).
find_library(SICONOS_NUMERICS_LIBRARY siconos_numerics
  PATHS "${SICONOS_NUMERICS_ROOT}/lib" NO_DEFAULT_PATH)
find_path(SICONOS_NUMERICS_INCLUDE_DIR LinearComplementarityProblem.h
  PATHS "${SICONOS_NUMERICS_ROOT}/include/siconos/numerics" NO_DEFAULT_PATH)
if(NOT SICONOS_NUMERICS_LIBRARY OR NOT SICONOS_NUMERICS_INCLUDE_DIR)
  message(FATAL_ERROR
    "Siconos Numerics not found under SICONOS_NUMERICS_ROOT=${SICONOS_NUMERICS_ROOT}.\n"
    "Build it from Debian's source package with: scripts/build_siconos.sh\n"
    "(scripts/cosim demo|test does this for you), or set SICONOS_NUMERICS_ROOT.")
endif()
add_library(Siconos::numerics SHARED IMPORTED GLOBAL)
set_target_properties(Siconos::numerics PROPERTIES
  IMPORTED_LOCATION "${SICONOS_NUMERICS_LIBRARY}"
  INTERFACE_INCLUDE_DIRECTORIES
    "${SICONOS_NUMERICS_ROOT}/include/siconos;${SICONOS_NUMERICS_INCLUDE_DIR}")
set(SICONOS_LCP_TEST_DATA "${SICONOS_NUMERICS_ROOT}/share/lcp_test_data")
message(STATUS "Siconos Numerics (built from source): ${SICONOS_NUMERICS_LIBRARY}")
