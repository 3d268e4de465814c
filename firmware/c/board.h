/* Board support for the C firmware on QEMU's mps2-an386 (Cortex-M4): the CMSDK UART0 registers, SysTick as a
 * millisecond clock, semihosting for the console, the exit code and the command line, and the stack's
 * high-water mark. As little as a DDS-XRCE client needs; no C library calls. */
#ifndef XRCE_FIRMWARE_BOARD_H_
#define XRCE_FIRMWARE_BOARD_H_

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

void board_init(void);

/* UART0: blocking write of one byte, non-blocking read (false when nothing is there). */
void uart_write(uint8_t byte);
bool uart_read(uint8_t* byte);

/* Time since reset. */
int64_t board_nanos(void);
int64_t board_millis(void);
/* Sleeps until a byte arrives or the next tick (a millisecond at most). */
void board_idle(void);

/* Semihosting: text to the host's console, a number in decimal, the program's end with its exit code, the
 * command line after the program's name (QEMU's -append) copied into buf (NUL-terminated). */
void board_print(const char* text);
void board_print_num(uint32_t n);
void board_report(const char* label, uint32_t n);
void board_exit(int code) __attribute__((noreturn));
const char* board_cmdline(char* buf, size_t size);

/* Bytes of stack used since reset (the start-up code paints it). */
size_t board_stack_used(void);

/* The custom transport's four callbacks over UART0 (uxr_set_custom_transport_callbacks, framing on). */
struct uxrCustomTransport;
bool uart_transport_open(struct uxrCustomTransport* transport);
bool uart_transport_close(struct uxrCustomTransport* transport);
size_t uart_transport_write(struct uxrCustomTransport* transport, const uint8_t* buf, size_t len, uint8_t* err);
size_t uart_transport_read(struct uxrCustomTransport* transport, uint8_t* buf, size_t len, int timeout,
                           uint8_t* err);

#endif
