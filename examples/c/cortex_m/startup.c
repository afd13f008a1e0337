/* Start-up for a bare Cortex-M4F under QEMU's mps2-an386: the vector table (SysTick is the
 * servo's, in main.c), the reset handler (copy .data, clear .bss, turn the FPU on, run main,
 * exit), a fault handler, and the few semihosting calls the example prints and exits with. No
 * C library is used. */
#include <stdint.h>

#include "semihost.h"

extern uint32_t __data_start, __data_end, __data_load, __bss_start, __bss_end, __stack_top;
int main(void);
/* The servo's timer event (main.c). */
void systick_handler(void);

/* Semihosting: operation `op` with argument `arg`, through the BKPT 0xAB trap QEMU serves
 * when started with -semihosting-config enable=on. */
static uint32_t semihost(uint32_t op, const void *arg) {
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void sh_puts(const char *s) { semihost(0x04 /* SYS_WRITE0 */, s); }

void sh_exit(int ok) {
    /* SYS_EXIT with ADP_Stopped_ApplicationExit (QEMU exits 0) or RunTimeErrorUnknown (1). */
    semihost(0x18, (const void *)(uintptr_t)(ok ? 0x20026u : 0x20023u));
    for (;;) {
    }
}

void reset_handler(void) {
    uint32_t *src = &__data_load;
    for (uint32_t *dst = &__data_start; dst < &__data_end;)
        *dst++ = *src++;
    for (uint32_t *dst = &__bss_start; dst < &__bss_end;)
        *dst++ = 0;
    /* CPACR: full access to the coprocessors CP10 and CP11 (the FPU) before any float code. */
    volatile uint32_t *cpacr = (volatile uint32_t *)0xE000ED88u;
    *cpacr |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    sh_exit(main() == 0);
}

/* Every fault, and the library's panic handler (an undefined instruction), ends here. */
static void fault_handler(void) {
    sh_puts("fault: the program stopped on a fault\n");
    sh_exit(0);
}

static void default_handler(void) {
    sh_puts("fault: unexpected interrupt\n");
    sh_exit(0);
}

/* The vector table: the initial stack pointer, then the 15 system exceptions (interrupts of
 * the board's peripherals are never enabled here; SysTick is the servo's timer). */
__attribute__((section(".vectors"), used)) static const void *const vectors[16] = {
    &__stack_top,
    (const void *)reset_handler,
    (const void *)default_handler, /* NMI */
    (const void *)fault_handler,   /* HardFault */
    (const void *)fault_handler,   /* MemManage */
    (const void *)fault_handler,   /* BusFault */
    (const void *)fault_handler,   /* UsageFault */
    0, 0, 0, 0,
    (const void *)default_handler, /* SVCall */
    (const void *)default_handler, /* DebugMonitor */
    0,
    (const void *)default_handler, /* PendSV */
    (const void *)systick_handler, /* SysTick: the servo */
};
