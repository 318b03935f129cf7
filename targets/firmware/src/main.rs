//! # vsaqem-firmware
//!
//! A `no_std`, `no_main` Cortex-M4F program that runs the whole VSA-QEM pipeline
//! of `vsaqem-core` on a point cloud it generates itself (points on a unit sphere,
//! made with `libm` by `vsaqem_core::sample`), with every byte in a static arena.
//!
//! What it proves, by building at all:
//! - core links into a bare-metal binary with **no global allocator**: there is no
//!   `#[global_allocator]` and no `extern crate alloc` here, so if core (or one of
//!   its dependencies) ever allocated, the link would fail ("no global memory
//!   allocator found but one is required");
//! - the static arena, the points and the stack fit the RAM described in
//!   `memory.x` (256 KiB), or the link fails ("region RAM overflowed").
//!
//! What it proves when run (`--features semihosting`, on QEMU's MPS2 AN386
//! Cortex-M4 board or with a debug probe): the pipeline completes on the target's
//! code generation and gives a closed 2-manifold mesh within `ARENA_BYTES`.
//!
//! No cortex-m-rt: the vector table and the reset code (FPU on, `.data` copied,
//! `.bss` zeroed, stack painted) are the assembly below; `link.x` places them.
#![no_std]
#![no_main]

use core::mem::MaybeUninit;
use core::panic::PanicInfo;
use core::ptr::{addr_of, addr_of_mut};
use vsaqem_core::sample::{fill, Shape};
use vsaqem_core::{Arena, Params, Silent, V3};

/// Points reconstructed.
const POINTS: usize = 1000;
/// Clusters asked for, and the cap splitting may reach (so the mesh has at most
/// this many vertices and the meshing memory stays small).
const CLUSTERS: u32 = 40;
/// Seed of the sample (the CLI's default seed, so `vsaqem reconstruct --sample
/// sphere --points 1000 --clusters 40 --max-clusters 40` runs the same job on a PC).
const SEED: u64 = 1;
/// Arena size. The run on the target peaks at about 131 KB (the firmware reports
/// it, see README.md); this leaves a quarter more. To change the job, measure its
/// peak (on the PC: `vsaqem reconstruct ... --report r.json`, `arena_peak_bytes`)
/// and set this, or use `vsaqem_core::reconstruct_bytes` for a safe upper bound.
const ARENA_BYTES: usize = 160 * 1024;

/// The arena's memory: `.bss`, never touched by anyone but `firmware_main`.
static mut ARENA: [MaybeUninit<u8>; ARENA_BYTES] = [MaybeUninit::uninit(); ARENA_BYTES];
/// The generated points (12 bytes each).
static mut CLOUD: [V3; POINTS] = [[0.0; 3]; POINTS];

/// What the run gave, for a debugger to read (`print RESULT` in gdb).
#[repr(C)]
#[derive(Clone, Copy)]
pub struct Outcome {
    /// 0: not finished; 1: closed manifold mesh; 2: a mesh, but not closed;
    /// 3: core returned an error.
    pub status: u32,
    /// Mesh vertices.
    pub vertices: u32,
    /// Mesh triangles.
    pub faces: u32,
    /// Edges with one face.
    pub boundary_edges: u32,
    /// Edge-connected components.
    pub components: u32,
    /// Arena peak in bytes.
    pub arena_peak: u32,
    /// Stack high-water mark in bytes (painted at reset, scanned at the end).
    pub stack_used: u32,
}

/// The last run's outcome.
#[no_mangle]
pub static mut RESULT: Outcome = Outcome {
    status: 0,
    vertices: 0,
    faces: 0,
    boundary_edges: 0,
    components: 0,
    arena_peak: 0,
    stack_used: 0,
};

const CLOSED: u32 = 1;
const OPEN: u32 = 2;
const FAILED: u32 = 3;

/// Reset code calls this once, with the FPU on and `.data`/`.bss` initialised.
#[no_mangle]
pub extern "C" fn firmware_main() -> ! {
    // SAFETY: this function runs once, with no interrupts enabled, and is the only
    // code that names ARENA and CLOUD, so these are the only references to them.
    let (buf, cloud) = unsafe { (&mut *addr_of_mut!(ARENA), &mut *addr_of_mut!(CLOUD)) };
    fill(Shape::Sphere, SEED, 0.0, cloud);
    let arena = Arena::new(&mut buf[..]);
    let params = Params {
        clusters: CLUSTERS,
        max_clusters: CLUSTERS,
        ..Params::default()
    };
    let run = vsaqem_core::reconstruct(&arena, cloud, None, &params, &mut Silent);
    let mut out = Outcome {
        status: FAILED,
        vertices: 0,
        faces: 0,
        boundary_edges: 0,
        components: 0,
        arena_peak: arena.peak() as u32,
        stack_used: stack_used(),
    };
    match &run {
        Ok(r) => {
            let m = &r.mesh.stats;
            // Closed 2-manifold of genus 0: no border, one piece, every edge in two
            // faces (E = 3F/2), so Euler V - E + F = 2 means 2V - F = 4.
            let sphere_like = m.faces > 0
                && m.boundary_edges == 0
                && m.components == 1
                && 2 * m.vertices == m.faces + 4
                && r.mesh.triangles.len() == m.faces as usize;
            out.status = if sphere_like { CLOSED } else { OPEN };
            out.vertices = m.vertices;
            out.faces = m.faces;
            out.boundary_edges = m.boundary_edges;
            out.components = m.components;
        }
        Err(_) => out.status = FAILED,
    }
    // SAFETY: single-threaded, no interrupts; a volatile write keeps the result
    // observable to a debugger even though nothing in the program reads it.
    unsafe { core::ptr::write_volatile(addr_of_mut!(RESULT), out) };
    finish(&out, run.as_ref().err())
}

/// With semihosting: print the outcome and exit with its status.
#[cfg(feature = "semihosting")]
fn finish(out: &Outcome, err: Option<&vsaqem_core::Error>) -> ! {
    semihosting::report(out, err)
}

/// On a board: leave the outcome in `RESULT` and sleep.
#[cfg(not(feature = "semihosting"))]
fn finish(_: &Outcome, _: Option<&vsaqem_core::Error>) -> ! {
    idle()
}

/// Something went wrong that the program cannot report as an `Outcome`.
#[cfg(feature = "semihosting")]
fn halt(what: &str) -> ! {
    semihosting::fail(what)
}

/// Something went wrong: stop here (a debugger shows where).
#[cfg(not(feature = "semihosting"))]
fn halt(_: &str) -> ! {
    idle()
}

/// Bytes of stack used so far: the painted words below the deepest write are intact.
fn stack_used() -> u32 {
    extern "C" {
        static _stack_bottom: u32;
        static _stack_top: u32;
    }
    let bottom = addr_of!(_stack_bottom) as usize;
    let top = addr_of!(_stack_top) as usize;
    let mut p = bottom;
    // SAFETY: [bottom, top) is the stack region from link.x; reading it as words
    // is always valid, and the part below the current stack pointer is unused.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == STACK_PAINT {
        p += 4;
    }
    (top - p) as u32
}

/// The word Reset writes over the whole stack.
const STACK_PAINT: u32 = 0x5AA5_F00D;

fn idle() -> ! {
    loop {
        // SAFETY: `wfi` only waits for an interrupt.
        unsafe { core::arch::asm!("wfi", options(nomem, nostack)) };
    }
}

#[panic_handler]
fn panic(_info: &PanicInfo) -> ! {
    // Core never panics by contract; if it did, say so where someone can see it.
    halt("panic")
}

/// Every exception but Reset (a fault lands here).
#[no_mangle]
pub extern "C" fn DefaultHandler() -> ! {
    halt("fault")
}

// Vector table and reset code. Thumb function addresses get their low bit set by
// the assembler/linker. Reset turns the FPU on (CPACR: CP10 and CP11 full access)
// before any Rust code runs, since this target's code uses FPU instructions.
core::arch::global_asm!(
    r#"
    .syntax unified
    .thumb

    .section .vectors, "a"
    .global VECTORS
    .p2align 2
VECTORS:
    .word _stack_top
    .word Reset
    .word DefaultHandler  /* NMI */
    .word DefaultHandler  /* HardFault */
    .word DefaultHandler  /* MemManage */
    .word DefaultHandler  /* BusFault */
    .word DefaultHandler  /* UsageFault */
    .word 0, 0, 0, 0
    .word DefaultHandler  /* SVCall */
    .word DefaultHandler  /* DebugMonitor */
    .word 0
    .word DefaultHandler  /* PendSV */
    .word DefaultHandler  /* SysTick */

    .section .text.Reset, "ax"
    .global Reset
    .type Reset, %function
    .thumb_func
Reset:
    ldr r0, =0xE000ED88
    ldr r1, [r0]
    orr r1, r1, #0xF00000
    str r1, [r0]
    dsb
    isb

    ldr r0, =_sbss
    ldr r1, =_ebss
    movs r2, #0
1:  cmp r0, r1
    bhs 2f
    str r2, [r0], #4
    b 1b

2:  ldr r0, =_sdata
    ldr r1, =_edata
    ldr r2, =_sidata
3:  cmp r0, r1
    bhs 4f
    ldr r3, [r2], #4
    str r3, [r0], #4
    b 3b

4:  ldr r0, =_stack_bottom
    mov r1, sp
    ldr r2, ={paint}
5:  cmp r0, r1
    bhs 6f
    str r2, [r0], #4
    b 5b

6:  bl firmware_main
    b 6b
    .size Reset, . - Reset
    .ltorg
    "#,
    paint = const STACK_PAINT,
);

/// Arm semihosting: text to the debugger's console and an exit status (QEMU
/// passes it on as its own exit code: 0 for a closed mesh, 1 otherwise).
#[cfg(feature = "semihosting")]
mod semihosting {
    use super::{Outcome, CLOSED};
    use core::fmt::Write;
    use vsaqem_core::Error;

    const SYS_WRITE0: usize = 0x04;
    const SYS_EXIT: usize = 0x18;
    const APPLICATION_EXIT: usize = 0x20026;
    const RUNTIME_ERROR: usize = 0x20023;

    fn call(op: usize, arg: usize) {
        // SAFETY: the semihosting trap: the debugger (or QEMU) reads r0/r1 and the
        // memory r1 points to; nothing else changes but r0.
        unsafe {
            core::arch::asm!("bkpt #0xab", inout("r0") op => _, in("r1") arg, options(nostack))
        };
    }

    /// A line of text, NUL-terminated for SYS_WRITE0 (long lines are cut).
    struct Line {
        buf: [u8; 160],
        len: usize,
    }

    impl Write for Line {
        fn write_str(&mut self, s: &str) -> core::fmt::Result {
            for &b in s.as_bytes() {
                if self.len + 1 < self.buf.len() {
                    self.buf[self.len] = b;
                    self.len += 1;
                }
            }
            Ok(())
        }
    }

    fn print(args: core::fmt::Arguments) {
        let mut line = Line {
            buf: [0; 160],
            len: 0,
        };
        let _ = line.write_fmt(args);
        line.buf[line.len] = 0;
        call(SYS_WRITE0, line.buf.as_ptr() as usize);
    }

    fn exit(ok: bool) -> ! {
        call(SYS_EXIT, if ok { APPLICATION_EXIT } else { RUNTIME_ERROR });
        super::idle()
    }

    pub fn report(o: &Outcome, err: Option<&Error>) -> ! {
        print(format_args!(
            "vsaqem-firmware: {} points, {} clusters, arena {} B\n",
            super::POINTS,
            super::CLUSTERS,
            super::ARENA_BYTES
        ));
        if let Some(e) = err {
            print(format_args!("error: {e}\n"));
        }
        print(format_args!(
            "mesh: {} vertices, {} faces, {} boundary edges, {} components\n",
            o.vertices, o.faces, o.boundary_edges, o.components
        ));
        print(format_args!(
            "arena peak {} B, stack used {} B\n",
            o.arena_peak, o.stack_used
        ));
        let ok = o.status == CLOSED;
        print(format_args!(
            "{}\n",
            if ok {
                "closed manifold: yes"
            } else {
                "closed manifold: no"
            }
        ));
        exit(ok)
    }

    pub fn fail(what: &str) -> ! {
        print(format_args!("vsaqem-firmware: {what}\n"));
        exit(false)
    }
}
