/*
 * The multithread profile's locking macros. This build has UCLIENT_PROFILE_MULTITHREAD off (config.h), so they
 * expand to nothing and a session belongs to one thread at a time, as in eProsima's default build; programs
 * that bracket writes with UXR_LOCK_STREAM_ID / UXR_UNLOCK_STREAM_ID (rmw_microxrcedds) compile unchanged.
 * A call made on a session while another thread is inside the library with it returns its failure value
 * (no data race: the library checks), it does not wait.
 */
#ifndef UXR_CLIENT_PROFILE_MULTITHREAD_H_
#define UXR_CLIENT_PROFILE_MULTITHREAD_H_

#include <uxr/client/config.h>
#include <uxr/client/core/session/stream/stream_id.h>
#include <uxr/client/visibility.h>

struct uxrSession;

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

#endif /* UXR_CLIENT_PROFILE_MULTITHREAD_H_ */
