//! libFuzzer target: the scene reader (see `dirac_fuzz::scene`).
#![no_main]

#[global_allocator]
static ALLOCATOR: dirac_fuzz::Limited = dirac_fuzz::Limited::new();

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    dirac_fuzz::cpu_limited(|| dirac_fuzz::scene(data));
});
