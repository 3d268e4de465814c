# CMake package of xrce-rs' C client library under eProsima's package and target names, so that projects
# written for eProsima's client (micro-ROS' rmw_microxrcedds, PX4, examples) find it with
# find_package(microxrcedds_client) and link the target `microxrcedds_client`. Installed by
# scripts/c-install.sh into <prefix>/lib/cmake/microxrcedds_client/.
get_filename_component(_uxr_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)

include(CMakeFindDependencyMacro)
# The library is Rust inside: it needs the system's threads, dynamic loader and math libraries.
find_dependency(Threads)
find_dependency(microcdr CONFIG PATHS "${_uxr_prefix}/lib/cmake/microcdr" NO_DEFAULT_PATH)

if(NOT TARGET microxrcedds_client)
    add_library(microxrcedds_client STATIC IMPORTED)
    set_target_properties(microxrcedds_client PROPERTIES
        IMPORTED_LOCATION "${_uxr_prefix}/lib/libmicroxrcedds_client.a"
        INTERFACE_INCLUDE_DIRECTORIES "${_uxr_prefix}/include"
        INTERFACE_LINK_LIBRARIES "microcdr;Threads::Threads;${CMAKE_DL_LIBS};m")
endif()

set(microxrcedds_client_INCLUDE_DIR "${_uxr_prefix}/include")
set(microxrcedds_client_LIB_DIR "${_uxr_prefix}/lib")
set(microxrcedds_client_FOUND TRUE)
unset(_uxr_prefix)
