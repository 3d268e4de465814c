/* An input reliable stream, as the session's `streams` table shows it (see stream_storage.h). */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_INPUT_RELIABLE_STREAM_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_INPUT_RELIABLE_STREAM_H_
#include <stdbool.h>
#include <uxr/client/config.h>
#include <uxr/client/core/session/stream/reliable_stream.h>
#include <uxr/client/core/session/stream/seq_num.h>
#ifdef UCLIENT_PROFILE_MULTITHREAD
#include <uxr/client/profile/multithread/multithread.h>
#endif
struct ucdrBuffer;
typedef enum FragmentationInfo {
    NO_FRAGMENTED,
    INTERMEDIATE_FRAGMENT,
    LAST_FRAGMENT,
    UXR_FRAGMENTATION_INFO_INT_SIZE_ = 0x7FFFFFFF
} FragmentationInfo;
typedef FragmentationInfo (*OnGetFragmentationInfo)(uint8_t* buffer);
typedef struct uxrInputReliableStream {
    uxrReliableStream base;
    uxrSeqNum last_handled;
    uxrSeqNum last_announced;
    OnGetFragmentationInfo on_get_fragmentation_info;
    bool cleanup_flag;
#ifdef UCLIENT_PROFILE_MULTITHREAD
    uxrMutex mutex;
#endif
} uxrInputReliableStream;
#endif /* UXR_CLIENT_CORE_SESSION_STREAM_INPUT_RELIABLE_STREAM_H_ */
