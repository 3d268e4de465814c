/* The multithread profile. With it on (a library built with XRCE_C_MULTITHREAD=1): one thread publishes 200
 * samples as rmw_microxrcedds does (uxr_prepare_output_stream, serialize, UXR_UNLOCK_STREAM_ID) while another
 * runs the same session all along; the subscriber receives all of them, in order, and every lock taken is
 * given back (a last UXR_LOCK_SESSION from a third thread gets it). With it off: the same 200 samples from one
 * thread, the lock macros expanding to nothing. Usage: multithread IP PORT [SETTLE_MS] */
#define _POSIX_C_SOURCE 200809L /* nanosleep */
#include "node.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define SAMPLES 200

static Node subscriber, publisher;
static uint32_t next_expected = 1;
static int in_order = 0, out_of_order = 0;
static volatile int publishing_done = 0;

static void on_topic(uxrSession* session, uxrObjectId object_id, uint16_t request_id, uxrStreamId stream_id,
                     struct ucdrBuffer* ub, uint16_t length, void* args) {
    (void)session; (void)object_id; (void)request_id; (void)stream_id; (void)length; (void)args;
    uint32_t index = 0;
    if (ucdr_deserialize_uint32_t(ub, &index)) {
        if (index == next_expected) {
            in_order++;
            next_expected++;
        } else {
            out_of_order++;
        }
    }
}

static bool create(Node* node, bool writer) {
    return node_create_endpoint(node, writer, "ThreadsTopic", "Index");
}

static void pause_ms(long ms) {
    struct timespec t = {0, ms * 1000000L};
    nanosleep(&t, NULL);
}

/* Writes the samples as rmw_microxrcedds does; a full history is waited out. */
static void* publish(void* arg) {
    (void)arg;
    for (uint32_t index = 1; index <= SAMPLES; index++) {
        ucdrBuffer ub;
        while (uxr_prepare_output_stream(&publisher.session, publisher.out, uxr_object_id(1, UXR_DATAWRITER_ID),
                                         &ub, 4) == UXR_INVALID_REQUEST_ID) {
#ifndef UCLIENT_PROFILE_MULTITHREAD
            /* one thread: make room itself, and let the subscriber read (the agent holds a publisher back
             * while a reliable subscriber has no room) */
            uxr_run_session_time(&publisher.session, 1);
            uxr_run_session_time(&subscriber.session, 0);
#endif
            pause_ms(1);
        }
        ucdr_serialize_uint32_t(&ub, index);
        UXR_UNLOCK_STREAM_ID(&publisher.session, publisher.out);
#ifndef UCLIENT_PROFILE_MULTITHREAD
        uxr_run_session_time(&publisher.session, 0);
        uxr_run_session_time(&subscriber.session, 0);
#endif
    }
    publishing_done = 1;
    return NULL;
}

#ifdef UCLIENT_PROFILE_MULTITHREAD
/* Runs the publisher's session while the other thread writes into it. */
static void* run(void* arg) {
    (void)arg;
    while (!publishing_done) {
        uxr_run_session_timeout(&publisher.session, 2);
    }
    uxr_run_session_until_confirm_delivery(&publisher.session, 3000);
    return NULL;
}

/* From a third thread: every lock the others took was given back. */
static void* lock_session(void* arg) {
    UXR_LOCK_SESSION(&publisher.session);
    UXR_LOCK_STREAM_ID(&publisher.session, publisher.out);
    *(int*)arg = 1;
    UXR_UNLOCK_STREAM_ID(&publisher.session, publisher.out);
    UXR_UNLOCK_SESSION(&publisher.session);
    return NULL;
}
#endif

int main(int argc, char** argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s IP PORT [SETTLE_MS]\n", argv[0]);
        return 2;
    }
    if (!node_start(&subscriber, argv[1], argv[2], 0x7EAD0001) || !node_start(&publisher, argv[1], argv[2], 0x7EAD0002)) {
        return 1;
    }
    uxr_set_topic_callback(&subscriber.session, on_topic, NULL);
    if (!create(&subscriber, false) || !create(&publisher, true)) {
        return 1;
    }
    node_read_all_then_settle(&subscriber, &publisher, argc, argv);

    int locked_after = 0;
#ifdef UCLIENT_PROFILE_MULTITHREAD
    pthread_t writer, runner, locker;
    pthread_create(&runner, NULL, run, NULL);
    pthread_create(&writer, NULL, publish, NULL);
    for (int round = 0; round < 2000 && in_order < SAMPLES; round++) {
        uxr_run_session_time(&subscriber.session, 5);
    }
    pthread_join(writer, NULL);
    pthread_join(runner, NULL);
    pthread_create(&locker, NULL, lock_session, &locked_after);
    pthread_join(locker, NULL);
    const char* profile = "on: one thread writing, another running the session";
#else
    publish(NULL);
    uxr_run_session_until_confirm_delivery(&publisher.session, 3000);
    for (int round = 0; round < 2000 && in_order < SAMPLES; round++) {
        uxr_run_session_time(&subscriber.session, 5);
    }
    locked_after = 1;
    const char* profile = "off: one thread";
#endif
    printf("multithread profile %s: %d of %d samples in order, %d out of order\n", profile, in_order, SAMPLES,
           out_of_order);
    node_stop(&publisher);
    node_stop(&subscriber);
    return in_order == SAMPLES && out_of_order == 0 && locked_after ? 0 : 1;
}
