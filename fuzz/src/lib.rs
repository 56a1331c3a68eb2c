//! The fuzz targets' bodies and the allocation limit they run under.
//!
//! Each target feeds arbitrary bytes to a reader and checks what must hold whatever the input:
//! no panic (libFuzzer reports one as a crash), no input taking more than [`CPU_LIMIT`] of CPU
//! time, no allocation beyond [`LIVE_LIMIT`] (the [`Limited`] allocator aborts), and the round
//! trips the readers promise.

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

/// Most CPU time a single input may take. Measured on the thread's CPU clock, not the wall clock
/// (libFuzzer's `-timeout`), so that a run at `nice -n 19` on a busy machine, where an input can
/// wait many seconds for a core, does not report slow scheduling as a hang. The slowest input
/// known (nested subcircuits stopped at 10⁵ elements) takes about 0.2 s.
pub const CPU_LIMIT: Duration = Duration::from_secs(1);

/// CPU time the calling thread has used so far.
fn thread_cpu_time() -> Duration {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec; the clock id is a constant Linux defines.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &raw mut t) };
    assert_eq!(status, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    Duration::new(
        u64::try_from(t.tv_sec).unwrap_or(0),
        u32::try_from(t.tv_nsec).unwrap_or(0),
    )
}

/// Runs `body` and panics (a crash to libFuzzer, which keeps the input) when it took more than
/// [`CPU_LIMIT`] of CPU time.
pub fn cpu_limited(body: impl FnOnce()) {
    let start = thread_cpu_time();
    body();
    let used = thread_cpu_time().saturating_sub(start);
    assert!(
        used <= CPU_LIMIT,
        "one input took {used:?} of CPU time (limit {CPU_LIMIT:?})"
    );
}

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

/// Largest circuit (in parts) whose scene conversion the netlist target checks. The conversion's
/// correctness does not depend on size, while its cost does: a 1 kB netlist of nested
/// subcircuits expands to 4·10⁴ resistors, whose 3.7 MB scene text takes the instrumented build
/// about 2 s to write and read back. The reader itself (parsing and building, bounded by the
/// netlist's 10⁵-element expansion limit) is held to [`CPU_LIMIT`] at every size.
pub const ROUND_TRIP_PARTS: usize = 10_000;

/// Netlist reader: text → [`dirac_netlist::Netlist`] → circuit, and a netlist that converts to a
/// scene must give a scene that parses and builds (`dirac convert` promises a runnable scene;
/// [`dirac_scene::Scene::parse`] builds the scene it reads).
pub fn netlist(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(netlist) = dirac_netlist::parse_netlist(text, "fuzz.cir") else {
        return;
    };
    let Ok(circuit) = dirac_netlist::build_circuit(&netlist, "fuzz.cir") else {
        return;
    };
    if circuit.graph.subsystems().len() > ROUND_TRIP_PARTS {
        return;
    }
    if let Ok(scene) = dirac_scene::netlist_to_scene(&netlist, "fuzz.cir") {
        if let Err(e) = dirac_scene::Scene::parse(&scene, "converted.toml") {
            panic!("converted scene does not parse or build: {e}\n{scene}");
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
