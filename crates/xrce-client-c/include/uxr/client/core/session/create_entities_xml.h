/* Entities described by XML strings (DDS profiles). Each returns the request id (0 on failure); the status
 * arrives through the status callback or uxr_run_session_until_*_status. */
#ifndef UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_XML_H_
#define UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_XML_H_
#include <uxr/client/core/session/common_create_entities.h>
#ifdef __cplusplus
extern "C" {
#endif
UXRDLLAPI uint16_t uxr_buffer_create_participant_xml(uxrSession* session, uxrStreamId stream_id,
                                                     uxrObjectId object_id, uint16_t domain_id, const char* xml,
                                                     uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_topic_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                               uxrObjectId participant_id, const char* xml, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_publisher_xml(uxrSession* session, uxrStreamId stream_id,
                                                   uxrObjectId object_id, uxrObjectId participant_id,
                                                   const char* xml, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_subscriber_xml(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId participant_id,
                                                    const char* xml, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_datawriter_xml(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId publisher_id,
                                                    const char* xml, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_datareader_xml(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId subscriber_id,
                                                    const char* xml, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_requester_xml(uxrSession* session, uxrStreamId stream_id,
                                                   uxrObjectId object_id, uxrObjectId participant_id,
                                                   const char* xml, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_replier_xml(uxrSession* session, uxrStreamId stream_id,
                                                 uxrObjectId object_id, uxrObjectId participant_id,
                                                 const char* xml, uint8_t mode);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_XML_H_ */
