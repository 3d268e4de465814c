/* A 49,999-byte sample written with uxr_prepare_output_stream (not the fragmented call) on a reliable stream of
 * 128 x 512 B, as eProsima's PublishBigHelloWorld does: the library spreads it over the stream's slots as
 * fragments and the subscriber receives it whole, three times in a row. A sample larger than the whole free
 * history is refused (0) with the buffer left failing. Entities by XML. Usage: big_prepare IP PORT [SETTLE_MS] */
#include "node.h"

#include <stdlib.h>
#include <string.h>

#define SAMPLE 49999
#define PAYLOAD (SAMPLE - 8) /* a uint32 index and a sequence of bytes */
#define HISTORY 128
#define BUFFER (UXR_CONFIG_UDP_TRANSPORT_MTU * HISTORY)

static Node subscriber, publisher;
static uint8_t subscriber_input[BUFFER];
static uint8_t publisher_output[BUFFER];
static uint8_t payload[PAYLOAD];
static uint8_t received[PAYLOAD];
static uint32_t received_len = 0, received_index = 0;
static int received_count = 0;

static void on_topic(uxrSession* session, uxrObjectId object_id, uint16_t request_id, uxrStreamId stream_id,
                     struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)session; (void)object_id; (void)request_id; (void)stream_id; (void)length; (void)args;
    uint32_t len = 0;
    if (ucdr_deserialize_uint32_t(ub, &received_index) &&
        ucdr_deserialize_sequence_uint8_t(ub, received, sizeof(received), &len)) {
        received_len = len;
        received_count++;
    }
}

static bool create(Node* node, bool writer) {
    return node_create_endpoint(node, writer, "BigHelloWorldTopic", "BigHelloWorld");
}

int main(int argc, char** argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s IP PORT [SETTLE_MS]\n", argv[0]);
        return 2;
    }
    for (size_t i = 0; i < PAYLOAD; i++) {
        payload[i] = (uint8_t)(i * 13 + i / 509);
    }
    if (!node_start_with(&subscriber, argv[1], argv[2], 0xB1600011, subscriber_input, BUFFER, HISTORY)) {
        return 1;
    }
    if (!uxr_init_udp_transport(&publisher.transport, UXR_IPv4, argv[1], argv[2])) {
        return 1;
    }
    uxr_init_session(&publisher.session, &publisher.transport.comm, 0xB1600012);
    if (!uxr_create_session(&publisher.session)) {
        return 1;
    }
    publisher.out = uxr_create_output_reliable_stream(&publisher.session, publisher_output, BUFFER, HISTORY);
    publisher.in = uxr_create_input_reliable_stream(&publisher.session, publisher.input, NODE_BUFFER, NODE_HISTORY);
    uxr_set_topic_callback(&subscriber.session, on_topic, NULL);
    if (!create(&subscriber, false) || !create(&publisher, true)) {
        return 1;
    }
    node_read_all_then_settle(&subscriber, &publisher, argc, argv);

    int intact = 0;
    for (uint32_t index = 1; index <= 3; index++) {
        ucdrBuffer ub;
        uint16_t request = uxr_prepare_output_stream(&publisher.session, publisher.out,
                                                     uxr_object_id(1, UXR_DATAWRITER_ID), &ub, SAMPLE);
        if (request == UXR_INVALID_REQUEST_ID) {
            fprintf(stderr, "sample %u: prepare refused\n", index);
            return 1;
        }
        if (!ucdr_serialize_uint32_t(&ub, index) || !ucdr_serialize_sequence_uint8_t(&ub, payload, PAYLOAD) ||
            ub.error) {
            fprintf(stderr, "sample %u: serialization failed\n", index);
            return 1;
        }
        uxr_run_session_until_confirm_delivery(&publisher.session, 3000);
        for (int round = 0; round < 300 && received_count < (int)index; round++) {
            uxr_run_session_time(&subscriber.session, 10);
            uxr_run_session_time(&publisher.session, 1);
        }
        if (received_count == (int)index && received_index == index && received_len == PAYLOAD &&
            memcmp(payload, received, PAYLOAD) == 0) {
            intact++;
        }
    }
    /* more than the history can hold: refused, the buffer fails */
    ucdrBuffer too_big;
    uint16_t refused = uxr_prepare_output_stream(&publisher.session, publisher.out,
                                                 uxr_object_id(1, UXR_DATAWRITER_ID), &too_big, BUFFER + 1);
    bool refused_ok = refused == UXR_INVALID_REQUEST_ID && !ucdr_serialize_uint32_t(&too_big, 1);
    printf("%d of 3 samples of %d bytes received intact; a sample larger than the history %s\n", intact, SAMPLE,
           refused_ok ? "refused" : "NOT refused");
    node_stop(&publisher);
    node_stop(&subscriber);
    return intact == 3 && refused_ok ? 0 : 1;
}
