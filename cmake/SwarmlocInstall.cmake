# `cmake --install build --prefix P` puts the binaries in P/bin, the scenarios in P/share/swarmloc, and
# the transport-free estimator libraries with their headers and a CMake package in P/lib and P/include:
# another project uses them with find_package(swarmloc) and swarmloc::estimators (tests/install checks
# it end to end). The container image is built this way (deploy/container/Containerfile).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS swarmloc swarmloc-agent RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/scenarios/ DESTINATION ${CMAKE_INSTALL_DATADIR}/swarmloc/scenarios)

# The estimators take plain C++/Eigen in and out: the part of swarmloc worth embedding elsewhere.
# swarmloc_warnings and swarmloc_sanitizers are linked privately; a static library's private links are
# exported as link-only, so they travel in the export set (they add nothing at link time).
install(TARGETS swarmloc_core swarmloc_models swarmloc_estimators swarmloc_warnings swarmloc_test_warnings swarmloc_sanitizers
        EXPORT swarmlocTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
foreach(library core models estimators)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/common/${library}/include/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
endforeach()
set(swarmloc_cmake_dir ${CMAKE_INSTALL_LIBDIR}/cmake/swarmloc)
install(EXPORT swarmlocTargets NAMESPACE swarmloc:: DESTINATION ${swarmloc_cmake_dir})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/swarmlocConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/swarmlocConfig.cmake INSTALL_DESTINATION ${swarmloc_cmake_dir})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/swarmlocConfigVersion.cmake COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/swarmlocConfig.cmake ${PROJECT_BINARY_DIR}/swarmlocConfigVersion.cmake
        DESTINATION ${swarmloc_cmake_dir})
