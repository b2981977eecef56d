//! fmi2FreeInstance frees the FMU states its instance made that the importer did not free
//! (FMI 2.0: freeing an instance frees all memory its functions allocated). A test binary of
//! its own with a global allocator that counts live bytes, and one test, so nothing else
//! allocates in the process while the bytes are counted.

mod common;
use common::*;
use mbfmu::fmi::Status;
use std::alloc::{GlobalAlloc, Layout, System};
use std::ffi::{c_char, c_void};
use std::sync::atomic::{AtomicIsize, Ordering};

/// The system allocator, counting the bytes it has handed out and not got back.
struct Counting;

static LIVE: AtomicIsize = AtomicIsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc(layout);
        if !p.is_null() {
            LIVE.fetch_add(layout.size() as isize, Ordering::SeqCst);
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = System.alloc_zeroed(layout);
        if !p.is_null() {
            LIVE.fetch_add(layout.size() as isize, Ordering::SeqCst);
        }
        p
    }
    unsafe fn dealloc(&self, p: *mut u8, layout: Layout) {
        System.dealloc(p, layout);
        LIVE.fetch_sub(layout.size() as isize, Ordering::SeqCst);
    }
    unsafe fn realloc(&self, p: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let q = System.realloc(p, layout, new_size);
        if !q.is_null() {
            LIVE.fetch_add(new_size as isize - layout.size() as isize, Ordering::SeqCst);
        }
        q
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

fn live() -> isize {
    LIVE.load(Ordering::SeqCst)
}

/// An initialised instance after 10 doSteps (DOPRI5, a point ahead in its state), with
/// `n` FMU states got and one deserialized, none freed; the bytes they hold.
fn instance_with_states(n: usize) -> (Fmu, isize) {
    let f = Fmu::new("states_left");
    f.init(&[("F", 0.5)]);
    run_to(&f, 0.0, 0.1, 0.01);
    let before = live();
    let mut states = Vec::new();
    for _ in 0..n {
        let mut s: *mut c_void = std::ptr::null_mut();
        assert_eq!(unsafe { fmi2GetFMUstate(f.c, &mut s) }, Status::Ok);
        states.push(s);
    }
    let mut size = 0usize;
    assert_eq!(
        unsafe { fmi2SerializedFMUstateSize(f.c, states[0], &mut size) },
        Status::Ok
    );
    let mut blob = vec![0u8; size];
    let status =
        unsafe { fmi2SerializeFMUstate(f.c, states[0], blob.as_mut_ptr() as *mut c_char, size) };
    assert_eq!(status, Status::Ok);
    let mut s: *mut c_void = std::ptr::null_mut();
    let status =
        unsafe { fmi2DeSerializeFMUstate(f.c, blob.as_ptr() as *const c_char, blob.len(), &mut s) };
    assert_eq!(status, Status::Ok);
    drop(blob);
    drop(states);
    (f, live() - before)
}

#[test]
fn free_instance_frees_the_states_left_to_it() {
    // A first round computes what the process keeps for good (the model's layout and GUID,
    // cached once) and warms up the registry of states.
    let (warm_up, _) = instance_with_states(2);
    drop(warm_up);
    let baseline = live();
    let (f, held) = instance_with_states(5);
    drop(f); // fmi2FreeInstance
    let lost = live() - baseline;
    // (Printed only now: the test harness's capture of stdout allocates.)
    println!(
        "METRIC 6 FMU states of MassSpringDamper hold {held} bytes ({} each); bytes lost after fmi2FreeInstance: {lost}",
        held / 6
    );
    assert!(held > 0);
    assert_eq!(lost, 0, "fmi2FreeInstance left {lost} bytes allocated");
    assert!(log_of("states_left").is_empty());
}
