/* The SocketCAN part of the CAN FD transport: the raw CAN socket, ready to poll(), and the frame id used. */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_CAN_CAN_TRANSPORT_POSIX_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_CAN_CAN_TRANSPORT_POSIX_H_
#include <linux/can.h>
#include <linux/can/raw.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/types.h>
typedef struct uxrCANPlatform {
    struct pollfd poll_fd;
    canid_t can_id;
} uxrCANPlatform;
#endif
