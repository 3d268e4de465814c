/* An output best-effort stream, as the session's `streams` table shows it (see stream_storage.h). */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_OUTPUT_BEST_EFFORT_STREAM_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_OUTPUT_BEST_EFFORT_STREAM_H_
#include <stdbool.h>
#include <stddef.h>
#include <uxr/client/config.h>
#include <uxr/client/core/session/stream/seq_num.h>
#ifdef UCLIENT_PROFILE_MULTITHREAD
#include <uxr/client/profile/multithread/multithread.h>
#endif
struct ucdrBuffer;
typedef struct uxrOutputBestEffortStream {
    uint8_t* buffer;
    size_t writer;
    size_t size;
    uint8_t offset;
    uxrSeqNum last_send;
#ifdef UCLIENT_PROFILE_MULTITHREAD
    uxrMutex mutex;
#endif
} uxrOutputBestEffortStream;
#endif /* UXR_CLIENT_CORE_SESSION_STREAM_OUTPUT_BEST_EFFORT_STREAM_H_ */
