//! A system's parameter declared an Enumeration ([`Var::enumeration`]) or an Integer
//! ([`Var::integer`]), on a test system of its own (no in-tree system has one): read and
//! written with fmi2Get/SetInteger and fmi3Get/SetInt64 (Int32 for the Integer), refused by
//! fmi2Get/SetReal and fmi3Get/SetFloat64 with one line naming the right function, a value
//! that is not one of its codes refused with one line listing them, settable only before
//! initialisation ends, checked again in a restored FMU state, declared in both
//! modelDescriptions with its type and items; the model reads its code from `p` as an f64.

use mbfmu::fmi::{CallbackFunctions, Export, Instance, Logger, Status};
use mbfmu::model::{Scalar, Scene, System, Var};
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::sync::Mutex;

/// `ẋ = −g k x` (law `linear`), `−g k x³` (`cubic`) or 0 (`off`): the law an Enumeration
/// parameter, the gain `g` an Integer one.
pub struct Relaxation;

const LAWS: &[(&str, &str)] = &[
    ("linear", "dx/dt = -g k x"),
    ("cubic", "dx/dt = -g k x^3"),
    ("off", "dx/dt = 0: x holds"),
];

impl System for Relaxation {
    const NAME: &'static str = "Relaxation";
    const DESCRIPTION: &'static str = "A first-order relaxation whose law is an enumeration";
    const EQUATIONS: &'static [&'static str] = &["ẋ = −g k x, −g k x³ or 0, by damping_law"];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("k", Some("1/s"), 1.0, "Rate").min(0.0),
            Var::new("damping_law", None, 0.0, "Which law relaxes x").enumeration(LAWS),
            Var::new("gain", None, 1.0, "Whole multiple of the rate")
                .integer()
                .min(1.0)
                .max(5.0),
        ]
    }

    fn inputs() -> Vec<Var> {
        Vec::new()
    }

    fn states() -> Vec<Var> {
        vec![Var::new("x", Some("m"), 1.0, "The relaxing quantity").nominal(1.0)]
    }

    fn outputs() -> Vec<Var> {
        vec![Var::new("E", None, 0.0, "½ x²")]
    }

    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    /// Linear unless the law is `cubic` (ExactLinear runs the others).
    fn linear_time_invariant(p: &[f64]) -> bool {
        p[1] != 1.0
    }

    fn derivatives<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], dx: &mut [S]) {
        let rate = p[0] * p[2];
        dx[0] = match p[1].re() as i32 {
            0 => -(rate * x[0]),
            1 => -(rate * x[0] * x[0] * x[0]),
            _ => S::zero(),
        };
    }

    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], _p: &[S], y: &mut [S]) {
        y[0] = x[0] * x[0] * 0.5;
    }

    fn scenes() -> Vec<Scene> {
        vec![Scene::new("held", "The law off: x holds", 1.0).set("damping_law", 2.0)]
    }

    fn default_experiment() -> (f64, f64, f64) {
        (1.0, 1e-8, 1e-2)
    }
}

mbfmu::export_fmu!(Relaxation);
use fmi2_symbols::*;
use fmi3_symbols::*;

/// Log lines received, FMI 2.0's and FMI 3.0's: (instance name or tag, status, message).
static LOG: Mutex<Vec<(String, c_int, String)>> = Mutex::new(Vec::new());

/// The variadic `fmi2CallbackLogger`, as tests/common reads it (the FMU always calls it as
/// (…, "%s", message); on x86-64 System V the fixed arguments sit where these are read).
extern "C" fn record2(
    _env: *mut c_void,
    name: *const c_char,
    status: c_int,
    _category: *const c_char,
    _format: *const c_char,
    message: *const c_char,
) {
    let s = |p: *const c_char| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned();
    LOG.lock().unwrap().push((s(name), status, s(message)));
}

unsafe extern "C" fn record3(
    env: *mut c_void,
    status: c_int,
    _category: *const c_char,
    message: *const c_char,
) {
    let message = CStr::from_ptr(message).to_string_lossy().into_owned();
    LOG.lock()
        .unwrap()
        .push((format!("fmi3-{}", env as usize), status, message));
}

fn lines(name: &str) -> Vec<(c_int, String)> {
    LOG.lock()
        .unwrap()
        .iter()
        .filter(|(n, ..)| n == name)
        .map(|(_, s, m)| (*s, m.clone()))
        .collect()
}

fn callbacks() -> &'static CallbackFunctions {
    struct Sync(CallbackFunctions);
    unsafe impl std::marker::Sync for Sync {}
    unsafe impl Send for Sync {}
    static CB: std::sync::OnceLock<Sync> = std::sync::OnceLock::new();
    &CB.get_or_init(|| {
        Sync(CallbackFunctions {
            // SAFETY: see `record2`.
            logger: Some(unsafe {
                std::mem::transmute::<*const (), mbfmu::fmi::CallbackLogger>(record2 as *const ())
            }),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        })
    })
    .0
}

fn token() -> CString {
    CString::new(ExportedModel::info().guid.clone()).unwrap()
}

fn vr(name: &str) -> u32 {
    ExportedModel::info().layout.vr_of(name).unwrap()
}

/// An FMI 2.0 Co-Simulation instance, in Initialization Mode.
struct Fmu2 {
    c: *mut c_void,
    name: String,
}

impl Fmu2 {
    fn new(name: &str) -> Fmu2 {
        let cname = CString::new(name).unwrap();
        let c = unsafe {
            fmi2Instantiate(
                cname.as_ptr(),
                1,
                token().as_ptr(),
                std::ptr::null(),
                callbacks(),
                0,
                0,
            )
        };
        assert!(!c.is_null());
        assert_eq!(fmi2SetupExperiment(c, 1, 1e-10, 0.0, 0, 0.0), Status::Ok);
        // Initialization Mode: values may be set and read.
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        Fmu2 {
            c,
            name: name.into(),
        }
    }

    fn init(&self) {
        assert_eq!(fmi2ExitInitializationMode(self.c), Status::Ok);
    }

    fn get_int(&self, name: &str) -> i32 {
        let mut v = -1;
        assert_eq!(
            unsafe { fmi2GetInteger(self.c, &vr(name), 1, &mut v) },
            Status::Ok
        );
        v
    }

    fn set_int(&self, name: &str, v: i32) -> Status {
        unsafe { fmi2SetInteger(self.c, &vr(name), 1, &v) }
    }

    fn x(&self) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(
            unsafe { fmi2GetReal(self.c, &vr("x"), 1, &mut v) },
            Status::Ok
        );
        v
    }

    /// The one line the last refusal logged (and that it was the only one since `before`).
    fn refused(&self, before: usize, status: Status) -> String {
        assert_eq!(status, Status::Error);
        let log = lines(&self.name);
        assert_eq!(log.len(), before + 1, "one line: {log:?}");
        assert_eq!(log[before].0, Status::Error as c_int);
        log[before].1.clone()
    }
}

impl Drop for Fmu2 {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

/// The parameters keep their place (declaration order, value references 0, 1, 2) and the
/// model reads the code as an f64.
#[test]
fn the_parameters_keep_their_value_references() {
    assert_eq!([vr("k"), vr("damping_law"), vr("gain")], [0, 1, 2]);
    assert_eq!(vr("solver"), 3);
}

#[test]
fn fmi2_reads_and_writes_the_enumeration_with_get_and_set_integer() {
    let f = Fmu2::new("fmi2-get-set");
    assert_eq!(f.get_int("damping_law"), 0, "the start value");
    assert_eq!(f.get_int("gain"), 1);
    assert_eq!(f.set_int("damping_law", 2), Status::Ok);
    assert_eq!(f.get_int("damping_law"), 2);
    assert_eq!(f.set_int("gain", 3), Status::Ok);
    // Several at once, with the solver (DOPRI5, code 2).
    let (vrs, values) = ([vr("damping_law"), vr("gain"), vr("solver")], [1, 2, 2]);
    assert_eq!(
        unsafe { fmi2SetInteger(f.c, vrs.as_ptr(), 3, values.as_ptr()) },
        Status::Ok
    );
    let mut back = [0; 3];
    assert_eq!(
        unsafe { fmi2GetInteger(f.c, vrs.as_ptr(), 3, back.as_mut_ptr()) },
        Status::Ok
    );
    assert_eq!(back, values);
    assert!(lines(&f.name).is_empty(), "{:?}", lines(&f.name));
}

/// The model sees the code the importer set: `off` holds x, `linear` with gain 2 decays it
/// as e^(−2 k t).
#[test]
fn the_model_runs_with_the_code_set() {
    for (law, gain, expected) in [(2, 1, 1.0), (0, 2, (-2.0f64).exp())] {
        let f = Fmu2::new(&format!("run-{law}-{gain}"));
        assert_eq!(f.set_int("damping_law", law), Status::Ok);
        assert_eq!(f.set_int("gain", gain), Status::Ok);
        f.init();
        let mut t = 0.0;
        for _ in 0..10 {
            assert_eq!(fmi2DoStep(f.c, t, 0.1, 1), Status::Ok);
            t += 0.1;
        }
        assert!((f.x() - expected).abs() < 1e-8, "{law}: {}", f.x());
    }
}

/// fmi2GetReal and fmi2SetReal refuse both parameters with one line naming the Integer
/// functions; a code that is not an item, or an Integer outside [min, max], is refused
/// with one line (the codes and names listed); after initialisation they cannot be set;
/// every refusal leaves the values as they were.
#[test]
fn fmi2_refuses_the_wrong_function_and_a_wrong_code_with_one_line() {
    let f = Fmu2::new("fmi2-refusals");
    assert_eq!(f.set_int("damping_law", 1), Status::Ok);
    let law = vr("damping_law");
    let n = lines(&f.name).len();
    let line = f.refused(n, unsafe { fmi2SetReal(f.c, &law, 1, &2.0) });
    assert!(
        line.contains("damping_law")
            && line.contains("Enumeration")
            && line.contains("fmi2SetInteger"),
        "{line}"
    );
    let line = f.refused(n + 1, unsafe { fmi2GetReal(f.c, &law, 1, &mut 0.0) });
    assert!(line.contains("fmi2GetInteger"), "{line}");
    let line = f.refused(n + 2, unsafe { fmi2SetReal(f.c, &vr("gain"), 1, &2.0) });
    assert!(
        line.contains("Integer") && line.contains("fmi2SetInteger"),
        "{line}"
    );
    for (i, bad) in [3, -1, i32::MAX].into_iter().enumerate() {
        let line = f.refused(n + 3 + i, f.set_int("damping_law", bad));
        assert!(
            line.contains(&format!(
                "value {bad} for damping_law is not one of its codes"
            )) && line.contains("0 = linear, 1 = cubic, 2 = off"),
            "{line}"
        );
    }
    let line = f.refused(n + 6, f.set_int("gain", 6));
    assert!(line.contains("outside [1.0, 5.0]"), "{line}");
    // A bad value in a call that also sets a good one changes neither.
    let (vrs, values) = ([law, vr("gain")], [2, 0]);
    f.refused(n + 7, unsafe {
        fmi2SetInteger(f.c, vrs.as_ptr(), 2, values.as_ptr())
    });
    assert_eq!((f.get_int("damping_law"), f.get_int("gain")), (1, 1));
    f.init();
    let line = f.refused(n + 8, f.set_int("damping_law", 0));
    assert!(
        line.contains("can only be set before fmi2ExitInitializationMode"),
        "{line}"
    );
    assert_eq!(f.get_int("damping_law"), 1);
}

/// The method is checked with the parameters a call leaves when the call sets it:
/// ExactLinear with the `cubic` law in one call is refused; the law set alone after it is
/// accepted (as a Real parameter would be) and fmi2ExitInitializationMode refuses the pair.
#[test]
fn the_method_is_checked_with_the_code_set() {
    let exact_linear = 11;
    let f = Fmu2::new("fmi2-method");
    let (vrs, values) = ([vr("damping_law"), vr("solver")], [1, exact_linear]);
    let line = f.refused(0, unsafe {
        fmi2SetInteger(f.c, vrs.as_ptr(), 2, values.as_ptr())
    });
    assert!(line.contains("linear time-invariant"), "{line}");
    assert_eq!((f.get_int("damping_law"), f.get_int("solver")), (0, 2));
    assert_eq!(f.set_int("solver", exact_linear), Status::Ok);
    assert_eq!(f.set_int("damping_law", 1), Status::Ok);
    let line = f.refused(1, fmi2ExitInitializationMode(f.c));
    assert!(line.contains("linear time-invariant"), "{line}");
}

/// An FMU state keeps the code; a state whose code is not an item is refused at
/// fmi2SetFMUstate's check (the Rust API: the C blob cannot hold one, its CRC would not
/// match), with the setter's message.
#[test]
fn the_fmu_state_round_trips_the_code_and_a_bad_one_is_refused() {
    let f = Fmu2::new("fmi2-state");
    assert_eq!(f.set_int("damping_law", 2), Status::Ok);
    let mut s: *mut c_void = std::ptr::null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(f.c, &mut s) }, Status::Ok);
    assert_eq!(f.set_int("damping_law", 1), Status::Ok);
    assert_eq!(unsafe { fmi2SetFMUstate(f.c, s) }, Status::Ok);
    assert_eq!(f.get_int("damping_law"), 2);

    // Serialized into another instance.
    let mut size = 0usize;
    assert_eq!(
        unsafe { fmi2SerializedFMUstateSize(f.c, s, &mut size) },
        Status::Ok
    );
    let mut blob = vec![0 as c_char; size];
    assert_eq!(
        unsafe { fmi2SerializeFMUstate(f.c, s, blob.as_mut_ptr(), size) },
        Status::Ok
    );
    let g = Fmu2::new("fmi2-state-2");
    let mut s2: *mut c_void = std::ptr::null_mut();
    assert_eq!(
        unsafe { fmi2DeSerializeFMUstate(g.c, blob.as_ptr(), size, &mut s2) },
        Status::Ok
    );
    assert_eq!(unsafe { fmi2SetFMUstate(g.c, s2) }, Status::Ok);
    assert_eq!(g.get_int("damping_law"), 2);
    for (inst, mut p) in [(&f, s), (&g, s2)] {
        assert_eq!(unsafe { fmi2FreeFMUstate(inst.c, &mut p) }, Status::Ok);
    }
    assert!(lines(&f.name).is_empty() && lines(&g.name).is_empty());

    let mut inst = Instance::<Relaxation>::new(ExportedModel::info(), Logger::silent("state"));
    let good = inst.snapshot();
    for (index, bad, needle) in [
        (
            1,
            3.0,
            "value 3 for damping_law is not one of its codes (0 = linear, 1 = cubic, 2 = off)",
        ),
        (1, 0.5, "value 0.5 for damping_law is not one of its codes"),
        (2, 1.5, "value 1.5 for gain is not an Integer"),
        (2, 9.0, "value 9 for gain is outside [1.0, 5.0]"),
    ] {
        let mut s = good.clone();
        s.params[index] = bad;
        let err = inst.restore(&s).unwrap_err();
        assert!(err.contains(needle), "{err}");
        let err = inst.deserialize(&inst.serialize(&s)).unwrap_err();
        assert!(err.contains(needle), "{err}");
    }
    assert_eq!(inst.snapshot(), good, "a refused state changes nothing");
}

/// The Rust callers that hold numbers (a scene's start values in the documentation and
/// bench runs) go through fmi2SetInteger's path for it, and meet its checks.
#[test]
fn set_value_takes_the_integer_path() {
    let mut inst = Instance::<Relaxation>::new(ExportedModel::info(), Logger::silent("value"));
    inst.set_value(vr("damping_law"), 2.0).unwrap();
    inst.set_value(vr("k"), 0.5).unwrap();
    assert_eq!(inst.get_value(vr("damping_law")).unwrap(), 2.0);
    assert_eq!(inst.get_value(vr("k")).unwrap(), 0.5);
    for bad in [1.5, 3.0, f64::NAN] {
        assert!(inst.set_value(vr("damping_law"), bad).is_err(), "{bad}");
    }
    assert!(inst.set_real(&[vr("damping_law")], &[1.0]).is_err());
    assert_eq!(inst.get_value(vr("damping_law")).unwrap(), 2.0);
}

/// An FMI 3.0 Co-Simulation instance on the same binary, in Initialization Mode, with
/// `tag` for its log lines.
struct Fmu3 {
    c: *mut c_void,
    tag: usize,
}

impl Fmu3 {
    fn new(tag: usize) -> Fmu3 {
        let name = CString::new(format!("cs{tag}")).unwrap();
        let c = unsafe {
            fmi3InstantiateCoSimulation(
                name.as_ptr(),
                token().as_ptr(),
                std::ptr::null(),
                0,
                0,
                0,
                0,
                std::ptr::null(),
                0,
                tag as *mut c_void,
                Some(record3),
                None,
            )
        };
        assert!(!c.is_null());
        assert_eq!(
            fmi3EnterInitializationMode(c, 1, 1e-10, 0.0, 0, 0.0),
            Status::Ok
        );
        Fmu3 { c, tag }
    }

    fn log(&self) -> Vec<(c_int, String)> {
        lines(&format!("fmi3-{}", self.tag))
    }
}

impl Drop for Fmu3 {
    fn drop(&mut self) {
        unsafe { fmi3FreeInstance(self.c) }
    }
}

#[test]
fn fmi3_reads_and_writes_the_enumeration_as_int64_and_the_integer_as_int32() {
    let f = Fmu3::new(1);
    let (law, gain) = (vr("damping_law"), vr("gain"));
    let mut v64 = -1i64;
    assert_eq!(
        unsafe { fmi3GetInt64(f.c, &law, 1, &mut v64, 1) },
        Status::Ok
    );
    assert_eq!(v64, 0);
    assert_eq!(unsafe { fmi3SetInt64(f.c, &law, 1, &2, 1) }, Status::Ok);
    assert_eq!(
        unsafe { fmi3GetInt64(f.c, &law, 1, &mut v64, 1) },
        Status::Ok
    );
    assert_eq!(v64, 2);
    assert_eq!(unsafe { fmi3SetInt32(f.c, &gain, 1, &4, 1) }, Status::Ok);
    let mut v32 = 0i32;
    assert_eq!(
        unsafe { fmi3GetInt32(f.c, &gain, 1, &mut v32, 1) },
        Status::Ok
    );
    assert_eq!(v32, 4);
    assert!(f.log().is_empty(), "{:?}", f.log());

    // Refusals: one line each, nothing changed.
    type Call<'a> = Box<dyn Fn() -> Status + 'a>;
    let cases: Vec<(&str, Call)> = vec![
        (
            "not one of its codes (0 = linear, 1 = cubic, 2 = off)",
            Box::new(|| unsafe { fmi3SetInt64(f.c, &law, 1, &3, 1) }),
        ),
        (
            "is not a value of damping_law",
            Box::new(|| unsafe { fmi3SetInt64(f.c, &law, 1, &(1 << 40), 1) }),
        ),
        (
            "is a Int64 (an Enumeration) variable, not a Float64",
            Box::new(|| unsafe { fmi3SetFloat64(f.c, &law, 1, &1.0, 1) }),
        ),
        (
            "is a Int64 (an Enumeration) variable, not a Float64",
            Box::new(|| unsafe { fmi3GetFloat64(f.c, &law, 1, &mut 0.0, 1) }),
        ),
        (
            "is a Int64 (an Enumeration) variable, not a Int32",
            Box::new(|| unsafe { fmi3SetInt32(f.c, &law, 1, &1, 1) }),
        ),
        (
            "is a Int32 variable, not a Float64",
            Box::new(|| unsafe { fmi3SetFloat64(f.c, &gain, 1, &1.0, 1) }),
        ),
        (
            "outside [1.0, 5.0]",
            Box::new(|| unsafe { fmi3SetInt32(f.c, &gain, 1, &0, 1) }),
        ),
    ];
    for (needle, call) in cases {
        let n = f.log().len();
        assert_eq!(call(), Status::Error, "{needle}");
        let log = f.log();
        assert_eq!(log.len(), n + 1, "{needle}: one line");
        assert!(log[n].1.contains(needle), "{needle}: {}", log[n].1);
    }
    assert_eq!(
        unsafe { fmi3GetInt64(f.c, &law, 1, &mut v64, 1) },
        Status::Ok
    );
    assert_eq!(v64, 2);

    // The FMU state keeps it.
    let mut state: *mut c_void = std::ptr::null_mut();
    assert_eq!(unsafe { fmi3GetFMUState(f.c, &mut state) }, Status::Ok);
    assert_eq!(unsafe { fmi3SetInt64(f.c, &law, 1, &1, 1) }, Status::Ok);
    assert_eq!(unsafe { fmi3SetFMUState(f.c, state) }, Status::Ok);
    assert_eq!(
        unsafe { fmi3GetInt64(f.c, &law, 1, &mut v64, 1) },
        Status::Ok
    );
    assert_eq!(v64, 2);
    assert_eq!(unsafe { fmi3FreeFMUState(f.c, &mut state) }, Status::Ok);
}

/// The element of `xml` that starts with `start`, up to its end (`/>` or its closing tag).
fn element<'a>(xml: &'a str, start: &str, end: &str) -> &'a str {
    let from = xml
        .find(start)
        .unwrap_or_else(|| panic!("no {start} in\n{xml}"));
    let len = xml[from..].find(end).expect("closed") + end.len();
    &xml[from..from + len]
}

/// Both modelDescriptions declare the type (`DampingLaw`: the name in UpperCamelCase),
/// its items with values 0, 1, 2 and their descriptions, and the variable of that type
/// with its start code; the Integer parameter is an Integer (Int32). A discrete parameter
/// is a dependency of every initial unknown (a derivative cannot see what it switches).
#[test]
fn the_model_descriptions_declare_the_type_and_its_items() {
    let items = |tag: &str| {
        [
            r#"<Item name="linear" value="0" description="dx/dt = -g k x"/>"#,
            r#"<Item name="cubic" value="1" description="dx/dt = -g k x^3"/>"#,
            r#"<Item name="off" value="2" description="dx/dt = 0: x holds"/>"#,
        ]
        .iter()
        .map(|item| format!("{tag}\n      {item}"))
        .collect::<Vec<_>>()
    };
    let xml2 = mbfmu::xml::model_description::<Relaxation>();
    let types = element(&xml2, "<TypeDefinitions>", "</TypeDefinitions>");
    let ty = element(types, r#"<SimpleType name="DampingLaw">"#, "</SimpleType>");
    let expected = format!(
        "<SimpleType name=\"DampingLaw\">\n      <Enumeration>\n        {}\n        {}\n        {}\n      </Enumeration>\n    </SimpleType>",
        items("")[0].trim(),
        items("")[1].trim(),
        items("")[2].trim()
    );
    assert_eq!(ty, expected);
    assert!(types.find(r#"name="Solver""#) < types.find("DampingLaw"));
    let var = element(
        &xml2,
        r#"<ScalarVariable name="damping_law""#,
        "</ScalarVariable>",
    );
    assert!(var.contains(r#"valueReference="1""#), "{var}");
    assert!(
        var.contains(r#"causality="parameter" variability="fixed" initial="exact""#),
        "{var}"
    );
    assert!(
        var.contains(r#"<Enumeration declaredType="DampingLaw" start="0"/>"#),
        "{var}"
    );
    let gain = element(&xml2, r#"<ScalarVariable name="gain""#, "</ScalarVariable>");
    assert!(
        gain.contains(r#"<Integer min="1" max="5" start="1"/>"#),
        "{gain}"
    );
    // der(x) (index 7) in Initialization Mode: k (1), damping_law (2), gain (3), x (6); E
    // (index 8): x and, declared for every unknown, the two discrete parameters.
    assert!(
        xml2.contains(r#"<Unknown index="7" dependencies="1 2 3 6"/>"#)
            && xml2.contains(r#"<Unknown index="8" dependencies="2 3 6"/>"#),
        "{xml2}"
    );

    let xml3 = mbfmu::xml::model_description3::<Relaxation>();
    let types = element(&xml3, "<TypeDefinitions>", "</TypeDefinitions>");
    let ty = element(
        types,
        r#"<EnumerationType name="DampingLaw">"#,
        "</EnumerationType>",
    );
    for item in items("") {
        assert!(ty.contains(item.trim()), "{item} in {ty}");
    }
    let var = element(&xml3, r#"<Enumeration name="damping_law""#, "/>");
    assert!(
        var.contains(r#"valueReference="1""#)
            && var.contains(r#"declaredType="DampingLaw" start="0""#),
        "{var}"
    );
    let gain = element(&xml3, r#"<Int32 name="gain""#, "/>");
    assert!(gain.contains(r#"min="1" max="5" start="1""#), "{gain}");
    assert!(
        xml3.contains(r#"<InitialUnknown valueReference="6" dependencies="0 1 2 5"/>"#),
        "{xml3}"
    );

    // For an outside validation (fmpy's schema and rules): the two files, in the
    // integration tests' scratch directory.
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("enumeration_parameter");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("fmi2.xml"), &xml2).unwrap();
    std::fs::write(dir.join("fmi3.xml"), &xml3).unwrap();
}

/// The type name rule and the declaration checks of the layout.
#[test]
fn the_type_name_is_the_variable_name_in_upper_camel_case() {
    let name = |n: &'static str| Var::new(n, None, 0.0, "").enumeration(LAWS).type_name();
    assert_eq!(name("limit_events").as_deref(), Some("LimitEvents"));
    assert_eq!(name("mode").as_deref(), Some("Mode"));
    assert_eq!(name("contact_model_2").as_deref(), Some("ContactModel2"));
    assert_eq!(Var::new("k", None, 0.0, "").type_name(), None);
    assert_eq!(Var::new("g", None, 0.0, "").integer().type_name(), None);
}

/// A scene's start value for it goes through fmi2SetInteger's path in the documentation's
/// runs, and `mbfmu linearize --set` checks it as the FMU does.
#[cfg(feature = "describe")]
#[test]
fn scenes_and_linearize_set_it_as_the_fmu_does() {
    use mbfmu::docs::run::{simulate, RunSettings};
    use mbfmu::integrators::Method;
    use mbfmu::linearize::{linearize, OperatingPoint};
    let scene = &Relaxation::scenes()[0];
    let settings = RunSettings {
        method: Method::Dopri5,
        tol: 1e-8,
        step: 1e-3,
        comm_step: 0.1,
        stop: 1.0,
    };
    let run = simulate::<Relaxation>(&scene.start_values, settings).unwrap();
    let x = &run.columns[run.names.iter().position(|n| n == "x").unwrap()];
    assert!(x.iter().all(|&v| v == 1.0), "law off: x holds ({x:?})");
    let err = simulate::<Relaxation>(&[("damping_law", 0.5)], settings).unwrap_err();
    assert!(err.contains("damping_law"), "{err}");

    let op =
        OperatingPoint::from_start_values::<Relaxation>(&[("damping_law".into(), 0.0)]).unwrap();
    assert_eq!(op.p, [1.0, 0.0, 1.0]);
    assert_eq!(linearize::<Relaxation>(&op).a[(0, 0)], -1.0);
    let err = OperatingPoint::from_start_values::<Relaxation>(&[("damping_law".into(), 4.0)])
        .unwrap_err();
    assert!(
        err.contains("not one of its codes (0 = linear, 1 = cubic, 2 = off)"),
        "{err}"
    );
}
