/* eProsima's serial transport for RTEMS; this library's serial transport is POSIX's (serial_transport.h). */
#include <uxr/client/profile/transport/serial/serial_transport.h>
