//! Serialized FMU states are checked before they are trusted: every single-bit flip of a
//! valid blob is refused (its CRC-32 no longer matches), for a plain system through the C
//! API and, through the instance API, for a Lagrangian system, a constrained one (surplus
//! coordinates with projection) and each integrator that keeps a dense-output state ahead of
//! the communication time (DOPRI5, DOP853, RADAU5).

mod common;
mod dense_common;

use common::*;
use dense_common::{Case, DOP853, RADAU5};
use mbfmu::fmi::{Instance, Snapshot, Status};
use mbfmu::integrators::Method;
use mbfmu::model::System;
use mbfmu::systems::{DoublePendulum, SliderCrankSurplus};
use std::ffi::{c_char, c_void};

/// Flips every bit of `blob` in turn and hands the copy to `deserialize`, which must refuse
/// it with a one-line message. Returns how many flips were tried and how many the checksum
/// caught (the others hit the magic or the version, checked first).
fn every_flip_is_refused(
    what: &str,
    blob: &[u8],
    mut deserialize: impl FnMut(&[u8]) -> Result<(), String>,
) -> (usize, usize) {
    let (mut tried, mut by_crc) = (0, 0);
    let mut bad = blob.to_vec();
    for byte in 0..blob.len() {
        for bit in 0..8 {
            bad[byte] ^= 1 << bit;
            match deserialize(&bad) {
                Ok(()) => panic!("{what}: the flip of bit {bit} of byte {byte} was accepted"),
                Err(e) => {
                    assert!(!e.contains('\n'), "{what}: {e}");
                    by_crc += e.contains("corrupted") as usize;
                }
            }
            bad[byte] ^= 1 << bit;
            tried += 1;
        }
    }
    assert_eq!(deserialize(blob), Ok(()), "{what}: the intact blob");
    println!(
        "METRIC {what}: {} bytes, {tried} flips refused ({by_crc} by the CRC-32)",
        blob.len()
    );
    // Only the 8 magic and 4 version bytes are checked before the checksum.
    assert_eq!(by_crc, tried - 12 * 8, "{what}");
    (tried, by_crc)
}

/// The blob of an instance of `S` started on `scene` with `solver` after `n` doSteps of
/// 1e-2 s, checked flip by flip through [`Instance::deserialize`].
fn check<S: System>(scene: &'static str, solver: i32, n: usize, what: &str) -> Instance<S> {
    let case = Case::<S>::new(scene, &[], 1e-8);
    let mut inst = case.started(solver, 1e-2, 0.0, &[("solver_step", 1e-3)]);
    for i in 0..n {
        inst.do_step(i as f64 * 1e-2, 1e-2).unwrap();
    }
    let blob = inst.serialize(&inst.snapshot());
    every_flip_is_refused(what, &blob, |b| inst.deserialize(b).map(|_| ()));
    inst
}

/// MassSpringDamper through fmi2DeSerializeFMUstate: each refusal returns fmi2Error, leaves
/// the state pointer NULL and logs one line.
#[test]
fn every_bit_flip_of_a_plain_systems_blob_is_refused_through_the_c_api() {
    for (solver, name) in [(Method::Rk4, "flip_rk4"), (Method::Dopri5, "flip_dopri5")] {
        let f = Fmu::new(name);
        assert_eq!(
            unsafe { fmi2SetInteger(f.c, &vr("solver"), 1, &solver.code()) },
            Status::Ok
        );
        f.init(&[("F", 0.5)]);
        run_to(&f, 0.0, 0.1, 0.01);
        let mut s: *mut c_void = std::ptr::null_mut();
        assert_eq!(unsafe { fmi2GetFMUstate(f.c, &mut s) }, Status::Ok);
        let mut size = 0usize;
        assert_eq!(
            unsafe { fmi2SerializedFMUstateSize(f.c, s, &mut size) },
            Status::Ok
        );
        let mut blob = vec![0u8; size];
        let status =
            unsafe { fmi2SerializeFMUstate(f.c, s, blob.as_mut_ptr() as *mut c_char, size) };
        assert_eq!(status, Status::Ok);
        let what = format!("MassSpringDamper {}", solver.name());
        every_flip_is_refused(&what, &blob, |b| {
            let mut out: *mut c_void = std::ptr::null_mut();
            let n = f.errors();
            let status = unsafe {
                fmi2DeSerializeFMUstate(f.c, b.as_ptr() as *const c_char, b.len(), &mut out)
            };
            match status {
                Status::Ok => {
                    assert_eq!(unsafe { fmi2FreeFMUstate(f.c, &mut out) }, Status::Ok);
                    Ok(())
                }
                _ => {
                    assert_eq!(status, Status::Error);
                    assert!(out.is_null());
                    let log = log_of(&f.name);
                    assert_eq!(log.len(), n + 1, "one line per refusal");
                    Err(log[n].2.clone())
                }
            }
        });
        assert_eq!(unsafe { fmi2FreeFMUstate(f.c, &mut s) }, Status::Ok);
    }
}

#[test]
fn every_bit_flip_of_a_lagrangian_systems_blob_is_refused() {
    let rattle = Method::Rattle.code();
    check::<DoublePendulum>("chaotic", rattle, 20, "DoublePendulum RATTLE");
}

#[test]
fn every_bit_flip_of_a_constrained_systems_blob_is_refused() {
    let rk4 = Method::Rk4.code();
    check::<SliderCrankSurplus>("run", rk4, 20, "SliderCrankSurplus RK4");
}

#[test]
fn every_bit_flip_of_a_blob_with_a_state_ahead_is_refused() {
    let dopri5 = Method::Dopri5.code();
    let owner = |s: Snapshot| s.memory.ahead.map(|a| a.method().code());
    let inst = check::<DoublePendulum>("chaotic", dopri5, 20, "DoublePendulum DOPRI5");
    assert_eq!(owner(inst.snapshot()), Some(dopri5));
    let inst = check::<DoublePendulum>("chaotic", DOP853, 20, "DoublePendulum DOP853");
    assert_eq!(owner(inst.snapshot()), Some(DOP853));
    let inst = check::<SliderCrankSurplus>("run", RADAU5, 20, "SliderCrankSurplus RADAU5");
    assert_eq!(owner(inst.snapshot()), Some(RADAU5));
}
