/* Time synchronisation lives in session.h (uxr_sync_session, uxr_epoch_*); this path exists as in eProsima's tree. */
#ifndef UXR_CLIENT_CORE_SESSION_TIME_SYNC_H_
#define UXR_CLIENT_CORE_SESSION_TIME_SYNC_H_
#include <uxr/client/core/session/session.h>
#endif /* UXR_CLIENT_CORE_SESSION_TIME_SYNC_H_ */
