# `cmake --install BUILD --prefix P`: the command line program, the static libraries with the
# headers they need, and a CMake package, so that a project outside this tree can write
#   find_package(mchex 0.1 REQUIRED)
#   target_link_libraries(app PRIVATE mchex::mchex)
# (docs/package.md; examples/find_package is such a project, built by tests/test_package.py).
#
# The exported libraries are the build's own static ones, one per stage, so the package is the
# code that the CLI and the tests run, with no second link step or symbol list to keep. Static
# libraries carry their private dependencies into their link interface, so mchexConfig.cmake finds
# each package they were linked with again (cmake/mchexConfig.cmake.in).
include(CMakePackageConfigHelpers)

# The one target a user links: every core stage and the backends (host/backends/registry.h
# make_backend), whose cpu backend the pipeline needs at least.
add_library(mchex INTERFACE)
target_link_libraries(mchex INTERFACE mchex_backends mchex_core)
add_library(mchex::mchex ALIAS mchex)

set(MCHEX_PACKAGE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/mchex)
set(exported mchex mchex_core mchex_backends)
foreach(stage base mesh io sdf grid cutting check optimize device pipeline)
  list(APPEND exported mchex_${stage})
endforeach()
if(MCHEX_WITH_VULKAN)
  list(APPEND exported mchex_spirv)
endif()
install(TARGETS mchex-gpu RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS ${exported} EXPORT mchexTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(EXPORT mchexTargets NAMESPACE mchex:: DESTINATION ${MCHEX_PACKAGE_DIR})

# Every header of core/, by its source path, since the entry points (core/pipeline/pipeline.h and
# the headers docs/package.md lists) include the stages below them; and the backend registry.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/mchex/core
        FILES_MATCHING PATTERN "*.h")
install(FILES ${PROJECT_SOURCE_DIR}/host/backends/registry.h DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/mchex/host/backends)

configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/mchexConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/mchexConfig.cmake INSTALL_DESTINATION ${MCHEX_PACKAGE_DIR})
# 0.x: a minor release may change the API, so only the same minor version is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/mchexConfigVersion.cmake VERSION ${PROJECT_VERSION}
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/mchexConfig.cmake ${PROJECT_BINARY_DIR}/mchexConfigVersion.cmake
              ${PROJECT_SOURCE_DIR}/cmake/mchexExodus.cmake DESTINATION ${MCHEX_PACKAGE_DIR})
