//! Host memory of recorded commands (re-recording 1,000 draws in
//! ≤ 1 ms of CPU): a chunked bump allocator given to command pools as their
//! `VkAllocationCallbacks`.
//!
//! Lavapipe (Mesa's common command queue) stores every recorded command as a
//! heap allocation, and its arrays (scissors, push-constant bytes, barriers,
//! attachments) as more, then frees them one by one when the buffer is reset.
//! With the system allocator that was 40% of the instructions of a
//! re-recording (callgrind, gear cst-i): thousands of small blocks freed into
//! the allocator's bins and coalesced again on the next large request. Here an
//! allocation is a pointer bump in a 64 KiB chunk and a free is a counter
//! decrement: a recording's commands fill chunks in order, and a reset empties
//! them all, so each chunk is reused as a whole once its last block is freed.
//! Blocks too large for a chunk go to the global allocator.
//!
//! Every block carries a 16-byte header before it (its chunk, alignment and
//! size), so that a free or a reallocation finds its chunk without a search.

use std::alloc::{self, Layout};
use std::ffi::c_void;
use std::ptr::{self, NonNull};
use std::sync::Mutex;

use ash::vk;

/// Bytes of a chunk.
const CHUNK: usize = 64 << 10;
/// Alignment of a chunk, and the least alignment of a block.
const CHUNK_ALIGN: usize = 64;
/// Bytes of the header before every block.
const HEADER: usize = 16;
/// The chunk index of a block from the global allocator.
const LARGE: u32 = u32::MAX;

/// Where a block lies and how big it is (the 16 bytes before it).
#[derive(Clone, Copy)]
#[repr(C)]
struct Header {
    chunk: u32,
    align: u32,
    size: u64,
}

struct Chunk {
    base: NonNull<u8>,
    /// Next free byte.
    bump: usize,
    /// Blocks not yet freed.
    live: u32,
}

/// The bookkeeping of the arena (behind the callbacks' lock).
#[derive(Default)]
struct Chunks {
    chunks: Vec<Chunk>,
    /// The chunk blocks are bumped from.
    current: Option<u32>,
    /// Empty chunks other than the current one.
    empty: Vec<u32>,
}

/// Counts of what the arena served (for tests and the figures of docs/perf/).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ArenaCounts {
    /// Blocks bumped from chunks.
    pub small: u64,
    /// Blocks from the global allocator.
    pub large: u64,
    /// Chunks allocated.
    pub chunks: u64,
}

/// A command pool's host allocator: give [`CmdArena::callbacks`] to its
/// creation and destruction, and keep the arena (boxed, not moved) until the
/// pool is destroyed.
#[derive(Default)]
pub struct CmdArena {
    inner: Mutex<(Chunks, ArenaCounts)>,
}

// SAFETY: the chunks are owned heap memory reached only under the mutex.
unsafe impl Send for CmdArena {}
// SAFETY: as above.
unsafe impl Sync for CmdArena {}

fn round_up(n: usize, align: usize) -> usize {
    (n + align - 1) & !(align - 1)
}

impl CmdArena {
    /// The callbacks for `vkCreateCommandPool`/`vkDestroyCommandPool`; valid
    /// while `self` lives at this address.
    pub fn callbacks(&self) -> vk::AllocationCallbacks<'_> {
        vk::AllocationCallbacks::default()
            .user_data(self as *const CmdArena as *mut c_void)
            .pfn_allocation(Some(allocation))
            .pfn_reallocation(Some(reallocation))
            .pfn_free(Some(free))
    }

    /// What the arena served so far.
    pub fn counts(&self) -> ArenaCounts {
        self.lock().1
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, (Chunks, ArenaCounts)> {
        // A panic under the lock leaves plain counters: still usable.
        self.inner.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// A block of `size` bytes aligned to `align` (a power of two).
    fn alloc(&self, size: usize, align: usize) -> *mut u8 {
        let align = align.max(HEADER);
        let mut g = self.lock();
        let (chunks, counts) = &mut *g;
        // The worst case in a chunk: the header and padding to the alignment.
        if size + HEADER + align > CHUNK / 4 {
            counts.large += 1;
            return alloc_large(size, align);
        }
        counts.small += 1;
        loop {
            if let Some(c) = chunks.current {
                let ch = &mut chunks.chunks[c as usize];
                let start = ch.base.as_ptr() as usize;
                let at = round_up(start + ch.bump + HEADER, align);
                if at + size <= start + CHUNK {
                    ch.bump = at + size - start;
                    ch.live += 1;
                    let p = at as *mut u8;
                    // SAFETY: `p - HEADER .. p + size` lies in the chunk, past
                    // every live block; the header is 16-aligned (`align` ≥ 16).
                    unsafe { write_header(p, c, align, size) };
                    return p;
                }
                // Left with blocks in it: back to `empty` when they are freed.
                assert!(ch.live > 0, "an empty chunk fits every small block");
            }
            let next = match chunks.empty.pop() {
                Some(e) => e,
                None => {
                    counts.chunks += 1;
                    let layout = chunk_layout();
                    // SAFETY: the layout has a non-zero size.
                    let base = NonNull::new(unsafe { alloc::alloc(layout) })
                        .unwrap_or_else(|| alloc::handle_alloc_error(layout));
                    chunks.chunks.push(Chunk {
                        base,
                        bump: 0,
                        live: 0,
                    });
                    (chunks.chunks.len() - 1) as u32
                }
            };
            chunks.chunks[next as usize].bump = 0;
            chunks.current = Some(next);
        }
    }

    /// Frees block `p` of this arena.
    ///
    /// # Safety
    /// `p` came from [`Self::alloc`] of this arena and is not freed yet.
    unsafe fn free(&self, p: *mut u8) {
        // SAFETY: the caller's block has its header before it.
        let h = unsafe { read_header(p) };
        if h.chunk == LARGE {
            // SAFETY: allocated by `alloc_large` with this size and alignment.
            unsafe { free_large(p, h) };
            return;
        }
        let mut g = self.lock();
        let chunks = &mut g.0;
        let ch = &mut chunks.chunks[h.chunk as usize];
        assert!(ch.live > 0, "a block freed twice in the command arena");
        ch.live -= 1;
        if ch.live == 0 {
            ch.bump = 0;
            if chunks.current != Some(h.chunk) {
                chunks.empty.push(h.chunk);
            }
        }
    }

    /// `p` grown or shrunk to `size` bytes (its contents kept up to the
    /// smaller size).
    ///
    /// # Safety
    /// As [`Self::free`].
    unsafe fn realloc(&self, p: *mut u8, size: usize, align: usize) -> *mut u8 {
        // SAFETY: the caller's block has its header before it.
        let old = unsafe { read_header(p) }.size as usize;
        let q = self.alloc(size, align);
        // SAFETY: both blocks are live and distinct, each at least the length.
        unsafe { ptr::copy_nonoverlapping(p, q, old.min(size)) };
        // SAFETY: the caller's block, copied above.
        unsafe { self.free(p) };
        q
    }
}

impl Drop for CmdArena {
    fn drop(&mut self) {
        let g = self.lock();
        for c in &g.0.chunks {
            // SAFETY: allocated in `alloc` with this layout; the pool that used
            // the arena is destroyed (the owner's contract).
            unsafe { alloc::dealloc(c.base.as_ptr(), chunk_layout()) };
        }
    }
}

fn chunk_layout() -> Layout {
    Layout::from_size_align(CHUNK, CHUNK_ALIGN).expect("a valid chunk layout")
}

/// The layout of a large block: its padding (≥ the header) then its bytes.
fn large_layout(size: usize, align: usize) -> Layout {
    Layout::from_size_align(size + align, align).expect("a Vulkan allocation's layout is valid")
}

fn alloc_large(size: usize, align: usize) -> *mut u8 {
    let layout = large_layout(size, align);
    // SAFETY: the layout has a non-zero size (the padding).
    let base = unsafe { alloc::alloc(layout) };
    if base.is_null() {
        alloc::handle_alloc_error(layout);
    }
    // SAFETY: `align` ≥ the header: the block starts `align` bytes in, and its
    // header lies in the padding.
    let p = unsafe { base.add(align) };
    // SAFETY: as above.
    unsafe { write_header(p, LARGE, align, size) };
    p
}

/// # Safety
/// `p` came from [`alloc_large`] with the header's size and alignment.
unsafe fn free_large(p: *mut u8, h: Header) {
    let align = h.align as usize;
    // SAFETY: the caller's block, `align` bytes past its allocation's start.
    unsafe { alloc::dealloc(p.sub(align), large_layout(h.size as usize, align)) };
}

/// # Safety
/// The 16 bytes before `p` are writable and 16-aligned.
unsafe fn write_header(p: *mut u8, chunk: u32, align: usize, size: usize) {
    let h = Header {
        chunk,
        align: align as u32,
        size: size as u64,
    };
    // SAFETY: the caller's contract.
    unsafe { p.sub(HEADER).cast::<Header>().write(h) };
}

/// # Safety
/// `p` is a live block of an arena (its header before it).
unsafe fn read_header(p: *mut u8) -> Header {
    // SAFETY: the caller's contract.
    unsafe { p.sub(HEADER).cast::<Header>().read() }
}

/// # Safety
/// `user` is the `CmdArena` of [`CmdArena::callbacks`], alive.
unsafe fn arena<'a>(user: *mut c_void) -> &'a CmdArena {
    // SAFETY: the caller's contract.
    unsafe { &*(user as *const CmdArena) }
}

unsafe extern "system" fn allocation(
    user: *mut c_void,
    size: usize,
    align: usize,
    _scope: vk::SystemAllocationScope,
) -> *mut c_void {
    // SAFETY: Vulkan passes back the user data of `callbacks`, whose arena
    // outlives the pool.
    let a = unsafe { arena(user) };
    a.alloc(size.max(1), align.max(1)) as *mut c_void
}

unsafe extern "system" fn reallocation(
    user: *mut c_void,
    original: *mut c_void,
    size: usize,
    align: usize,
    _scope: vk::SystemAllocationScope,
) -> *mut c_void {
    // SAFETY: as in `allocation`.
    let a = unsafe { arena(user) };
    if original.is_null() {
        return a.alloc(size.max(1), align.max(1)) as *mut c_void;
    }
    if size == 0 {
        // SAFETY: Vulkan frees a block these callbacks returned.
        unsafe { a.free(original as *mut u8) };
        return ptr::null_mut();
    }
    // SAFETY: as above.
    unsafe { a.realloc(original as *mut u8, size, align.max(1)) as *mut c_void }
}

unsafe extern "system" fn free(user: *mut c_void, memory: *mut c_void) {
    if memory.is_null() {
        return;
    }
    // SAFETY: as in `allocation`; Vulkan frees a block these callbacks returned.
    unsafe { arena(user).free(memory as *mut u8) };
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fill(p: *mut u8, n: usize, v: u8) {
        // SAFETY: `p` is a live block of at least `n` bytes.
        unsafe { ptr::write_bytes(p, v, n) };
    }

    #[test]
    fn blocks_are_aligned_disjoint_and_reused_after_a_reset() {
        let a = CmdArena::default();
        let mut blocks = Vec::new();
        // More than a chunk's worth, of mixed sizes and alignments.
        for i in 0..3000usize {
            let (size, align) = (8 + (i * 37) % 200, 1 << (i % 7));
            let p = a.alloc(size, align);
            assert_eq!(p as usize % align.max(HEADER), 0);
            fill(p, size, i as u8);
            blocks.push((p, size, i as u8));
        }
        // No block overwrote another.
        for &(p, size, v) in &blocks {
            // SAFETY: live blocks of `size` bytes.
            let s = unsafe { std::slice::from_raw_parts(p, size) };
            assert!(s.iter().all(|&b| b == v));
        }
        let first = a.counts();
        assert!(first.chunks >= 2 && first.small == 3000 && first.large == 0);
        // A reset frees everything; recording the same again needs no chunk.
        for &(p, ..) in &blocks {
            // SAFETY: each block once.
            unsafe { a.free(p) };
        }
        for i in 0..3000usize {
            let p = a.alloc(8 + (i * 37) % 200, 1 << (i % 7));
            // SAFETY: just allocated.
            unsafe { a.free(p) };
        }
        assert_eq!(a.counts().chunks, first.chunks);
    }

    #[test]
    fn a_chunk_stays_while_one_block_in_it_lives() {
        let a = CmdArena::default();
        let keep = a.alloc(64, 8);
        fill(keep, 64, 7);
        let many: Vec<*mut u8> = (0..2000).map(|_| a.alloc(100, 8)).collect();
        for p in many {
            // SAFETY: each block once.
            unsafe { a.free(p) };
        }
        // Reused space never overlaps the kept block.
        let again: Vec<*mut u8> = (0..2000).map(|_| a.alloc(100, 8)).collect();
        for &p in &again {
            fill(p, 100, 1);
        }
        // SAFETY: live block of 64 bytes.
        assert!(unsafe { std::slice::from_raw_parts(keep, 64) }
            .iter()
            .all(|&b| b == 7));
        for p in again.into_iter().chain([keep]) {
            // SAFETY: each block once.
            unsafe { a.free(p) };
        }
    }

    #[test]
    fn large_blocks_and_reallocation_keep_their_contents() {
        let a = CmdArena::default();
        let big = a.alloc(CHUNK, 256);
        assert_eq!(big as usize % 256, 0);
        fill(big, CHUNK, 3);
        assert_eq!(a.counts().large, 1);
        let small = a.alloc(40, 8);
        for i in 0..40 {
            // SAFETY: within the 40-byte block.
            unsafe { small.add(i).write(i as u8) };
        }
        // SAFETY: live blocks of this arena.
        let grown = unsafe { a.realloc(small, 4 * CHUNK, 8) };
        // SAFETY: the first 40 bytes were copied.
        let s = unsafe { std::slice::from_raw_parts(grown, 40) };
        assert!(s.iter().enumerate().all(|(i, &b)| b == i as u8));
        // SAFETY: each block once.
        unsafe { a.free(grown) };
        // SAFETY: as above.
        unsafe { a.free(big) };
    }

    #[test]
    #[should_panic(expected = "freed twice")]
    fn a_double_free_is_caught() {
        let a = CmdArena::default();
        let p = a.alloc(16, 8);
        let q = a.alloc(16, 8);
        // SAFETY: deliberately wrong, caught by the live count before any
        // memory is touched (`q` keeps the chunk alive... until it does not).
        unsafe {
            a.free(p);
            a.free(q);
            a.free(p);
        }
    }
}
