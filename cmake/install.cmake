# `cmake --install build --prefix P`: the libraries, their public headers and
# P/lib/cmake/Nephele/{NepheleConfig,NepheleConfigVersion,NepheleTargets}.cmake, so that a host
# calls find_package(Nephele) and links Nephele::core, ::platform, ::glfw, ::model, ::ellipsoid,
# ::layered, ::sky (the host's entry point, SkyRenderer), ::volume, ::reference or ::nephele
# (every method). Shaders are embedded in
# Nephele::core at build time: nothing to locate at run time.
include(CMakePackageConfigHelpers)
set(NEPHELE_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/Nephele)
install(TARGETS nephele_core nephele_platform nephele_glfw nephele_model nephele_ellipsoid nephele_layered nephele_sky nephele_volume
                nephele_reference nephele_all
        EXPORT NepheleTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(EXPORT NepheleTargets NAMESPACE Nephele:: DESTINATION ${NEPHELE_CMAKE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/NepheleConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/NepheleConfig.cmake
                              INSTALL_DESTINATION ${NEPHELE_CMAKE_DIR})
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/NepheleConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/NepheleConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/NepheleConfigVersion.cmake
        DESTINATION ${NEPHELE_CMAKE_DIR})
