// The client API from C++, the way PX4's uxrce_dds_client uses it: transports and sessions allocated with
// `new` (value-initialised), uxrQoS_t filled with designated initializers in eProsima's field order, a time
// callback writing session->time_offset, the pong flag read and cleared, the socket polled, a participant by
// XML and entities in binary, a sample written through uxr_prepare_output_stream and read back, a replier
// answering with the 6-argument uxr_buffer_reply. Usage: eprosima_api_cpp IP PORT (our agent, -m ced).
#include <uxr/client/client.h>
#include <uxr/client/util/ping.h>
#include <ucdr/microcdr.h>

#include <poll.h>
#include <cstdio>
#include <cstring>

static int failures = 0;
#define CHECK(cond)                                                                  \
    do {                                                                             \
        if (!(cond)) {                                                               \
            std::fprintf(stderr, "%s:%d: check failed: %s\n", __FILE__, __LINE__, #cond); \
            failures++;                                                              \
        }                                                                            \
    } while (0)

struct Timesync {
    int64_t offset_us = -1500000;  // PX4's estimate: microseconds, agent minus local
    int updates = 0;
};

static void on_time(uxrSession* session, int64_t now, int64_t transmit, int64_t received, int64_t originate,
                    void* args) {
    (void)now; (void)transmit; (void)received; (void)originate;
    auto* ts = static_cast<Timesync*>(args);
    ts->updates++;
    session->time_offset = -ts->offset_us * 1000;
}

struct Node {
    uxrSession session{};
    int samples = 0;
    int32_t last = 0;
    int requests = 0;
    SampleIdentity last_request{};
};

static void on_topic(uxrSession*, uxrObjectId object_id, uint16_t, uxrStreamId, ucdrBuffer* ub, uint16_t,
                     void* args) {
    auto* node = static_cast<Node*>(args);
    uint32_t header = 0;
    if (object_id.type == UXR_DATAREADER_ID && ucdr_deserialize_uint32_t(ub, &header) &&
        ucdr_deserialize_int32_t(ub, &node->last)) {
        node->samples++;
    }
}

static void on_request(uxrSession*, uxrObjectId, uint16_t, SampleIdentity* sample_id, ucdrBuffer*, uint16_t,
                       void* args) {
    auto* node = static_cast<Node*>(args);
    std::memcpy(&node->last_request, sample_id, sizeof(node->last_request));
    node->requests++;
}

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: %s IP PORT\n", argv[0]);
        return 2;
    }
    auto* transport = new uxrUDPTransport();
    CHECK(uxr_init_udp_transport(transport, UXR_IPv4, argv[1], argv[2]));
    int fd = transport->platform.poll_fd.fd;
    CHECK(fd >= 0);
    uxrCommunication* comm = &transport->comm;
    CHECK(uxr_ping_agent_attempts(comm, 1000, 1));

    auto* node = new Node();
    uxrSession* session = &node->session;
    uxr_init_session(session, comm, 0x0C0FFEE0);
    Timesync timesync;
    uxr_set_time_callback(session, on_time, &timesync);
    uxr_set_topic_callback(session, on_topic, node);
    uxr_set_request_callback(session, on_request, node);
    CHECK(uxr_create_session(session));

    static uint8_t out_buf[UXR_CONFIG_UDP_TRANSPORT_MTU * 4], in_buf[UXR_CONFIG_UDP_TRANSPORT_MTU * 4];
    static uint8_t be_buf[2048];
    uxrStreamId reliable_out = uxr_create_output_reliable_stream(session, out_buf, sizeof(out_buf), 4);
    uxrStreamId best_effort_out = uxr_create_output_best_effort_stream(session, be_buf, sizeof(be_buf));
    uxrStreamId reliable_in = uxr_create_input_reliable_stream(session, in_buf, sizeof(in_buf), 4);
    uxrStreamId best_effort_in = uxr_create_input_best_effort_stream(session);

    CHECK(uxr_sync_session(session, 1000) && timesync.updates == 1);
    CHECK(session->time_offset == 1500000000LL);
    int64_t diff = uxr_nanos() - uxr_epoch_nanos(session);
    CHECK(diff > 1400000000LL && diff < 1600000000LL);

    const char* participant_xml =
        "<dds><participant><rtps><name>px4_micro_xrce_dds</name></rtps></participant></dds>";
    uxrObjectId participant = uxr_object_id(0x01, UXR_PARTICIPANT_ID);
    uint16_t participant_req =
        uxr_buffer_create_participant_xml(session, reliable_out, participant, 0, participant_xml, UXR_REPLACE);
    uint8_t status = 0;
    CHECK(uxr_run_session_until_all_status(session, 1000, &participant_req, &status, 1));

    // as PX4's dds_topics.h: a best-effort writer and a reader of the same topic
    uxrObjectId topic = uxr_object_id(7, UXR_TOPIC_ID);
    uxrObjectId publisher = uxr_object_id(7, UXR_PUBLISHER_ID);
    uxrObjectId subscriber = uxr_object_id(7, UXR_SUBSCRIBER_ID);
    uxrObjectId writer = uxr_object_id(7, UXR_DATAWRITER_ID);
    uxrObjectId reader = uxr_object_id(7 + 2048, UXR_DATAREADER_ID);
    uxrQoS_t writer_qos = {
        .durability = UXR_DURABILITY_TRANSIENT_LOCAL,
        .reliability = UXR_RELIABILITY_BEST_EFFORT,
        .history = UXR_HISTORY_KEEP_LAST,
        .depth = 0,
    };
    uint16_t queue_depth = 5;
    uxrQoS_t reader_qos = {
        .durability = UXR_DURABILITY_VOLATILE,
        .reliability = UXR_RELIABILITY_BEST_EFFORT,
        .history = UXR_HISTORY_KEEP_LAST,
        .depth = queue_depth,
    };
    uint16_t requests[5] = {
        uxr_buffer_create_topic_bin(session, reliable_out, topic, participant, "rt/fmu/out/sensor",
                                    "px4_msgs::msg::dds_::Sensor_", UXR_REPLACE),
        uxr_buffer_create_publisher_bin(session, reliable_out, publisher, participant, UXR_REPLACE),
        uxr_buffer_create_subscriber_bin(session, reliable_out, subscriber, participant, UXR_REPLACE),
        uxr_buffer_create_datawriter_bin(session, reliable_out, writer, publisher, topic, writer_qos, UXR_REPLACE),
        uxr_buffer_create_datareader_bin(session, reliable_out, reader, subscriber, topic, reader_qos, UXR_REPLACE),
    };
    uint8_t statuses[5] = {};
    CHECK(uxr_run_session_until_all_status(session, 1000, requests, statuses, 5));
    uxrDeliveryControl delivery_control{};
    delivery_control.max_samples = UXR_MAX_SAMPLES_UNLIMITED;
    uxr_buffer_request_data(session, reliable_out, reader, best_effort_in, &delivery_control);

    // a replier, answered with the 6-argument uxr_buffer_reply, and a requester in the same session
    const uxrQoS_t qos = {
        .durability = UXR_DURABILITY_PERSISTENT,
        .reliability = UXR_RELIABILITY_RELIABLE,
        .history = UXR_HISTORY_KEEP_LAST,
        .depth = 1,
    };
    uxrObjectId replier = uxr_object_id(3 + 2048, UXR_REPLIER_ID);
    uint16_t replier_req = uxr_buffer_create_replier_bin(
        session, reliable_out, replier, participant, "vehicle_command", "px4_msgs::srv::dds_::VehicleCommand_Request_",
        "px4_msgs::srv::dds_::VehicleCommand_Response_", "rq/fmu/vehicle_commandRequest", "rr/fmu/vehicle_commandReply",
        qos, UXR_REPLACE);
    CHECK(uxr_run_session_until_all_status(session, 1000, &replier_req, &status, 1));
    uxr_buffer_request_data(session, reliable_out, replier, reliable_in, &delivery_control);
    uxr_run_session_until_confirm_delivery(session, 1000);

    // a sample into the best-effort stream, then the socket polls readable with the agent's delivery
    for (int32_t value = 1; value <= 3; value++) {
        ucdrBuffer ub;
        if (uxr_prepare_output_stream(session, best_effort_out, writer, &ub, 8) != UXR_INVALID_REQUEST_ID) {
            ucdr_serialize_uint32_t(&ub, 0x00000100);
            ucdr_serialize_int32_t(&ub, value);
        }
        uxr_flash_output_streams(session);
        pollfd fds[1] = {{fd, POLLIN, 0}};
        CHECK(poll(fds, 1, 1000) == 1 && (fds[0].revents & POLLIN));
        for (int i = 0; i < 10 && node->samples < value; i++) {
            uxr_run_session_timeout(session, 10);
        }
    }
    CHECK(node->samples == 3 && node->last == 3);

    // PX4's liveness check: clear the flag, ping without waiting, read the flag after the next runs
    session->on_pong_flag = 0;
    uxr_ping_agent_session(session, 0, 1);
    for (int i = 0; i < 50 && session->on_pong_flag != 1; i++) {
        uxr_run_session_timeout(session, 10);
    }
    CHECK(session->on_pong_flag == 1);

    uint8_t reply[4] = {1, 2, 3, 4};
    SampleIdentity identity{};
    identity.sequence_number.low = 7;
    CHECK(uxr_buffer_reply(session, reliable_out, replier, &identity, reply, sizeof(reply)) != UXR_INVALID_REQUEST_ID);
    uxr_run_session_until_confirm_delivery(session, 1000);

    CHECK(uxr_delete_session_retries(session, 1));
    uxr_close_udp_transport(transport);
    delete node;
    delete transport;
    std::printf("C++ (PX4's use): %d failed checks\n", failures);
    return failures == 0 ? 0 : 1;
}
