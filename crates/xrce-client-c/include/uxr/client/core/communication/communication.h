/*
 * The table through which a session uses its transport. Every transport's init function fills its `comm`;
 * a program may fill one itself for a transport of its own: `send_msg` sends one whole message (true when
 * sent), `recv_msg` waits up to `timeout` ms for one and points `*buf`/`*len` at it (memory the transport
 * keeps until its next call), `comm_error` returns the transport's last error code (may be NULL).
 */
#ifndef UXR_CLIENT_CORE_COMMUNICATION_COMMUNICATION_H_
#define UXR_CLIENT_CORE_COMMUNICATION_COMMUNICATION_H_

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <uxr/client/config.h>
#ifdef UCLIENT_PROFILE_MULTITHREAD
#include <uxr/client/profile/multithread/multithread.h>
#endif

#ifdef __cplusplus
extern "C" {
#endif

typedef bool (*send_msg_func)(void* instance, const uint8_t* buf, size_t len);
typedef bool (*recv_msg_func)(void* instance, uint8_t** buf, size_t* len, int timeout);
typedef uint8_t (*comm_error_func)(void);

typedef struct uxrCommunication {
    void* instance;
    send_msg_func send_msg;
    recv_msg_func recv_msg;
    comm_error_func comm_error;
    uint16_t mtu;
#ifdef UCLIENT_PROFILE_MULTITHREAD
    uxrMutex mutex;
#endif
} uxrCommunication;

#ifdef __cplusplus
}
#endif

#endif /* UXR_CLIENT_CORE_COMMUNICATION_COMMUNICATION_H_ */
