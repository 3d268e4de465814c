/* eProsima's API beyond the seed's text, as micro-ROS, PX4 and eProsima's examples use it: every public header
 * path of eProsima's tree; the session's named fields and their effects (info, comm, streams, time_offset
 * moving uxr_epoch_nanos, synchronized, on_pong_flag set by a ping in the session, on_data_flag); the UDP
 * transport's descriptor polling readable when the agent's answer waits; the xrce_types.h serializers against
 * eProsima's bytes; locators; object ids from and to the wire; the multithread macros.
 * Usage: eprosima_api IP PORT (our agent, -m ced). */
#include <uxr/client/client.h>
#include <uxr/client/config.h>
#include <uxr/client/defines.h>
#include <uxr/client/transport.h>
#include <uxr/client/visibility.h>
#include <uxr/client/core/communication/communication.h>
#include <uxr/client/core/session/common_create_entities.h>
#include <uxr/client/core/session/create_entities_bin.h>
#include <uxr/client/core/session/create_entities_ref.h>
#include <uxr/client/core/session/create_entities_xml.h>
#include <uxr/client/core/session/object_id.h>
#include <uxr/client/core/session/read_access.h>
#include <uxr/client/core/session/session.h>
#include <uxr/client/core/session/session_info.h>
#include <uxr/client/core/session/time_sync.h>
#include <uxr/client/core/session/write_access.h>
#include <uxr/client/core/session/stream/input_best_effort_stream.h>
#include <uxr/client/core/session/stream/input_reliable_stream.h>
#include <uxr/client/core/session/stream/output_best_effort_stream.h>
#include <uxr/client/core/session/stream/output_reliable_stream.h>
#include <uxr/client/core/session/stream/reliable_stream.h>
#include <uxr/client/core/session/stream/seq_num.h>
#include <uxr/client/core/session/stream/stream_id.h>
#include <uxr/client/core/session/stream/stream_storage.h>
#include <uxr/client/core/type/xrce_types.h>
#include <uxr/client/profile/discovery/discovery.h>
#include <uxr/client/profile/multithread/multithread.h>
#include <uxr/client/profile/transport/can/can_transport.h>
#include <uxr/client/profile/transport/can/can_transport_posix.h>
#include <uxr/client/profile/transport/custom/custom_transport.h>
#include <uxr/client/profile/transport/ip/ip.h>
#include <uxr/client/profile/transport/ip/tcp/tcp_transport.h>
#include <uxr/client/profile/transport/ip/tcp/tcp_transport_posix.h>
#include <uxr/client/profile/transport/ip/udp/udp_transport.h>
#include <uxr/client/profile/transport/ip/udp/udp_transport_posix.h>
#include <uxr/client/profile/transport/serial/serial_transport.h>
#include <uxr/client/profile/transport/serial/serial_transport_platform.h>
#include <uxr/client/profile/transport/serial/serial_transport_posix.h>
#include <uxr/client/profile/transport/stream_framing/stream_framing_protocol.h>
#include <uxr/client/util/ping.h>
#include <uxr/client/util/time.h>
#include <ucdr/config.h>
#include <ucdr/microcdr.h>
#include <ucdr/visibility.h>

#include <fcntl.h>
#include <poll.h>
#include <string.h>

#include "check.h"

#if !defined(UCLIENT_PROFILE_UDP) || !defined(UCLIENT_PROFILE_CUSTOM_TRANSPORT) || \
    UXR_CONFIG_UDP_TRANSPORT_MTU != 512 || UXR_CLIENT_VERSION_MAJOR != 3 || MICROCDR_VERSION_MAJOR != 2
#error "config.h does not describe this build"
#endif

static uxrUDPTransport transport;
static uxrSession session; /* static: its fields start zeroed, as a program's global would */
static uint8_t output[UXR_CONFIG_UDP_TRANSPORT_MTU * 4];
static uint8_t input[UXR_CONFIG_UDP_TRANSPORT_MTU * 4];

static int time_calls = 0;
static int64_t seen_transmit = 0, seen_received = 0;
/* PX4's time callback: it keeps its own offset estimate and writes it into the session. */
static void on_time(uxrSession* s, int64_t current, int64_t transmit, int64_t received, int64_t originate, void* args) {
    (void)current; (void)originate;
    time_calls++;
    seen_transmit = transmit;
    seen_received = received;
    s->time_offset = *(int64_t*)args;
}

static int topics = 0;
static void on_topic(uxrSession* s, uxrObjectId object_id, uint16_t request_id, uxrStreamId stream_id,
                     struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)s; (void)object_id; (void)request_id; (void)stream_id; (void)ub; (void)length; (void)args;
    topics++;
}

static void serializers(void) {
    SampleIdentity id;
    for (int i = 0; i < 12; i++) {
        id.writer_guid.guidPrefix.data[i] = (uint8_t)i;
    }
    id.writer_guid.entityId.entityKey[0] = 12;
    id.writer_guid.entityId.entityKey[1] = 13;
    id.writer_guid.entityId.entityKey[2] = 14;
    id.writer_guid.entityId.entityKind = 15;
    id.sequence_number.high = -2;
    id.sequence_number.low = 0x01020304;
    uint8_t buf[32];
    ucdrBuffer ub;
    ucdr_init_buffer(&ub, buf, sizeof(buf));
    CHECK(uxr_serialize_SampleIdentity(&ub, &id) && ucdr_buffer_length(&ub) == 24);
    /* eProsima's bytes: the GUID as it is, then high and low in the buffer's (little) endianness */
    static const uint8_t expected[24] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15,
                                         0xFE, 0xFF, 0xFF, 0xFF, 0x04, 0x03, 0x02, 0x01};
    CHECK(memcmp(buf, expected, 24) == 0);
    SampleIdentity back;
    memset(&back, 0, sizeof(back));
    ucdr_init_buffer(&ub, buf, 24);
    CHECK(uxr_deserialize_SampleIdentity(&ub, &back) && memcmp(&back, &id, sizeof(id)) == 0);
    ucdr_init_buffer(&ub, buf, 23); /* one byte short: fails */
    CHECK(!uxr_deserialize_SampleIdentity(&ub, &back) && ub.error);
    /* big endian */
    ucdr_init_buffer_origin_offset_endian(&ub, buf, sizeof(buf), 0, 0, UCDR_BIG_ENDIANNESS);
    CHECK(uxr_serialize_SequenceNumber_t(&ub, &id.sequence_number) && buf[0] == 0xFF && buf[3] == 0xFE &&
          buf[4] == 0x01 && buf[7] == 0x04);

    /* a medium (IPv4) locator: format, 4 address bytes, padding to 2, the port */
    TransportLocator l;
    CHECK(uxr_ip_to_locator("192.168.1.7", 8888, UXR_IPv4, &l) && l.format == ADDRESS_FORMAT_MEDIUM &&
          l._.medium_locator.address[0] == 192 && l._.medium_locator.address[3] == 7 &&
          l._.medium_locator.locator_port == 8888);
    ucdr_init_buffer(&ub, buf, sizeof(buf));
    CHECK(uxr_serialize_TransportLocator(&ub, &l) && ucdr_buffer_length(&ub) == 8);
    CHECK(buf[0] == 1 && buf[1] == 192 && buf[4] == 7 && buf[6] == (8888 & 0xFF) && buf[7] == (8888 >> 8));
    char ip[64];
    uint16_t port = 0;
    uxrIpProtocol protocol = UXR_IPv6;
    CHECK(uxr_locator_to_ip(&l, ip, sizeof(ip), &port, &protocol) && strcmp(ip, "192.168.1.7") == 0 &&
          port == 8888 && protocol == UXR_IPv4);
    CHECK(uxr_ip_to_locator("::1", 7400, UXR_IPv6, &l) && l.format == ADDRESS_FORMAT_LARGE &&
          l._.large_locator.address[15] == 1 && l._.large_locator.locator_port == 7400);

    Time_t t = {-5, 999999999u}, t2 = {0, 0};
    ucdr_init_buffer(&ub, buf, sizeof(buf));
    CHECK(uxr_serialize_Time_t(&ub, &t));
    ucdr_init_buffer(&ub, buf, sizeof(buf));
    CHECK(uxr_deserialize_Time_t(&ub, &t2) && t2.seconds == -5 && t2.nanoseconds == 999999999u);

    /* object ids on the wire: 12 bits of id, 4 of kind */
    uint8_t raw[2];
    uxr_object_id_to_raw(uxr_object_id(0x123, UXR_DATAWRITER_ID), raw);
    CHECK(raw[0] == 0x12 && raw[1] == 0x35);
    uxrObjectId o = uxr_object_id_from_raw(raw);
    CHECK(o.id == 0x123 && o.type == UXR_DATAWRITER_ID);
}

int main(int argc, char** argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s IP PORT\n", argv[0]);
        return 2;
    }
    serializers();
    int64_t before = uxr_millis();
    CHECK(uxr_nanos() / 1000000 >= before && before > 1600000000000LL);

    CHECK(uxr_init_udp_transport(&transport, UXR_IPv4, argv[1], argv[2]));
    /* the descriptor programs poll (PX4: platform.poll_fd.fd) */
    CHECK(transport.platform.poll_fd.fd >= 0 && transport.platform.poll_fd.events == POLLIN);
    CHECK(transport.comm.mtu == UXR_CONFIG_UDP_TRANSPORT_MTU && transport.comm.send_msg && transport.comm.recv_msg);
    CHECK(uxr_ping_agent_attempts(&transport.comm, 1000, 3));

    uxr_init_session(&session, &transport.comm, 0xAABBCCDD);
    CHECK(session.comm == &transport.comm && session.info.id == 0x81 && session.info.key[0] == 0xAA &&
          session.info.key[3] == 0xDD && session.info.last_requested_status == UXR_STATUS_NONE);
    CHECK(!session.synchronized && session.time_offset == 0 && session.on_pong_flag == NO_PONG_STATUS);
    CHECK(uxr_create_session(&session) && session.info.last_requested_status == UXR_STATUS_OK);
    uxrStreamId out = uxr_create_output_reliable_stream(&session, output, sizeof(output), 4);
    uxrStreamId in = uxr_create_input_reliable_stream(&session, input, sizeof(input), 4);
    uxrStreamId best = uxr_create_input_best_effort_stream(&session);
    CHECK(session.streams.output_reliable_size == 1 && session.streams.output_reliable[0].base.buffer == output &&
          session.streams.output_reliable[0].base.history == 4 && session.streams.input_reliable_size == 1 &&
          session.streams.input_best_effort_size == 1 && best.type == UXR_BEST_EFFORT_STREAM);

    /* the callbacks are the session's fields */
    uxr_set_topic_callback(&session, on_topic, &topics);
    CHECK(session.on_topic == on_topic && session.on_topic_args == &topics);

    /* time: without a callback the library computes the offset (same host: near 0) */
    CHECK(uxr_sync_session(&session, 1000) && session.synchronized);
    CHECK(session.time_offset > -100000000LL && session.time_offset < 100000000LL);
    /* with PX4's callback, the program's offset is what uxr_epoch_nanos subtracts */
    int64_t px4_offset = 5000000000LL;
    uxr_set_time_callback(&session, on_time, &px4_offset);
    CHECK(uxr_sync_session(&session, 1000) && session.synchronized && time_calls == 1);
    /* eProsima's argument order: the agent's receive time, then its transmit time (not earlier) */
    CHECK(seen_received >= seen_transmit && seen_transmit > 0);
    CHECK(session.time_offset == px4_offset);
    int64_t epoch = uxr_epoch_nanos(&session), local = uxr_nanos();
    CHECK(local - epoch > 4900000000LL && local - epoch < 5100000000LL);
    /* written directly, it moves the epoch too */
    session.time_offset = -2000000000LL;
    epoch = uxr_epoch_millis(&session);
    CHECK(epoch - uxr_millis() > 1900 && epoch - uxr_millis() < 2100);
    session.time_offset = 0;

    /* ping in the session: the flag goes to PONG_IN_SESSION_STATUS */
    session.on_pong_flag = 0;
    CHECK(uxr_ping_agent_session(&session, 1000, 1) && session.on_pong_flag == PONG_IN_SESSION_STATUS);
    /* PX4's way: clear it, ping without waiting, and the descriptor polls readable with the agent's answer;
     * the next run sets the flag */
    session.on_pong_flag = 0;
    uxr_ping_agent_session(&session, 0, 1);
    struct pollfd pfd = transport.platform.poll_fd;
    int ready = 0;
    for (int i = 0; i < 10 && session.on_pong_flag == 0 && ready == 0; i++) {
        ready = poll(&pfd, 1, 100);
    }
    CHECK(session.on_pong_flag == PONG_IN_SESSION_STATUS || (ready == 1 && (pfd.revents & POLLIN)));
    for (int i = 0; i < 20 && session.on_pong_flag == 0; i++) {
        uxr_run_session_timeout(&session, 10);
    }
    CHECK(session.on_pong_flag == PONG_IN_SESSION_STATUS);

    /* a writer and a reader of the same topic in this session: data sets on_data_flag */
    uxrObjectId participant = uxr_object_id(1, UXR_PARTICIPANT_ID), topic = uxr_object_id(1, UXR_TOPIC_ID);
    uxrObjectId publisher = uxr_object_id(1, UXR_PUBLISHER_ID), subscriber = uxr_object_id(1, UXR_SUBSCRIBER_ID);
    uxrObjectId writer = uxr_object_id(1, UXR_DATAWRITER_ID), reader = uxr_object_id(1, UXR_DATAREADER_ID);
    uxrQoS_t qos = {UXR_DURABILITY_VOLATILE, UXR_RELIABILITY_RELIABLE, UXR_HISTORY_KEEP_LAST, 4};
    uint16_t requests[6];
    requests[0] = uxr_buffer_create_participant_bin(&session, out, participant, 0, "eprosima_api", UXR_REPLACE);
    requests[1] = uxr_buffer_create_topic_bin(&session, out, topic, participant, "rt/api", "std_msgs::msg::dds_::Int32_", UXR_REPLACE);
    requests[2] = uxr_buffer_create_publisher_bin(&session, out, publisher, participant, UXR_REPLACE);
    requests[3] = uxr_buffer_create_subscriber_bin(&session, out, subscriber, participant, UXR_REPLACE);
    requests[4] = uxr_buffer_create_datawriter_bin(&session, out, writer, publisher, topic, qos, UXR_REPLACE);
    requests[5] = uxr_buffer_create_datareader_bin(&session, out, reader, subscriber, topic, qos, UXR_REPLACE);
    CHECK(session.info.last_request_id == requests[5]);
    uint8_t status[6];
    CHECK(uxr_run_session_until_all_status(&session, 3000, requests, status, 6));
    CHECK(session.request_list == NULL && session.request_status_list_size == 0);
    uxrDeliveryControl control = {0};
    control.max_samples = UXR_MAX_SAMPLES_UNLIMITED;
    uxr_buffer_request_data(&session, out, reader, in, &control);
    uxr_run_session_until_confirm_delivery(&session, 1000);
    ucdrBuffer ub;
    UXR_LOCK_STREAM_ID(&session, out);
    CHECK(uxr_prepare_output_stream(&session, out, writer, &ub, 8) != UXR_INVALID_REQUEST_ID);
    ucdr_serialize_uint32_t(&ub, 0x00000100); /* encapsulation: CDR little endian */
    ucdr_serialize_int32_t(&ub, 42);
    UXR_UNLOCK_STREAM_ID(&session, out);
    session.on_data_flag = false;
    CHECK(uxr_run_session_until_data(&session, 2000) && session.on_data_flag && topics == 1);

    CHECK(uxr_delete_session(&session) && session.info.last_requested_status == UXR_STATUS_OK);

    /* PX4 makes the socket non-blocking: a ping still waits for the answer (it used to fail at once) */
    int flags = fcntl(transport.platform.poll_fd.fd, F_GETFL, 0);
    CHECK(fcntl(transport.platform.poll_fd.fd, F_SETFL, flags | O_NONBLOCK) == 0);
    CHECK(uxr_ping_agent_attempts(&transport.comm, 1000, 1));
    CHECK(uxr_close_udp_transport(&transport));
    CHECK(!uxr_delete_session_retries(&session, 0)); /* no attempt at all, as eProsima's */

    /* nobody at the port (ICMP port unreachable): each attempt still waits its timeout, as eProsima's */
    uxrUDPTransport nobody;
    CHECK(uxr_init_udp_transport(&nobody, UXR_IPv4, "127.0.0.1", "9"));
    int64_t t0 = uxr_millis();
    CHECK(!uxr_ping_agent_attempts(&nobody.comm, 150, 2));
    CHECK(uxr_millis() - t0 >= 290);
    /* a session ping nobody answers returns after attempts x timeout (it took twice that) */
    uxrSession lonely;
    uxr_init_session(&lonely, &nobody.comm, 0x10E1);
    t0 = uxr_millis();
    CHECK(!uxr_ping_agent_session(&lonely, 400, 1) && lonely.on_pong_flag == NO_PONG_STATUS);
    int64_t took = uxr_millis() - t0;
    CHECK(took >= 390 && took < 750);
    uxr_delete_session_retries(&lonely, 0);
    CHECK(uxr_close_udp_transport(&nobody));
    printf("eProsima API: %d failed checks\n", failures);
    return failures == 0 ? 0 : 1;
}
