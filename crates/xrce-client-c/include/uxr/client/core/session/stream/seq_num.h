/* Sequence numbers of XRCE streams (16 bits, serial arithmetic). */
#ifndef UXR_CLIENT_CORE_SESSION_STREAM_SEQ_NUM_H_
#define UXR_CLIENT_CORE_SESSION_STREAM_SEQ_NUM_H_
#include <stdint.h>
typedef uint16_t uxrSeqNum;
#endif /* UXR_CLIENT_CORE_SESSION_STREAM_SEQ_NUM_H_ */
