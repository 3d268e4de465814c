/* A transport of the program's own (seed 004): four callbacks, packet-oriented or framed (HDLC-like, for byte
 * streams). `args` is what uxr_init_custom_transport was given; `buffer` holds the last message received. */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_CUSTOM_CUSTOM_TRANSPORT_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_CUSTOM_CUSTOM_TRANSPORT_H_
#include <uxr/client/config.h>
#include <uxr/client/core/communication/communication.h>
#include <uxr/client/profile/transport/stream_framing/stream_framing_protocol.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
struct uxrCustomTransport;
typedef bool (*open_custom_func)(struct uxrCustomTransport* transport);
typedef bool (*close_custom_func)(struct uxrCustomTransport* transport);
typedef size_t (*write_custom_func)(struct uxrCustomTransport* transport, const uint8_t* buffer, size_t length,
                                    uint8_t* error_code);
typedef size_t (*read_custom_func)(struct uxrCustomTransport* transport, uint8_t* buffer, size_t length,
                                   int timeout, uint8_t* error_code);
#define UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS 96
typedef struct uxrCustomTransport {
    uint8_t buffer[UXR_CONFIG_CUSTOM_TRANSPORT_MTU];
    bool framing;
    open_custom_func open;
    close_custom_func close;
    write_custom_func write;
    read_custom_func read;
    uxrCommunication comm;
    void* args;
    uint64_t _opaque[UXR_CUSTOM_TRANSPORT_OPAQUE_WORDS];
} uxrCustomTransport;
UXRDLLAPI void uxr_set_custom_transport_callbacks(uxrCustomTransport* transport, bool framing,
                                                  open_custom_func open, close_custom_func close,
                                                  write_custom_func write, read_custom_func read);
UXRDLLAPI bool uxr_init_custom_transport(uxrCustomTransport* transport, void* args);
UXRDLLAPI bool uxr_close_custom_transport(uxrCustomTransport* transport);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_PROFILE_TRANSPORT_CUSTOM_CUSTOM_TRANSPORT_H_ */
