/* The POSIX part of the UDP transport: the socket, ready to poll() (events POLLIN). */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_IP_UDP_UDP_TRANSPORT_POSIX_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_IP_UDP_UDP_TRANSPORT_POSIX_H_
#include <poll.h>
#include <sys/socket.h>
#include <sys/types.h>
typedef struct uxrUDPPlatform {
    struct pollfd poll_fd;
} uxrUDPPlatform;
#endif
