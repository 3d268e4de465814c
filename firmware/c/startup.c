/* Start-up for Cortex-M on QEMU's mps2-an386: the vector table, the reset handler (copies .data, zeroes .bss,
 * paints the stack for board_stack_used, calls main), and a fault handler that reports through semihosting. */
#include <stdint.h>

#include "board.h"

extern uint32_t __data_load, __data_start, __data_end, __bss_start, __bss_end, __stack_limit, __stack_top;
extern int main(void);

void Reset_Handler(void) __attribute__((noreturn));
void Fault_Handler(void);
void Default_Handler(void);
void SysTick_Handler(void);

__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(&__stack_top),
    Reset_Handler,
    Default_Handler, /* NMI */
    Fault_Handler,   /* HardFault */
    Fault_Handler,   /* MemManage */
    Fault_Handler,   /* BusFault */
    Fault_Handler,   /* UsageFault */
    0, 0, 0, 0,
    Default_Handler, /* SVCall */
    Default_Handler, /* DebugMonitor */
    0,
    Default_Handler, /* PendSV */
    SysTick_Handler,
};

void Reset_Handler(void) {
    uint32_t* src = &__data_load;
    for (uint32_t* dst = &__data_start; dst < &__data_end;) {
        *dst++ = *src++;
    }
    for (uint32_t* dst = &__bss_start; dst < &__bss_end;) {
        *dst++ = 0;
    }
    /* Paint the stack below the current frame (the reset handler's own frame is a few words). */
    uint32_t* sp;
    __asm volatile("mov %0, sp" : "=r"(sp));
    for (uint32_t* p = &__stack_limit; p < sp - 8;) {
        *p++ = 0xCCCCCCCCu;
    }
#if defined(__ARM_FP)
    /* Enable the FPU (CP10, CP11) before any floating-point instruction. */
    *(volatile uint32_t*)0xE000ED88u |= 0xFu << 20;
    __asm volatile("dsb\n isb");
#endif
    board_exit(main());
}

void Fault_Handler(void) {
    board_print("fault\n");
    board_exit(102);
}

void Default_Handler(void) {
    board_print("unexpected exception\n");
    board_exit(103);
}
