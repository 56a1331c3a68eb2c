//! Compiles the C peers (c/*.c) and links Debian's SUNDIALS 6 (libsundials-dev).
fn main() {
    let sources = ["c/scenes.c", "c/dopri5.c", "c/symplectic.c", "c/sundials.c"];
    for s in sources.iter().chain(&["c/peers.h"]) {
        println!("cargo:rerun-if-changed={s}");
    }
    cc::Build::new()
        .files(sources)
        .opt_level(3)
        .warnings(true)
        .extra_warnings(true)
        .compile("peers");
    for lib in [
        "sundials_cvode",
        "sundials_arkode",
        "sundials_ida",
        "sundials_nvecserial",
        "sundials_sunmatrixdense",
        "sundials_sunmatrixband",
        "sundials_sunlinsoldense",
        "sundials_sunlinsolband",
        "sundials_sunnonlinsolfixedpoint",
        "sundials_sunnonlinsolnewton",
        "m",
    ] {
        println!("cargo:rustc-link-lib={lib}");
    }
}
