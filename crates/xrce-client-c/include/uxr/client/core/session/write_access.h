/* Writing samples, requests and replies. Each returns the request id, 0 on failure (so it reads as the seed's
 * `bool` in a condition). */
#ifndef UXR_CLIENT_CORE_SESSION_WRITE_ACCESS_H_
#define UXR_CLIENT_CORE_SESSION_WRITE_ACCESS_H_
#include <uxr/client/core/session/session.h>
#ifdef __cplusplus
extern "C" {
#endif

UXRDLLAPI uint16_t uxr_buffer_request(uxrSession* session, uxrStreamId stream_id, uxrObjectId requester_id,
                                      uint8_t* buffer, size_t len);
UXRDLLAPI uint16_t uxr_buffer_reply(uxrSession* session, uxrStreamId stream_id, uxrObjectId replier_id,
                                    SampleIdentity* sample_id, uint8_t* buffer, size_t len);
/* Samples larger than a message are fragmented on reliable streams. */
UXRDLLAPI uint16_t uxr_buffer_topic(uxrSession* session, uxrStreamId stream_id, uxrObjectId datawriter_id,
                                    uint8_t* buffer, size_t len);

/* Reserves `len` bytes and points `ub` at them; serialize into `ub` before the session's next call. On a
 * reliable stream, a sample larger than one message is spread over the stream's slots as fragments (all
 * of it must fit the stream's free history; 0 otherwise), as eProsima's library does. */
UXRDLLAPI uint16_t uxr_prepare_output_stream(uxrSession* session, uxrStreamId stream_id, uxrObjectId entity_id,
                                             struct ucdrBuffer* ub, uint32_t len);

/* A sample larger than the whole reliable history: `flush_callback(session, flush_callback_args)` runs
 * whenever the history is full (it should run the session); reliable streams only. */
UXRDLLAPI uint16_t uxr_prepare_output_stream_fragmented(uxrSession* session, uxrStreamId stream_id,
                                                        uxrObjectId datawriter_id, struct ucdrBuffer* ub,
                                                        size_t data_size, uxrOnBuffersFull flush_callback,
                                                        void* flush_callback_args);

/* Two calls exist in two forms: the seed's text (Client API document) and eProsima's library differ in
 * their arguments. In C, a macro picks by argument count, so programs written against either compile:
 *  - uxr_prepare_output_stream_fragmented with 6 arguments takes the seed's one-argument flush callback
 *    (`bool f(uxrSession*)`); the type `uxrOnBuffersFull` is eProsima's (two arguments);
 *  - uxr_buffer_reply with 5 arguments (no request identity) answers the last request received.
 * C++ programs get eProsima's forms (function-like macros would hide the names from overloads). */
typedef bool (*uxrOnBuffersFullSeed)(struct uxrSession* session);
UXRDLLAPI uint16_t uxr_prepare_output_stream_fragmented_seed(uxrSession* session, uxrStreamId stream_id,
                                                             uxrObjectId datawriter_id, struct ucdrBuffer* ub,
                                                             size_t data_size, uxrOnBuffersFullSeed flush_callback);
UXRDLLAPI uint16_t uxr_buffer_reply_last(uxrSession* session, uxrStreamId stream_id, uxrObjectId replier_id,
                                         uint8_t* buffer, size_t len);
#ifndef __cplusplus
#define UXR_PICK_BY_COUNT_7_(_1, _2, _3, _4, _5, _6, _7, N, ...) N
#define uxr_prepare_output_stream_fragmented(...)                                                      \
    UXR_PICK_BY_COUNT_7_(__VA_ARGS__, (uxr_prepare_output_stream_fragmented),                          \
                         uxr_prepare_output_stream_fragmented_seed, uxr_too_few_arguments, uxr_too_few_arguments) \
    (__VA_ARGS__)
#define UXR_PICK_BY_COUNT_6R_(_1, _2, _3, _4, _5, _6, N, ...) N
#define uxr_buffer_reply(...) \
    UXR_PICK_BY_COUNT_6R_(__VA_ARGS__, (uxr_buffer_reply), uxr_buffer_reply_last, uxr_too_few_arguments)(__VA_ARGS__)
#endif

#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_CORE_SESSION_WRITE_ACCESS_H_ */
