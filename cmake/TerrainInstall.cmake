# What `cmake --install` puts in a prefix: the game's library, shared and static, and its package
# (find_package, pkg-config), the programs, and nothing of the build tree. A game then writes
#   find_package(terrain CONFIG REQUIRED)
#   target_link_libraries(game PRIVATE terrain::client)   # or terrain::client_static
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(TARGETS terrain-server terrain-replay terrain-bot terrain-sim
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

if(TERRAIN_PIC)
    set_target_properties(terrain_client PROPERTIES EXPORT_NAME client)
    install(TARGETS terrain_client EXPORT terrainTargets
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} NAMELINK_COMPONENT Development
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
    install(FILES ${PROJECT_SOURCE_DIR}/client/api/include/terrain_client.h
        ${PROJECT_SOURCE_DIR}/client/api/include/terrain_replica.h
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
    install(FILES ${PROJECT_SOURCE_DIR}/client/api/include/terrain/game/client.h
        ${PROJECT_SOURCE_DIR}/client/api/include/terrain/game/replica.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/terrain/game)
    # the static archive beside it (terrain::client_static in the package)
    install(FILES ${PROJECT_BINARY_DIR}/client/libterrain_client.a
        DESTINATION ${CMAKE_INSTALL_LIBDIR})
    set(package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/terrain)
    install(EXPORT terrainTargets NAMESPACE terrain:: DESTINATION ${package_dir})
    configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/terrainConfig.cmake.in
        ${PROJECT_BINARY_DIR}/terrainConfig.cmake INSTALL_DESTINATION ${package_dir})
    write_basic_package_version_file(${PROJECT_BINARY_DIR}/terrainConfigVersion.cmake
        COMPATIBILITY SameMinorVersion) # 0.x: a minor version may change the ABI
    install(FILES ${PROJECT_BINARY_DIR}/terrainConfig.cmake
        ${PROJECT_BINARY_DIR}/terrainConfigVersion.cmake DESTINATION ${package_dir})
    configure_file(${PROJECT_SOURCE_DIR}/cmake/terrain_client.pc.in
        ${PROJECT_BINARY_DIR}/terrain_client.pc @ONLY)
    configure_file(${PROJECT_SOURCE_DIR}/cmake/terrain_client_static.pc.in
        ${PROJECT_BINARY_DIR}/terrain_client_static.pc @ONLY)
    install(FILES ${PROJECT_BINARY_DIR}/terrain_client.pc
        ${PROJECT_BINARY_DIR}/terrain_client_static.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endif()
