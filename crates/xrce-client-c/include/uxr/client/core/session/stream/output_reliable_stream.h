/* An output reliable stream, as the session's `streams` table shows it (see stream_storage.h). */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_OUTPUT_RELIABLE_STREAM_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_OUTPUT_RELIABLE_STREAM_H_
#include <stdbool.h>
#include <uxr/client/config.h>
#include <uxr/client/core/session/stream/reliable_stream.h>
#include <uxr/client/core/session/stream/seq_num.h>
#ifdef UCLIENT_PROFILE_MULTITHREAD
#include <uxr/client/profile/multithread/multithread.h>
#endif
struct ucdrBuffer;
struct uxrOutputReliableStream;
typedef void (*OnNewFragment)(struct ucdrBuffer* ub, struct uxrOutputReliableStream* stream);
typedef struct uxrOutputReliableStream {
    uxrReliableStream base;
    uint8_t offset;
    uxrSeqNum last_written;
    uxrSeqNum last_sent;
    uxrSeqNum last_acknown;
    int64_t next_heartbeat_timestamp;
    uint8_t next_heartbeat_tries;
    bool send_lost;
#ifdef UCLIENT_PROFILE_MULTITHREAD
    uxrMutex mutex;
#endif
} uxrOutputReliableStream;
#endif /* UXR_CLIENT_CORE_SESSION_STREAM_OUTPUT_RELIABLE_STREAM_H_ */
