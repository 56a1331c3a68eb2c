//! libFuzzer target: the netlist reader (see `dirac_fuzz::netlist`).
#![no_main]

#[global_allocator]
static ALLOCATOR: dirac_fuzz::Limited = dirac_fuzz::Limited::new();

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    dirac_fuzz::cpu_limited(|| dirac_fuzz::netlist(data));
});
