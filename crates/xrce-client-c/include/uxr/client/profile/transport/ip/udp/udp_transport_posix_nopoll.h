/* eProsima's UDP transport for another platform; this library's UDP transport is POSIX's (udp_transport.h). */
#include <uxr/client/profile/transport/ip/udp/udp_transport.h>
