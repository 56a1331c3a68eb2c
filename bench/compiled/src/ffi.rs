//! The C peers (c/peers.h) behind a safe interface.

use std::ffi::CStr;
use std::os::raw::{c_char, c_double, c_int, c_long};

#[repr(C)]
struct Problem {
    _private: [u8; 0],
}

#[repr(C)]
struct TrajC {
    dim: usize,
    len: usize,
    cap: usize,
    t: *mut c_double,
    y: *mut c_double,
}

#[repr(C)]
#[derive(Default)]
struct StatsC {
    steps: c_long,
    rejected: c_long,
    rhs_evals: c_long,
    newton_iters: c_long,
}

unsafe extern "C" {
    fn problem_new(scene: c_int, n: c_int) -> *mut Problem;
    fn problem_free(p: *mut Problem);
    fn traj_init(tr: *mut TrajC, dim: usize);
    fn traj_free(tr: *mut TrajC);
    fn peers_last_error() -> *const c_char;
    fn dopri5(
        p: *const Problem,
        t0: c_double,
        t1: c_double,
        y0: *const c_double,
        rtol: c_double,
        atol: c_double,
        record: c_int,
        out: *mut TrajC,
        st: *mut StatsC,
    ) -> c_int;
    fn symplectic(
        p: *const Problem,
        t0: c_double,
        t1: c_double,
        y0: *const c_double,
        steps: c_long,
        order: c_int,
        record: c_int,
        out: *mut TrajC,
        st: *mut StatsC,
    ) -> c_int;
    fn sundials_run(
        p: *const Problem,
        method: c_int,
        t0: c_double,
        t1: c_double,
        y0: *const c_double,
        rtol: c_double,
        atol: c_double,
        record: c_int,
        out: *mut TrajC,
        st: *mut StatsC,
    ) -> c_int;
}

/// A recorded run: times, states row by row, counters.
#[derive(Debug, Clone, Default)]
pub struct Run {
    pub t: Vec<f64>,
    pub y: Vec<f64>,
    pub steps: usize,
    pub newton_iterations: usize,
    /// Wall time of the solve call alone (set-up, stepping, recording).
    pub wall_s: f64,
}

/// What to run in C.
#[derive(Debug, Clone, Copy)]
pub enum CMethod {
    Dopri5 { rtol: f64, atol: f64 },
    Symplectic { steps: usize, order: i32 },
    Sundials { method: i32, rtol: f64, atol: f64 },
}

/// SUNDIALS method codes (c/peers.h `enum sundials_method`).
pub const CVODE_ADAMS: i32 = 0;
pub const CVODE_BDF: i32 = 1;
pub const ARKODE_ERK: i32 = 2;
pub const ARKODE_DIRK: i32 = 3;
pub const IDA: i32 = 4;

/// A scene's C problem (owned).
pub struct CProblem(*mut Problem);

impl CProblem {
    pub fn new(scene: i32, n: usize) -> Result<Self, String> {
        let n = c_int::try_from(n).map_err(|_| format!("size {n} too large"))?;
        // SAFETY: problem_new only reads its integer arguments; NULL is handled below.
        let p = unsafe { problem_new(scene, n) };
        if p.is_null() {
            Err(format!("C problem for scene {scene} could not be created"))
        } else {
            Ok(Self(p))
        }
    }

    /// Runs `method` from `y0` on `[0, t1]`; `record`: every step, else the final state only.
    pub fn run(&self, method: CMethod, t1: f64, y0: &[f64], record: bool) -> Result<Run, String> {
        let mut tr = TrajC {
            dim: 0,
            len: 0,
            cap: 0,
            t: std::ptr::null_mut(),
            y: std::ptr::null_mut(),
        };
        let mut st = StatsC::default();
        let rec = c_int::from(record);
        let start = std::time::Instant::now();
        // SAFETY: `self.0` is a live problem of dimension y0.len(); `tr` and `st` are valid for
        // writes; the C side only reads y0.
        let rc = unsafe {
            traj_init(&mut tr, y0.len());
            match method {
                CMethod::Dopri5 { rtol, atol } => dopri5(
                    self.0,
                    0.0,
                    t1,
                    y0.as_ptr(),
                    rtol,
                    atol,
                    rec,
                    &mut tr,
                    &mut st,
                ),
                CMethod::Symplectic { steps, order } => symplectic(
                    self.0,
                    0.0,
                    t1,
                    y0.as_ptr(),
                    steps as c_long,
                    order,
                    rec,
                    &mut tr,
                    &mut st,
                ),
                CMethod::Sundials { method, rtol, atol } => sundials_run(
                    self.0,
                    method,
                    0.0,
                    t1,
                    y0.as_ptr(),
                    rtol,
                    atol,
                    rec,
                    &mut tr,
                    &mut st,
                ),
            }
        };
        let wall_s = start.elapsed().as_secs_f64();
        let out = if rc == 0 {
            // SAFETY: on success the C side filled len points of dim values.
            let (t, y) = unsafe {
                (
                    std::slice::from_raw_parts(tr.t, tr.len).to_vec(),
                    std::slice::from_raw_parts(tr.y, tr.len * tr.dim).to_vec(),
                )
            };
            Ok(Run {
                t,
                y,
                steps: st.steps as usize,
                newton_iterations: st.newton_iters as usize,
                wall_s,
            })
        } else {
            // SAFETY: peers_last_error returns a NUL-terminated static buffer.
            let msg = unsafe { CStr::from_ptr(peers_last_error()) };
            Err(format!("rc {rc}: {}", msg.to_string_lossy()))
        };
        // SAFETY: tr was initialised by traj_init and is freed once.
        unsafe { traj_free(&mut tr) };
        out
    }
}

impl Drop for CProblem {
    fn drop(&mut self) {
        // SAFETY: created by problem_new, freed once.
        unsafe { problem_free(self.0) };
    }
}
