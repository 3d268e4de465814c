/* The boundary without an agent: null pointers, sessions never initialised, unknown streams, too-small
 * buffers, a session whose agent never answered. Every call returns the seed's error value. */
#include <uxr/client/client.h>

#include <stdio.h>
#include <string.h>

#include "check.h"

static uxrSession never_initialised; /* zeroed storage */

int main(void) {
    uxrObjectId participant = uxr_object_id(1, UXR_PARTICIPANT_ID);
    uxrStreamId reliable = uxr_stream_id(0, UXR_RELIABLE_STREAM, UXR_OUTPUT_STREAM);
    uxrStreamId best_effort = uxr_stream_id(0, UXR_BEST_EFFORT_STREAM, UXR_OUTPUT_STREAM);
    ucdrBuffer ub;
    uint8_t data[8] = {0};
    uint8_t memory[4096];

    /* identifiers */
    CHECK(reliable.raw == 0x80 && reliable.index == 0 && reliable.type == UXR_RELIABLE_STREAM);
    CHECK(best_effort.raw == 0x01 && best_effort.direction == UXR_OUTPUT_STREAM);
    CHECK(uxr_stream_id_from_raw(0x81, UXR_INPUT_STREAM).index == 1);
    CHECK(participant.id == 1 && participant.type == UXR_PARTICIPANT_ID);

    /* null and never-initialised sessions */
    CHECK(!uxr_create_session(NULL));
    CHECK(!uxr_create_session(&never_initialised));
    CHECK(!uxr_delete_session(&never_initialised));
    CHECK(!uxr_run_session_time(NULL, 0));
    CHECK(uxr_buffer_create_participant_xml(NULL, reliable, participant, 0, "<dds/>", UXR_REPLACE) == UXR_INVALID_REQUEST_ID);
    CHECK(uxr_buffer_create_participant_xml(&never_initialised, reliable, participant, 0, "<dds/>", UXR_REPLACE) == UXR_INVALID_REQUEST_ID);
    CHECK(uxr_buffer_topic(&never_initialised, reliable, participant, data, sizeof(data)) == 0);
    CHECK(uxr_prepare_output_stream(&never_initialised, reliable, participant, &ub, 4) == UXR_INVALID_REQUEST_ID);
    CHECK(!ucdr_serialize_uint32_t(&ub, 1)); /* the buffer it left is empty */
    CHECK(uxr_create_output_reliable_stream(&never_initialised, memory, sizeof(memory), 8).type == UXR_NONE_STREAM);
    CHECK(uxr_epoch_millis(NULL) == 0);
    CHECK(!uxr_ping_agent(NULL, 10));
    uxr_init_session(NULL, NULL, 1);
    uxr_flash_output_streams(NULL);
    uxr_set_topic_callback(NULL, NULL, NULL);

    /* transports: bad arguments */
    uxrUDPTransport udp;
    CHECK(!uxr_init_udp_transport(NULL, UXR_IPv4, "127.0.0.1", "8888"));
    CHECK(!uxr_init_udp_transport(&udp, UXR_IPv4, NULL, "8888"));
    CHECK(!uxr_init_udp_transport(&udp, UXR_IPv4, "127.0.0.1", "not a port"));
    uxrCANTransport can;
    CHECK(!uxr_init_can_transport(&can, "no-such-can0", 0x123));
    CHECK(!uxr_init_can_transport(&can, "vcan0", 0x20000000)); /* not a 29-bit identifier */
    CHECK(!uxr_init_can_transport(NULL, "vcan0", 0x123));
    uxrCustomTransport custom;
    memset(&custom, 0, sizeof(custom));
    CHECK(!uxr_init_custom_transport(&custom, NULL)); /* no callbacks set */

    /* a session whose agent does not exist (a port nobody listens on) */
    CHECK(uxr_init_udp_transport(&udp, UXR_IPv4, "127.0.0.1", "9"));
    static uxrSession session;
    uxr_init_session(&session, &udp.comm, 0x0BAD);
    uxrStreamId out = uxr_create_output_reliable_stream(&session, memory, sizeof(memory), 8);
    CHECK(out.type == UXR_RELIABLE_STREAM);
    /* a history that does not divide the buffer, and the stream limit */
    CHECK(uxr_create_output_reliable_stream(&session, memory, 1000, 3).type == UXR_NONE_STREAM);
    CHECK(uxr_create_output_best_effort_stream(&session, NULL, 512).type == UXR_NONE_STREAM);
    /* unknown streams */
    uxrStreamId unknown = uxr_stream_id(3, UXR_RELIABLE_STREAM, UXR_OUTPUT_STREAM);
    CHECK(uxr_buffer_create_participant_xml(&session, unknown, participant, 0, "<dds/>", UXR_REPLACE) == UXR_INVALID_REQUEST_ID);
    CHECK(uxr_buffer_topic(&session, best_effort, participant, data, sizeof(data)) == 0);
    /* a sample larger than a message, prepared in place */
    CHECK(uxr_prepare_output_stream(&session, out, participant, &ub, 10000) == UXR_INVALID_REQUEST_ID);
    /* a request that fits is accepted (it waits in the stream) */
    CHECK(uxr_buffer_create_participant_xml(&session, out, participant, 0, "<dds/>", UXR_REPLACE) != UXR_INVALID_REQUEST_ID);
    /* null strings and lists */
    CHECK(uxr_buffer_create_participant_xml(&session, out, participant, 0, NULL, UXR_REPLACE) == UXR_INVALID_REQUEST_ID);
    CHECK(uxr_buffer_topic(&session, out, participant, NULL, 4) == 0);
    CHECK(!uxr_run_session_until_all_status(&session, 0, NULL, NULL, 2));
    CHECK(!uxr_create_session_retries(&session, 1)); /* nobody answers */
    CHECK(uxr_close_udp_transport(&udp));
    CHECK(!uxr_close_udp_transport(&udp)); /* already closed */

    printf("%s\n", failures == 0 ? "all checks passed" : "FAILED");
    return failures == 0 ? 0 : 1;
}
