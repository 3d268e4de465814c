/*
 * The session's table of streams. The library keeps each stream's memory (`buffer`, `size`, `history`) and the
 * counts (`*_size`) here as they are created; sequence numbers and heartbeat state live in the library's own
 * stream engine and read 0 here.
 */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_STREAM_STORAGE_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_STREAM_STORAGE_H_
#include <uxr/client/config.h>
#include <uxr/client/core/session/stream/input_best_effort_stream.h>
#include <uxr/client/core/session/stream/input_reliable_stream.h>
#include <uxr/client/core/session/stream/output_best_effort_stream.h>
#include <uxr/client/core/session/stream/output_reliable_stream.h>
#include <uxr/client/core/session/stream/stream_id.h>
typedef struct uxrStreamStorage {
    uxrOutputBestEffortStream output_best_effort[UXR_CONFIG_MAX_OUTPUT_BEST_EFFORT_STREAMS];
    uint8_t output_best_effort_size;
    uxrOutputReliableStream output_reliable[UXR_CONFIG_MAX_OUTPUT_RELIABLE_STREAMS];
    uint8_t output_reliable_size;
    uxrInputBestEffortStream input_best_effort[UXR_CONFIG_MAX_INPUT_BEST_EFFORT_STREAMS];
    uint8_t input_best_effort_size;
    uxrInputReliableStream input_reliable[UXR_CONFIG_MAX_INPUT_RELIABLE_STREAMS];
    uint8_t input_reliable_size;
} uxrStreamStorage;
#endif /* UXR_CLIENT_CORE_SESSION_STREAM_STREAM_STORAGE_H_ */
