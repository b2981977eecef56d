//! The FMI 3.0 C API driven from Rust through its `extern "C"` symbols, on SphereSlide (a
//! particle leaving a sphere: an event inside a step): the state machine and its
//! refusals, directional against adjoint derivatives, the FMU state blob, early return at
//! the event, and agreement with the FMI 2.0 symbols of the same binary.

use mbfmu::fmi::{CallbackFunctions, Export, Status};
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::sync::Mutex;

mbfmu::export_fmu!(mbfmu::systems::SphereSlide);
use fmi2_symbols::*;
use fmi3_symbols::*;

type Instance = *mut c_void;

/// Log lines received: (instance tag, status, message).
static LOG: Mutex<Vec<(usize, c_int, String)>> = Mutex::new(Vec::new());

unsafe extern "C" fn record(
    env: *mut c_void,
    status: c_int,
    _category: *const c_char,
    message: *const c_char,
) {
    let message = CStr::from_ptr(message).to_string_lossy().into_owned();
    LOG.lock().unwrap().push((env as usize, status, message));
}

fn lines(tag: usize) -> Vec<(c_int, String)> {
    LOG.lock()
        .unwrap()
        .iter()
        .filter(|(t, ..)| *t == tag)
        .map(|(_, s, m)| (*s, m.clone()))
        .collect()
}

fn token() -> CString {
    CString::new(ExportedModel::info().guid.clone()).unwrap()
}

fn vr(name: &str) -> u32 {
    ExportedModel::info().layout.vr_of(name).unwrap()
}

/// `time`'s value reference: the first one after FMI 2.0's.
fn time_vr() -> u32 {
    ExportedModel::info().layout.vars.len() as u32
}

struct Fmu3 {
    c: Instance,
    tag: usize,
}

impl Fmu3 {
    fn cs(tag: usize, event_mode_used: bool, early_return: bool) -> Fmu3 {
        Self::cs_with(tag, event_mode_used, early_return, None)
    }

    fn cs_with(
        tag: usize,
        event_mode_used: bool,
        early_return: bool,
        update: Option<mbfmu::fmi::fmi3::IntermediateUpdate>,
    ) -> Fmu3 {
        let name = CString::new(format!("cs{tag}")).unwrap();
        let c = unsafe {
            fmi3InstantiateCoSimulation(
                name.as_ptr(),
                token().as_ptr(),
                std::ptr::null(),
                0,
                0,
                event_mode_used as u8,
                early_return as u8,
                std::ptr::null(),
                0,
                tag as *mut c_void,
                Some(record),
                update,
            )
        };
        assert!(!c.is_null());
        Fmu3 { c, tag }
    }

    fn me(tag: usize) -> Fmu3 {
        let name = CString::new(format!("me{tag}")).unwrap();
        let c = unsafe {
            fmi3InstantiateModelExchange(
                name.as_ptr(),
                token().as_ptr(),
                std::ptr::null(),
                0,
                0,
                tag as *mut c_void,
                Some(record),
            )
        };
        assert!(!c.is_null());
        Fmu3 { c, tag }
    }

    fn init(&self) {
        assert_eq!(
            fmi3EnterInitializationMode(self.c, 1, 1e-10, 0.0, 0, 0.0),
            Status::Ok
        );
        assert_eq!(fmi3ExitInitializationMode(self.c), Status::Ok);
    }

    fn get(&self, vr: u32) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(
            unsafe { fmi3GetFloat64(self.c, &vr, 1, &mut v, 1) },
            Status::Ok
        );
        v
    }

    fn step(&self, t: f64, h: f64) -> (Status, bool, bool, f64) {
        let (mut event, mut terminate, mut early, mut last) = (0u8, 0u8, 0u8, f64::NAN);
        let status = unsafe {
            fmi3DoStep(
                self.c,
                t,
                h,
                0,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last,
            )
        };
        assert_eq!(terminate, 0);
        (status, event != 0, early != 0, last)
    }

    fn errors(&self) -> usize {
        lines(self.tag).iter().filter(|(s, _)| *s == 3).count()
    }
}

impl Drop for Fmu3 {
    fn drop(&mut self) {
        unsafe { fmi3FreeInstance(self.c) }
    }
}

fn states() -> Vec<u32> {
    ["x", "h", "vx", "vh", "on_surface"]
        .iter()
        .map(|n| vr(n))
        .collect()
}

#[test]
fn version_and_a_wrong_token() {
    assert_eq!(
        unsafe { CStr::from_ptr(fmi3GetVersion()) }.to_str(),
        Ok("3.0")
    );
    let name = CString::new("bad").unwrap();
    let wrong = CString::new("{not-this-model}").unwrap();
    let c = unsafe {
        fmi3InstantiateModelExchange(
            name.as_ptr(),
            wrong.as_ptr(),
            std::ptr::null(),
            0,
            0,
            900 as *mut c_void,
            Some(record),
        )
    };
    assert!(c.is_null());
    assert_eq!(lines(900).len(), 1, "one line for the refusal");
    // Scheduled Execution is not offered: NULL, one line.
    let c = unsafe {
        fmi3InstantiateScheduledExecution(
            name.as_ptr(),
            token().as_ptr(),
            std::ptr::null(),
            0,
            0,
            901 as *mut c_void,
            Some(record),
            std::ptr::null(),
            std::ptr::null(),
            std::ptr::null(),
        )
    };
    assert!(c.is_null());
    assert_eq!(lines(901).len(), 1);
}

/// Each refused call returns fmi3Error, logs exactly one line and changes nothing.
#[test]
fn the_state_machine_refuses_with_one_line_each() {
    let f = Fmu3::cs(1, false, false);
    let c = f.c;
    let mut refused = 0;
    let mut expect_error = |what: &str, status: Status| {
        assert_eq!(status, Status::Error, "{what}");
        refused += 1;
        assert_eq!(f.errors(), refused, "{what}: one line each");
    };
    // Instantiated.
    expect_error("doStep before init", f.step(0.0, 0.1).0);
    expect_error("exit before enter", fmi3ExitInitializationMode(c));
    expect_error("update discrete states", unsafe {
        let mut b = [0u8; 5];
        let mut t = 0.0;
        fmi3UpdateDiscreteStates(
            c, &mut b[0], &mut b[1], &mut b[2], &mut b[3], &mut b[4], &mut t,
        )
    });
    expect_error(
        "tolerance 2",
        fmi3EnterInitializationMode(c, 1, 2.0, 0.0, 0, 0.0),
    );
    expect_error(
        "stop before start",
        fmi3EnterInitializationMode(c, 0, 0.0, 1.0, 1, 0.5),
    );
    f.init();
    // Step Mode.
    let t = f.get(time_vr());
    assert_eq!(t, 0.0);
    let x = f.get(vr("x"));
    let nan = f64::NAN;
    expect_error("set time", unsafe {
        fmi3SetFloat64(c, &time_vr(), 1, &1.0, 1)
    });
    expect_error("NaN", unsafe { fmi3SetFloat64(c, &vr("g"), 1, &nan, 1) });
    expect_error("parameter after init", unsafe {
        fmi3SetFloat64(c, &vr("g"), 1, &1.0, 1)
    });
    expect_error("unknown vr", unsafe {
        fmi3GetFloat64(c, &9999, 1, &mut 0.0, 1)
    });
    expect_error("nValues", unsafe {
        fmi3GetFloat64(c, &vr("x"), 1, &mut 0.0, 2)
    });
    expect_error("NULL values", unsafe {
        fmi3GetFloat64(c, &vr("x"), 1, std::ptr::null_mut(), 1)
    });
    expect_error("Float64 as Int32", unsafe {
        fmi3GetInt32(c, &vr("x"), 1, &mut 0, 1)
    });
    expect_error("enumeration as Int32", unsafe {
        fmi3GetInt32(c, &vr("solver"), 1, &mut 0, 1)
    });
    expect_error("Boolean", unsafe {
        fmi3GetBoolean(c, &vr("x"), 1, &mut 0, 1)
    });
    expect_error("String", unsafe {
        fmi3GetString(c, &vr("x"), 1, &mut std::ptr::null(), 1)
    });
    expect_error("clock", fmi3GetClock(c, &0, 1, &mut 0));
    expect_error("configuration mode", fmi3EnterConfigurationMode(c));
    expect_error("event mode without eventModeUsed", fmi3EnterEventMode(c));
    expect_error("ME function on CS", fmi3SetTime(c, 0.0));
    expect_error("enter step mode from step mode", fmi3EnterStepMode(c));
    expect_error("h = 0", f.step(0.0, 0.0).0);
    expect_error("wrong time", f.step(0.5, 0.1).0);
    expect_error("h = NaN", f.step(0.0, nan).0);
    // The enumeration is an Int64.
    let mut solver = 0i64;
    assert_eq!(
        unsafe { fmi3GetInt64(c, &vr("solver"), 1, &mut solver, 1) },
        Status::Ok
    );
    assert!(solver > 0);
    // Nothing changed.
    assert_eq!(f.get(vr("x")), x);
    assert_eq!(f.step(0.0, 0.1).0, Status::Ok);
    assert!((f.get(time_vr()) - 0.1).abs() < 1e-15);
    assert_eq!(fmi3Terminate(c), Status::Ok);
    expect_error("doStep after terminate", f.step(0.1, 0.1).0);
    assert_eq!(fmi3Reset(c), Status::Ok);
    expect_error("doStep after reset", f.step(0.0, 0.1).0);
    f.init();
    assert_eq!(f.step(0.0, 0.1).0, Status::Ok);
}

/// Model Exchange: Event Mode after initialisation, Continuous-Time Mode, the counts, and
/// the event indicator read both ways.
#[test]
fn model_exchange_modes_and_counts() {
    let f = Fmu3::me(2);
    let c = f.c;
    let (mut nx, mut nz) = (0usize, 0usize);
    unsafe {
        assert_eq!(fmi3GetNumberOfContinuousStates(c, &mut nx), Status::Ok);
        assert_eq!(fmi3GetNumberOfEventIndicators(c, &mut nz), Status::Ok);
    }
    assert_eq!((nx, nz), (5, 1));
    assert_eq!(fmi3SetTime(c, 0.0), Status::Error);
    assert_eq!(f.step(0.0, 0.1).0, Status::Error, "a CS function");
    // FMI 3.0's table for the model evaluations (section 2.3): not in Instantiated; in
    // Initialization Mode all four, derivatives and nominals included (FMI 2.0 differs).
    let mut nominals = vec![0.0; 5];
    let mut dx0 = vec![f64::NAN; 5];
    unsafe {
        assert_eq!(
            fmi3GetNominalsOfContinuousStates(c, nominals.as_mut_ptr(), 5),
            Status::Error,
            "nominals in Instantiated"
        );
        assert_eq!(
            fmi3GetContinuousStateDerivatives(c, dx0.as_mut_ptr(), 5),
            Status::Error,
            "derivatives in Instantiated"
        );
        assert_eq!(
            fmi3EnterInitializationMode(c, 1, 1e-10, 0.0, 0, 0.0),
            Status::Ok
        );
        assert_eq!(
            fmi3GetNominalsOfContinuousStates(c, nominals.as_mut_ptr(), 5),
            Status::Ok
        );
        assert_eq!(
            fmi3GetContinuousStateDerivatives(c, dx0.as_mut_ptr(), 5),
            Status::Ok
        );
        assert_eq!(fmi3ExitInitializationMode(c), Status::Ok);
    }
    assert!(nominals.iter().all(|v| *v > 0.0), "{nominals:?}");
    assert!(dx0.iter().all(|v| v.is_finite()), "{dx0:?}");
    let mut b = [0u8; 5];
    let mut next = 0.0;
    assert_eq!(
        unsafe {
            fmi3UpdateDiscreteStates(
                c, &mut b[0], &mut b[1], &mut b[2], &mut b[3], &mut b[4], &mut next,
            )
        },
        Status::Ok
    );
    assert_eq!(b[0], 0, "no further iteration");
    assert_eq!(fmi3EnterContinuousTimeMode(c), Status::Ok);
    assert_eq!(fmi3SetTime(c, 0.25), Status::Ok);
    let mut x = vec![0.0; 5];
    let mut dx = vec![0.0; 5];
    let mut z = [0.0];
    unsafe {
        assert_eq!(fmi3GetContinuousStates(c, x.as_mut_ptr(), 5), Status::Ok);
        assert_eq!(
            fmi3GetContinuousStateDerivatives(c, dx.as_mut_ptr(), 5),
            Status::Ok
        );
        assert_eq!(fmi3GetEventIndicators(c, z.as_mut_ptr(), 1), Status::Ok);
        assert_eq!(
            fmi3GetContinuousStates(c, x.as_mut_ptr(), 4),
            Status::Error,
            "nx"
        );
    }
    assert_eq!(f.get(time_vr()), 0.25);
    assert_eq!(f.get(time_vr() + 1), z[0], "the indicator variable");
    // Explicit Euler for a few steps: the states move as the derivatives say.
    let h = 1e-3;
    let x1: Vec<f64> = x.iter().zip(&dx).map(|(x, d)| x + h * d).collect();
    unsafe {
        assert_eq!(fmi3SetContinuousStates(c, x1.as_ptr(), 5), Status::Ok);
        let (mut enter, mut term) = (9u8, 9u8);
        assert_eq!(
            fmi3CompletedIntegratorStep(c, 1, &mut enter, &mut term),
            Status::Ok
        );
        assert!(enter <= 1 && term == 0);
    }
    assert_eq!(f.get(vr("x")), x1[0]);
    assert_eq!(fmi3EnterEventMode(c), Status::Ok);
    assert_eq!(fmi3EnterStepMode(c), Status::Error, "a CS function");
    assert_eq!(fmi3EnterContinuousTimeMode(c), Status::Ok);
    assert_eq!(fmi3Terminate(c), Status::Ok);
    assert_eq!(f.errors(), 6);
}

/// fmi3GetAdjointDerivative is the transpose of fmi3GetDirectionalDerivative's Jacobian.
#[test]
fn adjoint_is_the_transpose_of_the_directional_derivative() {
    let f = Fmu3::cs(3, false, false);
    f.init();
    assert_eq!(f.step(0.0, 0.5).0, Status::Ok);
    let knowns = states();
    let unknowns: Vec<u32> = ["der(x)", "der(h)", "der(vx)", "der(vh)", "theta", "N", "E"]
        .iter()
        .map(|n| vr(n))
        .collect();
    let (nu, nk) = (unknowns.len(), knowns.len());
    // J column by column (directional), row by row (adjoint).
    let mut jd = vec![vec![0.0; nk]; nu];
    for j in 0..nk {
        let mut seed = vec![0.0; nk];
        seed[j] = 1.0;
        let mut col = vec![0.0; nu];
        let s = unsafe {
            fmi3GetDirectionalDerivative(
                f.c,
                unknowns.as_ptr(),
                nu,
                knowns.as_ptr(),
                nk,
                seed.as_ptr(),
                nk,
                col.as_mut_ptr(),
                nu,
            )
        };
        assert_eq!(s, Status::Ok);
        for i in 0..nu {
            jd[i][j] = col[i];
        }
    }
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 0.0;
    for i in 0..nu {
        let mut seed = vec![0.0; nu];
        seed[i] = 1.0;
        let mut row = vec![0.0; nk];
        let s = unsafe {
            fmi3GetAdjointDerivative(
                f.c,
                unknowns.as_ptr(),
                nu,
                knowns.as_ptr(),
                nk,
                seed.as_ptr(),
                nu,
                row.as_mut_ptr(),
                nk,
            )
        };
        assert_eq!(s, Status::Ok);
        for j in 0..nk {
            worst = worst.max((row[j] - jd[i][j]).abs());
            scale = scale.max(jd[i][j].abs());
        }
    }
    println!("adjoint vs directional transpose: max |diff| = {worst:e} (max |J| = {scale:e})");
    assert!(scale > 0.1, "a Jacobian with content");
    assert!(worst <= 1e-14 * scale, "{worst}");
    // A general seed: vᵀ(J w) = (Jᵀ v)ᵀ w.
    let v: Vec<f64> = (0..nu).map(|i| 0.3 + i as f64).collect();
    let mut jt_v = vec![0.0; nk];
    let s = unsafe {
        fmi3GetAdjointDerivative(
            f.c,
            unknowns.as_ptr(),
            nu,
            knowns.as_ptr(),
            nk,
            v.as_ptr(),
            nu,
            jt_v.as_mut_ptr(),
            nk,
        )
    };
    assert_eq!(s, Status::Ok);
    for j in 0..nk {
        let expected: f64 = (0..nu).map(|i| v[i] * jd[i][j]).sum();
        assert!((jt_v[j] - expected).abs() <= 1e-13 * (1.0 + expected.abs()));
    }
    // Wrong counts, unknown references: refused.
    let mut out = vec![0.0; nk];
    let s = unsafe {
        fmi3GetAdjointDerivative(
            f.c,
            unknowns.as_ptr(),
            nu,
            knowns.as_ptr(),
            nk,
            v.as_ptr(),
            nk,
            out.as_mut_ptr(),
            nk,
        )
    };
    assert_eq!(s, Status::Error);
    let bad = [9999u32];
    let s = unsafe {
        fmi3GetAdjointDerivative(
            f.c,
            unknowns.as_ptr(),
            1,
            bad.as_ptr(),
            1,
            v.as_ptr(),
            1,
            out.as_mut_ptr(),
            1,
        )
    };
    assert_eq!(s, Status::Error);
    assert_eq!(f.errors(), 2);
}

/// The FMU state: taken, serialised, deserialised, restored; runs from it repeat bit for
/// bit; a corrupted blob is refused.
#[test]
fn the_fmu_state_blob_round_trips() {
    let f = Fmu3::cs(4, false, false);
    f.init();
    let h = 0.05;
    for i in 0..10 {
        assert_eq!(f.step(i as f64 * h, h).0, Status::Ok);
    }
    let mut state: *mut c_void = std::ptr::null_mut();
    assert_eq!(unsafe { fmi3GetFMUState(f.c, &mut state) }, Status::Ok);
    let mut size = 0usize;
    assert_eq!(
        unsafe { fmi3SerializedFMUStateSize(f.c, state, &mut size) },
        Status::Ok
    );
    let mut blob = vec![0u8; size];
    assert_eq!(
        unsafe { fmi3SerializeFMUState(f.c, state, blob.as_mut_ptr(), size) },
        Status::Ok
    );
    let run = |from: usize| -> Vec<u64> {
        (from..from + 30)
            .map(|i| {
                assert_eq!(f.step(i as f64 * h, h).0, Status::Ok);
                f.get(vr("x")).to_bits() ^ f.get(vr("on_surface")).to_bits()
            })
            .collect()
    };
    let first = run(10);
    let mut restored: *mut c_void = std::ptr::null_mut();
    assert_eq!(
        unsafe { fmi3DeserializeFMUState(f.c, blob.as_ptr(), size, &mut restored) },
        Status::Ok
    );
    assert_eq!(unsafe { fmi3SetFMUState(f.c, restored) }, Status::Ok);
    assert_eq!(f.get(time_vr()), 10.0 * h);
    assert_eq!(run(10), first, "the same run from the restored state");
    // A blob with one byte flipped, a short one: refused, nothing made.
    let mut bad = blob.clone();
    let mid = bad.len() / 2;
    bad[mid] ^= 0x40;
    for (what, bytes) in [("flipped", &bad[..]), ("short", &blob[..size - 3])] {
        let mut s: *mut c_void = std::ptr::null_mut();
        let status = unsafe { fmi3DeserializeFMUState(f.c, bytes.as_ptr(), bytes.len(), &mut s) };
        assert_eq!(status, Status::Error, "{what}");
        assert!(s.is_null());
    }
    // A state pointer that is not ours.
    let mut junk = [0u8; 64];
    assert_eq!(
        unsafe { fmi3SetFMUState(f.c, junk.as_mut_ptr() as *mut c_void) },
        Status::Error
    );
    unsafe {
        assert_eq!(fmi3FreeFMUState(f.c, &mut state), Status::Ok);
        assert_eq!(fmi3FreeFMUState(f.c, &mut restored), Status::Ok);
        assert!(state.is_null() && restored.is_null());
    }
    assert_eq!(f.errors(), 3);
}

/// The departure angle from a smooth sphere, released at rest at θ0 (the start values):
/// cos θ = (2/3) cos θ0.
fn departure_theta() -> f64 {
    let start = |n: &str| ExportedModel::info().layout.vars[vr(n) as usize].1.start;
    let theta0 = start("x").atan2(start("h"));
    (2.0 / 3.0 * theta0.cos()).acos()
}

/// With eventModeUsed and earlyReturnAllowed, the doStep that holds the departure returns
/// early at it: earlyReturn, lastSuccessfulTime = the event, eventHandlingNeeded; Event
/// Mode, then Step Mode, and the run goes on.
#[test]
fn an_event_inside_a_step_returns_early() {
    let f = Fmu3::cs(5, true, true);
    f.init();
    // Event Mode after initialisation (eventModeUsed).
    assert_eq!(f.step(0.0, 0.1).0, Status::Error, "Event Mode first");
    assert_eq!(fmi3EnterStepMode(f.c), Status::Ok);
    let h = 0.1;
    let mut t = 0.0;
    let mut early_at = None;
    for _ in 0..100 {
        let (status, event, early, last) = f.step(t, h);
        assert_eq!(status, Status::Ok);
        if early {
            assert!(event, "eventHandlingNeeded with eventModeUsed");
            assert!(last > t && last < t + h, "{last} inside ({t}, {})", t + h);
            assert_eq!(f.get(time_vr()), last);
            early_at = Some(last);
            t = last;
            assert_eq!(fmi3EnterEventMode(f.c), Status::Ok);
            let mut b = [9u8; 5];
            let mut next = 0.0;
            let s = unsafe {
                fmi3UpdateDiscreteStates(
                    f.c, &mut b[0], &mut b[1], &mut b[2], &mut b[3], &mut b[4], &mut next,
                )
            };
            assert_eq!(s, Status::Ok);
            assert_eq!(b, [0; 5], "the event was applied in doStep");
            assert_eq!(fmi3EnterStepMode(f.c), Status::Ok);
            break;
        }
        assert!(!event);
        t = last;
    }
    let te = early_at.expect("an early return at the departure");
    assert_eq!(
        f.get(vr("on_surface")),
        0.0,
        "in free flight after the event"
    );
    let theta = f.get(vr("theta"));
    println!(
        "FMI 3 early return at t = {te}: theta = {theta}, closed form {}",
        departure_theta()
    );
    assert!((theta - departure_theta()).abs() < 1e-7);
    // The run goes on from the event; no second event (free flight).
    for _ in 0..5 {
        let (status, event, early, last) = f.step(t, h);
        assert_eq!((status, event, early), (Status::Ok, false, false));
        t = last;
    }
    assert_eq!(f.errors(), 1);
}

static UPDATES: Mutex<Vec<(usize, f64, bool)>> = Mutex::new(Vec::new());

unsafe extern "C" fn intermediate_update(
    env: *mut c_void,
    time: f64,
    _set_requested: bool,
    _get_allowed: bool,
    _step_finished: bool,
    can_return_early: bool,
    early_return_requested: *mut bool,
    _early_return_time: *mut f64,
) {
    UPDATES
        .lock()
        .unwrap()
        .push((env as usize, time, can_return_early));
    // Tag 7 asks to return early, tag 6 does not.
    *early_return_requested = env as usize == 7;
}

/// The intermediateUpdate callback is called at the event; without eventModeUsed the step
/// returns early only when the importer asks (and may), else it goes on to its end, and the
/// run agrees with FMI 2.0's doStep (which passes the event inside).
#[test]
fn intermediate_update_at_the_event() {
    let h = 0.1;
    let n = 30;
    // FMI 2.0 reference, same binary.
    let name = CString::new("ref2").unwrap();
    let functions = CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    };
    let c2 = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            1,
            token().as_ptr(),
            std::ptr::null(),
            &functions,
            0,
            0,
        )
    };
    assert!(!c2.is_null());
    assert_eq!(fmi2SetupExperiment(c2, 1, 1e-10, 0.0, 0, 0.0), Status::Ok);
    assert_eq!(fmi2EnterInitializationMode(c2), Status::Ok);
    assert_eq!(fmi2ExitInitializationMode(c2), Status::Ok);
    for i in 0..n {
        assert_eq!(fmi2DoStep(c2, i as f64 * h, h, 1), Status::Ok);
    }
    let get2 = |name: &str| {
        let mut v = 0.0;
        assert_eq!(unsafe { fmi2GetReal(c2, &vr(name), 1, &mut v) }, Status::Ok);
        v
    };
    let reference: Vec<f64> = ["x", "h", "vx", "vh"].iter().map(|s| get2(s)).collect();
    unsafe { fmi2FreeInstance(c2) };

    // Callback, no early return allowed: called once, at the event; steps end on the grid.
    let f = Fmu3::cs_with(6, false, false, Some(intermediate_update));
    f.init();
    for i in 0..n {
        let (status, _, early, last) = f.step(i as f64 * h, h);
        assert_eq!((status, early), (Status::Ok, false));
        assert!((last - (i + 1) as f64 * h).abs() < 1e-12);
    }
    let calls: Vec<(f64, bool)> = UPDATES
        .lock()
        .unwrap()
        .iter()
        .filter(|(tag, ..)| *tag == 6)
        .map(|&(_, t, can)| (t, can))
        .collect();
    assert_eq!(calls.len(), 1, "{calls:?}");
    assert!(!calls[0].1, "canReturnEarly = earlyReturnAllowed = false");
    let got: Vec<f64> = ["x", "h", "vx", "vh"]
        .iter()
        .map(|s| f.get(vr(s)))
        .collect();
    let diff = got
        .iter()
        .zip(&reference)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    println!("FMI 3 (stopping at the event) vs FMI 2 after {n} steps: max |diff| = {diff:e}");
    assert!(diff < 1e-7, "{diff}");

    // Early return allowed, asked by the callback (no Event Mode): returns at the event.
    let f = Fmu3::cs_with(7, false, true, Some(intermediate_update));
    f.init();
    let mut t = 0.0;
    let mut returned = None;
    for _ in 0..n {
        let (status, event, early, last) = f.step(t, h);
        assert_eq!(status, Status::Ok);
        assert!(!event, "no Event Mode asked");
        if early {
            returned = Some(last);
            break;
        }
        t = last;
    }
    let te = returned.expect("an early return");
    let at6 = calls[0].0;
    assert!((te - at6).abs() < 1e-12, "{te} vs {at6}");
    assert_eq!(f.errors(), 0);
}

/// Without callback and early return, FMI 3.0's doStep is FMI 2.0's, bit for bit.
#[test]
fn a_plain_run_equals_fmi2_bit_for_bit() {
    let f = Fmu3::cs(8, false, false);
    f.init();
    let name = CString::new("ref2b").unwrap();
    let functions = CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: std::ptr::null_mut(),
    };
    let c2 = unsafe {
        fmi2Instantiate(
            name.as_ptr(),
            1,
            token().as_ptr(),
            std::ptr::null(),
            &functions,
            0,
            0,
        )
    };
    assert_eq!(fmi2SetupExperiment(c2, 1, 1e-10, 0.0, 0, 0.0), Status::Ok);
    assert_eq!(fmi2EnterInitializationMode(c2), Status::Ok);
    assert_eq!(fmi2ExitInitializationMode(c2), Status::Ok);
    let h = 0.1;
    for i in 0..25 {
        let t = i as f64 * h;
        assert_eq!(fmi2DoStep(c2, t, h, 1), Status::Ok);
        assert_eq!(f.step(t, h).0, Status::Ok);
        for s in states() {
            let mut v2 = 0.0;
            assert_eq!(unsafe { fmi2GetReal(c2, &s, 1, &mut v2) }, Status::Ok);
            assert_eq!(f.get(s).to_bits(), v2.to_bits());
        }
    }
    unsafe { fmi2FreeInstance(c2) };
}

/// fmi3GetAdjointDerivative checks its unknowns even when there is no known to seed: an
/// unknown value reference and a variable that is no unknown (the Integer `me_projection`)
/// are refused with one line each (FMI 3.0: unknowns are Float64 outputs, derivatives or
/// states). Found by random call sequences: with nKnowns = 0 both were answered fmi3OK.
#[test]
fn adjoint_with_no_knowns_still_checks_its_unknowns() {
    let f = Fmu3::me(9);
    f.init();
    // One unknown, no knowns: a seed of one entry, a sensitivity of none.
    let adjoint = |unknown: u32| {
        let (seed, mut out) = ([1.0], [0.0; 1]);
        unsafe {
            fmi3GetAdjointDerivative(
                f.c,
                &unknown,
                1,
                std::ptr::null(),
                0,
                seed.as_ptr(),
                1,
                out.as_mut_ptr(),
                0,
            )
        }
    };
    for bad in [u32::MAX, vr("me_projection")] {
        assert_eq!(adjoint(bad), Status::Error, "unknown {bad}");
    }
    assert_eq!(f.errors(), 2);
    // A proper unknown with no knowns: nothing to compute, fmi3OK.
    assert_eq!(adjoint(vr("der(x)")), Status::Ok);
}

/// A Co-Simulation instance made with eventModeUsed that restores a state in Event Mode
/// stays in Event Mode: fmi3DoStep is refused until fmi3EnterStepMode, which is allowed.
#[test]
fn set_fmu_state_in_event_mode_stays_in_event_mode() {
    let f = Fmu3::cs(10, true, false);
    f.init(); // eventModeUsed: Event Mode after initialisation
    let mut state: *mut c_void = std::ptr::null_mut();
    assert_eq!(unsafe { fmi3GetFMUState(f.c, &mut state) }, Status::Ok);
    assert_eq!(fmi3EnterStepMode(f.c), Status::Ok);
    assert_eq!(f.step(0.0, 0.1).0, Status::Ok);
    assert_eq!(fmi3EnterEventMode(f.c), Status::Ok);
    assert_eq!(unsafe { fmi3SetFMUState(f.c, state) }, Status::Ok);
    assert_eq!(f.get(time_vr()), 0.0);
    assert_eq!(f.errors(), 0);
    let (status, ..) = f.step(0.0, 0.1);
    assert_eq!(status, Status::Error, "doStep in Event Mode");
    assert_eq!(f.errors(), 1);
    assert_eq!(fmi3EnterStepMode(f.c), Status::Ok, "Event Mode → Step Mode");
    assert_eq!(f.step(0.0, 0.1).0, Status::Ok);
    // Restored from Step Mode, it stays in Step Mode.
    assert_eq!(unsafe { fmi3SetFMUState(f.c, state) }, Status::Ok);
    assert_eq!(f.step(0.0, 0.1).0, Status::Ok);
    assert_eq!(f.errors(), 1);
    assert_eq!(unsafe { fmi3FreeFMUState(f.c, &mut state) }, Status::Ok);
}

/// FMI 3.0 has no stepFailed: after fmi3DoStep answered fmi3Discard the instance is in Step
/// Mode where lastSuccessfulTime says, and steps on from there with a shorter step; inputs
/// and outputs work as before. (The FMI 2.0 core state stepFailed used to leak into FMI
/// 3.0: the next fmi3DoStep was refused "in state StepFailed".) Every line names the fmi3
/// function and no fmi2 one.
#[test]
fn a_discarded_step_leaves_the_instance_in_step_mode() {
    let f = Fmu3::cs(11, false, false);
    let (solver, max_steps, step) = (vr("solver"), vr("solver_max_steps"), vr("solver_step"));
    unsafe {
        assert_eq!(fmi3SetInt64(f.c, &solver, 1, &1, 1), Status::Ok); // RK4
        assert_eq!(fmi3SetInt32(f.c, &max_steps, 1, &10, 1), Status::Ok);
        assert_eq!(fmi3SetFloat64(f.c, &step, 1, &0.01, 1), Status::Ok);
    }
    f.init();
    // 100 steps of 0.01 s planned, 10 allowed: refused before any work.
    let (status, _, _, last) = f.step(0.0, 1.0);
    assert_eq!(status, Status::Discard);
    assert_eq!(last, 0.0);
    let (status, _, _, last) = f.step(0.0, 0.05);
    assert_eq!(status, Status::Ok, "{:?}", lines(f.tag));
    assert_eq!(last, 0.05);
    assert_eq!(f.get(time_vr()), 0.05);
    assert_eq!(f.step(0.0, 0.05).0, Status::Error, "not the FMU's time");
    let all = lines(f.tag);
    assert_eq!(all.len(), 2, "{all:?}");
    for (_, line) in &all {
        assert!(
            line.starts_with("fmi3DoStep: ") && !line.contains("fmi2"),
            "{line}"
        );
    }
}
