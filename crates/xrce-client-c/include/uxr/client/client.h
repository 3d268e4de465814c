/*
 * Micro XRCE-DDS Client API of xrce-rs: eProsima's header tree (client 2.4.x / 3.0.x paths), implemented in
 * Rust over the xrce-client crate (crates/xrce-client-c). This header includes all of it, as eProsima's does.
 * Link with `-lmicroxrcedds_client -lmicrocdr` (and the system's -lpthread -ldl -lm), or find_package(
 * microxrcedds_client) on an installed library (docs/c-api.md).
 *
 * Structures that programs declare (sessions, transports) are complete types of fixed size: their named fields
 * are eProsima's, their `_opaque` storage holds the Rust state (checked against it when the library is built).
 * They must not be moved or copied after initialisation.
 */
#ifndef UXR_CLIENT_CLIENT_H_
#define UXR_CLIENT_CLIENT_H_

#include <uxr/client/config.h>
#ifdef UCLIENT_PROFILE_DISCOVERY
#include <uxr/client/profile/discovery/discovery.h>
#endif
#include <uxr/client/core/session/create_entities_bin.h>
#include <uxr/client/core/session/create_entities_ref.h>
#include <uxr/client/core/session/create_entities_xml.h>
#include <uxr/client/core/session/read_access.h>
#include <uxr/client/core/session/session.h>
#include <uxr/client/core/session/write_access.h>
#include <uxr/client/profile/multithread/multithread.h>
#include <uxr/client/transport.h>
#include <uxr/client/util/ping.h>
#include <uxr/client/util/time.h>
#include <uxr/client/platform.h>
#ifdef UCLIENT_PROFILE_UDP
#include <uxr/client/profile/transport/ip/ip.h>
#endif

/* ---- layout checks ---------------------------------------------------------------------------------------
 * The library's build checks every shared structure field by field against these headers compiled for its
 * target (build.rs). These checks catch a program compiled with settings that change layouts (packing, an
 * ABI option) on the structures whose size follows from the pointer size; UXR_PTR is that size. Enums are
 * int-sized whatever -fshort-enums says (their *_INT_SIZE_ enumerators). */
#define UXR_PTR (sizeof(void*))
#ifdef __cplusplus
#define UXR_ABI(T, SIZE, ALIGN) static_assert(sizeof(T) == (SIZE) && alignof(T) == (ALIGN), "layout of " #T);
#elif defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define UXR_ABI(T, SIZE, ALIGN) _Static_assert(sizeof(T) == (SIZE) && _Alignof(T) == (ALIGN), "layout of " #T);
#else
/* C99 (firmware built with -std=c99 -pedantic): no _Static_assert or _Alignof; an array of negative size
 * fails the build instead, and the alignment is the offset of T after a char. */
#define UXR_ABI(T, SIZE, ALIGN)                                                                              \
    struct uxr_abi_align_##T { char c; T t; };                                                                \
    typedef char uxr_abi_layout_of_##T[(sizeof(T) == (SIZE) && offsetof(struct uxr_abi_align_##T, t) == (ALIGN)) ? 1 : -1];
#endif
UXR_ABI(ucdrBuffer, 7 * UXR_PTR + 8, UXR_PTR)
UXR_ABI(uxrStreamId, 4, 1)
UXR_ABI(uxrObjectId, 4, 2)
UXR_ABI(uxrDeliveryControl, 8, 2)
UXR_ABI(uxrQoS_t, 16, 4)
UXR_ABI(SampleIdentity, 24, 4)
UXR_ABI(uxrSessionInfo, 8, 2)
UXR_ABI(Time_t, 8, 4)

#endif /* UXR_CLIENT_CLIENT_H_ */
