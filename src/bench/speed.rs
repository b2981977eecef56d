//! `mbfmu speed`: what one doStep, one right-hand side and one Jacobian cost, for every
//! system, beside hand-written floors ([`floors`](super::floors)) measured in the same run.
//!
//! - doStep: RK4 at `solver_step` = h = 1 ms (one internal step per doStep), logging off,
//!   through the same `fmi2::do_step` an exported `fmi2DoStep` forwards to (state
//!   machine, argument checks, the step, the outputs' finiteness check), in steady state:
//!   no allocation (tests/allocations.rs).
//! - RHS: `System::derivatives` in `f64` at the scene's start point.
//! - Jacobian: the n dual-number columns of ∂f/∂x in kept buffers
//!   ([`Duals::jacobian`]), as the implicit methods build it; reported against n × one RHS.
//!
//! Times are the best of several repetitions of a loop long enough (~20 ms) for the clock
//! not to matter; the ratios to the floor are what to read (a slower machine moves both).

use super::floors::{self, Floor};
use crate::fmi::{fmi2, Export, Instance, Logger, ModelInfo, Status};
use crate::model::jacobian::Duals;
use crate::model::{System, VarKind};
use std::any::TypeId;
use std::collections::HashMap;
use std::hint::black_box;
use std::marker::PhantomData;
use std::sync::Mutex;
use std::time::Instant;

/// The communication step and RK4 step of the doStep measurement (s).
const H: f64 = 1e-3;
/// RK4's code of the `solver` Enumeration.
const RK4: i32 = 1;

/// One system's costs (ns).
#[derive(Clone, Debug)]
pub struct SpeedRow {
    pub system: &'static str,
    pub states: usize,
    pub dostep_ns: f64,
    pub rhs_ns: f64,
    pub jacobian_ns: f64,
    /// The hand-written floor's doStep and RHS, where the bench has one.
    pub floor: Option<(f64, f64)>,
    /// A peer's evaluation of the same equations at the same state, measured in the same
    /// run where asked ([`fortran_andrews`]).
    pub peer_rhs_ns: Option<f64>,
}

/// An [`Export`] for any system, so the bench calls the same generic C-API function the
/// exported symbols forward to.
struct Exported<M>(PhantomData<M>);

impl<M: System> Export for Exported<M> {
    type Model = M;
    fn info() -> &'static ModelInfo {
        info::<M>()
    }
}

fn info<M: System>() -> &'static ModelInfo {
    static INFOS: Mutex<Option<HashMap<TypeId, &'static ModelInfo>>> = Mutex::new(None);
    let mut infos = INFOS.lock().expect("bench info map");
    infos
        .get_or_insert_with(HashMap::new)
        .entry(TypeId::of::<M>())
        .or_insert_with(|| Box::leak(Box::new(ModelInfo::of::<M>())))
}

/// Best time per call (ns) of `f`, over `reps` loops of about 20 ms each.
pub fn best_ns(reps: usize, mut f: impl FnMut()) -> f64 {
    let probe = Instant::now();
    let mut calls = 0u64;
    while probe.elapsed().as_secs_f64() < 2e-3 {
        f();
        calls += 1;
    }
    let per_call = probe.elapsed().as_secs_f64() / calls as f64;
    let iters = ((20e-3 / per_call) as u64).max(1);
    (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            for _ in 0..iters {
                f();
            }
            t0.elapsed().as_secs_f64() * 1e9 / iters as f64
        })
        .fold(f64::INFINITY, f64::min)
}

/// An instance in step mode at the first scene's start values, RK4 at h = [`H`].
fn started<M: System>() -> Instance<M> {
    let info = info::<M>();
    let mut inst = Instance::<M>::new(info, Logger::silent("speed"));
    inst.setup_experiment(Some(1e-8), 0.0, None).expect("setup");
    // Start values before initialization mode, as fmpy sets them (a dependent state,
    // initial = "approx", may only be set there).
    if let Some(scene) = M::scenes().first() {
        for (name, value) in &scene.start_values {
            let vr = info.layout.vr_of(name).expect("scene variable");
            inst.set_value(vr, *value).expect("scene value");
        }
    }
    let step = info.layout.vr_of("solver_step").expect("solver_step");
    inst.set_real(&[step], &[H]).expect("solver_step");
    let solver = info.layout.vr_of("solver").expect("solver");
    inst.set_integer(&[solver], &[RK4]).expect("RK4");
    inst.enter_initialization_mode().expect("init mode");
    inst.exit_initialization_mode().expect("exit init");
    inst
}

/// The values of one kind of variable of a started instance.
fn values<M: System>(inst: &Instance<M>, kind: VarKind) -> Vec<f64> {
    let layout = &inst.info.layout;
    let vrs: Vec<u32> = (0..layout.vars.len() as u32)
        .filter(|&vr| layout.slot(vr).is_some_and(|s| s.kind == kind))
        .collect();
    // Each with the getter of its type (a parameter may be an Integer or Enumeration).
    vrs.iter()
        .map(|&vr| inst.get_value(vr).expect("values"))
        .collect()
}

/// A floor's measurement: (start state, parameters, repetitions) → (doStep, RHS) in ns.
pub type FloorFn = fn(&[f64], &[f64], usize) -> (f64, f64);

/// The costs of `M` (see the module notes), and of its floor when given.
pub fn measure<M: System>(reps: usize, floor: Option<FloorFn>) -> SpeedRow {
    let probe = started::<M>();
    let (x, u, p) = (
        values(&probe, VarKind::State),
        values(&probe, VarKind::Input),
        values(&probe, VarKind::Parameter),
    );
    let n = x.len();

    // doStep: a fresh instance per repetition, so no run goes on long enough to leave
    // the scene's regime (a capsizing bicycle, a particle falling for minutes).
    let dostep_ns = (0..reps)
        .map(|_| {
            let inst = Box::leak(Box::new(started::<M>()));
            let c = inst as *mut Instance<M> as fmi2::Component;
            let mut t = 0.0;
            best_ns(1, || {
                let status = fmi2::do_step::<Exported<M>>(c, black_box(t), H, 1);
                debug_assert_eq!(status, Status::Ok);
                t += H;
            })
        })
        .fold(f64::INFINITY, f64::min);

    let (rhs_ns, jacobian_ns) = rhs_and_jacobian_ns::<M>(&x, &u, &p, reps);

    SpeedRow {
        system: M::NAME,
        states: n,
        dostep_ns,
        rhs_ns,
        jacobian_ns,
        floor: floor.map(|f| f(&x, &p, reps)),
        peer_rhs_ns: None,
    }
}

/// The Fortran `F` of the IVP test set's andrews problem (`SUBROUTINE
/// F(NEQN,T,Y,DY,IPAR,RPAR,IERR)`), as gfortran exports it.
type FortranF = unsafe extern "C" fn(
    *const i32,
    *const f64,
    *const f64,
    *mut f64,
    *const i32,
    *const f64,
    *mut i32,
) -> ();

/// The peer of `mbfmu speed --fortran-andrews PATH`: the IVP test set's Fortran `F` for
/// andrews, built by the user from the test set's source as a shared object exporting
/// `f_` (not in this repository: third-party code), timed as the RHS rows are (best of
/// `reps`) at the AndrewsSqueezer RHS row's state: the same q and q̇, with our q̈ and λ
/// as its w and λ. It evaluates the index-3 DAE's residual (27 components: the velocities,
/// `M w − f + Gᵀ λ`, g) and solves nothing; our RHS solves for q̈ and λ. Returns its ns
/// and the largest `|M w − f + Gᵀ λ|` of the seven force rows over the largest
/// `|M w − f|` (our accelerations and multipliers in its equations: rounding where both
/// are the same mechanism).
pub fn fortran_andrews(path: &std::path::Path, reps: usize) -> Result<(f64, f64), String> {
    use crate::model::lagrangian::accelerations_and_multipliers_into;
    use crate::systems::AndrewsSqueezer;
    use std::ffi::CString;
    let c_path = CString::new(path.to_string_lossy().as_bytes()).map_err(|e| e.to_string())?;
    // SAFETY: dlopen of a path the user names, as a shared object; its symbol `f_` is
    // called with the argument list of the test set's F (NEQN = 27 doubles in and out).
    let f: FortranF = unsafe {
        let handle = libc::dlopen(c_path.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL);
        if handle.is_null() {
            let err = std::ffi::CStr::from_ptr(libc::dlerror());
            return Err(format!("{}: {}", path.display(), err.to_string_lossy()));
        }
        let sym = libc::dlsym(handle, c"f_".as_ptr());
        if sym.is_null() {
            return Err(format!(
                "{}: no symbol f_ (the test set's F)",
                path.display()
            ));
        }
        std::mem::transmute::<*mut libc::c_void, FortranF>(sym)
    };
    let probe = started::<AndrewsSqueezer>();
    let (x, u, p) = (
        values(&probe, VarKind::State),
        values(&probe, VarKind::Input),
        values(&probe, VarKind::Parameter),
    );
    let (q, qd) = x.split_at(7);
    let (mut qdd, mut lambda) = ([0.0; 7], [0.0; 6]);
    accelerations_and_multipliers_into::<AndrewsSqueezer, f64>(
        0.0,
        q,
        qd,
        &u,
        &p,
        &mut qdd,
        &mut lambda,
    );
    let mut y = [0.0f64; 27];
    y[..7].copy_from_slice(q);
    y[7..14].copy_from_slice(qd);
    y[14..21].copy_from_slice(&qdd);
    y[21..].copy_from_slice(&lambda);
    let (neqn, t, ipar, rpar) = (27i32, 0.0f64, [0i32; 2], [0.0f64; 2]);
    let mut dy = [0.0f64; 27];
    let mut ierr = 0i32;
    let mut call = |y: &[f64; 27], dy: &mut [f64; 27]| {
        // SAFETY: the buffers are NEQN = 27 long, IPAR and RPAR 2, as F reads them.
        unsafe {
            f(
                &neqn,
                &t,
                y.as_ptr(),
                dy.as_mut_ptr(),
                ipar.as_ptr(),
                rpar.as_ptr(),
                &mut ierr,
            )
        }
    };
    let ns = best_ns(reps, || {
        call(black_box(&y), &mut dy);
        black_box(&dy);
    });
    // The residual's scale: its force rows' terms, M w − f and Gᵀ λ (λ zeroed: M w − f).
    let mut no_lambda = y;
    no_lambda[21..].fill(0.0);
    let mut inertial = [0.0f64; 27];
    call(&no_lambda, &mut inertial);
    let scale = inertial[14..21]
        .iter()
        .fold(f64::MIN_POSITIVE, |m, v| m.max(v.abs()));
    let residual = dy[14..21].iter().fold(0.0f64, |m, v| m.max(v.abs())) / scale;
    Ok((ns, residual))
}

/// Best ns of one `System::derivatives` and of one ∂f/∂x in kept dual-number buffers
/// (as the implicit methods and fmi2GetDirectionalDerivative build it) at `(x, u, p)`.
pub(crate) fn rhs_and_jacobian_ns<M: System>(
    x: &[f64],
    u: &[f64],
    p: &[f64],
    reps: usize,
) -> (f64, f64) {
    let n = x.len();
    let mut dx = vec![0.0; n];
    let rhs_ns = best_ns(reps, || {
        M::derivatives(0.0, black_box(x), u, p, &mut dx);
        black_box(&dx);
    });
    let (mut duals, mut jac) = (Duals::default(), vec![0.0; n * n]);
    let jacobian_ns = best_ns(reps, || {
        duals.jacobian::<M>(0.0, black_box(x), u, p, &mut jac);
        black_box(&jac);
    });
    (rhs_ns, jacobian_ns)
}

/// The floor's (doStep, RHS) in ns from the same start point.
fn floor_costs<F: Floor<N>, const N: usize>(x0: &[f64], p: &[f64], reps: usize) -> (f64, f64) {
    let start: [f64; N] = x0.try_into().expect("floor of the same size");
    let dostep = (0..reps)
        .map(|_| {
            let mut x = start;
            best_ns(1, || {
                black_box(floors::rk4_step::<F, N>(&mut x, black_box(p), H));
            })
        })
        .fold(f64::INFINITY, f64::min);
    let rhs = best_ns(reps, || {
        black_box(F::rhs(black_box(&start), p));
    });
    (dostep, rhs)
}

/// The floor of a system, by name, where the bench has one.
pub fn floor_of(system: &str) -> Option<FloorFn> {
    match system {
        "MassSpringDamper" => Some(floor_costs::<floors::MassSpringDamper, 2>),
        "TwoMassChain" => Some(floor_costs::<floors::TwoMassChain, 4>),
        "RigidBody" => Some(floor_costs::<floors::RigidBody, 7>),
        "CompoundPendulum" => Some(floor_costs::<floors::CompoundPendulum, 2>),
        "DoublePendulum" => Some(floor_costs::<floors::DoublePendulum, 4>),
        _ => None,
    }
}

pub const CSV_HEADER: &str =
    "system,states,dostep_ns,rhs_ns,jacobian_ns,jacobian_over_n_rhs,floor_dostep_ns,floor_rhs_ns,dostep_over_floor,rhs_over_floor,peer_rhs_ns,rhs_over_peer\n";

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:.3}"))
}

/// One CSV line (see [`CSV_HEADER`]).
pub fn csv_line(r: &SpeedRow) -> String {
    let jac_ratio = r.jacobian_ns / (r.states as f64 * r.rhs_ns);
    format!(
        "{},{},{:.1},{:.1},{:.1},{:.2},{},{},{},{},{},{}\n",
        r.system,
        r.states,
        r.dostep_ns,
        r.rhs_ns,
        r.jacobian_ns,
        jac_ratio,
        fmt_opt(r.floor.map(|f| f.0)),
        fmt_opt(r.floor.map(|f| f.1)),
        fmt_opt(r.floor.map(|f| r.dostep_ns / f.0)),
        fmt_opt(r.floor.map(|f| r.rhs_ns / f.1)),
        fmt_opt(r.peer_rhs_ns),
        fmt_opt(r.peer_rhs_ns.map(|f| r.rhs_ns / f)),
    )
}

/// The README's table row (markdown).
pub fn markdown_line(r: &SpeedRow) -> String {
    let ratio = |a: f64, b: f64| format!("{:.1}×", a / b);
    let (floor_step, floor_rhs) = match r.floor {
        Some((s, f)) => (
            format!("{s:.0} ({})", ratio(r.dostep_ns, s)),
            format!("{f:.0} ({})", ratio(r.rhs_ns, f)),
        ),
        None => ("—".into(), "—".into()),
    };
    format!(
        "| {} | {} | {:.0} | {} | {:.0} | {} | {:.0} | {:.1} |",
        r.system,
        r.states,
        r.dostep_ns,
        floor_step,
        r.rhs_ns,
        floor_rhs,
        r.jacobian_ns,
        r.jacobian_ns / (r.states as f64 * r.rhs_ns)
    )
}
