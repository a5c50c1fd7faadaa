# Finds every dependency; a missing one stops configuration with the Debian
# package that provides it.
include(FindPkgConfig)

function(hetinv_missing what package)
  message(FATAL_ERROR "libhetinv needs ${what}, which was not found.\n"
                      "On Debian/Ubuntu: apt-get install ${package}")
endfunction()

find_package(PkgConfig QUIET)
if(NOT PKG_CONFIG_FOUND)
  hetinv_missing("pkg-config" "pkg-config")
endif()

# OpenEXR: only its C API (OpenEXRCore) is used. pkg-config gives the C++
# libraries too, so link the core library alone.
pkg_check_modules(OPENEXR QUIET OpenEXR)
find_library(HETINV_OPENEXRCORE_LIBRARY NAMES OpenEXRCore-3_1 OpenEXRCore
             HINTS ${OPENEXR_LIBRARY_DIRS})
if(NOT OPENEXR_FOUND OR NOT HETINV_OPENEXRCORE_LIBRARY)
  hetinv_missing("OpenEXR (OpenEXRCore C API)" "libopenexr-dev")
endif()
add_library(hetinv_openexr INTERFACE)
target_include_directories(hetinv_openexr SYSTEM INTERFACE ${OPENEXR_INCLUDE_DIRS})
target_link_libraries(hetinv_openexr INTERFACE ${HETINV_OPENEXRCORE_LIBRARY})

pkg_check_modules(PNG QUIET IMPORTED_TARGET libpng)
if(NOT PNG_FOUND)
  hetinv_missing("libpng" "libpng-dev")
endif()

find_path(HETINV_RANDOM123_INCLUDE_DIR NAMES Random123/philox.h)
if(NOT HETINV_RANDOM123_INCLUDE_DIR)
  hetinv_missing("Random123 (header-only)" "librandom123-dev")
endif()

find_package(OpenMP QUIET COMPONENTS C)
if(NOT OpenMP_C_FOUND)
  hetinv_missing("OpenMP for C" "libgomp1 (gcc) or libomp-dev (clang)")
endif()

if(HETINV_WITH_MPI)
  find_package(MPI QUIET COMPONENTS C)
  if(NOT MPI_C_FOUND)
    hetinv_missing("MPI for C (because HETINV_WITH_MPI is ON; or -DHETINV_WITH_MPI=OFF)"
                   "libopenmpi-dev openmpi-bin")
  endif()
  # The mpi tests run programs under mpirun.
  if(HETINV_BUILD_TESTS AND NOT MPIEXEC_EXECUTABLE)
    hetinv_missing("mpirun (for the mpi tests; or -DHETINV_BUILD_TESTS=OFF)" "openmpi-bin")
  endif()
  # Their environment (tests/mpi, examples): mpirun refuses root unless told
  # twice; passive OpenMP waits keep oversubscribed ranks (4 ranks x 2
  # threads on a small machine) from spinning; a hung job is ended by
  # mpirun itself (MPIEXEC_TIMEOUT, before a test's TIMEOUT), which takes
  # its ranks with it: killed by CTest, mpirun could leave a rank spinning.
  set(HETINV_MPI_TEST_ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
      OMP_WAIT_POLICY=passive MPIEXEC_TIMEOUT=100)
endif()

if(HETINV_BUILD_TESTS)
  pkg_check_modules(CMOCKA QUIET IMPORTED_TARGET cmocka)
  if(NOT CMOCKA_FOUND)
    hetinv_missing("cmocka (for the tests; or -DHETINV_BUILD_TESTS=OFF)" "libcmocka-dev")
  endif()
endif()

if(HETINV_BUILD_EXAMPLES OR HETINV_BUILD_FUZZERS) # the scene fuzzers parse the examples' JSON
  pkg_check_modules(CJSON QUIET IMPORTED_TARGET libcjson)
  if(NOT CJSON_FOUND)
    hetinv_missing("cJSON (for the examples and scene fuzzers; or -DHETINV_BUILD_EXAMPLES=OFF)" "libcjson-dev")
  endif()
endif()
