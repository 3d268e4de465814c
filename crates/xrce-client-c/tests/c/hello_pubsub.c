/* Hello world through the agent: a subscriber session and a publisher session over UDP, entities by XML,
 * a HelloWorld topic serialized with ucdr_*, ten samples published reliably and received in order.
 * Usage: hello_pubsub IP PORT [SETTLE_MS]. Exit status 0 when every sample arrived. SETTLE_MS: time given to an
 * agent whose middleware matches writers and readers asynchronously (DDS) before the first sample. */
#include <stdlib.h>
#include "hello_world.h"
#include "node.h"

#include <stdio.h>
#include <string.h>

#define SAMPLES 10

static uint32_t received = 0;
static uint32_t next_index = 0;
static bool in_order = true;

static void on_topic(uxrSession* session, uxrObjectId object_id, uint16_t request_id, uxrStreamId stream_id,
                     struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)session; (void)object_id; (void)request_id; (void)stream_id; (void)length;
    HelloWorld topic;
    if (!HelloWorld_deserialize_topic(ub, &topic)) {
        in_order = false;
        return;
    }
    if (topic.index != next_index || strcmp(topic.message, "Hello DDS world!") != 0) {
        in_order = false;
    }
    next_index = topic.index + 1;
    received++;
    (*(uint32_t*)args)++;
}

static const char* participant_xml =
    "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
static const char* topic_xml = "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>";
static const char* datawriter_xml = "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>"
                                    "<dataType>HelloWorld</dataType></topic></data_writer></dds>";
static const char* datareader_xml = "<dds><data_reader><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name>"
                                    "<dataType>HelloWorld</dataType></topic></data_reader></dds>";

static bool create_entities(Node* node, bool writer) {
    uxrObjectId participant_id = uxr_object_id(0x01, UXR_PARTICIPANT_ID);
    uxrObjectId topic_id = uxr_object_id(0x01, UXR_TOPIC_ID);
    uxrObjectId parent_id = uxr_object_id(0x01, writer ? UXR_PUBLISHER_ID : UXR_SUBSCRIBER_ID);
    uxrObjectId endpoint_id = uxr_object_id(0x01, writer ? UXR_DATAWRITER_ID : UXR_DATAREADER_ID);
    uint16_t requests[4];
    requests[0] = uxr_buffer_create_participant_xml(&node->session, node->out, participant_id, 0, participant_xml, UXR_REPLACE);
    requests[1] = uxr_buffer_create_topic_xml(&node->session, node->out, topic_id, participant_id, topic_xml, UXR_REPLACE);
    if (writer) {
        requests[2] = uxr_buffer_create_publisher_xml(&node->session, node->out, parent_id, participant_id, "", UXR_REPLACE);
        requests[3] = uxr_buffer_create_datawriter_xml(&node->session, node->out, endpoint_id, parent_id, datawriter_xml, UXR_REPLACE);
    } else {
        requests[2] = uxr_buffer_create_subscriber_xml(&node->session, node->out, parent_id, participant_id, "", UXR_REPLACE);
        requests[3] = uxr_buffer_create_datareader_xml(&node->session, node->out, endpoint_id, parent_id, datareader_xml, UXR_REPLACE);
    }
    return node_statuses_ok(node, requests, 4, "entities");
}

int main(int argc, char** argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s IP PORT [SETTLE_MS]\n", argv[0]);
        return 2;
    }
    static Node subscriber, publisher;
    uint32_t count = 0;
    if (!node_start(&subscriber, argv[1], argv[2], 0xC0DE0001) || !node_start(&publisher, argv[1], argv[2], 0xC0DE0002)) {
        return 1;
    }
    uxr_set_topic_callback(&subscriber.session, on_topic, &count);
    if (!create_entities(&subscriber, false) || !create_entities(&publisher, true)) {
        return 1;
    }
    uxrDeliveryControl control = {0};
    control.max_samples = UXR_MAX_SAMPLES_UNLIMITED;
    uxrObjectId reader = uxr_object_id(0x01, UXR_DATAREADER_ID);
    uxrObjectId writer = uxr_object_id(0x01, UXR_DATAWRITER_ID);
    uint16_t read = uxr_buffer_request_data(&subscriber.session, subscriber.out, reader, subscriber.in, &control);
    /* the agent answers a READ_DATA with samples, not with a status: just make sure it arrived */
    if (read == UXR_INVALID_REQUEST_ID || !uxr_run_session_until_confirm_delivery(&subscriber.session, 1000)) {
        fprintf(stderr, "request data\n");
        return 1;
    }

    for (int waited = 0; argc > 3 && waited < atoi(argv[3]); waited += 10) {
        uxr_run_session_time(&subscriber.session, 5);
        uxr_run_session_time(&publisher.session, 5);
    }
    for (uint32_t i = 0; i < SAMPLES; i++) {
        HelloWorld topic = {i, "Hello DDS world!"};
        ucdrBuffer ub;
        uint32_t size = HelloWorld_size_of_topic(&topic, 0);
        if (uxr_prepare_output_stream(&publisher.session, publisher.out, writer, &ub, size) == UXR_INVALID_REQUEST_ID
            || !HelloWorld_serialize_topic(&ub, &topic)) {
            fprintf(stderr, "prepare sample %u\n", i);
            return 1;
        }
        if (!uxr_run_session_until_confirm_delivery(&publisher.session, 1000)) {
            fprintf(stderr, "sample %u not confirmed\n", i);
            return 1;
        }
        uxr_run_session_time(&subscriber.session, 10);
    }
    for (int round = 0; round < 100 && received < SAMPLES; round++) {
        uxr_run_session_until_data(&subscriber.session, 50);
    }
    printf("received %u of %u samples, %s\n", received, SAMPLES, in_order ? "in order" : "NOT in order");
    uint16_t cancel = uxr_buffer_cancel_data(&subscriber.session, subscriber.out, reader);
    bool cancelled = cancel != UXR_INVALID_REQUEST_ID && uxr_run_session_until_confirm_delivery(&subscriber.session, 1000);
    /* a sample after the cancellation is not delivered */
    HelloWorld late = {SAMPLES, "Hello DDS world!"};
    ucdrBuffer late_ub;
    uxr_prepare_output_stream(&publisher.session, publisher.out, writer, &late_ub, HelloWorld_size_of_topic(&late, 0));
    HelloWorld_serialize_topic(&late_ub, &late);
    uxr_run_session_until_confirm_delivery(&publisher.session, 1000);
    uxr_run_session_time(&subscriber.session, 100);
    cancelled &= received == SAMPLES;
    /* the other run functions return (an agent's heartbeats may count as messages: no expectation) */
    uxr_run_session_until_timeout(&subscriber.session, 50);
    uxr_run_session_timeout(&subscriber.session, 50);
    printf("read cancelled: %s\n", cancelled ? "no sample after it" : "FAILED");

    node_stop(&publisher);
    node_stop(&subscriber);
    return received == SAMPLES && count == SAMPLES && in_order && cancelled ? 0 : 1;
}
