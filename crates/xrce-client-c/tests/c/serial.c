/* Serial lines: two pseudoterminals, whose slave sides the harness gives to the agent (`multiserial`) after
 * reading their names from this program's first output line. One session over uxr_init_serial_transport on the
 * first master, one over a framed custom transport (seed 004, stream-oriented) written here on the second.
 * Each creates a participant and pings the agent in its session. Usage: serial. */
#define _XOPEN_SOURCE 600 /* pseudoterminals */
#include <uxr/client/client.h>

#include "check.h"

#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int open_master(char* name, size_t size) {
    int fd = posix_openpt(O_RDWR | O_NOCTTY);
    if (fd < 0 || grantpt(fd) != 0 || unlockpt(fd) != 0 || ptsname(fd) == NULL) {
        return -1;
    }
    strncpy(name, ptsname(fd), size - 1);
    return fd;
}

/* Stream-oriented callbacks over a file descriptor in `args`. */
static size_t fd_write(uxrCustomTransport* transport, const uint8_t* buf, size_t len, uint8_t* err) {
    ssize_t n = write(*(int*)transport->args, buf, len);
    if (n < 0) {
        *err = 1;
        return 0;
    }
    return (size_t)n;
}

static size_t fd_read(uxrCustomTransport* transport, uint8_t* buf, size_t len, int timeout, uint8_t* err) {
    struct pollfd p = {*(int*)transport->args, POLLIN, 0};
    if (poll(&p, 1, timeout) <= 0) {
        return 0;
    }
    ssize_t n = read(p.fd, buf, len);
    if (n < 0) {
        *err = 1;
        return 0;
    }
    return (size_t)n;
}

static void session_over(uxrCommunication* comm, uint32_t key) {
    static uxrSession session;
    static uint8_t out[UXR_CONFIG_SERIAL_TRANSPORT_MTU * 4], in[UXR_CONFIG_SERIAL_TRANSPORT_MTU * 4];
    uxr_init_session(&session, comm, key);
    CHECK(uxr_create_session(&session));
    uxrStreamId stream = uxr_create_output_reliable_stream(&session, out, sizeof(out), 4);
    uxr_create_input_reliable_stream(&session, in, sizeof(in), 4);
    uint16_t r = uxr_buffer_create_participant_bin(&session, stream, uxr_object_id(1, UXR_PARTICIPANT_ID), 0,
                                                   "over_serial", UXR_REPLACE);
    uint8_t status = UXR_STATUS_NONE;
    CHECK(uxr_run_session_until_all_status(&session, 2000, &r, &status, 1));
    CHECK(uxr_ping_agent_session(&session, 500, 3));
    CHECK(uxr_delete_session(&session));
}

int main(void) {
    char first[64] = {0}, second[64] = {0};
    int serial_fd = open_master(first, sizeof(first));
    int custom_fd = open_master(second, sizeof(second));
    if (serial_fd < 0 || custom_fd < 0) {
        return 1;
    }
    printf("%s %s\n", first, second);
    fflush(stdout);

    static uxrSerialTransport serial;
    CHECK(uxr_init_serial_transport(&serial, serial_fd, 0, 1));
    session_over(&serial.comm, 0x5E51A101);
    CHECK(uxr_close_serial_transport(&serial));

    static uxrCustomTransport custom;
    uxr_set_custom_transport_callbacks(&custom, true, NULL, NULL, fd_write, fd_read);
    CHECK(uxr_init_custom_transport(&custom, &custom_fd));
    session_over(&custom.comm, 0x5E51A102);
    CHECK(uxr_close_custom_transport(&custom));
    close(custom_fd);

    printf("%s\n", failures == 0 ? "all checks passed" : "FAILED");
    return failures == 0 ? 0 : 1;
}
