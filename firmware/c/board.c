/* Board support for the C firmware (board.h): QEMU's mps2-an386. */
#include "board.h"

#include <string.h>
#include <time.h>

#define UART0_BASE 0x40004000u
#define UART_DATA (*(volatile uint32_t*)(UART0_BASE + 0x0u))
#define UART_STATE (*(volatile uint32_t*)(UART0_BASE + 0x4u))
#define UART_CTRL (*(volatile uint32_t*)(UART0_BASE + 0x8u))
#define UART_INTCLEAR (*(volatile uint32_t*)(UART0_BASE + 0xCu))
#define UART_BAUDDIV (*(volatile uint32_t*)(UART0_BASE + 0x10u))
#define CTRL_TX_EN 1u
#define CTRL_RX_EN 2u
#define CTRL_RX_INT_EN 4u
#define INT_RX 2u
/* NVIC clear-pending register 0 (UART0's receive interrupt is line 0), and the system control register whose
 * SEVONPEND bit makes a newly pending interrupt wake `wfe` while it stays disabled in the NVIC. */
#define NVIC_ICPR0 (*(volatile uint32_t*)0xE000E280u)
#define SCB_SCR (*(volatile uint32_t*)0xE000ED10u)
#define SCR_SEVONPEND (1u << 4)
#define STATE_TX_FULL 1u
#define STATE_RX_FULL 2u

#define SYST_CSR (*(volatile uint32_t*)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t*)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t*)0xE000E018u)
#define CORE_HZ 25000000u
#define RELOAD (CORE_HZ / 1000u - 1u)
#define NS_PER_CYCLE (1000000000u / CORE_HZ)

static volatile uint32_t ticks;

void SysTick_Handler(void) {
    ticks++;
}

void board_init(void) {
    UART_BAUDDIV = 16;
    /* The receive interrupt is never taken: its pending state wakes board_idle as soon as a byte arrives. */
    UART_CTRL = CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INT_EN;
    SCB_SCR |= SCR_SEVONPEND;
    SYST_RVR = RELOAD;
    SYST_CVR = 0;
    SYST_CSR = 7; /* core clock, interrupt, enabled */
}

void uart_write(uint8_t byte) {
    while (UART_STATE & STATE_TX_FULL) {
    }
    UART_DATA = byte;
}

bool uart_read(uint8_t* byte) {
    if (!(UART_STATE & STATE_RX_FULL)) {
        return false;
    }
    *byte = (uint8_t)UART_DATA;
    /* Re-arm the wake-up: the next byte makes the interrupt pending again. */
    UART_INTCLEAR = INT_RX;
    NVIC_ICPR0 = 0xFFFFFFFFu;
    return true;
}

static void board_time(uint32_t* ms, uint32_t* sub_ns) {
    for (;;) {
        uint32_t before = ticks;
        uint32_t current = SYST_CVR;
        if (ticks == before) {
            uint32_t cycles = RELOAD - (current > RELOAD ? RELOAD : current);
            *ms = before;
            *sub_ns = cycles * NS_PER_CYCLE;
            return;
        }
    }
}

int64_t board_nanos(void) {
    uint32_t ms, ns;
    board_time(&ms, &ns);
    return (int64_t)ms * 1000000 + ns;
}

int64_t board_millis(void) {
    uint32_t ms, ns;
    board_time(&ms, &ns);
    return ms;
}

/* The platform's clock, as eProsima's client reads it on bare metal (and our library without a time source set
 * by uxr_set_time_source): CLOCK_REALTIME counts from reset here; time synchronisation gives the agent's. Milliseconds
 * and the nanoseconds below them come from the tick counter apart, so nothing divides a 64-bit value (a 1,000-byte
 * library routine on Cortex-M). */
int clock_gettime(clockid_t clock, struct timespec* ts) {
    (void)clock;
    uint32_t ms, ns;
    board_time(&ms, &ns);
    ts->tv_sec = (time_t)(ms / 1000);
    ts->tv_nsec = (long)((ms % 1000) * 1000000 + ns);
    return 0;
}

void board_idle(void) {
    __asm volatile("wfe");
}

/* ---- semihosting ---- */

static uint32_t semihost(uint32_t op, const void* arg) {
    register uint32_t r0 __asm("r0") = op;
    register const void* r1 __asm("r1") = arg;
    __asm volatile("bkpt #0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

static uint32_t console = 0xFFFFFFFFu;

static size_t length(const char* s) {
    size_t n = 0;
    while (s[n] != '\0') {
        n++;
    }
    return n;
}

void board_print(const char* text) {
    if (console == 0xFFFFFFFFu) {
        uint32_t open[3] = {(uint32_t)":tt", 4 /* "w" */, 3};
        console = semihost(0x01 /* SYS_OPEN */, open);
    }
    uint32_t write[3] = {console, (uint32_t)text, (uint32_t)length(text)};
    semihost(0x05 /* SYS_WRITE */, write);
}

void board_print_num(uint32_t n) {
    char buf[11];
    int i = 10;
    buf[i] = '\0';
    do {
        buf[--i] = (char)('0' + n % 10);
        n /= 10;
    } while (n != 0 && i > 0);
    board_print(&buf[i]);
}

void board_report(const char* label, uint32_t n) {
    board_print(label);
    board_print_num(n);
    board_print("\n");
}

void board_exit(int code) {
    uint32_t block[2] = {0x20026 /* ADP_Stopped_ApplicationExit */, (uint32_t)code};
    semihost(0x20 /* SYS_EXIT_EXTENDED */, block);
    for (;;) {
        board_idle();
    }
}

const char* board_cmdline(char* buf, size_t size) {
    uint32_t block[2] = {(uint32_t)buf, (uint32_t)size};
    if (size == 0 || semihost(0x15 /* SYS_GET_CMDLINE */, block) != 0) {
        return "";
    }
    buf[size - 1] = '\0';
    /* "<kernel file> <-append text>": skip the file name. */
    for (char* p = buf; *p != '\0'; p++) {
        if (*p == ' ') {
            return p + 1;
        }
    }
    return "";
}

/* ---- stack ---- */

extern uint32_t __stack_limit;
extern uint32_t __stack_top;

size_t board_stack_used(void) {
    const uint32_t* p = &__stack_limit;
    while (p < &__stack_top && *p == 0xCCCCCCCCu) {
        p++;
    }
    return (size_t)((uintptr_t)&__stack_top - (uintptr_t)p);
}

/* ---- memory routines ----
 * The board's memcpy/memmove/memset family in byte loops (volatile, so the compiler does not turn them back into
 * calls to themselves), as in the Rust board (firmware/board/src/arm.rs): one implementation for every firmware on
 * this board, ours and eProsima's, in place of the Rust library's compiler-builtins ones (weak symbols) and
 * newlib's. */

static void copy_forward(volatile uint8_t* d, const volatile uint8_t* s, size_t n) {
    for (size_t i = 0; i < n; i++) {
        d[i] = s[i];
    }
}

static void copy_backward(volatile uint8_t* d, const volatile uint8_t* s, size_t n) {
    while (n-- > 0) {
        d[n] = s[n];
    }
}

static void fill(volatile uint8_t* d, size_t n, uint8_t c) {
    for (size_t i = 0; i < n; i++) {
        d[i] = c;
    }
}

static void move(void* d, const void* s, size_t n) {
    if ((uintptr_t)d <= (uintptr_t)s) {
        copy_forward(d, s, n);
    } else {
        copy_backward(d, s, n);
    }
}

void* memcpy(void* d, const void* s, size_t n) {
    copy_forward(d, s, n);
    return d;
}

void* memmove(void* d, const void* s, size_t n) {
    move(d, s, n);
    return d;
}

void* memset(void* d, int c, size_t n) {
    fill(d, n, (uint8_t)c);
    return d;
}

int memcmp(const void* a, const void* b, size_t n) {
    const volatile uint8_t* x = a;
    const volatile uint8_t* y = b;
    for (size_t i = 0; i < n; i++) {
        if (x[i] != y[i]) {
            return (int)x[i] - (int)y[i];
        }
    }
    return 0;
}

int bcmp(const void* a, const void* b, size_t n) {
    return memcmp(a, b, n);
}

/* The ARM run-time ABI's forms; the 4 and 8 variants only promise alignment. memset's take the length first. */
void __aeabi_memcpy(void* d, const void* s, size_t n) { copy_forward(d, s, n); }
void __aeabi_memcpy4(void* d, const void* s, size_t n) { copy_forward(d, s, n); }
void __aeabi_memcpy8(void* d, const void* s, size_t n) { copy_forward(d, s, n); }
void __aeabi_memmove(void* d, const void* s, size_t n) { move(d, s, n); }
void __aeabi_memmove4(void* d, const void* s, size_t n) { move(d, s, n); }
void __aeabi_memmove8(void* d, const void* s, size_t n) { move(d, s, n); }
void __aeabi_memset(void* d, size_t n, int c) { fill(d, n, (uint8_t)c); }
void __aeabi_memset4(void* d, size_t n, int c) { fill(d, n, (uint8_t)c); }
void __aeabi_memset8(void* d, size_t n, int c) { fill(d, n, (uint8_t)c); }
void __aeabi_memclr(void* d, size_t n) { fill(d, n, 0); }
void __aeabi_memclr4(void* d, size_t n) { fill(d, n, 0); }
void __aeabi_memclr8(void* d, size_t n) { fill(d, n, 0); }
