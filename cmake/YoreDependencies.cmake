# Finds yore's system dependencies and fails with the Debian package to install when one is missing.

find_package(Eigen3 3.4 NO_MODULE QUIET)
if(NOT Eigen3_FOUND)
  message(FATAL_ERROR "yore: Eigen 3.4 not found. On Debian/Ubuntu: apt-get install libeigen3-dev")
endif()

# SuiteSparse 5.12 (Debian 12) ships no CMake config and no pkg-config file for CHOLMOD.
find_path(CHOLMOD_INCLUDE_DIR cholmod.h PATH_SUFFIXES suitesparse)
find_library(CHOLMOD_LIBRARY cholmod)
find_library(SUITESPARSECONFIG_LIBRARY suitesparseconfig)
if(NOT CHOLMOD_INCLUDE_DIR OR NOT CHOLMOD_LIBRARY OR NOT SUITESPARSECONFIG_LIBRARY)
  message(FATAL_ERROR "yore: CHOLMOD (SuiteSparse) not found "
    "(cholmod.h: ${CHOLMOD_INCLUDE_DIR}, libcholmod: ${CHOLMOD_LIBRARY}). "
    "On Debian/Ubuntu: apt-get install libsuitesparse-dev")
endif()
if(NOT TARGET SuiteSparse::CHOLMOD)
  add_library(SuiteSparse::CHOLMOD UNKNOWN IMPORTED)
  set_target_properties(SuiteSparse::CHOLMOD PROPERTIES
    IMPORTED_LOCATION "${CHOLMOD_LIBRARY}"
    INTERFACE_INCLUDE_DIRECTORIES "${CHOLMOD_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${SUITESPARSECONFIG_LIBRARY}")
endif()
message(STATUS "yore: CHOLMOD ${CHOLMOD_LIBRARY} (headers in ${CHOLMOD_INCLUDE_DIR})")

# SUNDIALS 6 (Debian 12's libsundials-dev) ships SUNDIALSConfig.cmake: CVODE and ARKODE for the
# error-controlled integrators (error_controlled.cpp).
find_package(SUNDIALS 6 QUIET CONFIG)
if(NOT SUNDIALS_FOUND OR NOT TARGET SUNDIALS::cvode_shared OR NOT TARGET SUNDIALS::arkode_shared)
  message(FATAL_ERROR "yore: SUNDIALS 6 (CVODE, ARKODE) not found. "
    "On Debian/Ubuntu: apt-get install --no-install-recommends libsundials-dev")
endif()
message(STATUS "yore: SUNDIALS ${SUNDIALS_VERSION}")

set(CGAL_DO_NOT_WARN_ABOUT_CMAKE_BUILD_TYPE TRUE)
find_package(CGAL QUIET)
if(NOT CGAL_FOUND)
  message(FATAL_ERROR "yore: CGAL not found. On Debian/Ubuntu: apt-get install libcgal-dev")
endif()

find_package(OpenMP COMPONENTS CXX)
if(NOT OpenMP_CXX_FOUND)
  message(WARNING "yore: OpenMP not found; the core will run single-threaded")
endif()
