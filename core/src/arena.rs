//! A bump arena over a caller-owned byte buffer: the only source of memory in core.
//!
//! Layout: *persistent* allocations grow upwards from the start of the buffer and
//! live as long as the arena; *scratch* allocations grow downwards from its end and
//! are reclaimed when the [`Arena::scratch`] scope that made them returns. The two
//! ends meet in the middle: a request that does not fit between them fails with
//! [`Exhausted`], never a panic.
//!
//! ```text
//!  buffer: [ persistent ->  ......free......  <- scratch (innermost scope lowest) ]
//!           0          front                back                              len
//! ```
//!
//! Only `Copy` types are handed out, so nothing ever needs dropping and reclaiming a
//! scope is just moving an offset. `used()` and `peak()` are exact byte counts
//! (alignment padding included), so the memory tests can compare them with the
//! predicted budget.
//!
//! Every allocation starts a multiple of [`GRANULE`] (8) bytes from the start and
//! takes a multiple of it, so no type of alignment up to 8 ever needs padding, and
//! `used()` and `peak()` depend only on the sequence of requests, not on where the
//! buffer lies or how long it is: a run that peaked at `P` bytes fits in any
//! buffer of `P` bytes that starts on an 8-byte boundary (as heap allocations
//! do). A buffer that does not loses up to 7 bytes at its start; its last
//! `len % 8` bytes are never used.
//!
//! This is the one module of the crate that uses `unsafe`: turning the raw buffer
//! into typed, disjoint `&mut [T]` slices. Every block states why it is sound.
#![allow(unsafe_code)]

use core::cell::Cell;
use core::fmt;
use core::marker::PhantomData;
use core::mem::{align_of, size_of, MaybeUninit};
use core::ptr::NonNull;

use crate::parallel;
use crate::progress::Progress;

/// The arena could not satisfy an allocation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Exhausted {
    /// Bytes the failed allocation asked for (alignment padding included;
    /// `usize::MAX` when the size itself overflowed).
    pub requested: usize,
    /// Bytes that were free between the two ends at that moment.
    pub available: usize,
}

impl fmt::Display for Exhausted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "memory arena exhausted: needed {} more bytes, {} available",
            self.requested, self.available
        )
    }
}

/// Every allocation starts on, and takes, a multiple of this many bytes.
pub const GRANULE: usize = 8;

/// Fewest bytes an allocation of [`Alloc::try_alloc_slice_on`] fills on
/// several threads (below it, handing out the tasks costs more than they
/// save). Under Miri a few hundred bytes, so that its run of the tests
/// takes the parallel path without filling megabytes an interpreted write
/// at a time (the test of the fills took Miri over twenty minutes).
pub const PARALLEL_FILL: usize = if cfg!(miri) { 256 } else { 64 * 1024 };

/// `bytes` rounded up to a multiple of [`GRANULE`] (`None` on overflow).
fn granules(bytes: usize) -> Option<usize> {
    bytes.checked_add(GRANULE - 1).map(|b| b & !(GRANULE - 1))
}

/// Bytes a request for `count` values of `T` takes from an [`Arena`], at either
/// end: its size rounded up to the granule, plus alignment padding for types
/// aligned to more than 8 bytes. Exact for the types core uses; saturates instead
/// of overflowing, for budgets.
pub fn padded_bytes<T>(count: usize) -> usize {
    count
        .checked_mul(size_of::<T>())
        .and_then(granules)
        .unwrap_or(usize::MAX)
        .saturating_add(align_of::<T>().saturating_sub(GRANULE))
}

/// Bump arena over `&'buf mut [MaybeUninit<u8>]`. See the module docs.
///
/// Not `Sync`: offsets live in `Cell`s, so allocation needs only `&self` and
/// any number of disjoint slices can be alive at once.
pub struct Arena<'buf> {
    base: NonNull<u8>,
    len: usize,
    /// First free byte after the persistent allocations.
    front: Cell<usize>,
    /// First byte of the innermost scratch allocation (`len` when none).
    back: Cell<usize>,
    /// Depth of the innermost live scratch scope (0: none).
    depth: Cell<u32>,
    peak: Cell<usize>,
    /// `used()` may not exceed this (`usize::MAX`: no ceiling). See
    /// [`Arena::with_ceiling`].
    ceiling: Cell<usize>,
    /// A request failed while the ceiling was at or below the buffer's end.
    ceiling_hit: Cell<bool>,
    _buf: PhantomData<&'buf mut [MaybeUninit<u8>]>,
}

impl<'buf> Arena<'buf> {
    /// An empty arena over `buf`. The arena borrows the buffer mutably for its whole
    /// life; dropping the arena gives the buffer back for reuse.
    /// The part of the buffer used starts at its first 8-byte boundary and ends at
    /// a multiple of 8 bytes from there (see the module docs).
    pub fn new(buf: &'buf mut [MaybeUninit<u8>]) -> Self {
        let skip = ((buf.as_ptr() as usize).wrapping_neg() & (GRANULE - 1)).min(buf.len());
        let buf = &mut buf[skip..];
        let len = buf.len() & !(GRANULE - 1);
        // A slice pointer is never null (it is dangling but aligned when empty).
        let base = NonNull::from(buf).cast::<u8>();
        Arena {
            base,
            len,
            front: Cell::new(0),
            back: Cell::new(len),
            depth: Cell::new(0),
            peak: Cell::new(0),
            ceiling: Cell::new(usize::MAX),
            ceiling_hit: Cell::new(false),
            _buf: PhantomData,
        }
    }

    /// Usable size of the buffer in bytes (see [`Arena::new`]).
    pub fn capacity(&self) -> usize {
        self.len
    }

    /// Bytes currently allocated (persistent plus live scratch), padding included.
    pub fn used(&self) -> usize {
        self.front.get() + (self.len - self.back.get())
    }

    /// The largest `used()` ever reached.
    pub fn peak(&self) -> usize {
        self.peak.get()
    }

    /// Whether a request of `bytes` (padding included) would fit and leave
    /// [`Arena::peak`] where it is: for memory a stage may use when the run
    /// has needed that much anyway (a cache, intermediate results kept for
    /// later), never a reason for a larger buffer.
    ///
    /// At the back (a [`Scratch`] request), with no [`Arena::reset`] since
    /// the peak, such a request also lies in bytes handed out before: the
    /// front has only grown since the peak, so `used() + bytes <= peak()`
    /// puts the new scratch above the deepest scratch of that moment. In a
    /// buffer the operating system backs page by page on first touch, it
    /// then adds no resident memory either.
    pub fn fits_under_peak(&self, bytes: usize) -> bool {
        bytes <= self.available() && self.used().saturating_add(bytes) <= self.peak()
    }

    /// Bytes the next allocation may take (padding included): the free space
    /// between the two ends, or less under a ceiling ([`Arena::with_ceiling`]).
    pub fn available(&self) -> usize {
        self.room()
            .min(self.ceiling.get().saturating_sub(self.used()))
    }

    /// Bytes between the two ends.
    fn room(&self) -> usize {
        self.back.get() - self.front.get()
    }

    /// The error for a request of `need` bytes that does not fit, noting when the
    /// ceiling, not the buffer's end, was the limit (or both, at the same place).
    fn refuse(&self, need: usize) -> Exhausted {
        if self.ceiling.get().saturating_sub(self.used()) <= self.room() {
            self.ceiling_hit.set(true);
        }
        Exhausted {
            requested: need,
            available: self.available(),
        }
    }

    /// Run `f` with `used()` capped at `ceiling` bytes (or at an enclosing
    /// ceiling, when lower): a request beyond it fails with [`Exhausted`] as if
    /// the buffer ended there, so a stage can be held to a budget of its own
    /// inside a larger buffer. Returns `f`'s result and whether some request
    /// failed while this ceiling was at or below the buffer's end: then the
    /// ceiling, not the buffer, was too small.
    pub fn with_ceiling<R>(&self, ceiling: usize, f: impl FnOnce() -> R) -> (R, bool) {
        let (outer, outer_hit) = (self.ceiling.get(), self.ceiling_hit.get());
        self.ceiling.set(outer.min(ceiling));
        self.ceiling_hit.set(false);
        let out = f();
        let hit = self.ceiling_hit.get();
        self.ceiling.set(outer);
        self.ceiling_hit.set(outer_hit || hit);
        (out, hit)
    }

    fn note_peak(&self) {
        let used = self.used();
        if used > self.peak.get() {
            self.peak.set(used);
        }
    }

    /// The bytes `count` values of `T` take: a multiple of the granule.
    fn byte_size<T>(count: usize) -> Result<usize, Exhausted> {
        count
            .checked_mul(size_of::<T>())
            .and_then(granules)
            .ok_or(Exhausted {
                requested: usize::MAX,
                available: 0,
            })
    }

    /// Reserve room for `count` values of `T` at the front. Returns the byte offset.
    /// Both ends stay on granule boundaries; padding is needed only for types
    /// aligned to more than the granule.
    fn reserve_front<T>(&self, count: usize) -> Result<usize, Exhausted> {
        let bytes = Self::byte_size::<T>(count)?;
        let front = self.front.get();
        let addr = self.base.as_ptr() as usize + front;
        let pad = addr.wrapping_neg() & (align_of::<T>() - 1);
        let need = bytes.saturating_add(pad);
        if need > self.available() {
            return Err(self.refuse(need));
        }
        self.front.set(front + need);
        self.note_peak();
        Ok(front + pad)
    }

    /// Reserve room for `count` values of `T` at the back. Returns the byte offset.
    fn reserve_back<T>(&self, count: usize) -> Result<usize, Exhausted> {
        let bytes = Self::byte_size::<T>(count)?;
        let back = self.back.get();
        if bytes > self.available() {
            return Err(self.refuse(bytes));
        }
        let start = back - bytes;
        let addr = self.base.as_ptr() as usize + start;
        let aligned = start - (addr & (align_of::<T>() - 1));
        if back - aligned > self.available() {
            return Err(self.refuse(back - aligned));
        }
        self.back.set(aligned);
        self.note_peak();
        Ok(aligned)
    }

    /// Fill `count` slots at byte `offset` with `value` and hand them out.
    #[allow(clippy::mut_from_ref)] // each offset is handed out once: see SAFETY
    fn fill_at<T: Copy>(&self, offset: usize, count: usize, value: T) -> &mut [T] {
        if size_of::<T>() == 0 {
            // SAFETY: a slice of a zero-sized type needs no memory, only a non-null,
            // aligned pointer, which `dangling` is.
            return unsafe {
                core::slice::from_raw_parts_mut(NonNull::<T>::dangling().as_ptr(), count)
            };
        }
        // SAFETY: `reserve_*` returned an offset inside the buffer where
        // `count * size_of::<T>()` bytes are free, aligned for `T`, and not handed out
        // to anyone else (the front and back regions never overlap, and a region is
        // only reused after the scope that owned it has ended, which the borrow on
        // `Scratch` enforces). `T: Copy` has no drop glue, so abandoning values when a
        // scope ends is fine. Every slot is written before the slice is formed.
        unsafe {
            let ptr = self.base.as_ptr().add(offset).cast::<T>();
            for i in 0..count {
                ptr.add(i).write(value);
            }
            core::slice::from_raw_parts_mut(ptr, count)
        }
    }

    /// `count` slots at byte `offset`, slot `i` set to `f(i)` by the tasks of
    /// `hooks` ([`parallel::TASKS`] ranges, on whatever threads it has), and
    /// handed out: a large allocation is not filled on the calling thread
    /// alone while the others wait.
    #[allow(clippy::mut_from_ref)] // each offset is handed out once: see `fill_at`
    fn fill_at_with<T: Copy + Send>(
        &self,
        offset: usize,
        count: usize,
        f: impl Fn(usize) -> T + Sync,
        hooks: &dyn Progress,
    ) -> &mut [T] {
        if size_of::<T>() == 0 {
            // No memory to write: the values are made one after another
            // (`f` is called for each index, as it is for any type).
            let mut last = None;
            for i in 0..count {
                last = Some(f(i));
            }
            return match last {
                Some(v) => self.fill_at(offset, count, v),
                None => &mut [],
            };
        }
        // SAFETY: as in `fill_at`, the `count` slots at `offset` are free,
        // aligned for `T` and handed to no one else; as `MaybeUninit<T>` they
        // may be formed before they are written.
        let slots = unsafe {
            let ptr = self.base.as_ptr().add(offset).cast::<MaybeUninit<T>>();
            core::slice::from_raw_parts_mut(ptr, count)
        };
        let written = parallel::rows(hooks, slots, 1, |items, part: &mut [MaybeUninit<T>]| {
            let len = items.len();
            for (s, i) in part.iter_mut().zip(items) {
                s.write(f(i));
            }
            len
        });
        // A task that did not run (a `Progress` that skipped it) returned 0:
        // its range is written here, so no slot is left unwritten.
        for (t, &w) in written.iter().enumerate() {
            let items = parallel::range(count, t);
            if w != items.len() {
                for i in items {
                    slots[i].write(f(i));
                }
            }
        }
        // SAFETY: every slot was written above (by its task, or here when its
        // task reported fewer), so the `MaybeUninit<T>`s are initialised `T`s
        // of the same layout.
        unsafe { core::slice::from_raw_parts_mut(slots.as_mut_ptr().cast::<T>(), count) }
    }

    /// Allocate `count` copies of `value`, persistent for the arena's life.
    /// Cost: O(count).
    #[allow(clippy::mut_from_ref)] // disjoint regions: see `fill_at`
    pub fn try_alloc_slice<T: Copy>(&self, count: usize, value: T) -> Result<&mut [T], Exhausted> {
        let offset = self.reserve_front::<T>(count)?;
        Ok(self.fill_at(offset, count, value))
    }

    /// `count` values persistent for the arena's life, value `i` being
    /// `f(i)`, computed in the tasks of `hooks` (on whatever threads it has).
    #[allow(clippy::mut_from_ref)] // disjoint regions: see `fill_at`
    pub fn try_alloc_from_fn_on<T: Copy + Send>(
        &self,
        count: usize,
        f: impl Fn(usize) -> T + Sync,
        hooks: &dyn Progress,
    ) -> Result<&mut [T], Exhausted> {
        let offset = self.reserve_front::<T>(count)?;
        Ok(self.fill_at_with(offset, count, f, hooks))
    }

    /// Copy `src` into a persistent allocation.
    #[allow(clippy::mut_from_ref)] // disjoint regions: see `fill_at`
    pub fn try_alloc_copy<T: Copy + Default>(&self, src: &[T]) -> Result<&mut [T], Exhausted> {
        let out = self.try_alloc_slice(src.len(), T::default())?;
        out.copy_from_slice(src);
        Ok(out)
    }

    /// Run `f` with a scratch sub-arena whose allocations are reclaimed when `f`
    /// returns. Persistent allocations from `self` remain possible inside `f`.
    /// The result type cannot borrow from the scratch scope.
    pub fn scratch<R>(&self, f: impl FnOnce(&Scratch<'_, 'buf>) -> R) -> R {
        let saved_back = self.back.get();
        let depth = self.depth.get() + 1;
        self.depth.set(depth);
        let scope = Scratch {
            arena: self,
            depth,
            _not_send: PhantomData,
        };
        let out = f(&scope);
        self.depth.set(depth - 1);
        self.back.set(saved_back);
        out
    }

    /// Forget every allocation (the peak is kept). Needs `&mut self`, so no slice
    /// handed out earlier can still be alive.
    pub fn reset(&mut self) {
        self.front.set(0);
        self.back.set(self.len);
        self.depth.set(0);
        self.ceiling.set(usize::MAX);
        self.ceiling_hit.set(false);
    }
}

impl fmt::Debug for Arena<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Arena")
            .field("capacity", &self.capacity())
            .field("used", &self.used())
            .field("peak", &self.peak())
            .finish()
    }
}

#[cfg(feature = "bumpalo")]
impl<'b> Arena<'b> {
    /// An arena of `bytes` bytes taken from `bump` instead of a caller's slice
    /// (feature `bumpalo`, for std hosts that manage memory with bumpalo). The
    /// bump's allocation limit (`Bump::set_allocation_limit`) is honoured: when
    /// the bump cannot give `bytes` more (the limit counts bumpalo's chunks, which
    /// round requests up, plus their headers), this is [`Exhausted`] with
    /// `requested: bytes` and what the limit still allows as `available`, never a
    /// panic or an abort. The bytes go back when the bump is reset or dropped.
    ///
    /// ```
    /// # use vsaqem_core::{arena_bytes, Arena, Params};
    /// let bump = bumpalo::Bump::new();
    /// bump.set_allocation_limit(Some(1 << 20));
    /// let params = Params::default();
    /// assert!(Arena::try_from_bump(&bump, arena_bytes(100_000, &params)).is_err());
    /// assert!(Arena::try_from_bump(&bump, 64 * 1024).is_ok());
    /// ```
    pub fn try_from_bump(bump: &'b bumpalo::Bump, bytes: usize) -> Result<Self, Exhausted> {
        let refused = || Exhausted {
            requested: bytes,
            available: bump
                .allocation_limit()
                .map_or(0, |limit| limit.saturating_sub(bump.allocated_bytes())),
        };
        let layout = core::alloc::Layout::from_size_align(bytes, GRANULE).map_err(|_| refused())?;
        let ptr = bump.try_alloc_layout(layout).map_err(|_| refused())?;
        // SAFETY: `try_alloc_layout` returned a fresh allocation of `bytes` bytes
        // that bumpalo hands to no one else and frees only on `reset` or drop, both
        // of which need the bump mutably, so it stays valid and unaliased while
        // `bump` is borrowed for 'b. `MaybeUninit<u8>` needs no initialisation.
        let buf = unsafe {
            core::slice::from_raw_parts_mut(ptr.as_ptr().cast::<MaybeUninit<u8>>(), bytes)
        };
        Ok(Arena::new(buf))
    }
}

/// A scratch scope of an [`Arena`]: allocations come from the arena's back end and
/// are reclaimed when the scope ends.
pub struct Scratch<'a, 'buf> {
    arena: &'a Arena<'buf>,
    depth: u32,
    _not_send: PhantomData<*const ()>,
}

impl<'buf> Scratch<'_, 'buf> {
    fn check_innermost(&self, count: usize) -> Result<(), Exhausted> {
        if self.arena.depth.get() != self.depth {
            // Allocating from an outer scope while an inner one is live would place
            // the memory inside the inner scope's region and free it too early.
            // Core never does this; refuse rather than corrupt.
            return Err(Exhausted {
                requested: count,
                available: 0,
            });
        }
        Ok(())
    }

    /// Allocate `count` copies of `value` for the life of this scope.
    #[allow(clippy::mut_from_ref)] // disjoint regions: see `Arena::fill_at`
    pub fn try_alloc_slice<T: Copy>(&self, count: usize, value: T) -> Result<&mut [T], Exhausted> {
        self.check_innermost(count)?;
        let offset = self.arena.reserve_back::<T>(count)?;
        Ok(self.arena.fill_at(offset, count, value))
    }

    /// `count` values for the life of this scope, value `i` being `f(i)`,
    /// computed in the tasks of `hooks` (on whatever threads it has).
    #[allow(clippy::mut_from_ref)] // disjoint regions: see `Arena::fill_at`
    pub fn try_alloc_from_fn_on<T: Copy + Send>(
        &self,
        count: usize,
        f: impl Fn(usize) -> T + Sync,
        hooks: &dyn Progress,
    ) -> Result<&mut [T], Exhausted> {
        self.check_innermost(count)?;
        let offset = self.arena.reserve_back::<T>(count)?;
        Ok(self.arena.fill_at_with(offset, count, f, hooks))
    }

    /// Copy `src` into this scope.
    #[allow(clippy::mut_from_ref)] // disjoint regions: see `Arena::fill_at`
    pub fn try_alloc_copy<T: Copy + Default>(&self, src: &[T]) -> Result<&mut [T], Exhausted> {
        let out = self.try_alloc_slice(src.len(), T::default())?;
        out.copy_from_slice(src);
        Ok(out)
    }

    /// A nested scope; this scope cannot allocate until the nested one ends.
    pub fn scratch<R>(&self, f: impl FnOnce(&Scratch<'_, 'buf>) -> R) -> R {
        self.arena.scratch(f)
    }

    /// The arena this scope belongs to (for persistent allocations and statistics).
    pub fn arena(&self) -> &Arena<'buf> {
        self.arena
    }

    /// Bytes free in the arena.
    pub fn available(&self) -> usize {
        self.arena.available()
    }

    /// See [`Arena::fits_under_peak`].
    pub fn fits_under_peak(&self, bytes: usize) -> bool {
        self.arena.fits_under_peak(bytes)
    }
}

/// Something to allocate from: an [`Arena`]'s persistent front, or a [`Scratch`]
/// scope. Pipeline stages take `&impl Alloc` so the same code can keep its results
/// for the whole run or only for a scope (a meshing round that may be redone).
pub trait Alloc<'buf> {
    /// Allocate `count` copies of `value`.
    #[allow(clippy::mut_from_ref)]
    fn try_alloc_slice<T: Copy>(&self, count: usize, value: T) -> Result<&mut [T], Exhausted>;

    /// Copy `src` into a new allocation.
    #[allow(clippy::mut_from_ref)]
    fn try_alloc_copy<T: Copy + Default>(&self, src: &[T]) -> Result<&mut [T], Exhausted> {
        let out = self.try_alloc_slice(src.len(), T::default())?;
        out.copy_from_slice(src);
        Ok(out)
    }

    /// [`Alloc::try_alloc_slice`], filled by the threads of `hooks` when it
    /// is large (at least [`PARALLEL_FILL`] bytes): the same slice, sooner.
    #[allow(clippy::mut_from_ref)]
    fn try_alloc_slice_on<T: Copy + Send + Sync>(
        &self,
        count: usize,
        value: T,
        hooks: &dyn Progress,
    ) -> Result<&mut [T], Exhausted> {
        if hooks.threads() < 2 || count.saturating_mul(size_of::<T>()) < PARALLEL_FILL {
            return self.try_alloc_slice(count, value);
        }
        self.try_alloc_from_fn_on(count, |_| value, hooks)
    }

    /// `count` values, value `i` being `f(i)`, computed in the tasks of
    /// `hooks` (on whatever threads it has): for values that cost more than a
    /// copy to make.
    #[allow(clippy::mut_from_ref)]
    fn try_alloc_from_fn_on<T: Copy + Send>(
        &self,
        count: usize,
        f: impl Fn(usize) -> T + Sync,
        hooks: &dyn Progress,
    ) -> Result<&mut [T], Exhausted>;

    /// A nested scratch scope.
    fn scratch<R>(&self, f: impl FnOnce(&Scratch<'_, 'buf>) -> R) -> R;

    /// The arena underneath (statistics, persistent allocations).
    fn base(&self) -> &Arena<'buf>;
}

/// The [`Alloc`] methods of `$ty` as calls of its own (inherent) methods of
/// the same names, and `base` as `$base`.
macro_rules! forward_alloc {
    ($ty:ty, |$this:ident| $base:expr) => {
        impl<'buf> Alloc<'buf> for $ty {
            fn try_alloc_slice<T: Copy>(
                &self,
                count: usize,
                value: T,
            ) -> Result<&mut [T], Exhausted> {
                <$ty>::try_alloc_slice(self, count, value)
            }

            fn try_alloc_from_fn_on<T: Copy + Send>(
                &self,
                count: usize,
                f: impl Fn(usize) -> T + Sync,
                hooks: &dyn Progress,
            ) -> Result<&mut [T], Exhausted> {
                <$ty>::try_alloc_from_fn_on(self, count, f, hooks)
            }

            fn scratch<R>(&self, f: impl FnOnce(&Scratch<'_, 'buf>) -> R) -> R {
                <$ty>::scratch(self, f)
            }

            fn base(&self) -> &Arena<'buf> {
                let $this = self;
                $base
            }
        }
    };
}

forward_alloc!(Arena<'buf>, |this| this);
forward_alloc!(Scratch<'_, 'buf>, |this| this.arena);

/// `bytes` as atomic bytes: flags that parallel tasks set on each other's
/// items (relaxed stores of one value, so the result does not depend on their
/// order). Safe code cannot form such a slice in place (`AtomicU8::from_mut_slice`
/// is unstable).
pub fn atomic_bytes(bytes: &mut [u8]) -> &[core::sync::atomic::AtomicU8] {
    // SAFETY: `AtomicU8` has the size, alignment and bit validity of `u8`, and
    // the exclusive borrow of `bytes` for the result's lifetime rules out any
    // non-atomic access while the atomic view exists.
    unsafe { &*(bytes as *mut [u8] as *const [core::sync::atomic::AtomicU8]) }
}

/// `values` as atomic `u16`s (see [`atomic_bytes`]).
pub fn atomic_u16s(values: &mut [u16]) -> &[core::sync::atomic::AtomicU16] {
    // SAFETY: `AtomicU16` has the size, alignment and bit validity of `u16`;
    // the exclusive borrow rules out non-atomic access meanwhile.
    unsafe { &*(values as *mut [u16] as *const [core::sync::atomic::AtomicU16]) }
}

/// `values` as atomic `u32`s (see [`atomic_bytes`]); [`plain_u32s`] gives
/// them back.
pub fn atomic_u32s(values: &mut [u32]) -> &mut [core::sync::atomic::AtomicU32] {
    // SAFETY: `AtomicU32` has the size, alignment and bit validity of `u32`,
    // and the result holds the exclusive borrow.
    unsafe { &mut *(values as *mut [u32] as *mut [core::sync::atomic::AtomicU32]) }
}

/// Rows of `W` `u32`s as rows of atomic `u32`s (see [`atomic_bytes`]): one
/// bounds check reaches a whole row.
pub fn atomic_u32_rows<const W: usize>(
    values: &mut [[u32; W]],
) -> &[[core::sync::atomic::AtomicU32; W]] {
    // SAFETY: `AtomicU32` has the size, alignment and bit validity of `u32`,
    // so `[AtomicU32; W]` has those of `[u32; W]`; the exclusive borrow of
    // `values` for the result's lifetime rules out non-atomic access.
    unsafe { &*(values as *mut [[u32; W]] as *const [[core::sync::atomic::AtomicU32; W]]) }
}

/// `values` as atomic `u32`s holding their bits (see [`atomic_bytes`]): each
/// set whole with `f32::to_bits` by one task, read as `f32`s again once the
/// view is dropped.
pub fn atomic_f32_bits(values: &mut [f32]) -> &[core::sync::atomic::AtomicU32] {
    // SAFETY: `AtomicU32` has the size and alignment of `f32`, every bit
    // pattern is valid for both, and the exclusive borrow of `values` for the
    // result's lifetime rules out non-atomic access meanwhile.
    unsafe { &*(values as *mut [f32] as *const [core::sync::atomic::AtomicU32]) }
}

/// `values` as atomic `u32` words, two a value (see [`atomic_bytes`]):
/// [`F64Words`] reads and sets each value whole; the values are plain `f64`s
/// again once the view is dropped. (Two words, not one `AtomicU64`: the
/// Cortex-M4F has no 64-bit atomics.)
pub fn atomic_f64_words(values: &mut [f64]) -> F64Words<'_> {
    let words = values.len() * 2;
    // SAFETY: an `f64` is 8 bytes aligned to at least 4, so the values' memory
    // holds `2 × len` `AtomicU32`s (size 4, alignment 4, every bit pattern
    // valid for both); the exclusive borrow of `values` for the result's
    // lifetime rules out non-atomic access meanwhile.
    F64Words(unsafe {
        core::slice::from_raw_parts(
            values.as_mut_ptr() as *const core::sync::atomic::AtomicU32,
            words,
        )
    })
}

/// `f64` values shared by parallel tasks as pairs of atomic words
/// ([`atomic_f64_words`]): relaxed loads and stores, so a value must not be
/// read while another task sets it (the caller's tasks set disjoint values
/// that no other task reads meanwhile).
#[derive(Clone, Copy)]
pub struct F64Words<'a>(&'a [core::sync::atomic::AtomicU32]);

impl F64Words<'_> {
    /// Value `i` (0 past the end).
    #[inline]
    pub fn get(&self, i: usize) -> f64 {
        let word = |k: usize| {
            self.0
                .get(2 * i + k)
                .map_or(0, |w| w.load(core::sync::atomic::Ordering::Relaxed))
        };
        let (a, b) = (word(0).to_ne_bytes(), word(1).to_ne_bytes());
        f64::from_ne_bytes([a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]])
    }

    /// Set value `i` (nothing past the end).
    #[inline]
    pub fn set(&self, i: usize, v: f64) {
        let b = v.to_ne_bytes();
        for (k, w) in [[b[0], b[1], b[2], b[3]], [b[4], b[5], b[6], b[7]]]
            .into_iter()
            .enumerate()
        {
            if let Some(a) = self.0.get(2 * i + k) {
                a.store(u32::from_ne_bytes(w), core::sync::atomic::Ordering::Relaxed);
            }
        }
    }
}

/// Atomic `u32`s as plain values again, once no other thread holds them.
pub fn plain_u32s(values: &mut [core::sync::atomic::AtomicU32]) -> &mut [u32] {
    // SAFETY: as for `atomic_u32s`, the other way; the exclusive borrow means
    // no atomic access can happen meanwhile.
    unsafe { &mut *(values as *mut [core::sync::atomic::AtomicU32] as *mut [u32]) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 256 bytes on an 8-byte boundary.
    #[repr(align(8))]
    struct Buf([MaybeUninit<u8>; 256]);

    fn buf(n: usize) -> Buf {
        assert!(n <= 256);
        Buf([MaybeUninit::uninit(); 256])
    }

    /// Claims two threads and runs only the tasks `keep` lets through, the
    /// last first: a host that skipped tasks must not leave slots unwritten.
    struct Skipping {
        keep: fn(usize) -> bool,
    }

    impl Progress for Skipping {
        fn report(&mut self, _: crate::Stage, _: u64, _: u64) -> crate::progress::Flow {
            crate::progress::Flow::Continue
        }

        fn run(&self, tasks: &mut [&mut dyn crate::Task]) {
            let keep = self.keep;
            for (t, task) in tasks.iter_mut().enumerate().rev() {
                if keep(t) {
                    task.run();
                }
            }
        }

        fn threads(&self) -> usize {
            2
        }
    }

    #[test]
    fn fills_on_threads_are_the_fills_of_one() {
        let mut b = std::vec![MaybeUninit::uninit(); 64 * PARALLEL_FILL];
        let a = Arena::new(&mut b);
        let n = PARALLEL_FILL; // u32s: four times the threshold in bytes
        for keep in [(|_| true) as fn(usize) -> bool, |t| t % 3 == 1, |_| false] {
            let hooks = Skipping { keep };
            // What the slots held before is not what they are filled with.
            a.scratch(|s| s.try_alloc_slice::<u32>(5 * n, u32::MAX).map(|_| ()))
                .unwrap();
            a.scratch(|s| {
                let one = s.try_alloc_slice::<u32>(n, 7).unwrap();
                let many = s.try_alloc_slice_on::<u32>(n, 7, &hooks).unwrap();
                assert_eq!(one, many);
                let made = s
                    .try_alloc_from_fn_on(n + 3, |i| (i as u64) * 3, &hooks)
                    .unwrap();
                assert!(made.iter().enumerate().all(|(i, &v)| v == i as u64 * 3));
                // Below the threshold, and in the persistent region.
                let small = s.arena().try_alloc_slice_on::<u8>(5, 2, &hooks).unwrap();
                assert_eq!(small, &[2; 5]);
                // Zero-sized values: `f` is called for no index when there
                // are none (it may index data of that length).
                let none: [(); 0] = [];
                let units = s
                    .try_alloc_from_fn_on(0, |i| none[i], &hooks)
                    .map(|u| u.len());
                assert_eq!(units, Ok(0));
                let three = [(); 3];
                let units = s
                    .try_alloc_from_fn_on(3, |i| three[i], &hooks)
                    .map(|u| u.len());
                assert_eq!(units, Ok(3));
            });
        }
    }

    #[test]
    fn exhaustion_is_an_error_with_exact_numbers() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..64]);
        let x = a.try_alloc_slice::<u32>(10, 7).unwrap();
        assert_eq!(x, &[7; 10]);
        let used = a.used();
        assert_eq!(used, 40);
        let e = a.try_alloc_slice::<u32>(100, 0).unwrap_err();
        assert_eq!(e.available, 64 - used);
        assert!(e.requested >= 400);
        // The failed request took nothing.
        assert_eq!(a.used(), used);
        assert_eq!(a.peak(), used);
    }

    #[test]
    fn size_overflow_is_an_error_not_a_panic() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..]);
        let e = a.try_alloc_slice::<u64>(usize::MAX / 2, 0).unwrap_err();
        assert_eq!(e.requested, usize::MAX);
    }

    #[test]
    fn scratch_is_reclaimed_and_peak_remembers_it() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..]);
        let p = a.try_alloc_slice::<u8>(16, 1).unwrap();
        let before = a.used();
        let s = a.scratch(|s| {
            let t = s.try_alloc_slice::<u64>(8, 3).unwrap();
            // A persistent allocation is allowed inside a scope and survives it.
            let q = s.arena().try_alloc_slice::<u8>(4, 9).unwrap();
            t.iter().sum::<u64>() + q.len() as u64
        });
        assert_eq!(s, 28);
        // 4 bytes take a granule.
        assert_eq!(a.used(), before + 8);
        assert_eq!(a.peak(), before + 8 + 64);
        assert_eq!(p, &[1; 16]);
    }

    #[test]
    fn fits_under_peak_is_scratch_in_bytes_handed_out_before() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..]);
        // The deepest scratch: 64 bytes, the peak.
        let deepest = a.scratch(|s| s.try_alloc_slice::<u8>(64, 1).unwrap().as_ptr() as usize);
        assert_eq!(a.peak(), 64);
        let _kept = a.try_alloc_slice::<u8>(16, 2).unwrap();
        assert!(a.fits_under_peak(48));
        assert!(
            !a.fits_under_peak(56),
            "16 kept + 56 would raise the peak to 72"
        );
        a.scratch(|s| {
            assert!(s.fits_under_peak(48));
            let t = s.try_alloc_slice::<u8>(48, 3).unwrap();
            assert!(t.as_ptr() as usize >= deepest, "below the deepest scratch");
            assert_eq!(s.arena().peak(), 64);
            assert!(!s.fits_under_peak(8), "the peak is reached");
        });
        // Under a ceiling the request must fit the ceiling too.
        let (fits, _) = a.with_ceiling(40, || a.fits_under_peak(32));
        assert!(!fits);
        assert!(a.fits_under_peak(32));
    }

    #[test]
    fn values_are_aligned_at_both_ends() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..]);
        let _ = a.try_alloc_slice::<u8>(3, 0).unwrap();
        let x = a.try_alloc_slice::<u64>(2, 0).unwrap();
        assert_eq!(x.as_ptr() as usize % align_of::<u64>(), 0);
        a.scratch(|s| {
            let _ = s.try_alloc_slice::<u8>(5, 0).unwrap();
            let y = s.try_alloc_slice::<u64>(1, 0).unwrap();
            assert_eq!(y.as_ptr() as usize % align_of::<u64>(), 0);
        });
    }

    #[test]
    fn outer_scope_cannot_allocate_while_inner_is_live() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..]);
        a.scratch(|outer| {
            let _keep = outer.try_alloc_slice::<u32>(2, 5).unwrap();
            outer.scratch(|inner| {
                assert!(inner.try_alloc_slice::<u32>(2, 0).is_ok());
                assert!(outer.try_alloc_slice::<u32>(2, 0).is_err());
            });
            assert!(outer.try_alloc_slice::<u32>(2, 0).is_ok());
        });
    }

    #[test]
    fn the_ends_never_overlap() {
        let mut b = buf(256);
        // 100 bytes: 96 used (whole granules).
        let a = Arena::new(&mut b.0[..100]);
        assert_eq!(a.capacity(), 96);
        let p = a.try_alloc_slice::<u8>(45, 1).unwrap();
        a.scratch(|s| {
            assert!(s.try_alloc_slice::<u8>(49, 2).is_err());
            let t = s.try_alloc_slice::<u8>(48, 2).unwrap();
            assert_eq!(a.available(), 0);
            assert!(a.try_alloc_slice::<u8>(1, 0).is_err());
            assert!(t.iter().all(|&v| v == 2));
        });
        assert!(p.iter().all(|&v| v == 1));
    }

    #[test]
    fn reset_makes_the_buffer_reusable() {
        let mut b = buf(256);
        let mut a = Arena::new(&mut b.0[..32]);
        assert!(a.try_alloc_slice::<u8>(32, 0).is_ok());
        assert!(a.try_alloc_slice::<u8>(1, 0).is_err());
        a.reset();
        assert!(a.try_alloc_slice::<u8>(32, 0).is_ok());
    }

    #[test]
    fn a_ceiling_caps_use_and_says_when_it_was_the_reason() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..]);
        let _ = a.try_alloc_slice::<u8>(16, 0).unwrap();
        let ((), hit) = a.with_ceiling(64, || {
            assert_eq!(a.available(), 48);
            assert!(a.try_alloc_slice::<u8>(40, 0).is_ok());
            a.scratch(|s| {
                let e = s.try_alloc_slice::<u8>(9, 0).unwrap_err();
                assert_eq!(e.available, 8);
                assert!(s.try_alloc_slice::<u8>(8, 0).is_ok());
            });
            assert!(a.used() <= 64);
        });
        assert!(hit, "the ceiling, not the buffer, refused the request");
        // Too big for the buffer as well: still the ceiling's refusal, as it is
        // the lower limit.
        let ((), hit) = a.with_ceiling(a.used() + 8, || {
            assert!(a.try_alloc_slice::<u8>(1000, 0).is_err());
        });
        assert!(hit);
        // Lifted again: the buffer's own end applies.
        assert!(a.try_alloc_slice::<u8>(100, 0).is_ok());
        let ((), hit) = a.with_ceiling(usize::MAX, || {
            assert!(a.try_alloc_slice::<u8>(200, 0).is_err());
        });
        assert!(!hit, "the buffer itself was too small");
        // A ceiling exactly at the buffer's end is the ceiling's refusal.
        let ((), hit) = a.with_ceiling(a.capacity(), || {
            assert!(a.try_alloc_slice::<u8>(200, 0).is_err());
        });
        assert!(hit);
        // An inner ceiling above an outer one does not lift it.
        let ((), _) = a.with_ceiling(a.used() + 8, || {
            let (r, inner_hit) =
                a.with_ceiling(usize::MAX, || a.try_alloc_slice::<u8>(9, 0).is_err());
            assert!(r && inner_hit);
        });
    }

    #[test]
    fn the_peak_depends_on_the_requests_not_on_the_buffer() {
        let mut b = buf(256);
        let run = |a: &Arena| -> Result<(), Exhausted> {
            let _ = a.try_alloc_slice::<u8>(3, 0)?;
            a.scratch(|s| -> Result<(), Exhausted> {
                let _ = s.try_alloc_slice::<u32>(5, 0)?;
                let _ = s.try_alloc_slice::<u64>(2, 0)?;
                let _ = a.try_alloc_slice::<[f32; 3]>(3, [0.0; 3])?;
                Ok(())
            })?;
            let _ = a.try_alloc_slice::<u16>(7, 0)?;
            Ok(())
        };
        let mut peaks = std::vec::Vec::new();
        for (start, len) in [(0, 256), (0, 203), (8, 131), (3, 200), (5, 99)] {
            let a = Arena::new(&mut b.0[start..start + len]);
            run(&a).unwrap();
            peaks.push(a.peak());
        }
        assert!(peaks.iter().all(|&p| p == peaks[0]), "{peaks:?}");
        let peak = peaks[0];
        assert_eq!(peak % GRANULE, 0);
        // Exactly the peak is enough; a granule less is not.
        assert!(run(&Arena::new(&mut b.0[8..8 + peak])).is_ok());
        assert!(run(&Arena::new(&mut b.0[8..8 + peak - 1])).is_err());
    }

    #[test]
    fn zero_sized_and_empty_requests_work() {
        let mut b = buf(256);
        let a = Arena::new(&mut b.0[..0]);
        assert_eq!(a.try_alloc_slice::<()>(1000, ()).unwrap().len(), 1000);
        assert_eq!(a.try_alloc_slice::<u32>(0, 0).unwrap().len(), 0);
        assert!(a.try_alloc_slice::<u32>(1, 0).is_err());
    }

    #[test]
    fn atomic_views_read_and_write_the_values_in_place() {
        use core::sync::atomic::Ordering::Relaxed;
        let mut b = buf(256);
        let a = Arena::new(&mut b.0);
        let bytes = a.try_alloc_slice::<u8>(5, 1).unwrap();
        atomic_bytes(bytes)[4].store(9, Relaxed);
        assert_eq!(bytes, [1, 1, 1, 1, 9]);
        let halves = a.try_alloc_slice::<u16>(3, 2).unwrap();
        assert_eq!(atomic_u16s(halves)[2].fetch_add(1, Relaxed), 2);
        assert_eq!(halves, [2, 2, 3]);
        let words = a.try_alloc_slice::<u32>(4, 7).unwrap();
        let atomic = atomic_u32s(words);
        atomic[0].store(u32::MAX, Relaxed);
        assert_eq!(plain_u32s(atomic), [u32::MAX, 7, 7, 7]);
        let floats = a.try_alloc_slice::<f32>(2, 0.5).unwrap();
        assert_eq!(atomic_f32_bits(floats)[1].load(Relaxed), 0.5f32.to_bits());
        atomic_f32_bits(floats)[0].store((-3.25f32).to_bits(), Relaxed);
        assert_eq!(floats, [-3.25, 0.5]);
        let doubles = a.try_alloc_slice::<f64>(3, 1.5).unwrap();
        let view = atomic_f64_words(doubles);
        let tiny = f64::from_bits(1);
        assert_eq!((view.get(1), view.get(3)), (1.5, 0.0));
        view.set(0, -0.1);
        view.set(2, tiny);
        view.set(3, 9.0);
        assert_eq!((view.get(0), view.get(2)), (-0.1, tiny));
        assert_eq!(doubles, [-0.1, 1.5, tiny]);
    }

    #[cfg(feature = "bumpalo")]
    #[test]
    fn an_arena_from_a_bump_holds_values_at_both_ends() {
        let bump = bumpalo::Bump::new();
        let a = Arena::try_from_bump(&bump, 256).unwrap();
        let front = a.try_alloc_copy(&[1u32, 2, 3]).unwrap();
        a.scratch(|s| {
            let back = s.try_alloc_slice::<u64>(4, 9).unwrap();
            back[3] = 10;
            assert_eq!(back, [9, 9, 9, 10]);
        });
        front[1] = 5;
        assert_eq!(front, [1, 5, 3]);
        assert!(a.try_alloc_slice::<u64>(64, 0).is_err());
        let limited = bumpalo::Bump::new();
        limited.set_allocation_limit(Some(100));
        assert!(Arena::try_from_bump(&limited, 4096).is_err());
    }
}
