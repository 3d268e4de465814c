# CMake package of the Micro-CDR functions of xrce-rs' C client library under eProsima's package and target
# names (find_package(microcdr), target `microcdr`). The functions live in the client library's archive
# (one Rust runtime per program), so the target points at it. As eProsima's package, it sets no
# microcdr_LIBRARIES: ament's micro-ROS type-support libraries then leave the ucdr_* symbols to the process's
# rmw library (which links the target) instead of each carrying a copy. Installed by scripts/c-install.sh.
get_filename_component(_ucdr_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)

include(CMakeFindDependencyMacro)
find_dependency(Threads)

if(NOT TARGET microcdr)
    add_library(microcdr STATIC IMPORTED)
    set_target_properties(microcdr PROPERTIES
        IMPORTED_LOCATION "${_ucdr_prefix}/lib/libmicrocdr.a"
        INTERFACE_INCLUDE_DIRECTORIES "${_ucdr_prefix}/include"
        INTERFACE_LINK_LIBRARIES "Threads::Threads;${CMAKE_DL_LIBS};m")
endif()

set(microcdr_INCLUDE_DIR "${_ucdr_prefix}/include")
set(microcdr_LIB_DIR "${_ucdr_prefix}/lib")
set(microcdr_FOUND TRUE)
unset(_ucdr_prefix)
