# Installation: library, public headers, pkg-config file, CMake package.
include(CMakePackageConfigHelpers)

install(TARGETS hetinv EXPORT hetinvTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
if(HETINV_WITH_MPI)
  set(HETINV_INSTALL_EXCLUDE "")
  set(HETINV_PC_REQUIRES "Requires: ompi-c") # hetinv/mpi.h includes <mpi.h>
else()
  set(HETINV_INSTALL_EXCLUDE PATTERN "mpi.h" EXCLUDE) # only the MPI build has it
  set(HETINV_PC_REQUIRES "")
endif()
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/hetinv DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h" ${HETINV_INSTALL_EXCLUDE})
install(FILES ${PROJECT_BINARY_DIR}/include/hetinv/version.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/hetinv)

# hetinv.pc locates its prefix from where it is installed (${pcfiledir}), so
# an install moved or made with `cmake --install --prefix DIR` (a prefix
# other than the configured one) still gives the right paths.
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  set(HETINV_PC_PREFIX "${CMAKE_INSTALL_PREFIX}")
else()
  file(RELATIVE_PATH hetinv_pc_up "/p/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/p")
  string(REGEX REPLACE "/$" "" hetinv_pc_up "${hetinv_pc_up}")
  set(HETINV_PC_PREFIX "\${pcfiledir}/${hetinv_pc_up}")
endif()
configure_file(${PROJECT_SOURCE_DIR}/hetinv.pc.in ${PROJECT_BINARY_DIR}/hetinv.pc @ONLY)
install(FILES ${PROJECT_BINARY_DIR}/hetinv.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)

set(HETINV_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/hetinv)
install(EXPORT hetinvTargets NAMESPACE hetinv:: DESTINATION ${HETINV_CMAKE_DIR})
# The build tree is a package too (find_package(hetinv) with hetinv_DIR=<build>):
# the hetinvConfig.cmake written below includes the hetinvTargets.cmake beside it.
export(EXPORT hetinvTargets NAMESPACE hetinv:: FILE ${PROJECT_BINARY_DIR}/hetinvTargets.cmake)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/hetinvConfig.cmake.in
  ${PROJECT_BINARY_DIR}/hetinvConfig.cmake INSTALL_DESTINATION ${HETINV_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/hetinvConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${PROJECT_BINARY_DIR}/hetinvConfig.cmake ${PROJECT_BINARY_DIR}/hetinvConfigVersion.cmake
        DESTINATION ${HETINV_CMAKE_DIR})
