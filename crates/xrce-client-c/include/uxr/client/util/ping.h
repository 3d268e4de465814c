/* Is an agent there? Outside a session (GET_INFO on the transport) or inside one (the pong also sets the
 * session's on_pong_flag). */
#ifndef UXR_CLIENT_UTIL_PING_H_
#define UXR_CLIENT_UTIL_PING_H_
#include <stdbool.h>
#include <uxr/client/core/communication/communication.h>
#include <uxr/client/transport.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
#define UXR_PING_BUF 16 /* a GET_INFO message: header 4, submessage header 4, payload 8 */
#define GET_INFO_MSG_SIZE 8
#define GET_INFO_REQUEST_PING_ID 10
struct uxrSession;
UXRDLLAPI bool uxr_ping_agent_session(struct uxrSession* session, const int timeout_ms, const uint8_t attempts);
UXRDLLAPI bool uxr_ping_agent(const uxrCommunication* comm, const int timeout_ms);
UXRDLLAPI bool uxr_ping_agent_attempts(const uxrCommunication* comm, const int timeout_ms, const uint8_t attempts);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_UTIL_PING_H_ */
