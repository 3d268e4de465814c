/* Micro-CDR round trips: every primitive in both byte orders, alignment from the buffer's offset, arrays,
 * sequences, strings, the buffer's state functions, errors on a full buffer, the on-full callback. */
#include <ucdr/microcdr.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "check.h"

#define ROUND_TRIP(NAME, TYPE, VALUE)                                                  \
    do {                                                                               \
        for (int e = 0; e < 2; e++) {                                                  \
            uint8_t mem[64] = {0};                                                     \
            ucdrBuffer w, r;                                                           \
            ucdr_init_buffer_origin_offset_endian(&w, mem, sizeof(mem), 0, 0, (ucdrEndianness)e); \
            TYPE in = (VALUE), out;                                                    \
            CHECK(ucdr_serialize_uint8_t(&w, 0xAA));                                   \
            CHECK(ucdr_serialize_##NAME(&w, in));                                      \
            CHECK(ucdr_buffer_length(&w) == (sizeof(TYPE) == 1 ? 2 : 2 * sizeof(TYPE))); \
            ucdr_init_buffer_origin_offset_endian(&r, mem, ucdr_buffer_length(&w), 0, 0, (ucdrEndianness)e); \
            uint8_t first;                                                             \
            CHECK(ucdr_deserialize_uint8_t(&r, &first) && first == 0xAA);             \
            CHECK(ucdr_deserialize_##NAME(&r, &out));                                  \
            CHECK(memcmp(&in, &out, sizeof(TYPE)) == 0);                               \
            CHECK(!r.error && ucdr_buffer_remaining(&r) == 0);                         \
            CHECK(!ucdr_deserialize_##NAME(&r, &out) && r.error);                      \
        }                                                                              \
    } while (0)

static void primitives(void) {
    ROUND_TRIP(bool, bool, true);
    ROUND_TRIP(char, char, 'x');
    ROUND_TRIP(int8_t, int8_t, -5);
    ROUND_TRIP(uint8_t, uint8_t, 250);
    ROUND_TRIP(int16_t, int16_t, -12345);
    ROUND_TRIP(uint16_t, uint16_t, 0xBEEF);
    ROUND_TRIP(int32_t, int32_t, -123456789);
    ROUND_TRIP(uint32_t, uint32_t, 0xDEADBEEFu);
    ROUND_TRIP(int64_t, int64_t, -1234567890123LL);
    ROUND_TRIP(uint64_t, uint64_t, 0x0123456789ABCDEFull);
    ROUND_TRIP(float, float, 3.5f);
    ROUND_TRIP(double, double, -2.25e300);
}

static void byte_order(void) {
    uint8_t mem[8];
    ucdrBuffer ub;
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(ucdr_serialize_endian_uint32_t(&ub, UCDR_BIG_ENDIANNESS, 0x01020304u));
    CHECK(ucdr_serialize_endian_uint32_t(&ub, UCDR_LITTLE_ENDIANNESS, 0x01020304u));
    const uint8_t expected[8] = {1, 2, 3, 4, 4, 3, 2, 1};
    CHECK(memcmp(mem, expected, 8) == 0);
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    uint32_t v;
    CHECK(ucdr_deserialize_endian_uint32_t(&ub, UCDR_BIG_ENDIANNESS, &v) && v == 0x01020304u);
    CHECK(ucdr_buffer_endianness(&ub) == UCDR_MACHINE_ENDIANNESS);
}

static void alignment(void) {
    uint8_t mem[32] = {0};
    ucdrBuffer ub;
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(ucdr_serialize_uint8_t(&ub, 1));
    CHECK(ucdr_buffer_alignment(&ub, 8) == 7);
    CHECK(ucdr_alignment(1, 4) == 3 && ucdr_alignment(4, 4) == 0 && ucdr_alignment(5, 2) == 1);
    CHECK(ucdr_serialize_uint64_t(&ub, 7));
    CHECK(ucdr_buffer_length(&ub) == 16);
    ucdr_align_to(&ub, 4);
    CHECK(ucdr_buffer_length(&ub) == 16);
    CHECK(ucdr_serialize_uint8_t(&ub, 2));
    ucdr_align_to(&ub, 4);
    CHECK(ucdr_buffer_length(&ub) == 20);
    ucdr_advance_buffer(&ub, 4);
    CHECK(!ucdr_buffer_has_error(&ub) && ucdr_buffer_remaining(&ub) == 8);
    /* an origin other than 0: alignment counts from the stream's start, not the memory's */
    ucdr_init_buffer_origin_offset(&ub, mem, sizeof(mem), 2, 2);
    CHECK(ucdr_serialize_uint32_t(&ub, 9));
    CHECK(ucdr_buffer_length(&ub) == 6);
    ucdr_reset_buffer(&ub);
    CHECK(ucdr_buffer_length(&ub) == 0 && !ucdr_buffer_has_error(&ub) && ucdr_buffer_size(&ub) == sizeof(mem));
}

static void arrays_and_sequences(void) {
    uint8_t mem[128];
    ucdrBuffer ub;
    const int16_t shorts[3] = {-1, 2, -3};
    const double doubles[2] = {1.5, -0.25};
    const uint32_t seq[4] = {10, 20, 30, 40};
    const char chars[3] = {'a', 'b', 'c'};
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(ucdr_serialize_array_int16_t(&ub, shorts, 3));
    CHECK(ucdr_serialize_array_double(&ub, doubles, 2));
    CHECK(ucdr_serialize_sequence_uint32_t(&ub, seq, 4));
    CHECK(ucdr_serialize_array_char(&ub, chars, 3));
    CHECK(ucdr_serialize_endian_sequence_uint16_t(&ub, UCDR_BIG_ENDIANNESS, (const uint16_t*)shorts, 3));
    size_t used = ucdr_buffer_length(&ub);

    int16_t shorts_in[3];
    double doubles_in[2];
    uint32_t seq_in[4], small[2], length = 0;
    char chars_in[3];
    uint16_t be_in[3];
    ucdr_init_buffer(&ub, mem, used);
    CHECK(ucdr_deserialize_array_int16_t(&ub, shorts_in, 3) && memcmp(shorts, shorts_in, sizeof(shorts)) == 0);
    CHECK(ucdr_deserialize_array_double(&ub, doubles_in, 2) && doubles_in[1] == -0.25);
    ucdrBuffer copy;
    ucdr_copy_buffer(&copy, &ub);
    CHECK(ucdr_deserialize_sequence_uint32_t(&ub, seq_in, 4, &length) && length == 4 && seq_in[3] == 40);
    CHECK(ucdr_deserialize_array_char(&ub, chars_in, 3) && chars_in[2] == 'c');
    CHECK(ucdr_deserialize_endian_sequence_uint16_t(&ub, UCDR_BIG_ENDIANNESS, be_in, 3, &length) && length == 3);
    CHECK(memcmp(be_in, shorts, sizeof(be_in)) == 0);
    CHECK(ucdr_buffer_remaining(&ub) == 0 && !ub.error);
    /* a sequence longer than the room given fails and marks the buffer */
    CHECK(!ucdr_deserialize_sequence_uint32_t(&copy, small, 2, &length) && length == 4 && copy.error);
}

static void strings(void) {
    uint8_t mem[32];
    ucdrBuffer ub;
    char out[16], tiny[4];
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(ucdr_serialize_string(&ub, "Hello"));
    CHECK(ucdr_buffer_length(&ub) == 4 + 6);
    CHECK(mem[0] == 6 || mem[3] == 6);
    CHECK(ucdr_serialize_string(&ub, ""));
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(ucdr_deserialize_string(&ub, out, sizeof(out)) && strcmp(out, "Hello") == 0);
    CHECK(ucdr_deserialize_string(&ub, out, sizeof(out)) && out[0] == '\0');
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(!ucdr_deserialize_string(&ub, tiny, sizeof(tiny)) && ub.error);
    /* a string that does not fit the buffer */
    ucdr_init_buffer(&ub, mem, 8);
    CHECK(!ucdr_serialize_string(&ub, "longer than eight") && ucdr_buffer_has_error(&ub));
    /* once in error, nothing more is written */
    CHECK(!ucdr_serialize_uint8_t(&ub, 1));
}

/* The on-full callback moves the buffer to a second block of memory. */
static uint8_t second_block[16];
static int full_calls = 0;
static bool on_full(ucdrBuffer* ub, void* args) {
    (void)args;
    full_calls++;
    if (full_calls > 1) {
        return true; /* give up */
    }
    ub->init = second_block;
    ub->iterator = second_block;
    ub->final = second_block + sizeof(second_block);
    return false;
}

static void full_buffer(void) {
    uint8_t first_block[4];
    ucdrBuffer ub;
    ucdr_init_buffer(&ub, first_block, sizeof(first_block));
    ucdr_set_on_full_buffer_callback(&ub, on_full, NULL);
    CHECK(ucdr_serialize_uint32_t(&ub, 1));
    CHECK(ucdr_serialize_uint32_t(&ub, 2) && full_calls == 1);
    CHECK(second_block[0] == 2 || second_block[3] == 2);
    CHECK(ucdr_serialize_array_uint32_t(&ub, (const uint32_t[3]){3, 4, 5}, 3));
    CHECK(!ucdr_serialize_uint64_t(&ub, 6) && full_calls == 2 && ub.error);
}

static void null_arguments(void) {
    ucdrBuffer ub;
    uint8_t mem[8];
    uint32_t v;
    CHECK(!ucdr_serialize_uint32_t(NULL, 1));
    CHECK(!ucdr_deserialize_uint32_t(NULL, &v));
    ucdr_init_buffer(NULL, mem, sizeof(mem));
    ucdr_init_buffer(&ub, NULL, 8);
    CHECK(ucdr_buffer_size(&ub) == 0 && !ucdr_serialize_uint8_t(&ub, 1));
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(!ucdr_deserialize_uint32_t(&ub, NULL) && ub.error);
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(!ucdr_serialize_string(&ub, NULL) && ub.error);
    ucdr_init_buffer(&ub, mem, sizeof(mem));
    CHECK(!ucdr_serialize_array_uint32_t(&ub, NULL, 2));
    CHECK(ucdr_buffer_has_error(NULL) && ucdr_buffer_remaining(NULL) == 0);
}

int main(void) {
    primitives();
    byte_order();
    alignment();
    arrays_and_sequences();
    strings();
    full_buffer();
    null_arguments();
    printf("%s\n", failures == 0 ? "all checks passed" : "FAILED");
    return failures == 0 ? 0 : 1;
}
