/*
 * Micro-CDR API of xrce-rs: the CDR (de)serialization functions that the Client API's callbacks and
 * generated topic types use, written from the Client API document (seed 000) and the function names
 * programs call. Implemented in Rust (crates/xrce-client-c/src/ucdr/) inside libmicroxrcedds_client.a;
 * libmicrocdr.a exists so that `-lmicroxrcedds_client -lmicrocdr` link lines keep working.
 *
 * Alignment is counted from `offset`: a buffer initialised with origin 0 aligns relative to its first byte,
 * which is how a topic's payload is aligned in an XRCE message.
 */
#ifndef UCDR_MICROCDR_H
#define UCDR_MICROCDR_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <ucdr/config.h>
#include <ucdr/visibility.h>

#ifdef __cplusplus
extern "C" {
#endif

/* UCDR_ENDIANNESS_INT_SIZE_ keeps the enum int-sized under -fshort-enums (ucdrBuffer's layout is fixed). */
typedef enum ucdrEndianness {
    UCDR_BIG_ENDIANNESS = 0,
    UCDR_LITTLE_ENDIANNESS = 1,
    UCDR_ENDIANNESS_INT_SIZE_ = 0x7FFFFFFF
} ucdrEndianness;

struct ucdrBuffer;

/* Called when the next value does not fit before `final`. Return false once the buffer has room again
 * (init/iterator/final moved to new memory), true to give up: the operation then fails and sets `error`. */
typedef bool (*OnFullBuffer)(struct ucdrBuffer* buffer, void* args);

typedef struct ucdrBuffer {
    uint8_t* init;            /* first byte of the memory */
    uint8_t* final;           /* one past its last byte */
    uint8_t* iterator;        /* next byte to read or write */
    size_t origin;            /* offset of `init` in the whole serialized stream */
    size_t offset;            /* offset of `iterator` in the whole serialized stream: alignment counts from 0 */
    ucdrEndianness endianness;
    uint8_t last_data_size;   /* size of the last primitive moved */
    bool error;               /* set by any operation that did not fit; stays set until reset */
    OnFullBuffer on_full_buffer;
    void* args;
} ucdrBuffer;

/* Buffer set-up and state */
void ucdr_init_buffer(ucdrBuffer* ub, uint8_t* data, size_t size);
void ucdr_init_buffer_origin(ucdrBuffer* ub, uint8_t* data, size_t size, size_t origin);
void ucdr_init_buffer_origin_offset(ucdrBuffer* ub, uint8_t* data, size_t size, size_t origin, size_t offset);
void ucdr_init_buffer_origin_offset_endian(ucdrBuffer* ub, uint8_t* data, size_t size, size_t origin,
                                           size_t offset, ucdrEndianness endianness);
void ucdr_copy_buffer(ucdrBuffer* ub_dest, const ucdrBuffer* ub_source);
void ucdr_set_on_full_buffer_callback(ucdrBuffer* ub, OnFullBuffer on_full_buffer, void* args);
void ucdr_reset_buffer(ucdrBuffer* ub);
void ucdr_reset_buffer_offset(ucdrBuffer* ub, size_t offset);
void ucdr_align_to(ucdrBuffer* ub, size_t data_size);
size_t ucdr_alignment(size_t current_alignment, size_t data_size);
size_t ucdr_buffer_alignment(const ucdrBuffer* ub, size_t data_size);
void ucdr_advance_buffer(ucdrBuffer* ub, size_t size);
size_t ucdr_buffer_size(const ucdrBuffer* ub);
size_t ucdr_buffer_length(const ucdrBuffer* ub);
size_t ucdr_buffer_remaining(const ucdrBuffer* ub);
ucdrEndianness ucdr_buffer_endianness(const ucdrBuffer* ub);
bool ucdr_buffer_has_error(const ucdrBuffer* ub);

/* Every primitive: serialize, deserialize, with an explicit endianness, fixed arrays (`size` elements) and
 * sequences (a uint32 length, then the elements; deserializing fails when more than `capacity` arrive). */
#define UCDR_DECLARE_PRIMITIVE(NAME, TYPE)                                                                     \
    bool ucdr_serialize_##NAME(ucdrBuffer* ub, TYPE value);                                                    \
    bool ucdr_serialize_endian_##NAME(ucdrBuffer* ub, ucdrEndianness endianness, TYPE value);                  \
    bool ucdr_deserialize_##NAME(ucdrBuffer* ub, TYPE* value);                                                 \
    bool ucdr_deserialize_endian_##NAME(ucdrBuffer* ub, ucdrEndianness endianness, TYPE* value);               \
    bool ucdr_serialize_array_##NAME(ucdrBuffer* ub, const TYPE* array, size_t size);                          \
    bool ucdr_serialize_endian_array_##NAME(ucdrBuffer* ub, ucdrEndianness endianness, const TYPE* array,      \
                                            size_t size);                                                      \
    bool ucdr_deserialize_array_##NAME(ucdrBuffer* ub, TYPE* array, size_t size);                              \
    bool ucdr_deserialize_endian_array_##NAME(ucdrBuffer* ub, ucdrEndianness endianness, TYPE* array,          \
                                              size_t size);                                                    \
    bool ucdr_serialize_sequence_##NAME(ucdrBuffer* ub, const TYPE* array, uint32_t length);                   \
    bool ucdr_serialize_endian_sequence_##NAME(ucdrBuffer* ub, ucdrEndianness endianness, const TYPE* array,   \
                                               uint32_t length);                                               \
    bool ucdr_deserialize_sequence_##NAME(ucdrBuffer* ub, TYPE* array, size_t capacity, uint32_t* length);     \
    bool ucdr_deserialize_endian_sequence_##NAME(ucdrBuffer* ub, ucdrEndianness endianness, TYPE* array,       \
                                                 size_t capacity, uint32_t* length);

UCDR_DECLARE_PRIMITIVE(bool, bool)
UCDR_DECLARE_PRIMITIVE(char, char)
UCDR_DECLARE_PRIMITIVE(int8_t, int8_t)
UCDR_DECLARE_PRIMITIVE(uint8_t, uint8_t)
UCDR_DECLARE_PRIMITIVE(int16_t, int16_t)
UCDR_DECLARE_PRIMITIVE(uint16_t, uint16_t)
UCDR_DECLARE_PRIMITIVE(int32_t, int32_t)
UCDR_DECLARE_PRIMITIVE(uint32_t, uint32_t)
UCDR_DECLARE_PRIMITIVE(int64_t, int64_t)
UCDR_DECLARE_PRIMITIVE(uint64_t, uint64_t)
UCDR_DECLARE_PRIMITIVE(float, float)
UCDR_DECLARE_PRIMITIVE(double, double)

#undef UCDR_DECLARE_PRIMITIVE

/* Strings: a uint32 length counting the terminating NUL, the bytes, the NUL. Deserializing fails (and sets
 * `error`) when the string and its NUL do not fit `capacity` bytes. */
bool ucdr_serialize_string(ucdrBuffer* ub, const char* string);
bool ucdr_serialize_endian_string(ucdrBuffer* ub, ucdrEndianness endianness, const char* string);
bool ucdr_deserialize_string(ucdrBuffer* ub, char* string, size_t capacity);
bool ucdr_deserialize_endian_string(ucdrBuffer* ub, ucdrEndianness endianness, char* string, size_t capacity);

#ifdef __cplusplus
}
#endif

#endif /* UCDR_MICROCDR_H */
