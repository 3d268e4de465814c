/*
 * Micro XRCE-DDS Client API of xrce-rs: the one header a client program includes (Client API document,
 * seed 000). Written for this project from that document; implemented in Rust over the xrce-client crate
 * (crates/xrce-client-c). Link with `-lmicroxrcedds_client -lmicrocdr` (and the system's -lpthread -ldl -lm).
 *
 * Structures that programs declare (sessions, transports) are complete types of fixed size; their `_opaque`
 * storage holds the Rust state and is checked against it when the library is built. They must not be moved
 * or copied after initialisation.
 */
#ifndef UXR_CLIENT_CLIENT_H
#define UXR_CLIENT_CLIENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <ucdr/microcdr.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- configuration: what this build of the library was made with ---------------------------------- */
#define UXR_CONFIG_UDP_TRANSPORT_MTU 512
#define UXR_CONFIG_TCP_TRANSPORT_MTU 512
#define UXR_CONFIG_SERIAL_TRANSPORT_MTU 512
#define UXR_CONFIG_CUSTOM_TRANSPORT_MTU 512
#define UXR_CONFIG_CAN_TRANSPORT_MTU 63
#define UXR_CONFIG_MAX_OUTPUT_BEST_EFFORT_STREAMS 1
#define UXR_CONFIG_MAX_OUTPUT_RELIABLE_STREAMS 1
#define UXR_CONFIG_MAX_INPUT_BEST_EFFORT_STREAMS 1
#define UXR_CONFIG_MAX_INPUT_RELIABLE_STREAMS 1
#define UXR_CONFIG_MAX_SESSION_CONNECTION_ATTEMPTS 10
#define UXR_CONFIG_MIN_SESSION_CONNECTION_INTERVAL 1000
#define UXR_CONFIG_MIN_HEARTBEAT_TIME_INTERVAL 100
#define UCLIENT_PROFILE_UDP 1
#define UCLIENT_PROFILE_TCP 1
#define UCLIENT_PROFILE_SERIAL 1
#define UCLIENT_PROFILE_CUSTOM_TRANSPORT 1
#define UCLIENT_PROFILE_CAN 1
#define UCLIENT_PROFILE_DISCOVERY 1

/* Sizes of the opaque storage, in 8-byte words (build.rs reads these; src/layout.rs checks them). */
#define UXR_SESSION_OPAQUE_WORDS 160
#define UXR_UDP_TRANSPORT_OPAQUE_WORDS 4
#define UXR_TCP_TRANSPORT_OPAQUE_WORDS 112
#define UXR_SERIAL_TRANSPORT_OPAQUE_WORDS 96
#define UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS 96
#define UXR_CAN_TRANSPORT_OPAQUE_WORDS 4

/* ---- constants ---------------------------------------------------------------------------------------- */
#define UXR_TIMEOUT_INF (-1)
#define UXR_INVALID_REQUEST_ID 0

#define UXR_REUSE 0x02
#define UXR_REPLACE 0x04

#define UXR_STATUS_OK 0x00
#define UXR_STATUS_OK_MATCHED 0x01
#define UXR_STATUS_ERR_DDS_ERROR 0x80
#define UXR_STATUS_ERR_MISMATCH 0x81
#define UXR_STATUS_ERR_ALREADY_EXISTS 0x82
#define UXR_STATUS_ERR_DENIED 0x83
#define UXR_STATUS_ERR_UNKNOWN_REFERENCE 0x84
#define UXR_STATUS_ERR_INVALID_DATA 0x85
#define UXR_STATUS_ERR_INCOMPATIBLE 0x86
#define UXR_STATUS_ERR_RESOURCES 0x87
#define UXR_STATUS_NONE 0xFF

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

#define UXR_MAX_SAMPLES_UNLIMITED 0xFFFF
#define UXR_MAX_ELAPSED_TIME_UNLIMITED 0x0000
#define UXR_MAX_BYTES_PER_SECOND_UNLIMITED 0x0000

/* ---- identifiers ---------------------------------------------------------------------------------------- */
typedef enum uxrStreamType {
    UXR_NONE_STREAM = 0,
    UXR_BEST_EFFORT_STREAM = 1,
    UXR_RELIABLE_STREAM = 2,
    UXR_SHARED_MEMORY_STREAM = 3
} uxrStreamType;

typedef enum uxrStreamDirection {
    UXR_INPUT_STREAM = 0,
    UXR_OUTPUT_STREAM = 1
} uxrStreamDirection;

typedef struct uxrStreamId {
    uint8_t raw;       /* the id on the wire: 0 none, 1-127 best effort, 128-255 reliable */
    uint8_t index;     /* position among the streams of its type and direction */
    uint8_t type;      /* uxrStreamType */
    uint8_t direction; /* uxrStreamDirection */
} uxrStreamId;

typedef struct uxrObjectId {
    uint16_t id;
    uint8_t type;
} uxrObjectId;

typedef struct GuidPrefix_t { uint8_t data[12]; } GuidPrefix_t;
typedef struct EntityId_t { uint8_t entityKey[3]; uint8_t entityKind; } EntityId_t;
typedef struct GUID_t { GuidPrefix_t guidPrefix; EntityId_t entityId; } GUID_t;
typedef struct SequenceNumber_t { int32_t high; uint32_t low; } SequenceNumber_t;
typedef struct SampleIdentity { GUID_t writer_guid; SequenceNumber_t sequence_number; } SampleIdentity;

typedef struct uxrDeliveryControl {
    uint16_t max_samples;
    uint16_t max_elapsed_time;
    uint16_t max_bytes_per_second;
    uint16_t min_pace_period;
} uxrDeliveryControl;

typedef enum uxrQoSDurability {
    UXR_DURABILITY_VOLATILE = 0,
    UXR_DURABILITY_TRANSIENT_LOCAL = 1,
    UXR_DURABILITY_TRANSIENT = 2,
    UXR_DURABILITY_PERSISTENT = 3
} uxrQoSDurability;

typedef enum uxrQoSReliability {
    UXR_RELIABILITY_BEST_EFFORT = 0,
    UXR_RELIABILITY_RELIABLE = 1
} uxrQoSReliability;

typedef enum uxrQoSHistory {
    UXR_HISTORY_KEEP_LAST = 0,
    UXR_HISTORY_KEEP_ALL = 1
} uxrQoSHistory;

typedef struct uxrQoS_t {
    uxrQoSDurability durability;
    uxrQoSReliability reliability;
    uxrQoSHistory history;
    uint16_t depth;
} uxrQoS_t;

/* ---- communication: what every transport hands to a session ------------------------------------------- */
/* send_msg: one whole message, true when sent. recv_msg: waits up to timeout_ms (negative: forever) for one
 * message copied into buf; its length, 0 on timeout, -1 on error. */
typedef bool (*uxrSendMsgFunc)(void* instance, const uint8_t* buf, size_t len);
typedef int32_t (*uxrRecvMsgFunc)(void* instance, uint8_t* buf, size_t capacity, int timeout_ms);

typedef struct uxrCommunication {
    void* instance;
    uxrSendMsgFunc send_msg;
    uxrRecvMsgFunc recv_msg;
    uint16_t mtu;
} uxrCommunication;

/* ---- session -------------------------------------------------------------------------------------------- */
struct uxrSession;
typedef struct uxrSession {
    uint64_t _opaque[UXR_SESSION_OPAQUE_WORDS];
} uxrSession;

typedef void (*uxrOnStatusFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                                uint8_t status, void* args);
typedef void (*uxrOnTopicFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                               uxrStreamId stream_id, struct ucdrBuffer* ub, uint16_t length, void* args);
typedef void (*uxrOnTimeFunc)(struct uxrSession* session, int64_t current_timestamp, int64_t transmit_timestamp,
                              int64_t received_timestamp, int64_t originate_timestamp, void* args);
typedef void (*uxrOnRequestFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                                 SampleIdentity* sample_id, struct ucdrBuffer* ub, uint16_t length, void* args);
typedef void (*uxrOnReplyFunc)(struct uxrSession* session, uxrObjectId object_id, uint16_t request_id,
                               uint16_t reply_id, struct ucdrBuffer* ub, uint16_t length, void* args);
typedef bool (*uxrOnBuffersFull)(struct uxrSession* session);

void uxr_init_session(uxrSession* session, uxrCommunication* comm, uint32_t key);
void uxr_set_status_callback(uxrSession* session, uxrOnStatusFunc on_status_func, void* args);
void uxr_set_topic_callback(uxrSession* session, uxrOnTopicFunc on_topic_func, void* args);
void uxr_set_time_callback(uxrSession* session, uxrOnTimeFunc on_time_func, void* args);
void uxr_set_request_callback(uxrSession* session, uxrOnRequestFunc on_request_func, void* args);
void uxr_set_reply_callback(uxrSession* session, uxrOnReplyFunc on_reply_func, void* args);

bool uxr_create_session(uxrSession* session);
bool uxr_create_session_retries(uxrSession* session, size_t retries);
bool uxr_delete_session(uxrSession* session);
bool uxr_delete_session_retries(uxrSession* session, size_t retries);

uxrStreamId uxr_create_output_best_effort_stream(uxrSession* session, uint8_t* buffer, size_t size);
uxrStreamId uxr_create_output_reliable_stream(uxrSession* session, uint8_t* buffer, size_t size, size_t history);
uxrStreamId uxr_create_input_best_effort_stream(uxrSession* session);
uxrStreamId uxr_create_input_reliable_stream(uxrSession* session, uint8_t* buffer, size_t size, size_t history);

void uxr_flash_output_streams(uxrSession* session);
bool uxr_run_session_time(uxrSession* session, int timeout_ms);
bool uxr_run_session_timeout(uxrSession* session, int timeout_ms);
bool uxr_run_session_until_timeout(uxrSession* session, int timeout_ms);
bool uxr_run_session_until_confirm_delivery(uxrSession* session, int timeout_ms);
bool uxr_run_session_until_all_status(uxrSession* session, int timeout_ms, const uint16_t* request_list,
                                      uint8_t* status_list, size_t list_size);
bool uxr_run_session_until_one_status(uxrSession* session, int timeout_ms, const uint16_t* request_list,
                                      uint8_t* status_list, size_t list_size);
bool uxr_run_session_until_data(uxrSession* session, int timeout_ms);

bool uxr_sync_session(uxrSession* session, int time);
int64_t uxr_epoch_millis(uxrSession* session);
int64_t uxr_epoch_nanos(uxrSession* session);
int64_t uxr_millis(void);
int64_t uxr_nanos(void);

bool uxr_ping_agent_session(struct uxrSession* session, const int timeout_ms, const uint8_t attempts);
bool uxr_ping_agent(const uxrCommunication* comm, const int timeout_ms);
bool uxr_ping_agent_attempts(const uxrCommunication* comm, const int timeout_ms, const uint8_t attempts);

/* ---- entities ------------------------------------------------------------------------------------------- */
uint16_t uxr_buffer_create_participant_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                           uint16_t domain, const char* xml, uint8_t mode);
uint16_t uxr_buffer_create_topic_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                     uxrObjectId participant_id, const char* xml, uint8_t mode);
uint16_t uxr_buffer_create_publisher_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                         uxrObjectId participant_id, const char* xml, uint8_t mode);
uint16_t uxr_buffer_create_subscriber_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId participant_id, const char* xml, uint8_t mode);
uint16_t uxr_buffer_create_datawriter_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId publisher_id, const char* xml, uint8_t mode);
uint16_t uxr_buffer_create_datareader_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId subscriber_id, const char* xml, uint8_t mode);
uint16_t uxr_buffer_create_requester_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                         uxrObjectId participant_id, const char* xml, uint8_t mode);
uint16_t uxr_buffer_create_replier_xml(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                       uxrObjectId participant_id, const char* xml, uint8_t mode);

uint16_t uxr_buffer_create_participant_ref(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                           uint16_t domain, const char* ref, uint8_t mode);
uint16_t uxr_buffer_create_topic_ref(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                     uxrObjectId participant_id, const char* ref, uint8_t mode);
uint16_t uxr_buffer_create_datawriter_ref(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId publisher_id, const char* ref, uint8_t mode);
uint16_t uxr_buffer_create_datareader_ref(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId subscriber_id, const char* ref, uint8_t mode);
uint16_t uxr_buffer_create_requester_ref(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                         uxrObjectId participant_id, const char* ref, uint8_t mode);
uint16_t uxr_buffer_create_replier_ref(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                       uxrObjectId participant_id, const char* ref, uint8_t mode);

uint16_t uxr_buffer_create_participant_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                           uint16_t domain_id, const char* participant_name, uint8_t mode);
uint16_t uxr_buffer_create_topic_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                     uxrObjectId participant_id, const char* topic_name, const char* type_name,
                                     uint8_t mode);
uint16_t uxr_buffer_create_publisher_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                         uxrObjectId participant_id, uint8_t mode);
uint16_t uxr_buffer_create_subscriber_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId participant_id, uint8_t mode);
uint16_t uxr_buffer_create_datawriter_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId publisher_id, uxrObjectId topic_id, uxrQoS_t qos, uint8_t mode);
uint16_t uxr_buffer_create_datareader_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                          uxrObjectId subscriber_id, uxrObjectId topic_id, uxrQoS_t qos, uint8_t mode);
uint16_t uxr_buffer_create_requester_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                         uxrObjectId participant_id, const char* service_name,
                                         const char* request_type, const char* reply_type,
                                         const char* request_topic_name, const char* reply_topic_name,
                                         uxrQoS_t qos, uint8_t mode);
uint16_t uxr_buffer_create_replier_bin(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                       uxrObjectId participant_id, const char* service_name,
                                       const char* request_type, const char* reply_type,
                                       const char* request_topic_name, const char* reply_topic_name,
                                       uxrQoS_t qos, uint8_t mode);
uint16_t uxr_buffer_delete_entity(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id);

/* ---- read and write access ------------------------------------------------------------------------------ */
uint16_t uxr_buffer_request_data(uxrSession* session, uxrStreamId stream_id, uxrObjectId datareader_id,
                                 uxrStreamId data_stream_id, const uxrDeliveryControl* const control);
uint16_t uxr_buffer_cancel_data(uxrSession* session, uxrStreamId stream_id, uxrObjectId datareader_id);

uint16_t uxr_prepare_output_stream(uxrSession* session, uxrStreamId stream_id, uxrObjectId entity_id,
                                   ucdrBuffer* ub, uint32_t data_size);
uint16_t uxr_prepare_output_stream_fragmented(uxrSession* session, uxrStreamId stream_id, uxrObjectId entity_id,
                                              struct ucdrBuffer* ub, size_t data_size,
                                              uxrOnBuffersFull flush_callback);
/* These return the request id (0 on failure): true/false in a condition, as the seed documents them. */
uint16_t uxr_buffer_topic(uxrSession* session, uxrStreamId stream_id, uxrObjectId datawriter_id, uint8_t* buffer,
                          size_t len);
uint16_t uxr_buffer_request(uxrSession* session, uxrStreamId stream_id, uxrObjectId requester_id, uint8_t* buffer,
                            size_t len);
uint16_t uxr_buffer_reply(uxrSession* session, uxrStreamId stream_id, uxrObjectId replier_id,
                          SampleIdentity* sample_id, uint8_t* buffer, size_t len);
/* The seed's form, without the request's identity: answers the last request the session received. */
uint16_t uxr_buffer_reply_last(uxrSession* session, uxrStreamId stream_id, uxrObjectId replier_id, uint8_t* buffer,
                               size_t len);

/* Two functions exist in two forms: the seed's text and eProsima's library differ in one argument. The macros
 * pick by argument count, so programs written against either compile unchanged. */
#define UXR_PICK_BY_COUNT_(_1, _2, _3, _4, _5, _6, N, ...) N
#define uxr_buffer_create_participant_ref(...)                                                                 \
    UXR_PICK_BY_COUNT_(__VA_ARGS__, (uxr_buffer_create_participant_ref), uxr_buffer_create_participant_ref_seed, \
                       uxr_too_few_arguments)(__VA_ARGS__)
#define uxr_buffer_reply(...)                                                                                  \
    UXR_PICK_BY_COUNT_(__VA_ARGS__, (uxr_buffer_reply), uxr_buffer_reply_last, uxr_too_few_arguments)(__VA_ARGS__)
/* The seed's participant by reference has no domain argument: domain 0. */
uint16_t uxr_buffer_create_participant_ref_seed(uxrSession* session, uxrStreamId stream_id, uxrObjectId object_id,
                                                const char* ref, uint8_t mode);

/* ---- utilities ------------------------------------------------------------------------------------------ */
uxrStreamId uxr_stream_id(uint8_t index, uxrStreamType type, uxrStreamDirection direction);
uxrStreamId uxr_stream_id_from_raw(uint8_t stream_id_raw, uxrStreamDirection direction);
uxrObjectId uxr_object_id(uint16_t id, uint8_t type);

/* ---- transports ----------------------------------------------------------------------------------------- */
typedef enum uxrIpProtocol {
    UXR_IPv4 = 0,
    UXR_IPv6 = 1
} uxrIpProtocol;

typedef struct uxrUDPTransport {
    uint64_t _opaque[UXR_UDP_TRANSPORT_OPAQUE_WORDS];
    uxrCommunication comm;
} uxrUDPTransport;

typedef struct uxrTCPTransport {
    uint64_t _opaque[UXR_TCP_TRANSPORT_OPAQUE_WORDS];
    uxrCommunication comm;
} uxrTCPTransport;

typedef struct uxrSerialTransport {
    uint64_t _opaque[UXR_SERIAL_TRANSPORT_OPAQUE_WORDS];
    uxrCommunication comm;
} uxrSerialTransport;

/* CAN FD over SocketCAN (Linux): messages up to UXR_CONFIG_CAN_TRANSPORT_MTU bytes, one per frame. */
typedef struct uxrCANTransport {
    uint64_t _opaque[UXR_CAN_TRANSPORT_OPAQUE_WORDS];
    uxrCommunication comm;
} uxrCANTransport;

struct uxrCustomTransport;
typedef bool (*open_custom_func)(struct uxrCustomTransport* transport);
typedef bool (*close_custom_func)(struct uxrCustomTransport* transport);
typedef size_t (*write_custom_func)(struct uxrCustomTransport* transport, const uint8_t* buffer, size_t length,
                                    uint8_t* error_code);
typedef size_t (*read_custom_func)(struct uxrCustomTransport* transport, uint8_t* buffer, size_t length,
                                   int timeout, uint8_t* error_code);

typedef struct uxrCustomTransport {
    void* args; /* what uxr_init_custom_transport was given, for the callbacks */
    bool framing;
    open_custom_func open;
    close_custom_func close;
    write_custom_func write;
    read_custom_func read;
    uint64_t _opaque[UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS];
    uxrCommunication comm;
} uxrCustomTransport;

bool uxr_init_udp_transport(uxrUDPTransport* transport, uxrIpProtocol ip_protocol, const char* ip, const char* port);
bool uxr_close_udp_transport(uxrUDPTransport* transport);
bool uxr_init_tcp_transport(uxrTCPTransport* transport, uxrIpProtocol ip_protocol, const char* ip, const char* port);
bool uxr_close_tcp_transport(uxrTCPTransport* transport);
bool uxr_init_can_transport(uxrCANTransport* transport, const char* dev, uint32_t can_id);
bool uxr_close_can_transport(uxrCANTransport* transport);
bool uxr_init_serial_transport(uxrSerialTransport* transport, const int fd, uint8_t remote_addr, uint8_t local_addr);
bool uxr_close_serial_transport(uxrSerialTransport* transport);
void uxr_set_custom_transport_callbacks(uxrCustomTransport* transport, bool framing, open_custom_func open,
                                        close_custom_func close, write_custom_func write, read_custom_func read);
bool uxr_init_custom_transport(uxrCustomTransport* transport, void* args);
bool uxr_close_custom_transport(uxrCustomTransport* transport);

/* ---- discovery ------------------------------------------------------------------------------------------ */
typedef struct TransportLocator {
    uint8_t format;       /* 1: IPv4 (address[0..4]), 3: IPv6 (address[0..16]) */
    uint8_t address[16];
    uint16_t port;
} TransportLocator;

typedef bool (*uxrOnAgentFound)(const TransportLocator* locator, void* args);

bool uxr_discovery_agents_default(uint32_t attempts, int period, uxrOnAgentFound on_agent_func, void* args);
bool uxr_discovery_agents(uint32_t attempts, int period, uxrOnAgentFound on_agent_func, void* args,
                          const TransportLocator* agent_list, size_t agent_list_size);
bool uxr_ip_to_locator(const char* ip, uint16_t port, uxrIpProtocol ip_protocol, TransportLocator* locator);
bool uxr_locator_to_ip(const TransportLocator* locator, char* ip, size_t size, uint16_t* port,
                       uxrIpProtocol* ip_protocol);

/* ---- layout checks ---------------------------------------------------------------------------------------
 * Size and alignment of every structure shared with the library. The C compiler checks them here; build.rs
 * reads the same lines and makes the Rust compiler check its definitions against them. UXR_PTR is the size of
 * a pointer. A failure means a compiler setting changes the layout (e.g. -fshort-enums) or a mismatch. */
#define UXR_PTR (sizeof(void*))
#ifdef __cplusplus
#define UXR_ABI(T, SIZE, ALIGN) static_assert(sizeof(T) == (SIZE) && alignof(T) == (ALIGN), "layout of " #T);
#elif defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define UXR_ABI(T, SIZE, ALIGN) _Static_assert(sizeof(T) == (SIZE) && _Alignof(T) == (ALIGN), "layout of " #T);
#else
/* C99 (firmware built with -std=c99 -pedantic): no _Static_assert or _Alignof; an array of negative size
 * fails the build instead, and the alignment is the offset of T after a char. */
#define UXR_ABI(T, SIZE, ALIGN)                                                                              \
    struct uxr_abi_align_##T { char c; T t; };                                                                \
    typedef char uxr_abi_layout_of_##T[(sizeof(T) == (SIZE) && offsetof(struct uxr_abi_align_##T, t) == (ALIGN)) ? 1 : -1];
#endif
UXR_ABI(ucdrBuffer, 7 * UXR_PTR + 8, UXR_PTR)
UXR_ABI(uxrStreamId, 4, 1)
UXR_ABI(uxrObjectId, 4, 2)
UXR_ABI(uxrDeliveryControl, 8, 2)
UXR_ABI(uxrQoS_t, 16, 4)
UXR_ABI(SampleIdentity, 24, 4)
UXR_ABI(TransportLocator, 20, 2)
UXR_ABI(uxrCommunication, 4 * UXR_PTR, UXR_PTR)
UXR_ABI(uxrSession, UXR_SESSION_OPAQUE_WORDS * 8, 8)
UXR_ABI(uxrUDPTransport, UXR_UDP_TRANSPORT_OPAQUE_WORDS * 8 + 4 * UXR_PTR, 8)
UXR_ABI(uxrTCPTransport, UXR_TCP_TRANSPORT_OPAQUE_WORDS * 8 + 4 * UXR_PTR, 8)
UXR_ABI(uxrSerialTransport, UXR_SERIAL_TRANSPORT_OPAQUE_WORDS * 8 + 4 * UXR_PTR, 8)
UXR_ABI(uxrCANTransport, UXR_CAN_TRANSPORT_OPAQUE_WORDS * 8 + 4 * UXR_PTR, 8)
UXR_ABI(uxrCustomTransport, UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS * 8 + 10 * UXR_PTR, 8)

#ifdef __cplusplus
}
#endif

#endif /* UXR_CLIENT_CLIENT_H */
