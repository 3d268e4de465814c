/* Entities described in XRCE's binary representation: names and QoS, no XML. */
#ifndef UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_BIN_H_
#define UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_BIN_H_
#include <uxr/client/core/session/common_create_entities.h>
#ifdef __cplusplus
extern "C" {
#endif

typedef enum uxrQoSDurability {
    UXR_DURABILITY_VOLATILE = 0,
    UXR_DURABILITY_TRANSIENT_LOCAL,
    UXR_DURABILITY_TRANSIENT,
    UXR_DURABILITY_PERSISTENT,
    UXR_DURABILITY_INT_SIZE_ = 0x7FFFFFFF
} uxrQoSDurability;

typedef enum uxrQoSReliability {
    UXR_RELIABILITY_BEST_EFFORT = 0,
    UXR_RELIABILITY_RELIABLE,
    UXR_RELIABILITY_INT_SIZE_ = 0x7FFFFFFF
} uxrQoSReliability;

typedef enum uxrQoSHistory {
    UXR_HISTORY_KEEP_LAST = 0,
    UXR_HISTORY_KEEP_ALL,
    UXR_HISTORY_INT_SIZE_ = 0x7FFFFFFF
} uxrQoSHistory;

/* eProsima's field order: C++ programs fill it with designated initializers (PX4). */
typedef struct uxrQoS_t {
    uxrQoSDurability durability;
    uxrQoSReliability reliability;
    uxrQoSHistory history;
    uint16_t depth;
} uxrQoS_t;

UXRDLLAPI uint16_t uxr_buffer_create_participant_bin(uxrSession* session, uxrStreamId stream_id,
                                                     uxrObjectId object_id, uint16_t domain_id,
                                                     const char* participant_name, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_topic_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                               uxrObjectId participant_id, const char* topic_name,
                                               const char* type_name, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_publisher_bin(uxrSession* session, uxrStreamId stream_id,
                                                   uxrObjectId object_id, uxrObjectId participant_id,
                                                   uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_subscriber_bin(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId participant_id,
                                                    uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_datawriter_bin(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId publisher_id,
                                                    uxrObjectId topic_id, uxrQoS_t qos, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_datareader_bin(uxrSession* session, uxrStreamId stream_id,
                                                    uxrObjectId object_id, uxrObjectId subscriber_id,
                                                    uxrObjectId topic_id, uxrQoS_t qos, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_requester_bin(uxrSession* session, uxrStreamId stream_id,
                                                   uxrObjectId object_id, uxrObjectId participant_id,
                                                   const char* service_name, const char* request_type,
                                                   const char* reply_type, const char* request_topic_name,
                                                   const char* reply_topic_name, uxrQoS_t qos, uint8_t mode);
UXRDLLAPI uint16_t uxr_buffer_create_replier_bin(uxrSession* session, uxrStreamId stream_id,
                                                 uxrObjectId object_id, uxrObjectId participant_id,
                                                 const char* service_name, const char* request_type,
                                                 const char* reply_type, const char* request_topic_name,
                                                 const char* reply_topic_name, uxrQoS_t qos, uint8_t mode);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_CORE_SESSION_CREATE_ENTITIES_BIN_H_ */
