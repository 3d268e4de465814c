/* Asking a datareader for samples, and cancelling. */
#ifndef UXR_CLIENT_CORE_SESSION_READ_ACCESS_H_
#define UXR_CLIENT_CORE_SESSION_READ_ACCESS_H_
#include <uxr/client/core/session/session.h>
#ifdef __cplusplus
extern "C" {
#endif
#define UXR_MAX_SAMPLES_UNLIMITED 0xFFFF
#define UXR_MAX_ELAPSED_TIME_UNLIMITED 0x0000
#define UXR_MAX_BYTES_PER_SECOND_UNLIMITED 0x0000

typedef struct uxrDeliveryControl {
    uint16_t max_samples;
    uint16_t max_elapsed_time;
    uint16_t max_bytes_per_second;
    uint16_t min_pace_period;
} uxrDeliveryControl;

UXRDLLAPI uint16_t uxr_buffer_request_data(uxrSession* session, uxrStreamId stream_id, uxrObjectId datareader_id,
                                           uxrStreamId data_stream_id,
                                           const uxrDeliveryControl* const delivery_control);
UXRDLLAPI uint16_t uxr_buffer_cancel_data(uxrSession* session, uxrStreamId stream_id, uxrObjectId datareader_id);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_CORE_SESSION_READ_ACCESS_H_ */
