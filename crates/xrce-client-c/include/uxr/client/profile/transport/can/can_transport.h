/* CAN FD over SocketCAN (Linux): one XRCE message per frame, at most UXR_CAN_TRANSPORT_MTU bytes. */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_CAN_CAN_TRANSPORT_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_CAN_CAN_TRANSPORT_H_
#include <uxr/client/config.h>
#include <uxr/client/core/communication/communication.h>
#include <uxr/client/profile/transport/can/can_transport_posix.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
#define UXR_CAN_TRANSPORT_MTU 63
#define UXR_CAN_TRANSPORT_OPAQUE_WORDS 4
typedef struct uxrCANTransport {
    uint8_t buffer[UXR_CAN_TRANSPORT_MTU];
    uxrCommunication comm;
    struct uxrCANPlatform platform;
    uint64_t _opaque[UXR_CAN_TRANSPORT_OPAQUE_WORDS];
} uxrCANTransport;
UXRDLLAPI bool uxr_init_can_transport(uxrCANTransport* transport, const char* dev, uint32_t can_id);
UXRDLLAPI bool uxr_close_can_transport(uxrCANTransport* transport);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_PROFILE_TRANSPORT_CAN_CAN_TRANSPORT_H_ */
