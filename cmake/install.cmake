# `cmake --install build/release --prefix P`: the library, the renderer, their headers, the
# `lamina` tool and a CMake package, so that another project does
#   find_package(lamina CONFIG REQUIRED)
#   target_link_libraries(app PRIVATE lamina::lamina)   # lamina::render for pictures, lamina::net to serve
# with nothing else to set (docs/embedding.md; tests/consumer builds such a project).
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(LAMINA_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/lamina)

# The installed tool and libraries find each other relative to where they are.
set_target_properties(lamina_cli PROPERTIES INSTALL_RPATH "$ORIGIN/../${CMAKE_INSTALL_LIBDIR}")
set_target_properties(lamina_render lamina_net PROPERTIES INSTALL_RPATH "$ORIGIN")

install(TARGETS lamina lamina_render lamina_net lamina_capi EXPORT laminaTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS lamina_cli RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/lamina DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
# The data compiled into the library and its licences (data/PROVENANCE.md), beside the library's docs.
install(FILES ${PROJECT_SOURCE_DIR}/data/PROVENANCE.md DESTINATION ${CMAKE_INSTALL_DOCDIR}/data)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/licenses DESTINATION ${CMAKE_INSTALL_DOCDIR}/data)
install(EXPORT laminaTargets NAMESPACE lamina:: FILE laminaTargets.cmake
        DESTINATION ${LAMINA_CMAKE_DIR})

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/laminaConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/laminaConfig.cmake
                              INSTALL_DESTINATION ${LAMINA_CMAKE_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/laminaConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/laminaConfig.cmake ${PROJECT_BINARY_DIR}/laminaConfigVersion.cmake
        DESTINATION ${LAMINA_CMAKE_DIR})
