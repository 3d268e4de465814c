/* An input best-effort stream, as the session's `streams` table shows it (see stream_storage.h). */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_INPUT_BEST_EFFORT_STREAM_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_INPUT_BEST_EFFORT_STREAM_H_
#include <stdbool.h>
#include <stdint.h>
#include <uxr/client/config.h>
#include <uxr/client/core/session/stream/seq_num.h>
#ifdef UCLIENT_PROFILE_MULTITHREAD
#include <uxr/client/profile/multithread/multithread.h>
#endif
typedef struct uxrInputBestEffortStream {
    uxrSeqNum last_handled;
#ifdef UCLIENT_PROFILE_MULTITHREAD
    uxrMutex mutex;
#endif
} uxrInputBestEffortStream;
#endif /* UXR_CLIENT_CORE_SESSION_STREAM_INPUT_BEST_EFFORT_STREAM_H_ */
