//! The fuzz targets' bodies and the allocation limit they run under.
//!
//! Each target feeds arbitrary bytes to a reader and checks what must hold whatever the input:
//! no panic (libFuzzer reports one as a crash), no input taking more than a second (`-timeout=1`),
//! no allocation beyond [`LIVE_LIMIT`] (the [`Limited`] allocator aborts), and the round trips
//! the readers promise.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

/// Most bytes a single input may hold allocated at once. The largest bundled model (a ladder of
/// subcircuits) needs well under 1 MiB; 256 MiB means an input made the reader allocate without
/// bound (an exploding subcircuit hierarchy, a huge repeat count).
pub const LIVE_LIMIT: usize = 256 << 20;

/// The system allocator with a cap on the bytes live at once: crossing it aborts, which
/// libFuzzer records as a crash with the input that caused it.
pub struct Limited {
    live: AtomicUsize,
}

impl Limited {
    /// An allocator with nothing allocated.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            live: AtomicUsize::new(0),
        }
    }

    fn grow(&self, bytes: usize) {
        let before = self.live.fetch_add(bytes, Ordering::Relaxed);
        if before.saturating_add(bytes) > LIVE_LIMIT {
            // No formatting here: it would allocate.
            let message = b"dirac-fuzz: more than LIVE_LIMIT bytes allocated at once\n";
            let _ = std::io::Write::write_all(&mut std::io::stderr(), message);
            std::process::abort();
        }
    }

    fn shrink(&self, bytes: usize) {
        self.live.fetch_sub(bytes, Ordering::Relaxed);
    }
}

impl Default for Limited {
    fn default() -> Self {
        Self::new()
    }
}

// SAFETY: every call is forwarded to `System` with the caller's arguments; the counter only
// observes sizes.
unsafe impl GlobalAlloc for Limited {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        self.grow(layout.size());
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        self.grow(layout.size());
        // SAFETY: forwarded unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        self.shrink(layout.size());
        // SAFETY: forwarded unchanged.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            self.grow(new_size - layout.size());
        } else {
            self.shrink(layout.size() - new_size);
        }
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Netlist reader: text → [`dirac_netlist::Netlist`] → circuit, and a netlist that converts to a
/// scene must give a scene that parses and builds (`dirac convert` promises a runnable scene).
pub fn netlist(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(netlist) = dirac_netlist::parse_netlist(text, "fuzz.cir") else {
        return;
    };
    if dirac_netlist::build_circuit(&netlist, "fuzz.cir").is_err() {
        return;
    }
    if let Ok(scene) = dirac_scene::netlist_to_scene(&netlist, "fuzz.cir") {
        let parsed = dirac_scene::Scene::parse(&scene, "converted.toml")
            .unwrap_or_else(|e| panic!("converted scene does not parse: {e}\n{scene}"));
        if let Err(e) = parsed.build() {
            panic!("converted scene does not build: {e}\n{scene}");
        }
    }
}

/// Scene reader: text → [`dirac_scene::Scene`] → built scene, and a parsed scene written back
/// with [`dirac_scene::Scene::to_toml`] parses to an equal scene.
pub fn scene(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = dirac_scene::Scene::parse(text, "fuzz.toml") else {
        return;
    };
    let _ = scene.build();
    let written = scene
        .to_toml()
        .unwrap_or_else(|e| panic!("a parsed scene does not serialise: {e}"));
    let again = dirac_scene::Scene::parse(&written, "again.toml")
        .unwrap_or_else(|e| panic!("a written scene does not parse: {e}\n{written}"));
    assert!(again == scene, "round trip changed the scene:\n{written}");
}
