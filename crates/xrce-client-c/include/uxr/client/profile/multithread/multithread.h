/*
 * The multithread profile's locks. With UCLIENT_PROFILE_MULTITHREAD off (config.h; the default build) the macros
 * expand to nothing: a session belongs to one thread at a time, and a call made on a session while another
 * thread is inside the library with it returns its failure value (the library checks), it does not wait.
 * With it on (a library built with XRCE_C_MULTITHREAD=1, POSIX), as in eProsima's library: the session, each
 * stream and each transport's `comm` hold a recursive mutex; every call on a session holds the session's lock
 * for its duration (other threads wait); uxr_prepare_output_stream and uxr_prepare_output_stream_fragmented
 * return with the stream's lock held when they succeed, and the program releases it with
 * UXR_UNLOCK_STREAM_ID once the sample is serialized (rmw_microxrcedds does). Unlike eProsima's library, the
 * lock of a stream (uxr_get_stream_mutex_from_id) is its session's: coarser, and no two threads can take two
 * locks in opposite orders. The streams' own `mutex` fields are initialised but the library does not use them.
 */
#ifndef UXR_CLIENT_PROFILE_MULTITHREAD_H_
#define UXR_CLIENT_PROFILE_MULTITHREAD_H_

#include <uxr/client/config.h>
#include <uxr/client/core/session/stream/stream_id.h>
#include <uxr/client/visibility.h>

struct uxrSession;

#ifdef UCLIENT_PROFILE_MULTITHREAD

#ifndef UCLIENT_PLATFORM_POSIX
#error "the multithread profile of this library needs POSIX threads"
#endif
#include <pthread.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct uxrMutex {
    pthread_mutex_t impl;
} uxrMutex;

/* The lock of a session's stream, NULL for a stream the session does not have. */
UXRDLLAPI uxrMutex* uxr_get_stream_mutex_from_id(struct uxrSession* session, uxrStreamId stream_id);
UXRDLLAPI void uxr_init_lock(uxrMutex* mutex); /* recursive */
UXRDLLAPI void uxr_lock(uxrMutex* mutex);
UXRDLLAPI void uxr_unlock(uxrMutex* mutex);

#ifdef __cplusplus
}
#endif

#define UXR_INIT_LOCK(X) uxr_init_lock(X)
#define UXR_LOCK(X) uxr_lock(X)
#define UXR_UNLOCK(X) uxr_unlock(X)
#define UXR_INIT_LOCK_SESSION uxr_init_lock(&session->mutex)
#define UXR_LOCK_SESSION(session) uxr_lock(&(session)->mutex)
#define UXR_UNLOCK_SESSION(session) uxr_unlock(&(session)->mutex)
#define UXR_LOCK_TRANSPORT(comm) uxr_lock(&(comm)->mutex)
#define UXR_UNLOCK_TRANSPORT(comm) uxr_unlock(&(comm)->mutex)
#define UXR_LOCK_STREAM_ID(session, stream_id)                                   \
    {                                                                            \
        uxrMutex* uxr_stream_mutex_ = uxr_get_stream_mutex_from_id(session, stream_id); \
        if (uxr_stream_mutex_ != NULL) {                                         \
            uxr_lock(uxr_stream_mutex_);                                         \
        }                                                                        \
    }
#define UXR_UNLOCK_STREAM_ID(session, stream_id)                                 \
    {                                                                            \
        uxrMutex* uxr_stream_mutex_ = uxr_get_stream_mutex_from_id(session, stream_id); \
        if (uxr_stream_mutex_ != NULL) {                                         \
            uxr_unlock(uxr_stream_mutex_);                                       \
        }                                                                        \
    }
#define UXR_LOCK_ALL_INPUT_STREAMS(session)                                      \
    for (uint8_t uxr_i_ = 0; uxr_i_ < (session)->streams.input_best_effort_size; ++uxr_i_) { \
        uxr_lock(&(session)->streams.input_best_effort[uxr_i_].mutex);           \
    }                                                                            \
    for (uint8_t uxr_i_ = 0; uxr_i_ < (session)->streams.input_reliable_size; ++uxr_i_) { \
        uxr_lock(&(session)->streams.input_reliable[uxr_i_].mutex);              \
    }
#define UXR_UNLOCK_ALL_INPUT_STREAMS(session)                                    \
    for (uint8_t uxr_i_ = 0; uxr_i_ < (session)->streams.input_best_effort_size; ++uxr_i_) { \
        uxr_unlock(&(session)->streams.input_best_effort[uxr_i_].mutex);         \
    }                                                                            \
    for (uint8_t uxr_i_ = 0; uxr_i_ < (session)->streams.input_reliable_size; ++uxr_i_) { \
        uxr_unlock(&(session)->streams.input_reliable[uxr_i_].mutex);            \
    }

#else /* UCLIENT_PROFILE_MULTITHREAD */

#define UXR_INIT_LOCK(X)
#define UXR_LOCK(X)
#define UXR_UNLOCK(X)
#define UXR_INIT_LOCK_SESSION
#define UXR_LOCK_SESSION(session)
#define UXR_UNLOCK_SESSION(session)
#define UXR_LOCK_TRANSPORT(comm)
#define UXR_UNLOCK_TRANSPORT(comm)
#define UXR_LOCK_STREAM_ID(session, stream_id)
#define UXR_UNLOCK_STREAM_ID(session, stream_id)
#define UXR_LOCK_ALL_INPUT_STREAMS(session)
#define UXR_UNLOCK_ALL_INPUT_STREAMS(session)

#endif /* UCLIENT_PROFILE_MULTITHREAD */

#endif /* UXR_CLIENT_PROFILE_MULTITHREAD_H_ */
