/* eProsima's hooks for porting its serial transport to a platform. This library's serial transport works on
 * any POSIX descriptor, so there is nothing to port: a platform without one uses the custom transport with
 * framing instead. The declarations exist for programs that name them; the library does not define them. */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_SERIAL_SERIAL_TRANSPORT_PLATFORM_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_SERIAL_SERIAL_TRANSPORT_PLATFORM_H_
#include <uxr/client/profile/transport/serial/serial_transport.h>
#ifdef __cplusplus
extern "C" {
#endif
bool uxr_init_serial_platform(void* args, const int fd, uint8_t remote_addr, uint8_t local_addr);
bool uxr_close_serial_platform(void* args);
size_t uxr_write_serial_data_platform(void* args, const uint8_t* buf, size_t len, uint8_t* errcode);
size_t uxr_read_serial_data_platform(void* args, uint8_t* buf, size_t len, int timeout, uint8_t* errcode);
#ifdef __cplusplus
}
#endif
#endif
