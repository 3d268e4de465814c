/* The POSIX part of the serial transport: the line's descriptor, ready to poll() (events POLLIN). */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_SERIAL_SERIAL_TRANSPORT_POSIX_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_SERIAL_SERIAL_TRANSPORT_POSIX_H_
#include <poll.h>
typedef struct uxrSerialPlatform {
    struct pollfd poll_fd;
} uxrSerialPlatform;
#endif
