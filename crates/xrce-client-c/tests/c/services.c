/* Request/reply through the agent with entities created in binary: a replier that answers from its request
 * callback (uxr_buffer_reply inside the callback), a requester sending three additions and matching each
 * reply to its request id. Usage: services IP PORT [SETTLE_MS] (as in hello_pubsub.c). */
#include <stdlib.h>
#include "node.h"

#include <string.h>

#define REQUESTS 3

static uxrStreamId replier_out;
static int replies = 0;
static bool replies_right = true;
static uint16_t request_ids[REQUESTS];

static void on_request(uxrSession* session, uxrObjectId object_id, uint16_t request_id, SampleIdentity* sample_id,
                       struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)request_id; (void)length; (void)args;
    int32_t a = 0, b = 0;
    ucdr_deserialize_int32_t(ub, &a);
    ucdr_deserialize_int32_t(ub, &b);
    uint8_t reply[4];
    ucdrBuffer out;
    ucdr_init_buffer(&out, reply, sizeof(reply));
    ucdr_serialize_int64_t(&out, 0); /* does not fit: the buffer reports the error, nothing is written past it */
    ucdr_reset_buffer(&out);
    ucdr_serialize_int32_t(&out, a + b);
    /* both forms: eProsima's (with the request's identity) and the seed's (the last request received) */
    uint16_t sent = (a % 20 == 0) ? uxr_buffer_reply(session, replier_out, object_id, sample_id, reply, sizeof(reply))
                                  : uxr_buffer_reply(session, replier_out, object_id, reply, sizeof(reply));
    if (sent == 0) {
        replies_right = false;
    }
}

static void on_reply(uxrSession* session, uxrObjectId object_id, uint16_t request_id, uint16_t reply_id,
                     struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)session; (void)object_id; (void)request_id; (void)args;
    int32_t sum = 0;
    if (length != 4 || !ucdr_deserialize_int32_t(ub, &sum)) {
        replies_right = false;
        return;
    }
    for (int i = 0; i < REQUESTS; i++) {
        if (request_ids[i] == reply_id) {
            replies_right &= sum == 10 * i + i;
            replies++;
            return;
        }
    }
    replies_right = false;
}

static bool create(Node* node, bool replier) {
    uxrObjectId participant = uxr_object_id(0x01, UXR_PARTICIPANT_ID);
    uxrObjectId endpoint = uxr_object_id(0x01, replier ? UXR_REPLIER_ID : UXR_REQUESTER_ID);
    uxrQoS_t qos = {UXR_DURABILITY_VOLATILE, UXR_RELIABILITY_RELIABLE, UXR_HISTORY_KEEP_LAST, 10};
    uint16_t requests[2];
    requests[0] = uxr_buffer_create_participant_bin(&node->session, node->out, participant, 0, "adder", UXR_REPLACE);
    if (replier) {
        requests[1] = uxr_buffer_create_replier_bin(&node->session, node->out, endpoint, participant, "adder",
                                                    "AddRequest", "AddReply", "adderRequest", "adderReply", qos,
                                                    UXR_REPLACE);
    } else {
        requests[1] = uxr_buffer_create_requester_bin(&node->session, node->out, endpoint, participant, "adder",
                                                      "AddRequest", "AddReply", "adderRequest", "adderReply", qos,
                                                      UXR_REPLACE);
    }
    if (!node_statuses_ok(node, requests, 2, replier ? "replier" : "requester")) {
        return false;
    }
    uxrDeliveryControl control = {UXR_MAX_SAMPLES_UNLIMITED, 0, 0, 0};
    uxr_buffer_request_data(&node->session, node->out, endpoint, node->in, &control);
    return uxr_run_session_until_confirm_delivery(&node->session, 1000);
}

int main(int argc, char** argv) {
    if (argc < 3) {
        return 2;
    }
    static Node replier, requester;
    if (!node_start(&replier, argv[1], argv[2], 0xADD00001) || !node_start(&requester, argv[1], argv[2], 0xADD00002)) {
        return 1;
    }
    replier_out = replier.out;
    uxr_set_request_callback(&replier.session, on_request, NULL);
    uxr_set_reply_callback(&requester.session, on_reply, NULL);
    if (!create(&replier, true) || !create(&requester, false)) {
        return 1;
    }
    for (int waited = 0; argc > 3 && waited < atoi(argv[3]); waited += 10) {
        uxr_run_session_time(&replier.session, 5);
        uxr_run_session_time(&requester.session, 5);
    }
    uxrObjectId requester_id = uxr_object_id(0x01, UXR_REQUESTER_ID);
    for (int i = 0; i < REQUESTS; i++) {
        uint8_t request[8];
        ucdrBuffer ub;
        ucdr_init_buffer(&ub, request, sizeof(request));
        ucdr_serialize_int32_t(&ub, 10 * i);
        ucdr_serialize_int32_t(&ub, i);
        request_ids[i] = uxr_buffer_request(&requester.session, requester.out, requester_id, request, sizeof(request));
        if (request_ids[i] == 0) {
            return 1;
        }
    }
    uxr_flash_output_streams(&requester.session);
    for (int round = 0; round < 200 && replies < REQUESTS; round++) {
        uxr_run_session_time(&replier.session, 5);
        uxr_run_session_time(&requester.session, 5);
    }
    printf("%d of %d replies, %s\n", replies, REQUESTS, replies_right ? "right" : "WRONG");
    node_stop(&requester);
    node_stop(&replier);
    return replies == REQUESTS && replies_right ? 0 : 1;
}
