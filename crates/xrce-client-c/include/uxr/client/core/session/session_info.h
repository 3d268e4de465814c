/* Status codes, creation modes and the session's identity (`uxrSession.info`). */
#ifndef UXR_CLIENT_CORE_SESSION_SESSION_INFO_H_
#define UXR_CLIENT_CORE_SESSION_SESSION_INFO_H_

#include <stdbool.h>
#include <uxr/client/core/session/object_id.h>
#include <uxr/client/core/session/stream/seq_num.h>

#define UXR_STATUS_OK 0x00
#define UXR_STATUS_OK_MATCHED 0x01
#define UXR_STATUS_ERR_DDS_ERROR 0x80
#define UXR_STATUS_ERR_MISMATCH 0x81
#define UXR_STATUS_ERR_ALREADY_EXISTS 0x82
#define UXR_STATUS_ERR_DENIED 0x83
#define UXR_STATUS_ERR_UNKNOWN_REFERENCE 0x84
#define UXR_STATUS_ERR_INVALID_DATA 0x85
#define UXR_STATUS_ERR_INCOMPATIBLE 0x86
#define UXR_STATUS_ERR_RESOURCES 0x87
#define UXR_STATUS_NONE 0xFF /* no status received (yet) */

#define UXR_REUSE (0x01 << 1)
#define UXR_REPLACE (0x01 << 2)

#define UXR_INVALID_REQUEST_ID 0
#define UXR_REQUEST_NONE 0x00
#define UXR_REQUEST_LOGIN 0x01
#define UXR_REQUEST_LOGOUT 0x02

/* Kept current by the library: `id` and `key` as sent in CREATE_CLIENT (key most significant byte first),
 * the last request id given out, and the status of the last session request (create or delete). */
typedef struct uxrSessionInfo {
    uint8_t id;
    uint8_t key[4];
    uint8_t last_requested_status;
    uint16_t last_request_id;
} uxrSessionInfo;

#endif /* UXR_CLIENT_CORE_SESSION_SESSION_INFO_H_ */
