/*
 * What this build of xrce-rs' client library is, under the macro names of eProsima's generated config.h, so
 * that programs sizing buffers or choosing code paths from them compile as they do against eProsima's build.
 * The version is the eProsima client release whose API this library provides.
 */
#ifndef UXR_CLIENT_CONFIG_H_
#define UXR_CLIENT_CONFIG_H_

#define UXR_CLIENT_VERSION_MAJOR 3
#define UXR_CLIENT_VERSION_MINOR 0
#define UXR_CLIENT_VERSION_MICRO 1
#define UXR_CLIENT_VERSION_STR "3.0.1"
/* The library behind these headers (not an eProsima macro). */
#define UXR_CLIENT_IMPLEMENTATION_XRCE_RS 1

/* Everywhere: sessions, custom transports (packet or framed), Micro-CDR. The operating system's transports
 * exist on POSIX systems only (the library's `std` build); bare-metal firmware has the custom transport. */
#define UCLIENT_PROFILE_CUSTOM_TRANSPORT
#define UCLIENT_PROFILE_STREAM_FRAMING
#if defined(__unix__) || defined(__unix) || defined(__APPLE__)
#define UCLIENT_PLATFORM_POSIX
#define UCLIENT_PROFILE_DISCOVERY
#define UCLIENT_PROFILE_UDP
#define UCLIENT_PROFILE_TCP
#define UCLIENT_PROFILE_SERIAL
#if defined(__linux__)
#define UCLIENT_PROFILE_CAN
#endif
#endif
/* The multithread profile: off in the default build (one thread per session at a time, as eProsima's default
 * build and PX4's). A library built with XRCE_C_MULTITHREAD=1 and installed by scripts/c-install.sh has it on
 * (POSIX: pthread recursive mutexes), the next line then reading `#define UCLIENT_PROFILE_MULTITHREAD`. */
/* #define UCLIENT_PROFILE_MULTITHREAD */
/* Not built: UCLIENT_PROFILE_SHARED_MEMORY (eProsima's in-process loopback between a client's own entities). */

#define UXR_CONFIG_MAX_OUTPUT_BEST_EFFORT_STREAMS 1
#define UXR_CONFIG_MAX_OUTPUT_RELIABLE_STREAMS 1
#define UXR_CONFIG_MAX_INPUT_BEST_EFFORT_STREAMS 1
#define UXR_CONFIG_MAX_INPUT_RELIABLE_STREAMS 1

#define UXR_CONFIG_MAX_SESSION_CONNECTION_ATTEMPTS 10
#define UXR_CONFIG_MIN_SESSION_CONNECTION_INTERVAL 1000
#define UXR_CONFIG_MIN_HEARTBEAT_TIME_INTERVAL 100

#define UXR_CONFIG_UDP_TRANSPORT_MTU 512
#define UXR_CONFIG_TCP_TRANSPORT_MTU 512
#define UXR_CONFIG_SERIAL_TRANSPORT_MTU 512
#define UXR_CONFIG_CUSTOM_TRANSPORT_MTU 512
/* Ours (eProsima fixes the CAN FD MTU in can_transport.h as UXR_CAN_TRANSPORT_MTU). */
#define UXR_CONFIG_CAN_TRANSPORT_MTU 63

/* Writes larger than 64 KiB are announced with length 0, as eProsima's UCLIENT_TWEAK_XRCE_WRITE_LIMIT does. */
#define UCLIENT_TWEAK_XRCE_WRITE_LIMIT

#endif /* UXR_CLIENT_CONFIG_H_ */
