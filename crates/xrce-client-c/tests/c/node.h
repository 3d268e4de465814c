/* A session over UDP with one reliable output and one reliable input stream, as the seed's examples set
 * one up; and the wait for a list of creation statuses. */
#ifndef XRCE_C_TEST_NODE_H
#define XRCE_C_TEST_NODE_H

#include <uxr/client/client.h>

#include <stdio.h>
#include <stdlib.h>

#define NODE_HISTORY 8
#define NODE_BUFFER (UXR_CONFIG_UDP_TRANSPORT_MTU * NODE_HISTORY)

typedef struct Node {
    uxrUDPTransport transport;
    uxrSession session;
    uint8_t output[NODE_BUFFER];
    uint8_t input[NODE_BUFFER];
    uxrStreamId out;
    uxrStreamId in;
} Node;

/* Opens the transport, creates the session and both streams; `input`/`input_size`/`input_history` override
 * the input stream's memory when non-null (a subscriber of large samples). */
static inline bool node_start_with(Node* node, const char* ip, const char* port, uint32_t key, uint8_t* input,
                            size_t input_size, size_t input_history) {
    if (!uxr_init_udp_transport(&node->transport, UXR_IPv4, ip, port)) {
        fprintf(stderr, "udp transport to %s:%s\n", ip, port);
        return false;
    }
    uxr_init_session(&node->session, &node->transport.comm, key);
    if (!uxr_create_session(&node->session)) {
        fprintf(stderr, "create session %08x\n", key);
        return false;
    }
    node->out = uxr_create_output_reliable_stream(&node->session, node->output, NODE_BUFFER, NODE_HISTORY);
    node->in = input ? uxr_create_input_reliable_stream(&node->session, input, input_size, input_history)
                     : uxr_create_input_reliable_stream(&node->session, node->input, NODE_BUFFER, NODE_HISTORY);
    return node->out.type == UXR_RELIABLE_STREAM && node->in.type == UXR_RELIABLE_STREAM;
}

static inline bool node_start(Node* node, const char* ip, const char* port, uint32_t key) {
    return node_start_with(node, ip, port, key, NULL, 0, 0);
}

/* Waits for every request of `requests` to be answered OK. */
static inline bool node_statuses_ok(Node* node, uint16_t* requests, size_t count, const char* what) {
    uint8_t status[8] = {0};
    if (count > 8 || !uxr_run_session_until_all_status(&node->session, 3000, requests, status, count)) {
        fprintf(stderr, "%s:", what);
        for (size_t i = 0; i < count && i < 8; i++) {
            fprintf(stderr, " %u", status[i]);
        }
        fprintf(stderr, "\n");
        return false;
    }
    return true;
}

/* Participant, topic, publisher or subscriber, and datawriter or datareader (ids 1) of topic `topic` of type
 * `type`, all by XML on the node's reliable output stream; waits for their statuses. */
static inline bool node_create_endpoint(Node* node, bool writer, const char* topic, const char* type) {
    char topic_xml[256], endpoint_xml[320];
    snprintf(topic_xml, sizeof(topic_xml), "<dds><topic><name>%s</name><dataType>%s</dataType></topic></dds>", topic,
             type);
    snprintf(endpoint_xml, sizeof(endpoint_xml),
             "<dds><data_%s><topic><kind>NO_KEY</kind><name>%s</name><dataType>%s</dataType></topic></data_%s></dds>",
             writer ? "writer" : "reader", topic, type, writer ? "writer" : "reader");
    const char* participant_xml =
        "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>";
    uxrObjectId participant = uxr_object_id(1, UXR_PARTICIPANT_ID);
    uxrObjectId topic_id = uxr_object_id(1, UXR_TOPIC_ID);
    uxrObjectId parent = uxr_object_id(1, writer ? UXR_PUBLISHER_ID : UXR_SUBSCRIBER_ID);
    uxrObjectId endpoint = uxr_object_id(1, writer ? UXR_DATAWRITER_ID : UXR_DATAREADER_ID);
    uint16_t r[4];
    r[0] = uxr_buffer_create_participant_xml(&node->session, node->out, participant, 0, participant_xml, UXR_REPLACE);
    r[1] = uxr_buffer_create_topic_xml(&node->session, node->out, topic_id, participant, topic_xml, UXR_REPLACE);
    r[2] = writer ? uxr_buffer_create_publisher_xml(&node->session, node->out, parent, participant, "", UXR_REPLACE)
                  : uxr_buffer_create_subscriber_xml(&node->session, node->out, parent, participant, "", UXR_REPLACE);
    r[3] = writer ? uxr_buffer_create_datawriter_xml(&node->session, node->out, endpoint, parent, endpoint_xml, UXR_REPLACE)
                  : uxr_buffer_create_datareader_xml(&node->session, node->out, endpoint, parent, endpoint_xml, UXR_REPLACE);
    return node_statuses_ok(node, r, 4, writer ? "writer" : "reader");
}

/* The subscriber asks its reader (id 1) for every sample on its input stream; both nodes then run for the
 * agent's settle time (argv[3] in ms, if given: an agent on DDS matches its writer and reader first). */
static inline void node_read_all_then_settle(Node* subscriber, Node* publisher, int argc, char** argv) {
    uxrDeliveryControl control = {UXR_MAX_SAMPLES_UNLIMITED, 0, 0, 0};
    uxr_buffer_request_data(&subscriber->session, subscriber->out, uxr_object_id(1, UXR_DATAREADER_ID), subscriber->in,
                            &control);
    uxr_run_session_until_confirm_delivery(&subscriber->session, 1000);
    for (int waited = 0; argc > 3 && waited < atoi(argv[3]); waited += 10) {
        uxr_run_session_time(&subscriber->session, 5);
        uxr_run_session_time(&publisher->session, 5);
    }
}

static inline void node_stop(Node* node) {
    uxr_delete_session(&node->session);
    uxr_close_udp_transport(&node->transport);
}

#endif
