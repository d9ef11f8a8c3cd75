/* Reset, vector table and semihosting for the C firmware (no newlib start files): enable the
 * FPU, zero .bss, run main, exit through semihosting with main's status. */
#include <stdint.h>
#include "semihost.h"

extern uint32_t __bss_start__, __bss_end__, __StackTop;
int main(void);

static int semihost(int op, const void *arg) {
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

/* QEMU's stdout: SYS_OPEN(":tt", "w"), then SYS_WRITE on that handle (SYS_WRITE0 goes to
 * the debug console, which -nographic does not show). */
void sh_write0(const char *s) {
    static int handle = -1;
    if (handle < 0) {
        const uint32_t open[3] = {(uint32_t)":tt", 4 /* "w" */, 3};
        handle = semihost(0x01 /* SYS_OPEN */, open);
    }
    uint32_t len = 0;
    while (s[len]) len++;
    const uint32_t write[3] = {(uint32_t)handle, (uint32_t)s, len};
    semihost(0x05 /* SYS_WRITE */, write);
}

void sh_exit(int status) {
    /* SYS_EXIT_EXTENDED: ADP_Stopped_ApplicationExit with the exit code. */
    const uint32_t block[2] = {0x20026, (uint32_t)status};
    semihost(0x20, block);
    for (;;) {
    }
}

void Reset_Handler(void) {
    /* CP10, CP11 full access: the library is built for the hard-float ABI. */
    *(volatile uint32_t *)0xE000ED88 |= 0xFu << 20;
    __asm__ volatile("dsb\n isb");
    for (uint32_t *p = &__bss_start__; p < &__bss_end__; p++) *p = 0;
    sh_exit(main());
}

static void fault(void) {
    sh_write0("X fault\n");
    sh_exit(2);
}

__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))&__StackTop, Reset_Handler, fault, fault, fault, fault, fault, 0, 0, 0, 0,
    fault, fault, 0, fault, fault,
};
