# `cmake --install` layout and the CMake package (find_package(nhnet) in outside projects):
#   lib/libnhnet.a, include/nhnet/*.hpp (+ nhnet/pcl/), bin/nhnet-cli (cli/CMakeLists.txt),
#   share/nhnet/models/ (the shipped model files), lib/cmake/nhnet/nhnet{Config,ConfigVersion,
#   Targets}.cmake exporting nhnet::core and nhnet::pcl. The version is project(VERSION) of the
#   top CMakeLists.txt, the same number nhnet-cli --version and nhnet.__version__ report.
include(CMakePackageConfigHelpers)

set(NHNET_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/nhnet)
set(NHNET_INSTALL_MODELDIR ${CMAKE_INSTALL_DATADIR}/nhnet/models)

set_target_properties(nhnet_core PROPERTIES EXPORT_NAME core)
install(TARGETS nhnet_core EXPORT nhnetTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT dev)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/include/nhnet
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev FILES_MATCHING PATTERN "*.hpp")
install(FILES ${PROJECT_BINARY_DIR}/core/include/nhnet/version.hpp
  DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/nhnet COMPONENT dev)
if(TARGET nhnet_pcl)
  install(TARGETS nhnet_pcl EXPORT nhnetTargets COMPONENT dev)
endif()

# The files of models/ (TorchScript model(s) and the model card); the directory is created even
# while models/ is empty or absent, so nhnet_MODEL_DIR always exists.
install(DIRECTORY DESTINATION ${NHNET_INSTALL_MODELDIR} COMPONENT models)
if(EXISTS ${PROJECT_SOURCE_DIR}/models)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/models/ DESTINATION ${NHNET_INSTALL_MODELDIR}
          COMPONENT models)
endif()

install(EXPORT nhnetTargets NAMESPACE nhnet:: DESTINATION ${NHNET_INSTALL_CMAKEDIR} COMPONENT dev)
get_property(NHNET_HAS_TORCH GLOBAL PROPERTY NHNET_HAS_TORCH)
if(NOT NHNET_HAS_TORCH)
  set(NHNET_HAS_TORCH OFF)
endif()
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/nhnetConfig.cmake.in
  ${PROJECT_BINARY_DIR}/nhnetConfig.cmake
  INSTALL_DESTINATION ${NHNET_INSTALL_CMAKEDIR}
  PATH_VARS NHNET_INSTALL_MODELDIR CMAKE_INSTALL_BINDIR)
# 0.x releases may break the API between minor versions: only the same minor is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/nhnetConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/nhnetConfig.cmake ${PROJECT_BINARY_DIR}/nhnetConfigVersion.cmake
  DESTINATION ${NHNET_INSTALL_CMAKEDIR} COMPONENT dev)
