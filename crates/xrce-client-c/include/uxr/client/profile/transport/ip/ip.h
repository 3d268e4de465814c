/* IP version of the UDP and TCP transports, and conversions between text addresses and XRCE locators
 * (IPv4: ADDRESS_FORMAT_MEDIUM, IPv6: ADDRESS_FORMAT_LARGE). */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_IP_IP_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_IP_IP_H_
#include <uxr/client/core/type/xrce_types.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
typedef enum uxrIpProtocol {
    UXR_IPv4,
    UXR_IPv6,
    UXR_IP_PROTOCOL_INT_SIZE_ = 0x7FFFFFFF
} uxrIpProtocol;
UXRDLLAPI bool uxr_ip_to_locator(char const* ip, uint16_t port, uxrIpProtocol ip_protocol,
                                 TransportLocator* locator);
UXRDLLAPI bool uxr_locator_to_ip(TransportLocator const* locator, char* ip, size_t size, uint16_t* port,
                                 uxrIpProtocol* ip_protocol);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_PROFILE_TRANSPORT_IP_IP_H_ */
