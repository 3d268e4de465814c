/* Stream identifiers: the wire id and its index, kind and direction. */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_STREAM_ID_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_STREAM_ID_H_

#include <stdint.h>
#include <uxr/client/visibility.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The *_INT_SIZE_ enumerators keep these enums int-sized under -fshort-enums (arm-none-eabi-gcc's default), so
 * that structures holding them have one layout whatever the compiler picks. */
typedef enum uxrStreamType {
    UXR_NONE_STREAM = 0,
    UXR_BEST_EFFORT_STREAM = 1,
    UXR_RELIABLE_STREAM = 2,
    UXR_SHARED_MEMORY_STREAM = 3,
    UXR_STREAM_TYPE_INT_SIZE_ = 0x7FFFFFFF
} uxrStreamType;

typedef enum uxrStreamDirection {
    UXR_INPUT_STREAM = 0,
    UXR_OUTPUT_STREAM = 1,
    UXR_STREAM_DIRECTION_INT_SIZE_ = 0x7FFFFFFF
} uxrStreamDirection;

typedef struct uxrStreamId {
    uint8_t raw;       /* the id on the wire: 0 none, 1-127 best effort, 128-255 reliable */
    uint8_t index;     /* position among the streams of its type and direction */
    uint8_t type;      /* uxrStreamType */
    uint8_t direction; /* uxrStreamDirection */
} uxrStreamId;

UXRDLLAPI uxrStreamId uxr_stream_id(uint8_t index, uxrStreamType type, uxrStreamDirection direction);
UXRDLLAPI uxrStreamId uxr_stream_id_from_raw(uint8_t stream_id_raw, uxrStreamDirection direction);

#ifdef __cplusplus
}
#endif

#endif /* UXR_CLIENT_CORE_SESSION_STREAM_STREAM_ID_H_ */
