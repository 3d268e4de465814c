/* Footprint probe: eProsima's PublishHelloWorld written against client.h, on the no_std library with the
 * platform's UDP socket as a custom transport (as firmware brings its own network stack), one reliable output
 * and one reliable input stream of 4 x 512 B, entities by XML, HelloWorld samples serialized with ucdr_* in
 * place. scripts/c-footprint.sh builds it and subtracts empty.c. Usage: publisher IP PORT [SAMPLES]. */
#include "../tests/c/udp_custom.h"
#include "../tests/c/hello_world.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define HISTORY 4
#define BUFFER_SIZE (UXR_CONFIG_CUSTOM_TRANSPORT_MTU * HISTORY)

static uxrCustomTransport transport;
static uxrSession session;
static uint8_t output_reliable_stream_buffer[BUFFER_SIZE];
static uint8_t input_reliable_stream_buffer[BUFFER_SIZE];

int main(int argc, char** argv) {
    if (argc < 3) {
        printf("usage: %s IP PORT [SAMPLES]\n", argv[0]);
        return 1;
    }
    uint32_t max_topics = argc > 3 ? (uint32_t)atoi(argv[3]) : 10;
    Endpoint endpoint = {argv[1], (uint16_t)atoi(argv[2]), -1, 0, 0};
    uxr_set_custom_transport_callbacks(&transport, false, custom_open, custom_close, custom_write, custom_read);
    if (!uxr_init_custom_transport(&transport, &endpoint)) {
        printf("Error at create transport.\n");
        return 1;
    }
    uxr_init_session(&session, &transport.comm, 0xAAAABBBB);
    if (!uxr_create_session(&session)) {
        printf("Error at create session.\n");
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
        printf("Error at create entities: participant: %i topic: %i publisher: %i darawriter: %i\n", status[0],
               status[1], status[2], status[3]);
        return 1;
    }

    bool connected = true;
    uint32_t count = 0;
    while (connected && count < max_topics) {
        HelloWorld topic = {++count, "Hello DDS world!"};
        ucdrBuffer ub;
        uint32_t topic_size = HelloWorld_size_of_topic(&topic, 0);
        uxr_prepare_output_stream(&session, out, datawriter_id, &ub, topic_size);
        HelloWorld_serialize_topic(&ub, &topic);
        printf("Send topic: %s, id: %i\n", topic.message, topic.index);
        connected = uxr_run_session_time(&session, 1000);
    }
    uxr_delete_session(&session);
    uxr_close_custom_transport(&transport);
    return 0;
}
