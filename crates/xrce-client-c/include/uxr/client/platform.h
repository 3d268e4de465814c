/*
 * What a board gives the library (xrce-rs additions; eProsima's client has no such hooks). Firmware built
 * on the `no_std` library needs no C library function but `clock_gettime` (as eProsima's embedded ports) and
 * `memcpy`/`memset`-like compiler intrinsics; these setters replace the defaults.
 */
#ifndef UXR_CLIENT_PLATFORM_H_
#define UXR_CLIENT_PLATFORM_H_

#include <stdint.h>
#include <uxr/client/visibility.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The clock of uxr_nanos, uxr_millis and every session: nanoseconds since the Unix epoch (or since boot, if
 * time synchronisation is not used). NULL goes back to the default: clock_gettime(CLOCK_REALTIME) without
 * the library's `std` feature, the system clock with it. */
typedef int64_t (*uxrTimeSource)(void);
UXRDLLAPI void uxr_set_time_source(uxrTimeSource source);

/* Called if the library ever panics (none is expected on any input: it has no panicking path on the data
 * it is given), before it stops: halts in a loop without `std` (no abort(), no signals, no malloc), aborts
 * the process with it. A board would reset or log here. */
typedef void (*uxrPanicHook)(void);
UXRDLLAPI void uxr_set_panic_hook(uxrPanicHook hook);

#ifdef __cplusplus
}
#endif

#endif /* UXR_CLIENT_PLATFORM_H_ */
