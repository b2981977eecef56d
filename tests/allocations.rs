//! No heap allocation per doStep in steady state, for every method on hand-written
//! systems and on the Lagrangian ones that run generated code: a counting global
//! allocator (a count, never a time) around the C-API calls an importer makes once the
//! run is going: fmi2DoStep, fmi2GetReal of every output and state derivative,
//! fmi2GetDirectionalDerivative.
//!
//! Each case instantiates, initialises, takes doSteps until the integrator's buffers have
//! their sizes (and, for the adaptive methods, several steps ahead of the grid), then
//! counts the allocations over many more doSteps, which must themselves take internal
//! steps (checked from the statistics): fixed-step methods with one and with several
//! internal steps per doStep; adaptive ones in dense mode with many communication points
//! inside one step; for MassSpringDamper also with input derivatives set (the polynomial
//! input, adaptive methods landing). A test binary of its own: its `#[global_allocator]` counts per thread,
//! so the tests running beside each other do not see each other's allocations.
//!
//! The Lagrangian systems with generated equations of motion (`generated_eom!`) are
//! counted too (projection included). RATTLE runs only on
//! systems written as a `Lagrangian`, whose `Mechanics` is still automatic
//! differentiation (src/model/lagrangian.rs; and the FMU boxes it once per doStep), so
//! the FMU cases leave it out; the last test counts the integrator's own
//! allocations, through `rattle::advance_in` on hand-written `Mechanics` that allocate
//! nothing.

use mbfmu::fmi::fmi2::{self as capi, Component};
use mbfmu::fmi::{Export, Instance, Logger, ModelInfo, Status};
use mbfmu::integrators::problem::FixedCall;
use mbfmu::integrators::problem::Mechanics;
use mbfmu::integrators::{rattle, Stats};
use mbfmu::model::{System, VarKind};
use std::alloc::{GlobalAlloc, Layout, System as Heap};
use std::cell::Cell;
use std::sync::OnceLock;

struct Counting;

thread_local! {
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn count() {
    // `try_with`: a thread being torn down may still free and allocate.
    let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
}

// SAFETY: forwards to the system allocator; only counts on the side.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        Heap.alloc(layout)
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        Heap.alloc_zeroed(layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        Heap.realloc(ptr, layout, new_size)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        Heap.dealloc(ptr, layout)
    }
}

#[global_allocator]
static COUNTING: Counting = Counting;

/// Allocations made by this thread while `f` runs.
fn allocations(f: impl FnOnce()) -> u64 {
    let before = ALLOCATIONS.with(Cell::get);
    f();
    ALLOCATIONS.with(Cell::get) - before
}

macro_rules! exported {
    ($name:ident, $model:ty) => {
        struct $name;
        impl Export for $name {
            type Model = $model;
            fn info() -> &'static ModelInfo {
                static INFO: OnceLock<ModelInfo> = OnceLock::new();
                INFO.get_or_init(ModelInfo::of::<$model>)
            }
        }
    };
}

exported!(MassSpringDamper, mbfmu::systems::MassSpringDamper);
exported!(TwoMassChain, mbfmu::systems::TwoMassChain);
exported!(RigidBody, mbfmu::systems::RigidBody);
exported!(RollingDisk, mbfmu::systems::RollingDisk);
exported!(WhippleBicycle, mbfmu::systems::WhippleBicycle);
exported!(SphereSlide, mbfmu::systems::SphereSlide);
exported!(CompoundPendulum, mbfmu::systems::CompoundPendulum);
exported!(DoublePendulum, mbfmu::systems::DoublePendulum);
exported!(SliderCrank, mbfmu::systems::SliderCrank);
exported!(SliderCrankSurplus, mbfmu::systems::SliderCrankSurplus);
exported!(SpringRodPendulum, mbfmu::systems::SpringRodPendulum);

/// How one case is run.
#[derive(Clone, Copy, Debug)]
struct Case {
    method: i32,
    /// `solver_step` (fixed-step methods).
    step: f64,
    /// The communication step.
    h: f64,
    /// The adaptive methods land on every communication point (a system with an event
    /// indicator) instead of running ahead with dense output.
    landing: bool,
    /// The input `F` moves (derivatives of orders 1 and 2 set before initialisation): the
    /// right-hand side evaluates the polynomial input, and the adaptive methods land.
    moving: bool,
}

/// Allocations over the counted doSteps of one case, by the call that made them.
#[derive(Debug, Default, PartialEq)]
struct Counts {
    do_step: u64,
    get_real: u64,
    directional: u64,
}

const WARM_UP: usize = 300;
const COUNTED: usize = 1000;

/// Runs `case` on a scene of `E`'s model (by name, with more start values): the
/// allocations over [`COUNTED`] communication steps after [`WARM_UP`] ones.
fn run<E: Export>((scene, extra): (&str, &[(&str, f64)]), case: Case) -> Counts {
    let info = E::info();
    let layout = &info.layout;
    let vr = |name: &str| layout.vr_of(name).unwrap();
    let inst = Box::new(Instance::<E::Model>::new(info, Logger::silent("alloc")));
    let c = Box::into_raw(inst) as Component;
    let ok = |status: Status, what: &str| assert_eq!(status, Status::Ok, "{what} {case:?}");
    // DOP853 at 1e-6 takes steps too long for the counted window.
    let tolerance = if case.method == 9 { 1e-10 } else { 1e-6 };
    ok(
        capi::setup_experiment::<E>(c, 1, tolerance, 0.0, 0, 0.0),
        "setup",
    );
    let scene = <E::Model as System>::scenes()
        .into_iter()
        .find(|s| s.name == scene)
        .unwrap();
    for (name, value) in scene.start_values.iter().chain(extra) {
        let r = [vr(name)];
        ok(
            unsafe { capi::set_real::<E>(c, r.as_ptr(), 1, value) },
            name,
        );
    }
    let r = [vr("solver_step")];
    ok(
        unsafe { capi::set_real::<E>(c, r.as_ptr(), 1, &case.step) },
        "step",
    );
    let r = [vr("solver")];
    ok(
        unsafe { capi::set_integer::<E>(c, r.as_ptr(), 1, &case.method) },
        "solver",
    );
    if case.moving {
        let (r, orders, values) = ([vr("F"), vr("F")], [1, 2], [0.5, -0.25]);
        let status = unsafe {
            capi::set_real_input_derivatives::<E>(
                c,
                r.as_ptr(),
                2,
                orders.as_ptr(),
                values.as_ptr(),
            )
        };
        ok(status, "input derivatives");
    }
    // Start values before initialization mode, as fmpy sets them (a dependent state,
    // initial = "approx", may only be set there).
    ok(capi::enter_initialization_mode::<E>(c), "init");
    ok(capi::exit_initialization_mode::<E>(c), "exit init");

    let of_kind = |kinds: &[VarKind]| -> Vec<u32> {
        (0..layout.vars.len() as u32)
            .filter(|&v| kinds.contains(&layout.slot(v).unwrap().kind))
            .collect()
    };
    let outputs = of_kind(&[VarKind::State, VarKind::Output, VarKind::Derivative]);
    let unknowns = of_kind(&[VarKind::Output, VarKind::Derivative]);
    let knowns = of_kind(&[VarKind::State, VarKind::Input]);
    let seeds = vec![1.0; knowns.len()];
    let mut values = vec![0.0; outputs.len()];
    let mut sensitivities = vec![0.0; unknowns.len()];
    let mut t = 0.0;
    let stats = || unsafe { &*(c as *const Instance<E::Model>) }.stats();
    // One communication step as an importer takes it, with the allocations of each call.
    let mut step = || Counts {
        do_step: allocations(|| {
            ok(capi::do_step::<E>(c, t, case.h, 1), "doStep");
            t += case.h;
        }),
        get_real: allocations(|| {
            let status = unsafe {
                capi::get_real::<E>(c, outputs.as_ptr(), outputs.len(), values.as_mut_ptr())
            };
            ok(status, "getReal");
        }),
        directional: allocations(|| {
            let status = unsafe {
                capi::get_directional_derivative::<E>(
                    c,
                    unknowns.as_ptr(),
                    unknowns.len(),
                    knowns.as_ptr(),
                    knowns.len(),
                    seeds.as_ptr(),
                    sensitivities.as_mut_ptr(),
                )
            };
            ok(status, "getDirectionalDerivative");
        }),
    };
    for _ in 0..WARM_UP {
        step();
    }
    let steps_before = stats().steps;
    let mut counts = Counts::default();
    for _ in 0..COUNTED {
        let c = step();
        counts.do_step += c.do_step;
        counts.get_real += c.get_real;
        counts.directional += c.directional;
    }
    let steps = stats().steps - steps_before;
    if adaptive(case.method) && (case.landing || case.moving) {
        assert!(steps >= COUNTED as u64, "{case:?}: {steps} steps");
    } else if adaptive(case.method) {
        // Dense mode: many communication points per step, and still steps in the window.
        assert!(
            steps >= 3 && steps < COUNTED as u64 / 3,
            "{case:?}: {steps} steps"
        );
    } else {
        let per_call = (case.h / case.step).round() as u64;
        assert_eq!(steps, per_call * COUNTED as u64, "{case:?}");
    }
    unsafe { mbfmu::fmi::boundary::free_instance::<capi::Inst<E>>(c) };
    counts
}

fn adaptive(method: i32) -> bool {
    matches!(method, 2 | 9 | 10)
}

/// Every case of `methods` on one scene: fixed-step methods with one and with `several`
/// internal steps per doStep, adaptive ones with a communication step of `step` (far below
/// theirs in dense mode). Prints the counts, and fails unless all are zero.
fn check<E: Export>(
    scene: (&str, &[(&str, f64)]),
    methods: &[i32],
    (step, several): (f64, f64),
    landing: bool,
) {
    check_inputs::<E>(scene, methods, (step, several), landing, false)
}

/// [`check`], with the input moving (`moving`) or held.
fn check_inputs<E: Export>(
    scene: (&str, &[(&str, f64)]),
    methods: &[i32],
    (step, several): (f64, f64),
    landing: bool,
    moving: bool,
) {
    let mut failures = Vec::new();
    for &method in methods {
        let hs: &[f64] = if adaptive(method) {
            &[step]
        } else {
            &[step, several * step]
        };
        for &h in hs {
            let case = Case {
                method,
                step,
                h,
                landing,
                moving,
            };
            let counts = run::<E>(scene, case);
            let name = <E::Model as System>::NAME;
            println!("{name} solver {method} h {h}: {counts:?} over {COUNTED} doSteps");
            if counts != Counts::default() {
                failures.push(format!("solver {method} h {h}: {counts:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "allocations: {failures:#?}");
}

/// 1 RK4, 2 DOPRI5, 3 ExplicitEuler, 4 SymplecticEuler, 5 Verlet, 6 ImplicitMidpoint,
/// 7 Gauss4, 8 Gauss6, 9 DOP853, 10 RADAU5, 11 ExactLinear.
const ALL_BUT_RATTLE: [i32; 11] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11];

#[test]
fn mass_spring_damper() {
    check::<MassSpringDamper>(("damped", &[]), &ALL_BUT_RATTLE, (1e-3, 4.0), false);
}

/// Input derivatives set: every method but ExactLinear (its input polynomial is tested in
/// tests/input_output_derivatives.rs).
#[test]
fn mass_spring_damper_with_input_derivatives() {
    let methods = &ALL_BUT_RATTLE[..10];
    check_inputs::<MassSpringDamper>(("damped", &[]), methods, (1e-3, 4.0), false, true);
}

#[test]
fn two_mass_chain() {
    check::<TwoMassChain>(("release", &[]), &ALL_BUT_RATTLE, (1e-3, 4.0), false);
}

#[test]
fn whipple_bicycle() {
    check::<WhippleBicycle>(("stable", &[]), &ALL_BUT_RATTLE, (1e-3, 4.0), false);
}

#[test]
fn rigid_body() {
    // No (q, q̇) split (symplectic Euler, Verlet refused), not linear (ExactLinear).
    check::<RigidBody>(
        ("symmetric_top", &[]),
        &[1, 2, 3, 6, 7, 8, 9, 10],
        (1e-3, 4.0),
        false,
    );
}

#[test]
fn rolling_disk() {
    // Constrained: projected after every doStep. Not linear (ExactLinear refused). The
    // torques make the motion more than a polynomial the adaptive methods step over.
    let torques: &[(&str, f64)] = &[("tau_phi", 0.1), ("tau_theta", 0.05)];
    let methods = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10];
    check::<RollingDisk>(("circle", torques), &methods, (1e-3, 4.0), false);
}

#[test]
fn sphere_slide() {
    // On the sphere (it leaves at t = 2.376 s, after the counted window): an event
    // indicator, so every method lands on each communication point and the event search
    // copies the start of each doStep. Not second order, not linear.
    let methods = [1, 2, 3, 6, 7, 8, 9, 10];
    check::<SphereSlide>(("slide", &[]), &methods, (5e-4, 2.0), true);
}

/// Every method but RATTLE and ExactLinear (the Lagrangians are not linear).
const LAGRANGIAN_METHODS: [i32; 10] = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10];

// The Lagrangian systems on their generated equations of motion (`generated_eom!`).

#[test]
fn compound_pendulum() {
    let torque: &[(&str, f64)] = &[("tau", 0.3)];
    check::<CompoundPendulum>(("large", torque), &LAGRANGIAN_METHODS, (1e-3, 4.0), false);
}

#[test]
fn double_pendulum() {
    check::<DoublePendulum>(("chaotic", &[]), &LAGRANGIAN_METHODS, (1e-3, 4.0), false);
}

#[test]
fn slider_crank() {
    check::<SliderCrank>(("driven", &[]), &LAGRANGIAN_METHODS, (1e-3, 4.0), false);
}

#[test]
fn spring_rod_pendulum() {
    check::<SpringRodPendulum>(("wobble", &[]), &LAGRANGIAN_METHODS, (1e-3, 4.0), false);
}

#[test]
fn slider_crank_surplus() {
    // Surplus coordinates: projected after every doStep (on the generated terms too).
    check::<SliderCrankSurplus>(("driven", &[]), &LAGRANGIAN_METHODS, (1e-3, 4.0), false);
}

/// A pendulum in Cartesian coordinates (mass 2 kg at (x, z), z down, on a 1.5 m rod):
/// T = ½ m (ẋ² + ż²), V = −m g z, g(q) = (x² + z² − L²)/2.
struct CartesianPendulum;

impl Mechanics for CartesianPendulum {
    fn dims(&self) -> (usize, usize) {
        (2, 1)
    }
    fn mass_matrix(&mut self, _q: &[f64], m: &mut [f64]) {
        m.copy_from_slice(&[2.0, 0.0, 0.0, 2.0]);
    }
    fn momentum_offset(&mut self, _q: &[f64], b: &mut [f64]) {
        b.fill(0.0);
    }
    fn force(&mut self, _t: f64, _q: &[f64], _qd: &[f64], f: &mut [f64]) {
        f.copy_from_slice(&[0.0, 2.0 * 9.81]);
    }
    fn constraints(&mut self, q: &[f64], g: &mut [f64], jac: &mut [f64]) {
        g[0] = 0.5 * (q[0] * q[0] + q[1] * q[1] - 1.5 * 1.5);
        jac.copy_from_slice(&[q[0], q[1]]);
    }
}

/// A spring pendulum in polar coordinates (r, θ): a mass matrix that depends on q
/// (diag(m, m r²)), no constraint.
struct PolarSpringPendulum;

impl Mechanics for PolarSpringPendulum {
    fn dims(&self) -> (usize, usize) {
        (2, 0)
    }
    fn mass_matrix(&mut self, q: &[f64], m: &mut [f64]) {
        m.copy_from_slice(&[1.0, 0.0, 0.0, q[0] * q[0]]);
    }
    fn momentum_offset(&mut self, _q: &[f64], b: &mut [f64]) {
        b.fill(0.0);
    }
    fn force(&mut self, _t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) {
        // ∂L/∂q: r θ̇² + g cos θ − c (r − r0), −g r sin θ.
        let (r, theta) = (q[0], q[1]);
        f[0] = r * qd[1] * qd[1] + 9.81 * theta.cos() - 40.0 * (r - 1.0);
        f[1] = -9.81 * r * theta.sin();
    }
    fn constraints(&mut self, _q: &[f64], _g: &mut [f64], _jac: &mut [f64]) {}
}

/// RATTLE's own allocations over 1000 calls of `rattle::advance_in` after 300, with one
/// and with four steps per call.
fn rattle_allocations(mech: &mut dyn Mechanics, x0: [f64; 4]) -> [u64; 2] {
    [1.0, 4.0].map(|steps| {
        let (h, mut stats) = (1e-3, Stats::default());
        let mut scratch = rattle::Scratch::default();
        let (mut t, mut x) = (0.0, x0);
        let mut call = |stats: &mut Stats| {
            let t_end = t + steps * h;
            let call = FixedCall {
                t: &mut t,
                x: &mut x,
                t_end,
                h,
                stats,
            };
            rattle::advance_in(mech, call, &mut scratch).unwrap();
        };
        for _ in 0..WARM_UP {
            call(&mut stats);
        }
        let before = stats.steps;
        let count = allocations(|| (0..COUNTED).for_each(|_| call(&mut stats)));
        assert_eq!(stats.steps - before, steps as u64 * COUNTED as u64);
        count
    })
}

#[test]
fn rattle_itself() {
    let (s, c) = 1.0f64.sin_cos();
    let cartesian = rattle_allocations(&mut CartesianPendulum, [1.5 * s, 1.5 * c, 0.0, 0.0]);
    let polar = rattle_allocations(&mut PolarSpringPendulum, [1.2, 0.5, 0.0, 0.3]);
    println!("RATTLE: {cartesian:?} (Cartesian, 1 and 4 steps a call), {polar:?} (polar)");
    assert_eq!((cartesian, polar), ([0, 0], [0, 0]));
}

/// ABA, RNEA and CRBA with their workspace ([`mbfmu::multibody::Data`], made once per model)
/// allocate nothing per call, and give the allocating forms' results bit for bit: the
/// Panda (7 joints), UR5 and a 16-link chain, 10 rounds of the three.
#[test]
fn multibody_algorithms_allocate_nothing_with_their_data() {
    use mbfmu::multibody::{codegen::benchmark_model, Data};
    for name in ["panda", "ur5", "chain_16"] {
        let model = benchmark_model(name);
        let n = model.nq();
        let q: Vec<f64> = (0..n).map(|i| 0.3 * i as f64 - 0.7).collect();
        let qd: Vec<f64> = (0..n).map(|i| 0.5 - 0.11 * i as f64).collect();
        let tau: Vec<f64> = (0..n).map(|i| (i as f64).sin()).collect();
        let mut data = Data::<f64>::new(&model);
        let (mut qdd, mut back, mut m) = (vec![0.0; n], vec![0.0; n], vec![0.0; n * n]);
        let count = allocations(|| {
            for _ in 0..10 {
                model.aba_in(&mut data, &q, &qd, &tau, &mut qdd);
                model.rnea_in(&mut data, &q, &qd, &qdd, &mut back);
                model.crba_in(&mut data, &q, &mut m);
            }
        });
        assert_eq!(
            count, 0,
            "{name}: allocations in 10 rounds of ABA, RNEA, CRBA"
        );
        assert_eq!(qdd, model.aba(&q, &qd, &tau), "{name}");
        assert_eq!(back, model.rnea(&q, &qd, &qdd), "{name}");
        assert_eq!(m, model.crba(&q).concat(), "{name}");
        // RNEA inverts ABA: the joint forces back, τ − d q̇ (ABA applies the damping, RNEA
        // gives what acts on the bodies), to rounding.
        let scale = tau.iter().fold(1.0f64, |s, t| s.max(t.abs()));
        for i in 0..n {
            let acting = tau[i] - qd[i] * model.damping[i];
            assert!(
                (back[i] - acting).abs() < 1e-9 * scale,
                "{name}: {back:?} vs τ − d q̇"
            );
        }
    }
}

exported!(
    RuntimeRobot,
    mbfmu::multibody::fmu::Robot<mbfmu::multibody::runtime::Runtime>
);

/// A three-joint arm as URDF text, as the mechanism runtime reads it from an FMU.
const ARM: &str = r#"<robot name="arm">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0 0 0.2"/><mass value="2"/>
    <inertia ixx="0.03" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.004"/></inertial></link>
  <link name="fore"><inertial><origin xyz="0 0 0.15"/><mass value="1.2"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.002"/></inertial></link>
  <link name="hand"><inertial><origin xyz="0 0.02 0.05"/><mass value="0.4"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.0005"/></inertial></link>
  <joint name="shoulder" type="continuous"><parent link="base"/><child link="upper"/>
    <axis xyz="0 1 0"/></joint>
  <joint name="elbow" type="continuous"><parent link="upper"/><child link="fore"/>
    <origin xyz="0 0 0.4" rpy="0.1 0 0"/><axis xyz="0 1 0"/></joint>
  <joint name="wrist" type="continuous"><parent link="fore"/><child link="hand"/>
    <origin xyz="0 0 0.3"/><axis xyz="1 0 0"/></joint>
</robot>"#;

/// The mechanism runtime (a robot read at run time, `mbfmu build --urdf` without a
/// compiler): its right-hand side allocates nothing (q̈ by the interpreted articulated-body
/// algorithm on a workspace kept per thread), so a doStep's allocations do not grow with
/// its internal steps. What it allocates is its outputs' (the ends' forward kinematics and
/// the energy, once per doStep): counted and printed.
#[test]
fn mechanism_runtime_steps_without_allocating_per_step() {
    mbfmu::multibody::runtime::load("arm", ARM, false).unwrap();
    type R = mbfmu::multibody::fmu::Robot<mbfmu::multibody::runtime::Runtime>;
    let x = [0.8, -0.5, 0.3, 0.0, 0.1, 0.2];
    let (u, p) = ([0.0; 3], [2.0]);
    let mut dx = [0.0; 6];
    assert_eq!(<R as System>::parameters().len(), p.len());
    <R as System>::derivatives(0.0, &x, &u, &p, &mut dx);
    let per_rhs = allocations(|| {
        for _ in 0..100 {
            <R as System>::derivatives(0.0, &x, &u, &p, &mut dx);
        }
    });
    assert_eq!(per_rhs, 0, "allocations in 100 right-hand sides");
    let scene = ("released", &[("shoulder", 0.8), ("elbow", -0.5)][..]);
    for method in [1, 2] {
        let step = 1e-3;
        let mut per_do_step = Vec::new();
        for internal in [1.0, 4.0] {
            let case = Case {
                method,
                step,
                h: internal * step,
                landing: false,
                moving: false,
            };
            let counts = run::<RuntimeRobot>(scene, case);
            println!(
                "mechanism runtime solver {method} h {}: {counts:?} over {COUNTED} doSteps",
                case.h
            );
            per_do_step.push(counts.do_step);
        }
        assert_eq!(
            per_do_step[0], per_do_step[1],
            "solver {method}: allocations grow with the steps"
        );
    }
}

/// AndrewsSqueezer's right-hand side runs on its generated closed terms
/// (`src/systems/generated/andrews_squeezer.rs`) in a workspace kept per thread: after
/// the first call, no allocation, in f64 and in the dual numbers of the Jacobians. (Its
/// doStep is not counted: the projection onto the closures after each step,
/// `closed::project`, still allocates.)
#[test]
fn andrews_squeezer_right_hand_side() {
    use mbfmu::systems::andrews_squeezer::{p, START};
    use mbfmu::systems::AndrewsSqueezer;
    use num_dual::Dual64;
    let start = |v: Vec<mbfmu::model::Var>| v.iter().map(|v| v.start).collect::<Vec<f64>>();
    let par = start(<AndrewsSqueezer as System>::parameters());
    let mut u = vec![0.0; 7];
    u[0] = p::MOM;
    // Off the start's rest: a velocity on no closure, which the tangent step moves.
    let x: Vec<f64> = START
        .iter()
        .copied()
        .chain((0..7).map(|i| 0.3 * i as f64 - 1.0))
        .collect();
    let mut dx = vec![0.0; 14];
    <AndrewsSqueezer as System>::derivatives(0.0, &x, &u, &par, &mut dx);
    let n = allocations(|| {
        for _ in 0..100 {
            <AndrewsSqueezer as System>::derivatives(0.0, &x, &u, &par, &mut dx);
        }
    });
    assert_eq!(n, 0, "{n} allocations in 100 right-hand sides");
    assert!(dx.iter().all(|v| v.is_finite()));
    let xd: Vec<Dual64> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| Dual64::new(v, (i == 2) as u8 as f64))
        .collect();
    let (ud, pd): (Vec<Dual64>, Vec<Dual64>) = (
        u.iter().map(|&v| Dual64::from(v)).collect(),
        par.iter().map(|&v| Dual64::from(v)).collect(),
    );
    let mut dxd = vec![Dual64::from(0.0); 14];
    <AndrewsSqueezer as System>::derivatives(0.0, &xd, &ud, &pd, &mut dxd);
    let n = allocations(|| {
        for _ in 0..100 {
            <AndrewsSqueezer as System>::derivatives(0.0, &xd, &ud, &pd, &mut dxd);
        }
    });
    assert_eq!(n, 0, "{n} allocations in 100 dual right-hand sides");
}
