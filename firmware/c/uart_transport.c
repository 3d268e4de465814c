/* The custom transport's callbacks over UART0, as a micro-ROS board port writes them: stream-oriented, so the
 * session is set up with framing on (uxr_set_custom_transport_callbacks(&t, true, ...)) and the library frames
 * the messages (HDLC-like, CRC-16), as eProsima's serial transport does. */
#include <uxr/client/profile/transport/custom/custom_transport.h>

#include "board.h"

bool uart_transport_open(struct uxrCustomTransport* transport) {
    (void)transport;
    return true;
}

bool uart_transport_close(struct uxrCustomTransport* transport) {
    (void)transport;
    return true;
}

size_t uart_transport_write(struct uxrCustomTransport* transport, const uint8_t* buf, size_t len, uint8_t* err) {
    (void)transport;
    (void)err;
    for (size_t i = 0; i < len; i++) {
        uart_write(buf[i]);
    }
    return len;
}

/* Waits up to `timeout` ms for a first byte, then takes what the UART holds. */
size_t uart_transport_read(struct uxrCustomTransport* transport, uint8_t* buf, size_t len, int timeout,
                           uint8_t* err) {
    (void)transport;
    (void)err;
    int64_t deadline = board_millis() + timeout;
    size_t n = 0;
    for (;;) {
        while (n < len && uart_read(&buf[n])) {
            n++;
        }
        if (n > 0 || len == 0 || (timeout >= 0 && board_millis() >= deadline)) {
            return n;
        }
        board_idle();
    }
}
