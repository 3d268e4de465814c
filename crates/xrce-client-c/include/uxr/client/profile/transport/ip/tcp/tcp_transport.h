/* TCP to an agent (POSIX sockets, 2-byte length prefix). `platform.poll_fd.fd` is the connected socket;
 * `input_buffer.buffer` holds the last message received (the library decodes the byte stream itself, so the
 * other input_buffer fields stay 0). */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_IP_TCP_TCP_TRANSPORT_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_IP_TCP_TCP_TRANSPORT_H_
#include <uxr/client/config.h>
#include <uxr/client/core/communication/communication.h>
#include <uxr/client/profile/transport/ip/ip.h>
#include <uxr/client/profile/transport/ip/tcp/tcp_transport_posix.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
typedef enum uxrTCPInputBufferState {
    UXR_TCP_BUFFER_EMPTY,
    UXR_TCP_SIZE_INCOMPLETE,
    UXR_TCP_SIZE_READ,
    UXR_TCP_MESSAGE_INCOMPLETE,
    UXR_TCP_MESSAGE_AVAILABLE,
    UXR_TCP_INPUT_BUFFER_STATE_INT_SIZE_ = 0x7FFFFFFF
} uxrTCPInputBufferState;
typedef struct uxrTCPInputBuffer {
    uint8_t buffer[UXR_CONFIG_TCP_TRANSPORT_MTU];
    size_t position;
    uxrTCPInputBufferState state;
    size_t msg_size;
} uxrTCPInputBuffer;
#define UXR_TCP_TRANSPORT_OPAQUE_WORDS 112
typedef struct uxrTCPTransport {
    uxrTCPInputBuffer input_buffer;
    uxrCommunication comm;
    struct uxrTCPPlatform platform;
    uint64_t _opaque[UXR_TCP_TRANSPORT_OPAQUE_WORDS];
} uxrTCPTransport;
UXRDLLAPI bool uxr_init_tcp_transport(uxrTCPTransport* transport, uxrIpProtocol ip_protocol, const char* ip,
                                      const char* port);
UXRDLLAPI bool uxr_close_tcp_transport(uxrTCPTransport* transport);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_PROFILE_TRANSPORT_IP_TCP_TCP_TRANSPORT_H_ */
