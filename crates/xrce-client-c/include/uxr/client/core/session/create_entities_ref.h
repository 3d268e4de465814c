/* Entities named by a reference to a profile the agent knows (its -r file). */
#ifndef UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_REF_H_
#define UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_REF_H_
#include <uxr/client/core/session/common_create_entities.h>
#ifdef __cplusplus
extern "C" {
#endif
UXRDLLAPI uint16_t uxr_buffer_create_participant_ref(uxrSession* session, uxrStreamId stream_id,
                                                     uxrObjectId object_id, uint16_t domain_id, const char* ref,
                                                     uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_topic_ref(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                               uxrObjectId participant_id, const char* ref, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_datawriter_ref(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId publisher_id,
                                                    const char* ref, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_datareader_ref(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId subscriber_id,
                                                    const char* ref, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_requester_ref(uxrSession* session, uxrStreamId stream_id,
                                                   uxrObjectId object_id, uxrObjectId participant_id,
                                                   const char* ref, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_replier_ref(uxrSession* session, uxrStreamId stream_id,
                                                 uxrObjectId object_id, uxrObjectId participant_id,
                                                 const char* ref, uint8_t mode);

/* The seed's text (Client API document) shows the participant by reference without its domain; eProsima's
 * library takes one. A macro picks the form by argument count, so both compile (the seed's: domain 0). C++
 * programs get eProsima's form only (a function-like macro would hide the name from overload resolution). */
UXRDLLAPI uint16_t uxr_buffer_create_participant_ref_seed(uxrSession* session, uxrStreamId stream_id,
                                                          uxrObjectId object_id, const char* ref, uint8_t mode);
#ifndef __cplusplus
#define UXR_PICK_BY_COUNT_6_(_1, _2, _3, _4, _5, _6, N, ...) N
#define uxr_buffer_create_participant_ref(...)                                                              \
    UXR_PICK_BY_COUNT_6_(__VA_ARGS__, (uxr_buffer_create_participant_ref), uxr_buffer_create_participant_ref_seed, \
                         uxr_too_few_arguments)(__VA_ARGS__)
#endif
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_REF_H_ */
