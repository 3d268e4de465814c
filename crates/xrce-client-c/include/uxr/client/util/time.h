/* The local clock: milliseconds and nanoseconds since the epoch (CLOCK_REALTIME, as eProsima's POSIX port). */
#ifndef UXR_CLIENT_UTIL_TIME_H_
#define UXR_CLIENT_UTIL_TIME_H_
#include <stdint.h>
#include <uxr/client/visibility.h>
#ifdef __cplusplus
extern "C" {
#endif
UXRDLLAPI int64_t uxr_millis(void);
UXRDLLAPI int64_t uxr_nanos(void);
#ifdef __cplusplus
}
#endif
#endif /* UXR_CLIENT_UTIL_TIME_H_ */
