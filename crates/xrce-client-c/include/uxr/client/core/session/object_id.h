/* Object identifiers: a 12-bit number and a 4-bit kind, as the XRCE wire carries them. */
#ifndef UXR_CLIENT_CORE_SESSION_OBJECT_ID_H_
#define UXR_CLIENT_CORE_SESSION_OBJECT_ID_H_

#include <stdint.h>
#include <uxr/client/visibility.h>

#ifdef __cplusplus
extern "C" {
#endif

#define UXR_INVALID_ID 0x00
#define UXR_PARTICIPANT_ID 0x01
#define UXR_TOPIC_ID 0x02
#define UXR_PUBLISHER_ID 0x03
#define UXR_SUBSCRIBER_ID 0x04
#define UXR_DATAWRITER_ID 0x05
#define UXR_DATAREADER_ID 0x06
#define UXR_REQUESTER_ID 0x07
#define UXR_REPLIER_ID 0x08
#define UXR_OTHER_ID 0x0F

typedef struct uxrObjectId {
    uint16_t id;
    uint8_t type;
} uxrObjectId;

UXRDLLAPI uxrObjectId uxr_object_id(uint16_t id, uint8_t type);
/* The two wire bytes of an object id, and back. */
UXRDLLAPI uxrObjectId uxr_object_id_from_raw(const uint8_t* raw);
UXRDLLAPI void uxr_object_id_to_raw(uxrObjectId object_id, uint8_t* raw);

#ifdef __cplusplus
}
#endif

#endif /* UXR_CLIENT_CORE_SESSION_OBJECT_ID_H_ */
