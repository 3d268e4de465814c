/* Every transport this build has (config.h's UCLIENT_PROFILE_*). */
#ifndef UXR_CLIENT_TRANSPORT_H_
#define UXR_CLIENT_TRANSPORT_H_
#include <uxr/client/config.h>
#ifdef UCLIENT_PROFILE_UDP
#include <uxr/client/profile/transport/ip/udp/udp_transport.h>
#endif
#ifdef UCLIENT_PROFILE_TCP
#include <uxr/client/profile/transport/ip/tcp/tcp_transport.h>
#endif
#ifdef UCLIENT_PROFILE_SERIAL
#include <uxr/client/profile/transport/serial/serial_transport.h>
#endif
#ifdef UCLIENT_PROFILE_CAN
#include <uxr/client/profile/transport/can/can_transport.h>
#endif
#ifdef UCLIENT_PROFILE_CUSTOM_TRANSPORT
#include <uxr/client/profile/transport/custom/custom_transport.h>
#endif
#endif /* UXR_CLIENT_TRANSPORT_H_ */
