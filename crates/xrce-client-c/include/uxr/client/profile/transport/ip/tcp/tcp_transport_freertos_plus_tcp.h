/* eProsima's TCP transport for another platform; this library's TCP transport is POSIX's (tcp_transport.h). */
#include <uxr/client/profile/transport/ip/tcp/tcp_transport.h>
