/* A serial line the program opened and configured (any fd: tty, pseudoterminal, pipe), framed HDLC-like.
 * `platform.poll_fd.fd` is that descriptor; `buffer` holds the last message received. */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_SERIAL_SERIAL_TRANSPORT_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_SERIAL_SERIAL_TRANSPORT_H_
#include <uxr/client/config.h>
#include <uxr/client/core/communication/communication.h>
#include <uxr/client/profile/transport/serial/serial_transport_posix.h>
#include <uxr/client/profile/transport/stream_framing/stream_framing_protocol.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
#define UXR_SERIAL_TRANSPORT_OPAQUE_WORDS 96
typedef struct uxrSerialTransport {
    uint8_t buffer[UXR_CONFIG_SERIAL_TRANSPORT_MTU];
    uint8_t remote_addr;
    uxrCommunication comm;
    struct uxrSerialPlatform platform;
    uint64_t _opaque[UXR_SERIAL_TRANSPORT_OPAQUE_WORDS];
} uxrSerialTransport;
UXRDLLAPI bool uxr_init_serial_transport(uxrSerialTransport* transport, const int fd, uint8_t remote_addr,
                                         uint8_t local_addr);
UXRDLLAPI bool uxr_close_serial_transport(uxrSerialTransport* transport);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_PROFILE_TRANSPORT_SERIAL_SERIAL_TRANSPORT_H_ */
