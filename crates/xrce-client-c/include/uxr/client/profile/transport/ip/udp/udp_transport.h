/* UDP to an agent (POSIX sockets). `platform.poll_fd.fd` is the connected socket: a program may poll() it to
 * learn when the agent sent something; `buffer` holds the last message received. */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_IP_UDP_UDP_TRANSPORT_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_IP_UDP_UDP_TRANSPORT_H_
#include <uxr/client/config.h>
#include <uxr/client/core/communication/communication.h>
#include <uxr/client/profile/transport/ip/ip.h>
#include <uxr/client/profile/transport/ip/udp/udp_transport_posix.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
#define UXR_UDP_TRANSPORT_OPAQUE_WORDS 4
typedef struct uxrUDPTransport {
    uint8_t buffer[UXR_CONFIG_UDP_TRANSPORT_MTU];
    uxrCommunication comm;
    struct uxrUDPPlatform platform;
    uint64_t _opaque[UXR_UDP_TRANSPORT_OPAQUE_WORDS];
} uxrUDPTransport;
UXRDLLAPI bool uxr_init_udp_transport(uxrUDPTransport* transport, uxrIpProtocol ip_protocol, const char* ip,
                                      const char* port);
UXRDLLAPI bool uxr_close_udp_transport(uxrUDPTransport* transport);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_PROFILE_TRANSPORT_IP_UDP_UDP_TRANSPORT_H_ */
