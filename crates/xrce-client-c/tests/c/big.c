/* Continuous fragmentation: two 20,000-byte samples written through uxr_prepare_output_stream_fragmented into
 * a reliable history of 4 x 512 B, the flush callback running the session whenever the history is full: the
 * first in eProsima's form (7 arguments, the callback gets its argument), the second in the seed's (6, a
 * one-argument callback); the subscriber receives both whole. Entities by XML. Usage: big IP PORT [SETTLE_MS]
 * (the last one ignored: the reliable reader gets the sample whenever it matched). */
#include "node.h"

#include <stdlib.h>
#include <string.h>

#define PAYLOAD 20000
#define INPUT_HISTORY 64
#define INPUT_SIZE (UXR_CONFIG_UDP_TRANSPORT_MTU * INPUT_HISTORY)

static Node subscriber, publisher;
static uint8_t subscriber_input[INPUT_SIZE];
static uint8_t payload[PAYLOAD];
static uint8_t received[PAYLOAD];
static uint32_t received_len = 0;
static int received_count = 0;
static int flushes = 0;

static void on_topic(uxrSession* session, uxrObjectId object_id, uint16_t request_id, uxrStreamId stream_id,
                     struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)session; (void)object_id; (void)request_id; (void)stream_id; (void)length; (void)args;
    uint32_t len = 0;
    if (ucdr_deserialize_sequence_uint8_t(ub, received, sizeof(received), &len)) {
        received_len = len;
        received_count++;
    }
}

/* eProsima's flush callback: `args` is what the write was given. */
static bool flush(uxrSession* session, void* args) {
    (*(int*)args)++;
    bool confirmed = uxr_run_session_until_confirm_delivery(session, 1000);
    uxr_run_session_time(&subscriber.session, 1);
    return confirmed;
}

/* The seed's flush callback. */
static int seed_flushes = 0;
static bool flush_seed(uxrSession* session) {
    seed_flushes++;
    return flush(session, &flushes);
}

/* Waits for sample number `count` at the subscriber; whether it is the payload, intact. */
static bool received_intact(int count) {
    for (int round = 0; round < 200 && received_count < count; round++) {
        uxr_run_session_time(&subscriber.session, 10);
        uxr_run_session_time(&publisher.session, 1);
    }
    return received_count == count && received_len == PAYLOAD && memcmp(payload, received, PAYLOAD) == 0;
}

static bool create(Node* node, bool writer) {
    return node_create_endpoint(node, writer, "BigTopic", "Big");
}

int main(int argc, char** argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s IP PORT [SETTLE_MS]\n", argv[0]);
        return 2;
    }
    for (size_t i = 0; i < PAYLOAD; i++) {
        payload[i] = (uint8_t)(i * 7 + i / 251);
    }
    if (!node_start_with(&subscriber, argv[1], argv[2], 0xB1600001, subscriber_input, INPUT_SIZE, INPUT_HISTORY)) {
        return 1;
    }
    /* the publisher's output history: 4 slots of 512 B, a fifth of the sample */
    if (!uxr_init_udp_transport(&publisher.transport, UXR_IPv4, argv[1], argv[2])) {
        return 1;
    }
    uxr_init_session(&publisher.session, &publisher.transport.comm, 0xB1600002);
    if (!uxr_create_session(&publisher.session)) {
        return 1;
    }
    publisher.out = uxr_create_output_reliable_stream(&publisher.session, publisher.output, 4 * 512, 4);
    publisher.in = uxr_create_input_reliable_stream(&publisher.session, publisher.input, NODE_BUFFER, NODE_HISTORY);
    uxr_set_topic_callback(&subscriber.session, on_topic, NULL);
    if (!create(&subscriber, false) || !create(&publisher, true)) {
        return 1;
    }
    node_read_all_then_settle(&subscriber, &publisher, argc, argv);

    ucdrBuffer ub;
    uint32_t size = 4 + PAYLOAD;
    uint16_t request = uxr_prepare_output_stream_fragmented(&publisher.session, publisher.out,
                                                            uxr_object_id(1, UXR_DATAWRITER_ID), &ub, size, flush,
                                                            &flushes);
    if (request == UXR_INVALID_REQUEST_ID || !ucdr_serialize_sequence_uint8_t(&ub, payload, PAYLOAD) || ub.error) {
        fprintf(stderr, "fragmented write failed\n");
        return 1;
    }
    /* best-effort streams are refused (a second write would end this one: the program has serialized it) */
    ucdrBuffer other;
    if (uxr_prepare_output_stream_fragmented(&publisher.session, uxr_stream_id(0, UXR_BEST_EFFORT_STREAM,
                                             UXR_OUTPUT_STREAM), uxr_object_id(1, UXR_DATAWRITER_ID),
                                             &other, 8, flush, &flushes) != UXR_INVALID_REQUEST_ID) {
        return 1;
    }
    bool confirmed = uxr_run_session_until_confirm_delivery(&publisher.session, 3000);
    bool first = received_intact(1);
    int first_flushes = flushes;

    /* the seed's form: six arguments, a one-argument callback */
    request = uxr_prepare_output_stream_fragmented(&publisher.session, publisher.out,
                                                   uxr_object_id(1, UXR_DATAWRITER_ID), &ub, size, flush_seed);
    if (request == UXR_INVALID_REQUEST_ID || !ucdr_serialize_sequence_uint8_t(&ub, payload, PAYLOAD) || ub.error) {
        fprintf(stderr, "fragmented write (seed form) failed\n");
        return 1;
    }
    confirmed = uxr_run_session_until_confirm_delivery(&publisher.session, 3000) && confirmed;
    bool second = received_intact(2);
    printf("7 arguments: sample of %u bytes %s after %d flushes; 6 arguments: %s after %d flushes; delivery %s\n",
           PAYLOAD, first ? "intact" : "NOT received intact", first_flushes,
           second ? "intact" : "NOT received intact", seed_flushes, confirmed ? "confirmed" : "NOT confirmed");
    node_stop(&publisher);
    node_stop(&subscriber);
    return first && second && confirmed && first_flushes > 0 && seed_flushes > 0 ? 0 : 1;
}
