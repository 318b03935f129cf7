/* vsaqem from C on a Cortex-M4F: a bare-metal program (no C library, no heap)
 * that reconstructs a 1,000-point sphere it generates itself, with every byte
 * in one static buffer, and reports over semihosting. Linked with
 * arm-none-eabi-gcc against the thumbv7em-none-eabihf static library and the
 * Rust firmware's linker script (targets/firmware/link.x and memory.x: 1 MiB
 * flash, 256 KiB RAM, where QEMU's mps2-an386 board has them). bindings/c/test.sh
 * builds it and runs it on QEMU; it exits 0 only for a closed sphere-like mesh. */
#include "vsaqem.h"

#include <stddef.h>
#include <stdint.h>

#define POINTS 1000
/* The CLI's `vsaqem reconstruct --sample sphere --points 1000 --clusters 40
 * --max-clusters 40 --min-fragment 0` runs the same job (on its own sample). */
#define CLUSTERS 40
/* The library's arrays (29 bytes a point: the points, their normals, an index
 * and flags) and an arena of 160 KiB, as the Rust firmware's: smaller than
 * vsaqem_arena_bytes (the worst case, see the README), since core checks what
 * this cloud needs as it goes. The program prints the peak. */
#define BUFFER_BYTES (29 * POINTS + 160 * 1024)

static float cloud[3 * POINTS];
static uint8_t buffer[BUFFER_BYTES];

/* --- semihosting: the debugger's (or QEMU's) console and exit ------------- */

static void semihost(uint32_t op, const void *arg) {
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt #0xab" : "+r"(r0) : "r"(r1) : "memory");
}

static void print(const char *s) { semihost(0x04, s); /* SYS_WRITE0 */ }

static void print_uint(uint32_t v) {
    char digits[11];
    int i = 10;
    digits[i] = 0;
    do {
        digits[--i] = (char)('0' + v % 10);
        v /= 10;
    } while (v);
    print(digits + i);
}

static void finish(int ok) {
    /* SYS_EXIT with ADP_Stopped_ApplicationExit or _RunTimeErrorUnknown. */
    semihost(0x18, (const void *)(ok ? 0x20026u : 0x20023u));
    for (;;) __asm__ volatile("wfi");
}

/* --- the points: a Fibonacci sphere, without a maths library --------------- */

static float sqrt_f(float x) {
    float r;
    __asm__("vsqrt.f32 %0, %1" : "=t"(r) : "t"(x));
    return r;
}

static void sphere(float *p, int n) {
    /* Successive points turn by the golden angle: rotate (c, s) by it. */
    const float cg = -0.73736887f, sg = 0.67549029f; /* cos, sin of 2.39996323 */
    float c = 1.0f, s = 0.0f;
    for (int i = 0; i < n; i++) {
        float y = 1.0f - 2.0f * ((float)i + 0.5f) / (float)n;
        float r = sqrt_f(1.0f - y * y);
        p[3 * i] = r * c;
        p[3 * i + 1] = y;
        p[3 * i + 2] = r * s;
        float c2 = c * cg - s * sg;
        s = c * sg + s * cg;
        c = c2;
    }
}

/* --- the job ---------------------------------------------------------------- */

static void run(void) {
    sphere(cloud, POINTS);
    vsaqem_params p = vsaqem_params_default();
    p.clusters = CLUSTERS;
    p.max_clusters = CLUSTERS;
    p.min_fragment = 0; /* one generated piece: no cleaning, no k-NN table */
    vsaqem_mesh m;
    int32_t s = vsaqem_reconstruct(buffer, sizeof buffer, cloud, POINTS, NULL, &p, &m);
    if (s != VSAQEM_OK) {
        print("vsaqem_reconstruct failed: ");
        print(m.message);
        print("\n");
        finish(0);
    }
    /* Closed, one piece, genus 0: 2V - F = 4; every index in range. */
    int ok = m.boundary_edges == 0 && m.components == 1 &&
             2 * m.vertex_count == m.triangle_count + 4;
    for (size_t i = 0; i < 3 * m.triangle_count; i++) ok = ok && m.triangles[i] < m.vertex_count;
    print("C firmware: ");
    print_uint(POINTS);
    print(" points -> ");
    print_uint((uint32_t)m.vertex_count);
    print(" vertices, ");
    print_uint((uint32_t)m.triangle_count);
    print(" triangles, ");
    print_uint(m.boundary_edges);
    print(" boundary edges; buffer ");
    print_uint(BUFFER_BYTES);
    print(" bytes, peak ");
    print_uint((uint32_t)m.buffer_peak);
    print(" (vsaqem_arena_bytes: ");
    print_uint((uint32_t)m.buffer_needed);
    print(")\nclosed manifold: ");
    print(ok ? "yes\n" : "no\n");
    finish(ok);
}

/* --- reset and vectors (the names link.x expects) --------------------------- */

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _stack_top;

void Reset(void) {
    /* FPU on (CPACR: CP10 and CP11 full access) before any float instruction. */
    *(volatile uint32_t *)0xE000ED88 |= 0xFu << 20;
    __asm__ volatile("dsb\n isb");
    uint32_t *src = &_sidata, *dst = &_sdata;
    while (dst < &_edata) *dst++ = *src++;
    for (dst = &_sbss; dst < &_ebss;) *dst++ = 0;
    run();
}

void DefaultHandler(void) {
    print("fault\n");
    finish(0);
}

__attribute__((section(".vectors"), used)) const void *const VECTORS[16] = {
    &_stack_top, (const void *)Reset,
    (const void *)DefaultHandler, (const void *)DefaultHandler, /* NMI, HardFault */
    (const void *)DefaultHandler, (const void *)DefaultHandler, /* MemManage, BusFault */
    (const void *)DefaultHandler, 0, 0, 0, 0,                   /* UsageFault */
    (const void *)DefaultHandler, (const void *)DefaultHandler, /* SVCall, DebugMonitor */
    0, (const void *)DefaultHandler, (const void *)DefaultHandler, /* PendSV, SysTick */
};
