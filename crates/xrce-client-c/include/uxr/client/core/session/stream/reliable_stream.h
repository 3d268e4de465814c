/* What every reliable stream has: the memory the program lent it, cut into `history` slots. */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_RELIABLE_STREAM_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_RELIABLE_STREAM_H_
#include <stddef.h>
#include <stdint.h>
typedef struct uxrReliableStream {
    uint8_t* buffer;
    size_t size;
    uint16_t history;
} uxrReliableStream;
#endif /* UXR_CLIENT_CORE_SESSION_STREAM_RELIABLE_STREAM_H_ */
