/* Ping, time synchronisation, entities by reference, deletion, a packet-oriented custom transport written
 * here over a POSIX UDP socket (seed 004), and the TCP transport.
 * Usage: misc IP UDP_PORT TCP_PORT (agents listening on both). */
#include "udp_custom.h" /* first: it asks for POSIX declarations */
#include "node.h"
#include "check.h"

#include <stdlib.h>
#include <string.h>

/* ---- time ---- */
static int time_calls = 0;
static void on_time(uxrSession* session, int64_t current, int64_t transmit, int64_t received, int64_t originate,
                    void* args) {
    (void)session; (void)args;
    /* the agent stamps its two times between the client's two */
    if (originate <= current && received <= transmit) {
        time_calls++;
    }
}

static uint8_t last_status = UXR_STATUS_NONE;
static void on_status(uxrSession* session, uxrObjectId object_id, uint16_t request_id, uint8_t status, void* args) {
    (void)session; (void)object_id; (void)request_id; (void)args;
    last_status = status;
}

/* ---- discovery: the agent at a known address answers; its locator converts back to text ---- */
static int agents_found = 0;
static bool on_agent(const TransportLocator* locator, void* args) {
    char ip[64];
    uint16_t port = 0;
    uxrIpProtocol protocol = UXR_IPv6;
    if (uxr_locator_to_ip(locator, ip, sizeof(ip), &port, &protocol) && strcmp(ip, "127.0.0.1") == 0
        && port == *(uint16_t*)args && protocol == UXR_IPv4) {
        agents_found++;
    }
    return true; /* stop at the first */
}

static void discovery(const char* ip, const char* port) {
    TransportLocator agent;
    uint16_t agent_port = (uint16_t)atoi(port);
    CHECK(uxr_ip_to_locator(ip, agent_port, UXR_IPv4, &agent));
    CHECK(!uxr_ip_to_locator("not an address", agent_port, UXR_IPv4, &agent) && !uxr_ip_to_locator(ip, 1, UXR_IPv4, NULL));
    CHECK(uxr_discovery_agents(3, 200, on_agent, &agent_port, &agent, 1));
    CHECK(agents_found == 1);
    char tiny[4];
    CHECK(!uxr_locator_to_ip(&agent, tiny, sizeof(tiny), NULL, NULL));
}

static void over_udp(const char* ip, const char* port) {
    static Node node;
    CHECK(uxr_init_udp_transport(&node.transport, UXR_IPv4, ip, port));
    CHECK(uxr_ping_agent_attempts(&node.transport.comm, 500, 3));
    CHECK(uxr_ping_agent(&node.transport.comm, 500));
    CHECK(uxr_close_udp_transport(&node.transport));
    CHECK(node_start(&node, ip, port, 0x11115C01));
    CHECK(uxr_ping_agent_session(&node.session, 500, 3));

    /* time: the agent's clock, then a callback taking over */
    int64_t before = uxr_millis();
    CHECK(uxr_sync_session(&node.session, 1000));
    int64_t agent_ms = uxr_epoch_millis(&node.session);
    CHECK(llabs(agent_ms - before) < 5000); /* same machine: the clocks agree */
    CHECK(uxr_epoch_nanos(&node.session) / 1000000 >= agent_ms);
    uxr_set_time_callback(&node.session, on_time, NULL);
    CHECK(uxr_sync_session(&node.session, 1000));
    CHECK(time_calls == 1);

    /* entities by reference: the agent answers (whether it knows the reference or not) */
    uxr_set_status_callback(&node.session, on_status, NULL);
    uxrObjectId participant = uxr_object_id(7, UXR_PARTICIPANT_ID);
    uint16_t r = uxr_buffer_create_participant_ref(&node.session, node.out, participant, 0, "default_xrce_participant", UXR_REPLACE);
    uint8_t status = UXR_STATUS_NONE;
    CHECK(r != UXR_INVALID_REQUEST_ID);
    uxr_run_session_until_one_status(&node.session, 2000, &r, &status, 1);
    CHECK(status != UXR_STATUS_NONE && last_status == status);
    uxrObjectId topic = uxr_object_id(7, UXR_TOPIC_ID);
    uint16_t t = uxr_buffer_create_topic_ref(&node.session, node.out, topic, participant, "unknown_topic_profile", UXR_REPLACE);
    status = UXR_STATUS_NONE;
    uxr_run_session_until_one_status(&node.session, 2000, &t, &status, 1);
    CHECK(status != UXR_STATUS_NONE);
    /* the seed's form of the participant by reference (no domain) */
    uint16_t seed_form = uxr_buffer_create_participant_ref(&node.session, node.out, uxr_object_id(9, UXR_PARTICIPANT_ID),
                                                           "default_xrce_participant", UXR_REPLACE);
    status = UXR_STATUS_NONE;
    CHECK(seed_form != UXR_INVALID_REQUEST_ID);
    uxr_run_session_until_one_status(&node.session, 2000, &seed_form, &status, 1);
    CHECK(status != UXR_STATUS_NONE);
    /* a participant by XML, then deleted */
    uxrObjectId other = uxr_object_id(8, UXR_PARTICIPANT_ID);
    uint16_t c = uxr_buffer_create_participant_xml(&node.session, node.out, other, 0,
        "<dds><participant><rtps><name>p8</name></rtps></participant></dds>", UXR_REPLACE);
    CHECK(node_statuses_ok(&node, &c, 1, "participant 8"));
    uint16_t d = uxr_buffer_delete_entity(&node.session, node.out, other);
    CHECK(node_statuses_ok(&node, &d, 1, "delete participant 8"));
    /* best-effort streams exist too */
    static uint8_t be[UXR_CONFIG_UDP_TRANSPORT_MTU];
    uxrStreamId best_effort = uxr_create_output_best_effort_stream(&node.session, be, sizeof(be));
    CHECK(best_effort.type == UXR_BEST_EFFORT_STREAM);
    CHECK(uxr_create_input_best_effort_stream(&node.session).type == UXR_BEST_EFFORT_STREAM);

    /* deleted: everything after answers with its error value */
    CHECK(uxr_delete_session(&node.session));
    CHECK(uxr_buffer_create_participant_xml(&node.session, node.out, other, 0, "<dds/>", UXR_REPLACE) == UXR_INVALID_REQUEST_ID);
    ucdrBuffer ub;
    CHECK(uxr_prepare_output_stream(&node.session, node.out, other, &ub, 4) == UXR_INVALID_REQUEST_ID);
    CHECK(uxr_close_udp_transport(&node.transport));
}

static void over_custom(const char* ip, const char* port) {
    static uxrCustomTransport transport;
    static uxrSession session;
    Endpoint endpoint = {ip, (uint16_t)atoi(port), -1, 0, 0};
    uxr_set_custom_transport_callbacks(&transport, false, custom_open, custom_close, custom_write, custom_read);
    CHECK(uxr_init_custom_transport(&transport, &endpoint));
    CHECK(endpoint.opened == 1 && transport.args == &endpoint);
    uxr_init_session(&session, &transport.comm, 0x11115C02);
    CHECK(uxr_create_session(&session));
    CHECK(uxr_ping_agent_session(&session, 500, 3));
    CHECK(uxr_delete_session(&session));
    CHECK(uxr_close_custom_transport(&transport));
    CHECK(endpoint.closed == 1);
}

static void over_tcp(const char* ip, const char* port) {
    static uxrTCPTransport transport;
    static uxrSession session;
    static uint8_t out[UXR_CONFIG_TCP_TRANSPORT_MTU * 4], in[UXR_CONFIG_TCP_TRANSPORT_MTU * 4];
    CHECK(uxr_init_tcp_transport(&transport, UXR_IPv4, ip, port));
    uxr_init_session(&session, &transport.comm, 0x11115C03);
    CHECK(uxr_create_session(&session));
    uxrStreamId stream = uxr_create_output_reliable_stream(&session, out, sizeof(out), 4);
    uxr_create_input_reliable_stream(&session, in, sizeof(in), 4); /* statuses come back on it */
    uxrObjectId participant = uxr_object_id(1, UXR_PARTICIPANT_ID);
    uint16_t r = uxr_buffer_create_participant_bin(&session, stream, participant, 0, "over_tcp", UXR_REPLACE);
    uint8_t status = UXR_STATUS_NONE;
    bool ok = uxr_run_session_until_all_status(&session, 2000, &r, &status, 1);
    if (!ok) {
        fprintf(stderr, "tcp: request %u status %u\n", r, status);
    }
    CHECK(ok);
    CHECK(uxr_delete_session(&session));
    CHECK(uxr_close_tcp_transport(&transport));
}

/* Sessions on the stack, as eProsima's examples keep them: created with entities, deleted, gone. Under
 * LeakSanitizer (the sanitized build of this test) a session that kept heap memory after
 * uxr_delete_session would fail the run at exit. */
static void on_the_stack(const char* ip, const char* port) {
    uxrUDPTransport transport;
    uxrSession sessions[3]; /* distinct storage: none is initialised twice */
    uint8_t out[UXR_CONFIG_UDP_TRANSPORT_MTU * 4], in[UXR_CONFIG_UDP_TRANSPORT_MTU * 4];
    CHECK(uxr_init_udp_transport(&transport, UXR_IPv4, ip, port));
    for (uint32_t i = 0; i < 3; i++) {
        uxrSession* session = &sessions[i];
        uxr_init_session(session, &transport.comm, 0x11115D00 + i);
        CHECK(uxr_create_session(session));
        uxrStreamId stream = uxr_create_output_reliable_stream(session, out, sizeof(out), 4);
        uxr_create_input_reliable_stream(session, in, sizeof(in), 4);
        uxrObjectId participant = uxr_object_id(1, UXR_PARTICIPANT_ID);
        uint16_t r = uxr_buffer_create_participant_bin(session, stream, participant, 0, "on_the_stack", UXR_REPLACE);
        uint8_t status = UXR_STATUS_NONE;
        CHECK(uxr_run_session_until_all_status(session, 2000, &r, &status, 1));
        CHECK(uxr_delete_session(session));
    }
    CHECK(uxr_close_udp_transport(&transport));
    memset(sessions, 0, sizeof(sessions)); /* what a later frame would do: no pointer into the heap stays */
}

int main(int argc, char** argv) {
    if (argc != 4) {
        return 2;
    }
    over_udp(argv[1], argv[2]);
    discovery(argv[1], argv[2]);
    over_custom(argv[1], argv[2]);
    over_tcp(argv[1], argv[3]);
    on_the_stack(argv[1], argv[2]);
    printf("%s\n", failures == 0 ? "all checks passed" : "FAILED");
    return failures == 0 ? 0 : 1;
}
