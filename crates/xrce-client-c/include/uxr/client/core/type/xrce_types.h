/*
 * XRCE types programs meet outside the session's internals: time, keys, object ids, locators, RTPS GUIDs and
 * sample identities, with their CDR serializers (`uxr_serialize_<Type>` / `uxr_deserialize_<Type>`, eProsima's
 * names). The submessage payload structures of eProsima's header (CREATE_Payload, DATA_Payload_*, ...) are
 * its library's internal model of the wire and are not declared here: docs/c-api.md.
 */
#ifndef UXR_CLIENT_CORE_TYPE_XRCETYPES_H_
#define UXR_CLIENT_CORE_TYPE_XRCETYPES_H_

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <ucdr/microcdr.h>
#include <uxr/client/config.h>
#include <uxr/client/defines.h>
#include <uxr/client/visibility.h>

#ifdef __cplusplus
extern "C" {
#endif

#define UXR_STRING_SIZE_MAX 512
#define UXR_SAMPLE_DATA_SIZE_MAX 512
#define UXR_STRING_SEQUENCE_MAX 8
#define UXR_BINARY_SEQUENCE_MAX 512
#define UXR_BINARY_SEQUENCE_SMALL_MAX 8
#define UXR_SAMPLE_SEQUENCE_MAX 8
#define UXR_SAMPLE_DATA_SEQUENCE_MAX 8
#define UXR_SAMPLE_DELTA_SEQUENCE_MAX 8
#define UXR_PACKED_SAMPLES_SEQUENCE_MAX 8
#define UXR_TRANSPORT_LOCATOR_SEQUENCE_MAX 4
#define UXR_PROPERTY_SEQUENCE_MAX 1

typedef struct Time_t {
    int32_t seconds;
    uint32_t nanoseconds;
} Time_t;

typedef struct BinarySequence_t {
    uint32_t size;
    uint8_t data[UXR_BINARY_SEQUENCE_MAX];
} BinarySequence_t;

typedef struct BinarySequenceSmall_t {
    uint32_t size;
    uint8_t data[UXR_BINARY_SEQUENCE_SMALL_MAX];
} BinarySequenceSmall_t;

typedef struct StringSequence_t {
    uint32_t size;
    char* data[UXR_STRING_SEQUENCE_MAX];
} StringSequence_t;

typedef struct ClientKey {
    uint8_t data[4];
} ClientKey;
#define DDS_XRCE_CLIENT_INVALID COMPOUND_LITERAL(ClientKey){{0x00, 0x00, 0x00, 0x00}}

typedef uint8_t ObjectKind;
#define DDS_XRCE_OBJK_INVALID 0x00
#define DDS_XRCE_OBJK_PARTICIPANT 0x01
#define DDS_XRCE_OBJK_TOPIC 0x02
#define DDS_XRCE_OBJK_PUBLISHER 0x03
#define DDS_XRCE_OBJK_SUBSCRIBER 0x04
#define DDS_XRCE_OBJK_DATAWRITER 0x05
#define DDS_XRCE_OBJK_DATAREADER 0x06
#define DDS_XRCE_OBJK_REQUESTER 0x07
#define DDS_XRCE_OBJK_REPLIER 0x08
#define DDS_XRCE_OBJK_TYPE 0x0A
#define DDS_XRCE_OBJK_QOSPROFILE 0x0B
#define DDS_XRCE_OBJK_APPLICATION 0x0C
#define DDS_XRCE_OBJK_AGENT 0x0D
#define DDS_XRCE_OBJK_CLIENT 0x0E
#define DDS_XRCE_OBJK_OTHER 0x0F

typedef struct ObjectId {
    uint8_t data[2];
} ObjectId;

typedef struct ObjectPrefix {
    uint8_t data[2];
} ObjectPrefix;

#define DDS_XRCE_OBJECTID_INVALID COMPOUND_LITERAL(ObjectId){{0x00, 0x00}}
#define DDS_XRCE_OBJECTID_AGENT COMPOUND_LITERAL(ObjectId){{0xFF, 0xFD}}
#define DDS_XRCE_OBJECTID_CLIENT COMPOUND_LITERAL(ObjectId){{0xFF, 0xFE}}
#define DDS_XRCE_OBJECTID_SESSION COMPOUND_LITERAL(ObjectId){{0xFF, 0xFF}}

typedef struct XrceCookie {
    uint8_t data[4];
} XrceCookie;
#define DDS_XRCE_XRCE_COOKIE COMPOUND_LITERAL(XrceCookie){{0x58, 0x52, 0x43, 0x45}}

typedef struct XrceVersion {
    uint8_t data[2];
} XrceVersion;
#define DDS_XRCE_XRCE_VERSION_MAJOR 0x01
#define DDS_XRCE_XRCE_VERSION_MINOR 0x00
#define DDS_XRCE_XRCE_VERSION \
    COMPOUND_LITERAL(XrceVersion){{DDS_XRCE_XRCE_VERSION_MAJOR, DDS_XRCE_XRCE_VERSION_MINOR}}

typedef struct XrceVendorId {
    uint8_t data[2];
} XrceVendorId;
#define DDS_XRCE_XRCE_VENDOR_INVALID {0x00, 0x00}

/* Locators: `format` says which member of `_` holds the address (IPv4: medium, IPv6: large). */
typedef enum TransportLocatorFormat {
    ADDRESS_FORMAT_SMALL = 0,
    ADDRESS_FORMAT_MEDIUM = 1,
    ADDRESS_FORMAT_LARGE = 2,
    ADDRESS_FORMAT_STRING = 3,
    UXR_ADDRESS_FORMAT_INT_SIZE_ = 0x7FFFFFFF
} TransportLocatorFormat;

typedef struct TransportLocatorSmall {
    uint8_t address[2];
    uint8_t locator_port;
} TransportLocatorSmall;

typedef struct TransportLocatorMedium {
    uint8_t address[4];
    uint16_t locator_port;
} TransportLocatorMedium;

typedef struct TransportLocatorLarge {
    uint8_t address[16];
    uint32_t locator_port;
} TransportLocatorLarge;

typedef struct TransportLocatorString {
    char* value;
} TransportLocatorString;

typedef union TransportLocatorU {
    TransportLocatorSmall small_locator;
    TransportLocatorMedium medium_locator;
    TransportLocatorLarge large_locator;
    TransportLocatorString string_locator;
} TransportLocatorU;

typedef struct TransportLocator {
    uint8_t format;
    TransportLocatorU _;
} TransportLocator;

typedef struct TransportLocatorSeq {
    uint32_t size;
    TransportLocator data[UXR_TRANSPORT_LOCATOR_SEQUENCE_MAX];
} TransportLocatorSeq;

typedef uint8_t RepresentationFormat;
#define DDS_XRCE_REPRESENTATION_BY_REFERENCE 0x01
#define DDS_XRCE_REPRESENTATION_AS_XML_STRING 0x02
#define DDS_XRCE_REPRESENTATION_IN_BINARY 0x03
#define DDS_XRCE_REFERENCE_MAX_LEN 128

/* RTPS identities (requests and replies carry the request's SampleIdentity). */
typedef struct GuidPrefix {
    uint8_t data[12];
} GuidPrefix_t;

typedef struct EntityId_t {
    uint8_t entityKey[3];
    uint8_t entityKind;
} EntityId_t;

typedef struct GUID_t {
    GuidPrefix_t guidPrefix;
    EntityId_t entityId;
} GUID_t;

typedef struct SequenceNumber_t {
    int32_t high;
    uint32_t low;
} SequenceNumber_t;

typedef struct SampleIdentity {
    GUID_t writer_guid;
    SequenceNumber_t sequence_number;
} SampleIdentity;

/* CDR of each type (the buffer's endianness, XRCE alignment): true when it fit. */
#define UXR_DECLARE_TYPE_SERIALIZERS(T)                                    \
    UXRDLLAPI bool uxr_serialize_##T(ucdrBuffer* buffer, const T* input); \
    UXRDLLAPI bool uxr_deserialize_##T(ucdrBuffer* buffer, T* output);
UXR_DECLARE_TYPE_SERIALIZERS(Time_t)
UXR_DECLARE_TYPE_SERIALIZERS(BinarySequence_t)
UXR_DECLARE_TYPE_SERIALIZERS(StringSequence_t)
UXR_DECLARE_TYPE_SERIALIZERS(ClientKey)
UXR_DECLARE_TYPE_SERIALIZERS(ObjectId)
UXR_DECLARE_TYPE_SERIALIZERS(ObjectPrefix)
UXR_DECLARE_TYPE_SERIALIZERS(XrceCookie)
UXR_DECLARE_TYPE_SERIALIZERS(XrceVersion)
UXR_DECLARE_TYPE_SERIALIZERS(XrceVendorId)
UXR_DECLARE_TYPE_SERIALIZERS(TransportLocatorSmall)
UXR_DECLARE_TYPE_SERIALIZERS(TransportLocatorMedium)
UXR_DECLARE_TYPE_SERIALIZERS(TransportLocatorLarge)
UXR_DECLARE_TYPE_SERIALIZERS(TransportLocatorString)
UXR_DECLARE_TYPE_SERIALIZERS(TransportLocator)
UXR_DECLARE_TYPE_SERIALIZERS(TransportLocatorSeq)
UXR_DECLARE_TYPE_SERIALIZERS(GuidPrefix_t)
UXR_DECLARE_TYPE_SERIALIZERS(EntityId_t)
UXR_DECLARE_TYPE_SERIALIZERS(GUID_t)
UXR_DECLARE_TYPE_SERIALIZERS(SequenceNumber_t)
UXR_DECLARE_TYPE_SERIALIZERS(SampleIdentity)
#undef UXR_DECLARE_TYPE_SERIALIZERS

#ifdef __cplusplus
}
#endif

#endif /* UXR_CLIENT_CORE_TYPE_XRCETYPES_H_ */
