//! One process-wide lock around the validation layer's table of instances and
//! devices, so that contexts on several threads can run with validation on.
//!
//! `VK_LAYER_KHRONOS_validation` (1.3.239 here, Debian 12) keeps one global map
//! from a dispatchable handle's dispatch key to its per-instance or per-device
//! state (`layer_data_map`). Creating or destroying an instance or a device
//! inserts into or erases from that map without a lock, and every call through the
//! layer looks its handle up in it (`GetLayerDataPtr`), also without a lock
//! (KhronosGroup/Vulkan-ValidationLayers#4391, open against this version). A call
//! on one context while another thread creates or destroys a context walks a map
//! being rewritten: the parallel GPU test run died of SIGSEGV inside that lookup
//! (core dumps: a `vkDestroyFence` in `GetLayerDataPtr`'s bucket walk while another
//! thread was in `vkCreateInstance`/`vkDestroyDevice`).
//!
//! So a context whose calls go through the layer (validation on, or a host's
//! device, which may have it) holds the lock shared at each of its entry points
//! (executor, embedder, presenter methods, resource drops), and creating or
//! destroying a validated instance and device holds it exclusively. Contexts
//! without validation never take it: their calls never reach the layer.
//!
//! The lock is re-entrant per thread (entry points call one another, and an
//! exclusive holder may use contexts); asking for exclusive use while the thread
//! holds shared use would deadlock and panics instead.

use std::cell::Cell;
use std::sync::{RwLock, RwLockReadGuard, RwLockWriteGuard};

static TABLE: RwLock<()> = RwLock::new(());

/// What the current thread holds, and how many nested uses share it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Held {
    Nothing,
    Shared(u32),
    Exclusive(u32),
}

thread_local! {
    static HELD: Cell<Held> = const { Cell::new(Held::Nothing) };
}

enum Guard {
    /// Not taken: the context's calls do not go through the layer.
    Off,
    /// Nested inside a use this thread already holds.
    Nested,
    Shared(#[allow(dead_code)] RwLockReadGuard<'static, ()>),
    Exclusive(#[allow(dead_code)] RwLockWriteGuard<'static, ()>),
}

/// A held use of the layer's table; released on drop. Not `Send` (the guards are
/// not), so it is released on the thread that took it.
#[must_use = "the lock is released when this is dropped"]
pub struct LayerUse(Guard);

/// Shared use, for calls on a context whose calls go through the layer (`layered`).
pub(crate) fn shared(layered: bool) -> LayerUse {
    if !layered {
        return LayerUse(Guard::Off);
    }
    HELD.with(|h| match h.get() {
        Held::Nothing => {
            // A panic while holding the lock leaves no broken data: `()` is all
            // it guards, so a poisoned lock is still a lock.
            let g = TABLE.read().unwrap_or_else(|e| e.into_inner());
            h.set(Held::Shared(1));
            LayerUse(Guard::Shared(g))
        }
        Held::Shared(n) => {
            h.set(Held::Shared(n + 1));
            LayerUse(Guard::Nested)
        }
        Held::Exclusive(n) => {
            h.set(Held::Exclusive(n + 1));
            LayerUse(Guard::Nested)
        }
    })
}

/// Exclusive use: no call through the layer runs on another thread of this process
/// while it is held. Peeltrim takes it to create and destroy a validated instance
/// and device; an embedding host that creates or destroys its own instance or
/// device with the validation layer while peeltrim contexts run on other threads
/// takes it around that too.
///
/// # Panics
/// When this thread already holds shared use (waiting would never end).
pub fn exclusive() -> LayerUse {
    HELD.with(|h| match h.get() {
        Held::Nothing => {
            let g = TABLE.write().unwrap_or_else(|e| e.into_inner());
            h.set(Held::Exclusive(1));
            LayerUse(Guard::Exclusive(g))
        }
        Held::Exclusive(n) => {
            h.set(Held::Exclusive(n + 1));
            LayerUse(Guard::Nested)
        }
        Held::Shared(_) => panic!(
            "vk::layer_lock::exclusive() on a thread that is inside a peeltrim call of a \
             validated context: the exclusive lock would wait for itself (create or drop \
             contexts outside executor, embedder and presenter calls)"
        ),
    })
}

impl Drop for LayerUse {
    fn drop(&mut self) {
        if matches!(self.0, Guard::Off) {
            return;
        }
        HELD.with(|h| {
            let next = match h.get() {
                Held::Shared(1) | Held::Exclusive(1) => Held::Nothing,
                Held::Shared(n) => Held::Shared(n - 1),
                Held::Exclusive(n) => Held::Exclusive(n - 1),
                Held::Nothing => panic!("a layer-table use released twice"),
            };
            h.set(next);
        });
        // The guard itself (if any) is released right after, with the field.
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn held() -> Held {
        HELD.with(|h| h.get())
    }

    #[test]
    fn nested_uses_count_and_release_in_order() {
        assert_eq!(held(), Held::Nothing);
        {
            let _a = shared(true);
            let _b = shared(true);
            assert_eq!(held(), Held::Shared(2));
            let _off = shared(false);
            assert_eq!(held(), Held::Shared(2));
        }
        assert_eq!(held(), Held::Nothing);
        {
            let _x = exclusive();
            let _s = shared(true);
            let _y = exclusive();
            assert_eq!(held(), Held::Exclusive(3));
        }
        assert_eq!(held(), Held::Nothing);
    }

    #[test]
    fn exclusive_waits_for_shared_use_on_another_thread() {
        use std::sync::atomic::{AtomicBool, Ordering};
        use std::sync::Arc;
        let _s = shared(true);
        let done = Arc::new(AtomicBool::new(false));
        let d = done.clone();
        let t = std::thread::spawn(move || {
            let _x = exclusive();
            d.store(true, Ordering::SeqCst);
        });
        std::thread::sleep(std::time::Duration::from_millis(50));
        assert!(
            !done.load(Ordering::SeqCst),
            "exclusive use while shared use is held"
        );
        drop(_s);
        t.join().expect("the exclusive user finishes");
        assert!(done.load(Ordering::SeqCst));
    }

    #[test]
    #[should_panic(expected = "would wait for itself")]
    fn exclusive_inside_shared_use_panics() {
        let _s = shared(true);
        let _x = exclusive();
    }
}
