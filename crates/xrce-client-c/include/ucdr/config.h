/* What this build of the Micro-CDR functions is (eProsima's generated ucdr/config.h names). */
#ifndef UCDR_CONFIG_H_
#define UCDR_CONFIG_H_
#define MICROCDR_VERSION_MAJOR 2
#define MICROCDR_VERSION_MINOR 0
#define MICROCDR_VERSION_MICRO 1
#define MICROCDR_VERSION_STR "2.0.1"
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
#define UCDR_MACHINE_ENDIANNESS UCDR_BIG_ENDIANNESS
#else
#define UCDR_MACHINE_ENDIANNESS UCDR_LITTLE_ENDIANNESS
#endif
#endif /* UCDR_CONFIG_H_ */
