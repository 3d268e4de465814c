/* Deleting an entity, whatever created it. */
#ifndef UXR_CLIENT_CORE_SESSION_COMMON_CREATE_ENTITIES_H_
#define UXR_CLIENT_CORE_SESSION_COMMON_CREATE_ENTITIES_H_
#include <uxr/client/core/session/session.h>
#ifdef __cplusplus
extern "C" {
#endif
UXRDLLAPI uint16_t uxr_buffer_delete_entity(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_CORE_SESSION_COMMON_CREATE_ENTITIES_H_ */
