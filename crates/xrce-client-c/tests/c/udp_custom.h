/* The callbacks of a packet-oriented custom transport (seed 004) over a connected POSIX UDP socket, as a
 * program on a platform without our UDP transport would write them. `transport->args` is an Endpoint. */
#ifndef XRCE_C_TEST_UDP_CUSTOM_H
#define XRCE_C_TEST_UDP_CUSTOM_H

#define _POSIX_C_SOURCE 200809L
#include <uxr/client/client.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

typedef struct Endpoint {
    const char* ip;
    uint16_t port;
    int fd;
    int opened, closed;
} Endpoint;

static bool custom_open(uxrCustomTransport* transport) {
    Endpoint* e = (Endpoint*)transport->args;
    struct sockaddr_in agent = {0};
    agent.sin_family = AF_INET;
    agent.sin_port = htons(e->port);
    inet_pton(AF_INET, e->ip, &agent.sin_addr);
    e->fd = socket(AF_INET, SOCK_DGRAM, 0);
    e->opened++;
    return e->fd >= 0 && connect(e->fd, (struct sockaddr*)&agent, sizeof(agent)) == 0;
}

static bool custom_close(uxrCustomTransport* transport) {
    Endpoint* e = (Endpoint*)transport->args;
    e->closed++;
    return close(e->fd) == 0;
}

static size_t custom_write(uxrCustomTransport* transport, const uint8_t* buf, size_t len, uint8_t* err) {
    Endpoint* e = (Endpoint*)transport->args;
    ssize_t n = send(e->fd, buf, len, 0);
    if (n < 0) {
        *err = 1;
        return 0;
    }
    return (size_t)n;
}

static size_t custom_read(uxrCustomTransport* transport, uint8_t* buf, size_t len, int timeout, uint8_t* err) {
    Endpoint* e = (Endpoint*)transport->args;
    struct pollfd p = {e->fd, POLLIN, 0};
    if (poll(&p, 1, timeout) <= 0) {
        return 0;
    }
    ssize_t n = recv(e->fd, buf, len, 0);
    if (n < 0) {
        *err = 1;
        return 0;
    }
    return (size_t)n;
}

#endif
