/*
 * The session: its structure, callbacks, creation and the run functions.
 *
 * `uxrSession` is a complete type a program declares (on the stack, static, in a larger structure). Its named
 * fields are eProsima's and are live: `info` follows the session, `comm` is the transport it was initialised
 * with, the callbacks set by uxr_set_*_callback are these fields (setting one directly works too),
 * `time_offset` is what uxr_epoch_nanos subtracts (a time callback may write it), `synchronized` turns true
 * when a time reply arrives, `on_data_flag` when data arrives, `on_pong_flag` when the agent answers a ping
 * in this session (the program may clear it). The library's own state lives in `_opaque`. A session must not
 * be moved or copied after uxr_init_session.
 */
#ifndef UXR_CLIENT_CORE_SESSION_SESSION_H_
#define UXR_CLIENT_CORE_SESSION_SESSION_H_

#include <uxr/client/config.h>
#include <uxr/client/core/session/session_info.h>
#include <uxr/client/core/session/stream/stream_storage.h>
#include <uxr/client/core/type/xrce_types.h>
#include <uxr/client/profile/multithread/multithread.h>

#ifdef __cplusplus
extern "C" {
#endif

#define UXR_TIMEOUT_INF (-1)

struct uxrSession;
struct uxrCommunication;

typedef void (*uxrOnStatusFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                                uint8_t status, void* args);
typedef void (*uxrOnTopicFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                               uxrStreamId stream_id, struct ucdrBuffer* ub, uint16_t length, void* args);
/* Called with the local time when the reply arrived, the agent's receive and transmit times and the local
 * time the request left (eProsima's argument order); with it set, the library leaves `time_offset` to it. */
typedef void (*uxrOnTimeFunc)(struct uxrSession* session, int64_t current_timestamp, int64_t transmit_timestamp,
                              int64_t received_timestamp, int64_t originate_timestamp, void* args);
typedef void (*uxrOnRequestFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                                 SampleIdentity* sample_id, struct ucdrBuffer* ub, uint16_t length, void* args);
typedef void (*uxrOnReplyFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                               uint16_t reply_id, struct ucdrBuffer* ub, uint16_t length, void* args);
/* uxr_prepare_output_stream_fragmented's flush callback: run the session until the stream has room again;
 * false gives the write up. */
typedef bool (*uxrOnBuffersFull)(struct uxrSession* session, void* args);

/* A uxr_prepare_output_stream_fragmented write in progress. */
typedef struct uxrContinuousArgs {
    uxrOnBuffersFull flush_callback;
    void* flush_callback_args;
    uxrStreamId stream_id;
    size_t data_size;
} uxrContinuousArgs;

typedef uint8_t pong_status_t;
#define NO_PONG_STATUS 0x00
#define PONG_IN_SESSION_STATUS 0x01
#define PONG_NO_SESSION_STATUS 0x02

/* Storage of the library's session state, in 8-byte words (build.rs and src/layout.rs check it). */
#define UXR_SESSION_OPAQUE_WORDS 160

typedef struct uxrSession {
    uxrSessionInfo info;
    uxrStreamStorage streams;
    struct uxrCommunication* comm;

    const uint16_t* request_list;
    uint8_t* status_list;
    size_t request_status_list_size;

    uxrOnStatusFunc on_status;
    void* on_status_args;
    uxrOnTopicFunc on_topic;
    void* on_topic_args;
    uxrOnTimeFunc on_time;
    void* on_time_args;
    int64_t time_offset;
    bool synchronized;
    uxrOnRequestFunc on_request;
    void* on_request_args;
    uxrOnReplyFunc on_reply;
    void* on_reply_args;

    bool on_data_flag;
    pong_status_t on_pong_flag;
    uxrContinuousArgs continuous_args;
#ifdef UCLIENT_PROFILE_MULTITHREAD
    uxrMutex mutex;
#endif

    uint64_t _opaque[UXR_SESSION_OPAQUE_WORDS];
} uxrSession;

UXRDLLAPI void uxr_init_session(uxrSession* session, struct uxrCommunication* comm, uint32_t key);
UXRDLLAPI void uxr_set_status_callback(uxrSession* session, uxrOnStatusFunc on_status_func, void* args);
UXRDLLAPI void uxr_set_topic_callback(uxrSession* session, uxrOnTopicFunc on_topic_func, void* args);
UXRDLLAPI void uxr_set_time_callback(uxrSession* session, uxrOnTimeFunc on_time_func, void* args);
UXRDLLAPI void uxr_set_request_callback(uxrSession* session, uxrOnRequestFunc on_request_func, void* args);
UXRDLLAPI void uxr_set_reply_callback(uxrSession* session, uxrOnReplyFunc on_reply_func, void* args);

UXRDLLAPI bool uxr_create_session(uxrSession* session);
UXRDLLAPI bool uxr_create_session_retries(uxrSession* session, size_t retries);
UXRDLLAPI bool uxr_delete_session(uxrSession* session);
UXRDLLAPI bool uxr_delete_session_retries(uxrSession* session, size_t retries);

UXRDLLAPI uxrStreamId uxr_create_output_best_effort_stream(uxrSession* session, uint8_t* buffer, size_t size);
UXRDLLAPI uxrStreamId uxr_create_output_reliable_stream(uxrSession* session, uint8_t* buffer, size_t size,
                                                        uint16_t history);
UXRDLLAPI uxrStreamId uxr_create_input_best_effort_stream(uxrSession* session);
UXRDLLAPI uxrStreamId uxr_create_input_reliable_stream(uxrSession* session, uint8_t* buffer, size_t size,
                                                       uint16_t history);

UXRDLLAPI void uxr_flash_output_streams(uxrSession* session);
UXRDLLAPI bool uxr_run_session_time(uxrSession* session, int timeout);
UXRDLLAPI bool uxr_run_session_timeout(uxrSession* session, int timeout);
UXRDLLAPI bool uxr_run_session_until_data(uxrSession* session, int timeout);
UXRDLLAPI bool uxr_run_session_until_timeout(uxrSession* session, int timeout);
UXRDLLAPI bool uxr_run_session_until_confirm_delivery(uxrSession* session, int timeout);
UXRDLLAPI bool uxr_run_session_until_all_status(uxrSession* session, int timeout, const uint16_t* request_list,
                                                uint8_t* status_list, size_t list_size);
UXRDLLAPI bool uxr_run_session_until_one_status(uxrSession* session, int timeout, const uint16_t* request_list,
                                                uint8_t* status_list, size_t list_size);

UXRDLLAPI bool uxr_sync_session(uxrSession* session, int time);
UXRDLLAPI int64_t uxr_epoch_millis(uxrSession* session);
UXRDLLAPI int64_t uxr_epoch_nanos(uxrSession* session);

#ifdef __cplusplus
}
#endif

#endif /* UXR_CLIENT_CORE_SESSION_SESSION_H_ */
