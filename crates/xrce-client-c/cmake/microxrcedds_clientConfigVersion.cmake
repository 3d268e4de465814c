# The eProsima client release whose API the library provides (uxr/client/config.h): 3.0.1. Projects that ask
# for 2.x (micro-ROS Jazzy, PX4) are accepted too: the 2.4 and 3.0 APIs are the same headers.
set(PACKAGE_VERSION "3.0.1")
if(PACKAGE_FIND_VERSION_MAJOR AND (PACKAGE_FIND_VERSION_MAJOR LESS 2 OR PACKAGE_FIND_VERSION_MAJOR GREATER 3))
    set(PACKAGE_VERSION_COMPATIBLE FALSE)
else()
    set(PACKAGE_VERSION_COMPATIBLE TRUE)
    if(PACKAGE_FIND_VERSION STREQUAL PACKAGE_VERSION)
        set(PACKAGE_VERSION_EXACT TRUE)
    endif()
endif()
