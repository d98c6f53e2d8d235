/*
 * Freestanding link test of the DynaSlice core (see docs/firmware.md).
 *
 * Built with `gcc -ffreestanding -nostdlib -static`: no libc, no crt0, no dynamic loader. The
 * program brings its own `_start`, talks to Linux through raw syscalls, and supplies the four
 * memory functions that both GCC (even with -ffreestanding) and rustc's code may call.
 *
 * It asks the Rust static library for the transcript of the embedded models and compares every
 * word with the host reference `expected.h` written by modelgen. Exit status: 0 when all words
 * match bit for bit, 1 on a mismatch, 2 when a model was refused, 3 on a length mismatch, 101 on
 * a Rust panic.
 *
 * Run with any argument (`./selftest control`) it is its own negative control: it flips one bit
 * of the reference and must then exit 1, which shows the comparison can fail.
 */
#include <stddef.h>
#include <stdint.h>

#include "expected.h"

int32_t dynaslice_fw_transcript(uint32_t *out, size_t cap);

/* --- Linux x86-64 system calls ------------------------------------------------------------- */

static long sys3(long nr, long a, long b, long c) {
    long ret;
    __asm__ volatile("syscall"
                     : "=a"(ret)
                     : "a"(nr), "D"(a), "S"(b), "d"(c)
                     : "rcx", "r11", "memory");
    return ret;
}

static void say(const char *s) {
    size_t n = 0;
    while (s[n]) n++;
    sys3(1 /* write */, 1, (long)s, (long)n);
}

static void say_hex(uint32_t v) {
    char buf[11] = "0x";
    for (int i = 0; i < 8; i++) buf[2 + i] = "0123456789abcdef"[(v >> (28 - 4 * i)) & 0xF];
    buf[10] = 0;
    say(buf);
}

static void say_int(int32_t v) {
    char buf[12];
    int i = 11;
    uint32_t u = v < 0 ? 0u - (uint32_t)v : (uint32_t)v;
    buf[i] = 0;
    do {
        buf[--i] = (char)('0' + u % 10);
        u /= 10;
    } while (u);
    if (v < 0) buf[--i] = '-';
    say(buf + i);
}

static _Noreturn void exit_group(int status) {
    sys3(231 /* exit_group */, status, 0, 0);
    for (;;) {
    }
}

/* Called by the Rust panic handler. */
_Noreturn void dynaslice_fw_panic(void) {
    say("selftest: Rust panic\n");
    exit_group(101);
}

/* --- The memory functions a freestanding program must provide ------------------------------ */
/* Byte loops on purpose: tiny and obviously right. This file is compiled with -fno-builtin and
 * -fno-tree-loop-distribute-patterns so GCC does not turn these loops into calls to themselves. */

void *memcpy(void *dst, const void *src, size_t n) {
    unsigned char *d = dst;
    const unsigned char *s = src;
    while (n--) *d++ = *s++;
    return dst;
}

void *memmove(void *dst, const void *src, size_t n) {
    unsigned char *d = dst;
    const unsigned char *s = src;
    if (d < s) {
        while (n--) *d++ = *s++;
    } else {
        while (n--) d[n] = s[n];
    }
    return dst;
}

void *memset(void *dst, int c, size_t n) {
    unsigned char *d = dst;
    while (n--) *d++ = (unsigned char)c;
    return dst;
}

int memcmp(const void *a, const void *b, size_t n) {
    const unsigned char *x = a, *y = b;
    for (; n; n--, x++, y++)
        if (*x != *y) return *x < *y ? -1 : 1;
    return 0;
}

int bcmp(const void *a, const void *b, size_t n) { return memcmp(a, b, n); }

/* --- The test -------------------------------------------------------------------------------- */

static uint32_t got[DYNASLICE_EXPECTED_LEN + 1];

static int run(long argc) {
    int control = argc > 1;
    int32_t n = dynaslice_fw_transcript(got, DYNASLICE_EXPECTED_LEN + 1);
    if (n < 0) {
        say("selftest: transcript failed with code ");
        say_int(n);
        say("\n");
        return 2;
    }
    if (n != DYNASLICE_EXPECTED_LEN) {
        say("selftest: transcript has ");
        say_int(n);
        say(" words, the reference ");
        say_int(DYNASLICE_EXPECTED_LEN);
        say("\n");
        return 3;
    }
    int32_t mismatches = 0;
    for (int32_t i = 0; i < n; i++) {
        uint32_t want = dynaslice_expected[i];
        if (control && i == 0) want ^= 1u; /* the negative control: one bit of f off */
        if (got[i] != want) {
            if (mismatches < 5) {
                say("selftest: word ");
                say_int(i);
                say(" is ");
                say_hex(got[i]);
                say(", the host says ");
                say_hex(want);
                say("\n");
            }
            mismatches++;
        }
    }
    say("selftest: f(first query) = ");
    say_hex(got[0]);
    say(control ? " (negative control)\n" : "\n");
    if (mismatches) {
        say("selftest: ");
        say_int(mismatches);
        say(" mismatching words\n");
        return 1;
    }
    say("selftest: all ");
    say_int(n);
    say(" words match the host reference bit for bit\n");
    return 0;
}

/* Called from _start with the initial stack pointer, where the kernel put argc. */
_Noreturn void start_c(long *sp) { exit_group(run(sp[0])); }

/* The entry point: clear the frame pointer (end of backtraces), pass the initial stack pointer,
 * and align the stack to 16 bytes as the System V ABI requires at a call. */
__asm__(".text\n"
        ".global _start\n"
        "_start:\n"
        "    xor %ebp, %ebp\n"
        "    mov %rsp, %rdi\n"
        "    and $-16, %rsp\n"
        "    call start_c\n"
        "    hlt\n");
