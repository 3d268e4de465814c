/* The C firmware: a node as micro-ROS firmware drives its client, on our C library (libmicroxrcedds_client.a,
 * the no_std build) over a framed custom transport on UART0, with the board's clock as the platform's
 * clock_gettime (board.c), where eProsima's client reads time on bare metal too.
 *
 * Entities in binary, REUSE|REPLACE, reliable streams of 4 x 512 B: it publishes PUB_COUNT HelloWorld samples
 * (index from 0, "Hello DDS world!") on HelloWorldTopic, one every PERIOD_MS, and subscribes to rt/chatter
 * (std_msgs/String "<tag> <index> <time>", what the host's micro_ros_node --pub chatter writes), checking that
 * the indices 0..SUB_COUNT-1 arrive in order. Like micro-ROS (rmw_uros_ping_agent), it pings the agent every
 * second; when the agent stops answering it creates its session, entities and read again, and a gap in the
 * indices is then allowed across the loss, not after.
 *
 * Command line (QEMU's -append): [PUB_COUNT=10] [SUB_COUNT=20] [TIMEOUT_S=60] [PERIOD_MS=100]. Prints "ready" once
 * its entities exist. Verdict: PASS (exit 0) when every sample was written and acknowledged and every index
 * arrived in order, else FAIL (exit 1). */
#include <uxr/client/client.h>
#include <uxr/client/platform.h>
#include <ucdr/microcdr.h>

#include "board.h"

#define HISTORY 4
#define BUFFER_SIZE (UXR_CONFIG_CUSTOM_TRANSPORT_MTU * HISTORY)
#define MESSAGE "Hello DDS world!"

static uxrCustomTransport transport;
static uxrSession session;
static uint8_t output_reliable[BUFFER_SIZE];
static uint8_t input_reliable[BUFFER_SIZE];
static uxrStreamId out;
static uxrStreamId in;

static const uxrObjectId participant_id = {0x01, UXR_PARTICIPANT_ID};
static const uxrObjectId pub_topic_id = {0x01, UXR_TOPIC_ID};
static const uxrObjectId sub_topic_id = {0x02, UXR_TOPIC_ID};
static const uxrObjectId publisher_id = {0x01, UXR_PUBLISHER_ID};
static const uxrObjectId subscriber_id = {0x01, UXR_SUBSCRIBER_ID};
static const uxrObjectId writer_id = {0x01, UXR_DATAWRITER_ID};
static const uxrObjectId reader_id = {0x01, UXR_DATAREADER_ID};

/* What the subscription received. */
static struct {
    uint32_t received;
    bool any;
    uint32_t first;
    uint32_t last;
    uint32_t gaps;             /* indices skipped while the session was up */
    uint32_t gaps_across_loss; /* indices skipped across a lost session */
    uint32_t repeated;         /* indices at or below the last one */
    bool lost_since_last;
} sub;

static uint32_t parse_index(const char* text) {
    /* "<tag> <index> <time>": the second word. */
    while (*text != '\0' && *text != ' ') {
        text++;
    }
    while (*text == ' ') {
        text++;
    }
    uint32_t n = 0;
    while (*text >= '0' && *text <= '9') {
        n = n * 10 + (uint32_t)(*text - '0');
        text++;
    }
    return n;
}

static void on_topic(uxrSession* s, uxrObjectId object_id, uint16_t request_id, uxrStreamId stream_id,
                     struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)s;
    (void)object_id;
    (void)request_id;
    (void)stream_id;
    (void)length;
    (void)args;
    char text[64];
    if (!ucdr_deserialize_string(ub, text, sizeof(text))) {
        return;
    }
    uint32_t index = parse_index(text);
    sub.received++;
    if (!sub.any) {
        sub.any = true;
        sub.first = index;
        sub.last = index;
    } else if (index <= sub.last) {
        sub.repeated++;
    } else {
        if (sub.lost_since_last) {
            sub.gaps_across_loss += index - sub.last - 1;
        } else {
            sub.gaps += index - sub.last - 1;
        }
        sub.last = index;
    }
    sub.lost_since_last = false;
    if (sub.received <= 3 || index % 10 == 0) {
        board_report("received index ", index);
    }
}

static void on_panic(void) {
    board_print("the client library panicked\n");
    board_exit(101);
}

static uint32_t arg(const char** line, uint32_t fallback) {
    const char* p = *line;
    while (*p == ' ') {
        p++;
    }
    if (*p < '0' || *p > '9') {
        return fallback;
    }
    uint32_t n = 0;
    while (*p >= '0' && *p <= '9') {
        n = n * 10 + (uint32_t)(*p - '0');
        p++;
    }
    *line = p;
    return n;
}

/* Creates (or finds again) the entities and asks for every chatter sample; whether the agent accepted. */
static bool create_entities(void) {
    const uint8_t mode = UXR_REUSE | UXR_REPLACE;
    uxrQoS_t qos = {UXR_DURABILITY_VOLATILE, UXR_RELIABILITY_RELIABLE, UXR_HISTORY_KEEP_LAST, 10};
    uint16_t requests[8] = {
        uxr_buffer_create_participant_bin(&session, out, participant_id, 0, "firmware_c", mode),
        uxr_buffer_create_topic_bin(&session, out, pub_topic_id, participant_id, "HelloWorldTopic", "HelloWorld",
                                    mode),
        uxr_buffer_create_publisher_bin(&session, out, publisher_id, participant_id, mode),
        uxr_buffer_create_datawriter_bin(&session, out, writer_id, publisher_id, pub_topic_id, qos, mode),
        uxr_buffer_create_topic_bin(&session, out, sub_topic_id, participant_id, "rt/chatter",
                                    "std_msgs::msg::dds_::String_", mode),
        uxr_buffer_create_subscriber_bin(&session, out, subscriber_id, participant_id, mode),
        uxr_buffer_create_datareader_bin(&session, out, reader_id, subscriber_id, sub_topic_id, qos, mode),
        0,
    };
    uint8_t status[8];
    bool ok = false;
    for (int i = 0; i < 5 && !ok; i++) {
        ok = uxr_run_session_until_all_status(&session, 1000, requests, status, 7);
    }
    if (!ok) {
        return false;
    }
    uxrDeliveryControl control = {UXR_MAX_SAMPLES_UNLIMITED, 0, 0, 0};
    return uxr_buffer_request_data(&session, out, reader_id, in, &control) != UXR_INVALID_REQUEST_ID;
}

/* Writes sample `index`: false when the reliable history is full. */
static bool publish(uint32_t index) {
    ucdrBuffer ub;
    uint32_t size = 4 + 4 + (uint32_t)sizeof(MESSAGE);
    if (uxr_prepare_output_stream(&session, out, writer_id, &ub, size) == UXR_INVALID_REQUEST_ID) {
        return false;
    }
    ucdr_serialize_uint32_t(&ub, index);
    ucdr_serialize_string(&ub, MESSAGE);
    return !ub.error;
}

int main(void) {
    board_init();
    uxr_set_panic_hook(on_panic);
    char buf[96];
    const char* line = board_cmdline(buf, sizeof(buf));
    uint32_t pub_count = arg(&line, 10);
    uint32_t sub_count = arg(&line, 20);
    int64_t timeout_ms = (int64_t)arg(&line, 60) * 1000;
    int64_t period = arg(&line, 100);
    board_print("C firmware: publisher and subscriber\n");

    uxr_set_custom_transport_callbacks(&transport, true, uart_transport_open, uart_transport_close,
                                       uart_transport_write, uart_transport_read);
    if (!uxr_init_custom_transport(&transport, NULL)) {
        board_print("FAIL: no transport\n");
        return 1;
    }
    uxr_init_session(&session, &transport.comm, 0xC0C00001);
    uxr_set_topic_callback(&session, on_topic, NULL);
    if (!uxr_create_session(&session)) {
        board_print("FAIL: no session\n");
        return 2;
    }
    board_print("session created\n");
    out = uxr_create_output_reliable_stream(&session, output_reliable, BUFFER_SIZE, HISTORY);
    in = uxr_create_input_reliable_stream(&session, input_reliable, BUFFER_SIZE, HISTORY);
    if (!create_entities()) {
        board_print("FAIL: entities refused\n");
        return 1;
    }
    board_print("ready\n");

    uint32_t written = 0;
    uint32_t lost = 0;
    uint32_t restored = 0;
    int64_t start = board_millis();
    int64_t next = start;
    int64_t next_ping = start + 1000;
    bool up = true;
    while (board_millis() - start < timeout_ms) {
        bool sub_done = sub.any && sub.last + 1 >= sub_count;
        if (sub_done && written >= pub_count) {
            break;
        }
        int64_t now = board_millis();
        if (now >= next_ping) {
            next_ping = now + 1000;
            if (!uxr_ping_agent_session(&session, 200, 2)) {
                if (up) {
                    board_print("agent lost\n");
                    lost++;
                    up = false;
                    sub.lost_since_last = true;
                }
                /* One attempt per second, as the ping's period. */
                if (uxr_create_session_retries(&session, 1)) {
                    if (create_entities()) {
                        board_print("agent back (session and entities created again)\n");
                        restored++;
                        up = true;
                    }
                }
                continue;
            }
        }
        if (up && written < pub_count && now >= next) {
            if (publish(written)) {
                written++;
                next += period;
            }
        }
        uxr_run_session_time(&session, 10);
    }
    bool confirmed = uxr_run_session_until_confirm_delivery(&session, 5000);
    board_report("samples written: ", written);
    board_print(confirmed ? "all acknowledged\n" : "not all acknowledged\n");
    board_report("samples received: ", sub.received);
    board_report("first index: ", sub.first);
    board_report("last index: ", sub.last);
    board_report("indices missing: ", sub.gaps);
    board_report("indices missing across a lost session: ", sub.gaps_across_loss);
    board_report("repeated or late: ", sub.repeated);
    board_report("sessions lost: ", lost);
    board_report("sessions restored: ", restored);
    bool ok = written == pub_count && confirmed && sub.any && sub.first == 0 && sub.gaps == 0 &&
              sub.last + 1 == sub_count && (sub.repeated == 0 || lost > 0);
    uxr_delete_session_retries(&session, 3);
    board_report("peak stack: ", (uint32_t)board_stack_used());
    board_print(ok ? "PASS\n" : "FAIL\n");
    return ok ? 0 : 1;
}
