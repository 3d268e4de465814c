/* The POSIX part of the TCP transport: the socket, ready to poll() (events POLLIN). */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_IP_TCP_TCP_TRANSPORT_POSIX_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_IP_TCP_TCP_TRANSPORT_POSIX_H_
#include <poll.h>
#include <sys/socket.h>
#include <sys/types.h>
typedef struct uxrTCPPlatform {
    struct pollfd poll_fd;
} uxrTCPPlatform;
#endif
