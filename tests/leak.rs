//! Instantiate/free in a loop must not grow memory. A test binary of its own, so no
//! other test allocates in the same process while resident memory is measured.

mod common;
use common::*;
use std::ffi::c_void;

fn resident_kib() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap();
    let pages: u64 = statm.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * 4
}

#[test]
fn instantiate_and_free_do_not_leak() {
    let cycle = || {
        let f = Fmu::new("leak");
        f.init(&[]);
        run_to(&f, 0.0, 0.02, 0.01);
        let mut s: *mut c_void = std::ptr::null_mut();
        unsafe {
            fmi2GetFMUstate(f.c, &mut s);
            fmi2FreeFMUstate(f.c, &mut s);
        }
    };
    for _ in 0..200 {
        cycle();
    }
    let after_warmup = resident_kib();
    for _ in 0..2000 {
        cycle();
    }
    let grown = resident_kib().saturating_sub(after_warmup);
    // One leaked instance is ~1 KiB: 2000 of them would show as ≥ 2 MiB.
    assert!(
        grown < 1024,
        "resident memory grew by {grown} KiB over 2000 cycles"
    );
}
