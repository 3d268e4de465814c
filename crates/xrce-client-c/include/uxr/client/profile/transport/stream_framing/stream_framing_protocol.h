/* The HDLC-like framing of serial and framed custom transports: its flag bytes and eProsima's state type. */
#ifndef UXR_CLIENT_PROFILE_TRANSPORT_STREAM_FRAMING_PROTOCOL_H_
#define UXR_CLIENT_PROFILE_TRANSPORT_STREAM_FRAMING_PROTOCOL_H_
#include <stdint.h>
#define UXR_FRAMING_BEGIN_FLAG 0x7E
#define UXR_FRAMING_ESC_FLAG 0x7D
#define UXR_FRAMING_XOR_FLAG 0x20
typedef enum uxrFramingInputState {
    UXR_FRAMING_UNINITIALIZED,
    UXR_FRAMING_READING_SRC_ADDR,
    UXR_FRAMING_READING_DST_ADDR,
    UXR_FRAMING_READING_LEN_LSB,
    UXR_FRAMING_READING_LEN_MSB,
    UXR_FRAMING_READING_PAYLOAD,
    UXR_FRAMING_READING_CRC_LSB,
    UXR_FRAMING_READING_CRC_MSB,
    UXR_FRAMING_INPUT_STATE_INT_SIZE_ = 0x7FFFFFFF
} uxrFramingInputState;
/* eProsima's framing state. The transports of this library frame in their own engine (shared with the agent)
 * and hold no uxrFramingIO: the type exists for programs that name it. */
typedef struct uxrFramingIO {
    uxrFramingInputState state;
    uint8_t local_addr;
    uint8_t rb[42];
    uint8_t rb_head;
    uint8_t rb_tail;
    uint8_t src_addr;
    uint16_t msg_len;
    uint16_t msg_pos;
    uint16_t msg_crc;
    uint16_t cmp_crc;
    uint8_t wb[42];
    uint8_t wb_pos;
} uxrFramingIO;
#endif /* UXR_CLIENT_PROFILE_TRANSPORT_STREAM_FRAMING_PROTOCOL_H_ */
