/* Footprint probe on the board: eProsima's PublishHelloWorld written against client.h (as
 * crates/xrce-client-c/footprint/publisher.c) with the board's UART as a framed custom transport: one reliable
 * output and one reliable input stream of 4 x 512 B, entities by XML, ten HelloWorld samples serialized with
 * ucdr_* in place, session deleted. scripts/c-footprint.sh subtracts fp_empty.c. Runs against an agent on the
 * UART's line and prints its peak stack. */
#include <uxr/client/client.h>
#include <ucdr/microcdr.h>

#include "board.h"

#define HISTORY 4
#define BUFFER_SIZE (UXR_CONFIG_CUSTOM_TRANSPORT_MTU * HISTORY)

static uxrCustomTransport transport;
static uxrSession session;
static uint8_t output_reliable_stream_buffer[BUFFER_SIZE];
static uint8_t input_reliable_stream_buffer[BUFFER_SIZE];

int main(void) {
    board_init();
    uxr_set_custom_transport_callbacks(&transport, true, uart_transport_open, uart_transport_close,
                                       uart_transport_write, uart_transport_read);
    if (!uxr_init_custom_transport(&transport, NULL)) {
        return 1;
    }
    uxr_init_session(&session, &transport.comm, 0xAAAABBBB);
    if (!uxr_create_session(&session)) {
        board_print("no agent\n");
        return 1;
    }
    uxrStreamId out = uxr_create_output_reliable_stream(&session, output_reliable_stream_buffer, BUFFER_SIZE, HISTORY);
    uxr_create_input_reliable_stream(&session, input_reliable_stream_buffer, BUFFER_SIZE, HISTORY);

    uxrObjectId participant_id = uxr_object_id(0x01, UXR_PARTICIPANT_ID);
    uint16_t participant_req = uxr_buffer_create_participant_xml(&session, out, participant_id, 0,
        "<dds><participant><rtps><name>default_xrce_participant</name></rtps></participant></dds>", UXR_REPLACE);
    uxrObjectId topic_id = uxr_object_id(0x01, UXR_TOPIC_ID);
    uint16_t topic_req = uxr_buffer_create_topic_xml(&session, out, topic_id, participant_id,
        "<dds><topic><name>HelloWorldTopic</name><dataType>HelloWorld</dataType></topic></dds>", UXR_REPLACE);
    uxrObjectId publisher_id = uxr_object_id(0x01, UXR_PUBLISHER_ID);
    uint16_t publisher_req = uxr_buffer_create_publisher_xml(&session, out, publisher_id, participant_id, "", UXR_REPLACE);
    uxrObjectId datawriter_id = uxr_object_id(0x01, UXR_DATAWRITER_ID);
    uint16_t datawriter_req = uxr_buffer_create_datawriter_xml(&session, out, datawriter_id, publisher_id,
        "<dds><data_writer><topic><kind>NO_KEY</kind><name>HelloWorldTopic</name><dataType>HelloWorld</dataType>"
        "</topic></data_writer></dds>", UXR_REPLACE);
    uint8_t status[4];
    uint16_t requests[4] = {participant_req, topic_req, publisher_req, datawriter_req};
    if (!uxr_run_session_until_all_status(&session, 1000, requests, status, 4)) {
        board_print("entities refused\n");
        return 1;
    }
    for (uint32_t count = 0; count < 10; count++) {
        ucdrBuffer ub;
        uxr_prepare_output_stream(&session, out, datawriter_id, &ub, 4 + 4 + 17);
        ucdr_serialize_uint32_t(&ub, count);
        ucdr_serialize_string(&ub, "Hello DDS world!");
        uxr_run_session_time(&session, 100);
    }
    bool deleted = uxr_delete_session(&session);
    board_print(deleted ? "published 10 samples, session deleted\n" : "session not deleted\n");
    board_report("peak stack: ", (uint32_t)board_stack_used());
    return deleted ? 0 : 1;
}
