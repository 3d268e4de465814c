/* The HelloWorld topic type (uint32 index, string message) as a type generator would emit it for Micro-CDR. */
#ifndef XRCE_C_TEST_HELLO_WORLD_H
#define XRCE_C_TEST_HELLO_WORLD_H

#include <ucdr/microcdr.h>

#include <string.h>

typedef struct HelloWorld {
    uint32_t index;
    char message[255];
} HelloWorld;

static inline bool HelloWorld_serialize_topic(ucdrBuffer* writer, const HelloWorld* topic) {
    bool ok = ucdr_serialize_uint32_t(writer, topic->index);
    ok &= ucdr_serialize_string(writer, topic->message);
    return ok && !writer->error;
}

static inline bool HelloWorld_deserialize_topic(ucdrBuffer* reader, HelloWorld* topic) {
    bool ok = ucdr_deserialize_uint32_t(reader, &topic->index);
    ok &= ucdr_deserialize_string(reader, topic->message, sizeof(topic->message));
    return ok;
}

static inline uint32_t HelloWorld_size_of_topic(const HelloWorld* topic, uint32_t size) {
    uint32_t previous = size;
    size += ucdr_alignment(size, 4) + 4;
    size += ucdr_alignment(size, 4) + 4 + (uint32_t)strlen(topic->message) + 1;
    return size - previous;
}

#endif
