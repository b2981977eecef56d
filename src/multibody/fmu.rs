//! A declared mechanism as a model: bodies and joints become a [`Lagrangian`], and so get
//! everything the Lagrangian systems have (the FMU, RATTLE, linearisation, the page).
//!
//! A mechanism is declared once per type ([`Declared`], written by
//! [`mechanism_fmu!`](crate::mechanism_fmu)): its builder, its name, and a static [`Built`]
//! (the [`Model`] and the variables) made on first use. [`Robot<D>`] is the model:
//!
//! - coordinates: one per moving joint, in the [`Model`]'s order (depth first from the root),
//!   named as the joint (rad, or m for a prismatic joint; a continuous joint's is a plain
//!   angle); velocities `J_dot`;
//! - inputs `tau_J`: the joint's generalised force (N.m, or N for a prismatic joint), with
//!   the URDF effort limit as min/max; their start values hold the start configuration
//!   against gravity (inverse dynamics at rest), so the default experiment is an
//!   equilibrium;
//! - T and V the mechanism's kinetic and potential energies, Q = τ − d q̇ (viscous damping);
//!   q̈ by the articulated-body algorithm ([`Model::aba`], or the straight-line code of
//!   [`Declared::generated_aba`] when it has some), which equals the Euler–Lagrange equations
//!   of these T, V and Q (the automatic-differentiation path stays the oracle);
//! - outputs `E = T + V` and, for every end of a branch (a link with no child, fixed
//!   children merged), `LINK_x`, `LINK_y`, `LINK_z` and the quaternion `LINK_q0`…`LINK_q3`
//!   in the base frame;
//! - joint position limits, as the Enumeration parameter `limit_events` says
//!   ([`LimitMode`]): end stops by default ([`stops`](super::stops): an impact located as
//!   an event, restitution the parameter `restitution`; a joint rests on its stop while the
//!   load pushes into it, with its reaction as the output `tau_stop_J`, and leaves when it
//!   pulls); or fmi2Discard at the limit (the signed distance to the nearest limit as the
//!   event indicator); or ignored. A mechanism with loop closures has no end stops;
//! - Coulomb friction ([`friction`](super::friction)): slipping and sticking, a joint
//!   coming to rest located as an event, the force as the output `tau_friction_J`.
//!
//! Not modelled, and said so ([`unmodelled`], the page): velocity limits, and friction in
//! a mechanism with loop closures. A model layer: nothing here knows FMI, packaging or the CLI.

use super::dynamics::{Axis, Model};
use super::mechanism::{Error, JointKind, Mechanism};
use super::{closed, friction, stops};
use crate::model::lagrangian::Lagrangian;
use crate::model::{Scalar, Scene, Var};
use num_dual::{Dual, Dual64};
use std::marker::PhantomData;

/// The one line of a mechanism's modelDescription (unless its declaration gives its own).
pub const DESCRIPTION: &str =
    "A rigid-body mechanism (bodies and joints, e.g. read from a URDF) with a generalised force input per joint";

/// The lines of a mechanism's documentation: [`Declared::EQUATIONS`]' default, and the
/// start of what [`mechanism_fmu!`](crate::mechanism_fmu) writes (its notes follow).
#[doc(hidden)]
#[macro_export]
macro_rules! mechanism_equations {
    ($($note:expr),* $(,)?) => {
        &[
            "q: one coordinate per moving joint, named as the joint (rad, or m for a prismatic joint; a continuous joint's is a plain angle, not wrapped), and its velocity q̇",
            "Bodies in a tree from a fixed base, or from a floating one (--floating-base: the root link free, states base_x … base_z in the world, base_q0 … base_q3 a unit quaternion world ← base, base_vx … base_wz its velocity in the base frame; no ground); fixed joints fold their child into the parent (mass, centre of mass and inertia combined)",
            "T = ½ Σ vᵢᵀ Iᵢ vᵢ (spatial velocities and inertias), V = −Σ mᵢ g·cᵢ over the moving bodies + Σ ½ k (ℓ − ℓ₀)² over the springs, L = T − V",
            "Generalised forces: Q = τ − d q̇ − Σ C (dℓ/dt) ∂ℓ/∂q, with τ the joint's input (a torque, or a force for a prismatic joint), d its viscous damping and C the damper of a spring-damper (of length ℓ)",
            "M(q) q̈ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇, solved by the articulated-body algorithm (Featherstone, Rigid Body Dynamics Algorithms, table 7.1): O(n), no mass matrix formed",
            "E = T + V; for the end of each branch, its position and orientation quaternion (w, x, y, z) in the base frame",
            "Joint position limits are end stops (parameter limit_events = stops, the default): a joint reaching one moving into it is an impact, located as an event: its velocity becomes −e times what it was (e = restitution) and every other joint's changes by the same impulse through M (the velocities change by M⁻¹ e_k Λ); a rebound that would rise less than 1e-9 rad (m) rests instead",
            "A joint resting on its stop (on it, q̇ = 0) stays there while the load pushes into it: q̈_k = 0 by a reaction λ_k (output tau_stop_J) with M q̈ = Q + … + e_k λ_k; where λ would have to pull, the joint leaves. limit_events = discard ends the doStep with fmi2Discard at a limit instead; ignore runs through",
            "Coulomb friction F (URDF <dynamics friction>, output tau_friction_J): −F sign(q̇) while a joint slips; a joint at rest (q̇ = 0 exactly) sticks, held by a force within ±F found with the stops' reactions, and breaks away at ±F where the load needs more; a slipping joint coming to rest (within 1e-9 of q̇ = 0) is an event, located (use DOPRI5 or DOP853: RADAU5's Newton iteration and a fixed step may not step through it)",
            "Not modelled: velocity limits; effort limits are the ranges of the inputs; a mimic joint follows the joint it names (q = r q_joint + o, no coordinate or input of its own: its position and velocity are outputs), q̈ then from the mass matrix reduced to the independent joints",
            $($note,)*
        ]
    };
}

/// [`mechanism_equations!`](crate::mechanism_equations) for a mechanism with loop closures.
#[doc(hidden)]
#[macro_export]
macro_rules! mechanism_loop_equations {
    ($($note:expr),* $(,)?) => {
        &[
            "q: one coordinate per moving joint, named as the joint (rad, or m for a prismatic joint), and its velocity q̇; those the closures determine are dependent (solved from the others at initialisation)",
            "Bodies in a tree from a fixed base, closed into loops by loop closures: a point of body A held on a point of body B along base-frame axes, Φ(q) = (p_A − p_B)·e = 0 by forward kinematics",
            "T = ½ Σ vᵢᵀ Iᵢ vᵢ (spatial velocities and inertias), V = −Σ mᵢ g·cᵢ + Σ ½ k (ℓ − ℓ₀)² over the springs, L = T − V",
            "Generalised forces: Q = τ − d q̇ − Σ C (dℓ/dt) ∂ℓ/∂q, with τ the joint's input (a torque, or a force for a prismatic joint), d its viscous damping and C the damper of a spring-damper (of length ℓ)",
            "λ-method: [M Gᵀ; G 0] [q̈; λ] = [Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇; −q̇ᵀ∇²Φ q̇], G = ∂Φ/∂q, by automatic differentiation; λ is the force of each closure on its body B",
            "After every step: coordinate projection onto Φ = 0 (Newton, M-metric) and of q̇ onto G q̇ = 0; residual_C_x … are Φ(q), force_C_x … the multipliers λ",
            "E = T + V; for the end of each branch, its position and orientation quaternion (w, x, y, z) in the base frame",
            $($note,)*
        ]
    };
}

/// A mechanism declared in Rust: written by [`mechanism_fmu!`](crate::mechanism_fmu) (Rust
/// has no generic statics, so the macro writes the static behind [`Declared::built`]).
pub trait Declared: 'static {
    /// The FMU's modelIdentifier.
    const NAME: &'static str;

    /// The modelIdentifier the FMU has: [`Declared::NAME`], but for the mechanism runtime
    /// ([`runtime`](super::runtime)), whose robot is read at run time.
    fn name() -> &'static str {
        Self::NAME
    }

    /// [`System::token_text`](crate::model::System::token_text): the modelDescription
    /// without its start values, which a mechanism computes with the platform's sin and
    /// cos (the torques that hold the start, a closed loop's dependent joints): their last
    /// bits differ between libms, and every platform's binary must compute the token the
    /// host wrote. The mechanism runtime's is its robot's URDF instead.
    fn token_text(model_description: String) -> String {
        without_start_values(&model_description)
    }

    /// [`Declared::EQUATIONS`], but for the mechanism runtime (its robot's notes).
    fn equations() -> &'static [&'static str] {
        Self::EQUATIONS
    }
    /// One line: what the mechanism is.
    const DESCRIPTION: &'static str = DESCRIPTION;
    /// Equations and notes for the documentation, one per line.
    const EQUATIONS: &'static [&'static str] = crate::mechanism_equations!();
    /// How many loop-closure residuals the mechanism has (one per closure axis): a
    /// [`Lagrangian`]'s constraint count is a constant, so the declaration states it and
    /// [`Built::of`] checks it against the mechanism.
    const CONSTRAINTS: usize = 0;
    /// DefaultExperiment: stop time, relative tolerance, communication step size.
    const DEFAULT_EXPERIMENT: (f64, f64, f64) = (2.0, 1e-8, 1e-2);
    /// Whether the FMU integrates `E_dissipated`, the energy the viscous dampers (the
    /// springs' and the joints') took out since the start: a state after `(q, q̇)`
    /// ([`Lagrangian::integrals`]), so that `E + E_dissipated` is kept where no input
    /// does work. Coulomb friction is not counted: a mechanism with it is refused.
    const DISSIPATED_ENERGY: bool = false;
    /// [`System::DEFAULT_METHOD`](crate::model::System::DEFAULT_METHOD).
    const DEFAULT_METHOD: crate::integrators::Method = crate::integrators::Method::Dopri5;

    /// The bodies and joints (called once per process, by [`Declared::built`]).
    fn mechanism() -> Mechanism;

    /// The model and its variables, made once from [`Declared::mechanism`].
    fn built() -> &'static Built;

    /// The dynamics model (fixed joints merged).
    fn model() -> &'static Model {
        &Self::built().model
    }

    /// `q̈` from `(q, q̇, τ)` as [`Model::aba`] (damping applied inside: `τ − d q̇`) by
    /// straight-line code generated for this mechanism, into `qdd`, returning `true`;
    /// `false` (the default): none, [`Model::aba`] runs instead. With a floating base, the
    /// base's state and acceleration follow the joints'
    /// ([`codegen::floating_dynamics`](super::codegen::floating_dynamics)).
    fn generated_aba<S: Scalar>(_q: &[S], _qd: &[S], _tau: &[S], _qdd: &mut [S]) -> bool {
        false
    }

    /// The [`fingerprint`](super::codegen::fingerprint) of the model
    /// [`Declared::generated_aba`]'s code was generated from (its `FINGERPRINT`): with
    /// `Some`, that code runs only while the declared mechanism's model has this fingerprint
    /// ([`Built::fingerprint`]); a mechanism edited since, or a stale generated file, runs
    /// [`Model::aba`] instead. `None` (the default): not checked.
    const GENERATED_FROM: Option<u64> = None;

    /// A mechanism with loop closures: q̈ and λ as [`closed_accelerations`] computes them,
    /// on the straight-line terms of [`codegen::loops`](super::codegen::loops)
    /// ([`generated_closed_accelerations`], written by
    /// [`generated_closed_terms!`](crate::generated_closed_terms)), returning `true`;
    /// `false` (the default): none, the interpreted path runs ([`closed::Factored`]). Runs
    /// only while [`Declared::CLOSED_GENERATED_FROM`] is the mechanism's
    /// [`Built::closed_fingerprint`].
    fn generated_closed<S: Scalar>(
        _t: f64,
        _x: (&[S], &[S], &[S], &[S]),
        _qdd: &mut [S],
        _lambda: &mut [S],
    ) -> bool {
        false
    }

    /// The projection onto the closures after a step ([`closed::project`]'s) on the same
    /// generated terms ([`generated_closed_projection`]), returning `true`; `false` (the
    /// default): none, [`closed::project`] runs. Runs only where
    /// [`Declared::generated_closed`] does.
    fn generated_closed_project(_q: &mut [f64], _qd: &mut [f64], _p: &[f64]) -> bool {
        false
    }

    /// The [`closed_fingerprint`](super::codegen::loops::closed_fingerprint) the closed
    /// terms were generated from (their `FINGERPRINT`); `None` (the default): none.
    const CLOSED_GENERATED_FROM: Option<u64> = None;

    /// The scenes, given those made for every mechanism ([`Built::scenes`]): those by
    /// default; a declaration may add its own or replace them.
    fn scenes(generated: Vec<Scene>) -> Vec<Scene> {
        generated
    }

    /// [`System::linearization_point`]. Default: none (the start values).
    fn linearization_point() -> Vec<(String, f64)> {
        Vec::new()
    }
}

/// Declares a mechanism type for an FMU: `mechanism_fmu!(pub Ur5, "ur5", mechanism)` with
/// `mechanism` a function (or closure) returning the [`Mechanism`](crate::multibody::Mechanism),
/// optionally followed by `constraints = N` (the number of loop-closure residuals, when the
/// mechanism has closures: checked when it is built), by `notes = ["…", …]`
/// (documentation lines after the standard ones) and by items of the `Declared` impl in
/// braces (`{ fn generated_aba… }`). Then
/// `mbfmu::export_fmu!(mechanism Ur5)` exports its FMU; the model type is
/// `mbfmu::multibody::fmu::Robot<Ur5>`.
#[macro_export]
macro_rules! mechanism_fmu {
    (
        $(#[$attr:meta])* $vis:vis $name:ident, $id:expr, $mechanism:expr
        $(, constraints = $constraints:expr)?
        $(, notes = [$($note:expr),* $(,)?])?
        $(, { $($item:tt)* })? $(,)?
    ) => {
        $(#[$attr])*
        $vis struct $name;

        impl $crate::multibody::fmu::Declared for $name {
            const NAME: &'static str = $id;
            const CONSTRAINTS: usize = 0 $(+ $constraints)?;
            const EQUATIONS: &'static [&'static str] = if 0 $(+ $constraints)? == 0 {
                $crate::mechanism_equations!($($($note),*)?)
            } else {
                $crate::mechanism_loop_equations!($($($note),*)?)
            };
            fn mechanism() -> $crate::multibody::Mechanism {
                ($mechanism)()
            }
            fn built() -> &'static $crate::multibody::fmu::Built {
                static BUILT: ::std::sync::OnceLock<$crate::multibody::fmu::Built> =
                    ::std::sync::OnceLock::new();
                BUILT.get_or_init($crate::multibody::fmu::Built::of::<$name>)
            }
            $($($item)*)?
        }
    };
}

/// The items of a [`Declared`] impl that run a mechanism's generated closed terms (a module
/// written by [`codegen::loops`](super::codegen::loops), named by its path):
/// `crate::generated_closed_terms!(crate::systems::generated::andrews_squeezer)` in the
/// braces of [`mechanism_fmu!`](crate::mechanism_fmu).
#[macro_export]
macro_rules! generated_closed_terms {
    ($($code:ident)::+) => {
        const CLOSED_GENERATED_FROM: Option<u64> = Some($($code)::+::FINGERPRINT);
        fn generated_closed<S: $crate::model::Scalar>(
            t: f64,
            x: (&[S], &[S], &[S], &[S]),
            qdd: &mut [S],
            lambda: &mut [S],
        ) -> bool {
            use $($code)::+ as code;
            $crate::multibody::fmu::generated_closed_accelerations::<Self, S, code::Code, { code::N }, { code::K }>(
                t, x, qdd, lambda,
            );
            true
        }
        fn generated_closed_project(q: &mut [f64], qd: &mut [f64], p: &[f64]) -> bool {
            use $($code)::+ as code;
            $crate::multibody::fmu::generated_closed_projection::<Self, code::Code, { code::N }, { code::K }>(
                q, qd, p,
            );
            true
        }
    };
}

/// A joint position limit on one coordinate (the end stops' data, kept by [`stops`]).
pub use super::stops::PositionLimit;

/// What [`Robot`] needs of a mechanism, made once: the model, the variables (their names
/// leaked, as scenes want `&'static str`: once per mechanism and process), the start
/// configuration and the torques that hold it.
///
/// Vectors per coordinate (`start`, `hold`, `damping`, the variables) are in coordinate
/// order: the mechanism's declared [`order`](Mechanism::order), else the model's (depth
/// first); `order[k]` is the model index of coordinate k.
#[derive(Clone, Debug)]
pub struct Built {
    pub model: Model,
    /// The mechanism as declared (before fixed joints were merged).
    pub mechanism: Mechanism,
    /// Coordinate k is the model's coordinate `order[k]`.
    pub order: Vec<usize>,
    /// Whether `order` is the identity (no permutation on the way to the model).
    pub natural_order: bool,
    /// Whether each coordinate is dependent (determined by the closures).
    pub dependent: Vec<bool>,
    /// The start configuration: 0, or the middle of a joint's limits when 0 is not
    /// strictly inside them, or the declared start; with closures the dependent
    /// coordinates are solved from the others (the declared values are the first guess).
    pub start: Vec<f64>,
    /// The generalised forces that hold `start` at rest against gravity and the springs
    /// (RNEA; with closures, by virtual work with the dependent joints unactuated),
    /// clamped to the effort limits; a declared start torque instead where there is one.
    pub hold: Vec<f64>,
    /// The limits that raise events (revolute and prismatic joints with lower < upper).
    pub limits: Vec<PositionLimit>,
    pub parameters: Vec<Var>,
    pub coordinates: Vec<Var>,
    pub velocities: Vec<Var>,
    pub inputs: Vec<Var>,
    /// The declared outputs: all the mechanism has, or those it names
    /// ([`Mechanism::outputs`]).
    pub outputs: Vec<Var>,
    /// Where each declared output sits among all of them (`None`: all are declared).
    pub kept_outputs: Option<Vec<usize>>,
    /// How many outputs the mechanism has before [`Mechanism::outputs`] picks.
    pub all_outputs: usize,
    pub scenes: Vec<Scene>,
    /// Viscous damping per coordinate.
    pub damping: Vec<f64>,
    /// Coulomb friction per coordinate (a mimic joint's on the joint it follows, `|r| F`;
    /// [`super::friction`]); empty for a mechanism with loop closures, whose friction is
    /// not modelled (its build warning says so).
    pub friction: Vec<f64>,
    /// [`codegen::fingerprint`](super::codegen::fingerprint) of `model`: generated code
    /// runs only on the model it was generated from ([`Declared::GENERATED_FROM`]).
    pub fingerprint: u64,
    /// [`closed_fingerprint`](super::codegen::loops::closed_fingerprint) of `model` and
    /// `order` for a mechanism with loop closures (0 without): the generated closed terms
    /// run only on it ([`Declared::CLOSED_GENERATED_FROM`]).
    pub closed_fingerprint: u64,
    /// The tree's and the closures' sparsity in coordinate order, for [`closed::solve`].
    pub structure: closed::Structure,
}

/// Index of the `limit_events` parameter ([`LimitMode`]'s code).
pub const LIMIT_EVENTS: usize = 0;
/// Index of the `restitution` parameter (a mechanism with end stops only).
pub const RESTITUTION: usize = 1;

/// What a joint reaching a position limit does: the `limit_events` parameter's codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LimitMode {
    /// Limits are ignored: the joint moves through them.
    Ignore = 0,
    /// The doStep ends with fmi2Discard at the limit (the behaviour before end stops).
    Discard = 1,
    /// End stops ([`stops`](super::stops)): impact, rest, release.
    Stops = 2,
}

impl LimitMode {
    /// The items of the `limit_events` enumeration: name and description, code = index.
    pub const ITEMS: &'static [crate::model::Item] = &[
        ("ignore", "Limits are ignored: a joint moves through them"),
        (
            "discard",
            "A joint reaching a limit ends the doStep with fmi2Discard there, naming the joint",
        ),
        (
            "stops",
            "End stops: a joint reaching a limit hits a stop (restitution e), rests on it while the load pushes into it and leaves when it pulls away",
        ),
    ];

    /// The mode of the parameter's value (set values are checked against its range).
    pub fn of(code: f64) -> LimitMode {
        match code as i64 {
            0 => LimitMode::Ignore,
            1 => LimitMode::Discard,
            _ => LimitMode::Stops,
        }
    }
}

/// Names the FMU gives its own variables, which no joint or link may take.
const RESERVED: [&str; 6] = [
    "time",
    "solver",
    "solver_step",
    "solver_max_steps",
    "limit_events",
    "restitution",
];

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// Newton iterations allowed when solving the closures for the start configuration.
const START_ITERATIONS: usize = 50;

/// `G = ∂Φ/∂q` of the closures at `q` (model order), one dual evaluation per column.
pub(crate) fn closure_jacobian(model: &Model, q: &[f64]) -> Vec<Vec<f64>> {
    let (n, m) = (model.nq(), model.closure_residuals());
    let mut g = vec![vec![0.0; n]; m];
    let mut phi = vec![Dual64::from(0.0); m];
    for j in 0..n {
        let mut qd: Vec<Dual64> = q.iter().map(|&v| Dual64::from(v)).collect();
        qd[j].eps = 1.0;
        model.closure_residuals_at(&qd, &mut phi);
        for (row, v) in g.iter_mut().zip(&phi) {
            row[j] = v.eps;
        }
    }
    g
}

/// `∂V_springs/∂q` (model order), one dual evaluation per coordinate.
pub fn spring_gradient<S: Scalar>(model: &Model, q: &[S]) -> Vec<S> {
    let mut out = vec![S::zero(); q.len()];
    if model.springs.is_empty() {
        return out;
    }
    let mut qd: Vec<Dual<S>> = q.iter().map(|&v| Dual::from_re(v)).collect();
    for (j, o) in out.iter_mut().enumerate() {
        qd[j].eps = S::one();
        *o = model.spring_energy(&qd).eps;
        qd[j].eps = S::zero();
    }
    out
}

/// The closures' residuals are at rounding: the criterion of the projection after each
/// step.
fn closed(phi: &[f64], q: &[f64]) -> bool {
    let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
    phi.iter().all(|v| v.abs() <= 4.0 * f64::EPSILON * scale)
}

impl Built {
    /// [`Built::new`] of `D`'s mechanism; panics with the error (a mechanism that does not
    /// validate cannot be a model: `mbfmu build --urdf` validates before it generates),
    /// and when `D` declares another number of closure residuals than its mechanism has.
    pub fn of<D: Declared>() -> Built {
        let built = Built::new(D::mechanism()).unwrap_or_else(|e| panic!("{}: {e}", D::name()));
        assert!(
            !(D::DISSIPATED_ENERGY && friction::any(&built.friction)),
            "{}: E_dissipated counts viscous damping only, and the mechanism has Coulomb friction",
            D::NAME
        );
        let m = built.model.closure_residuals();
        assert_eq!(
            D::CONSTRAINTS,
            m,
            "{}: the mechanism's closures have {m} residuals but its declaration says `constraints = {}`",
            D::NAME,
            D::CONSTRAINTS
        );
        built
    }

    pub fn new(mechanism: Mechanism) -> Result<Built, Error> {
        let model = Model::new(&mechanism)?;
        let n = model.nq();
        let robot = || format!("robot \"{}\"", mechanism.name);
        let joint_of = |i: usize| {
            mechanism
                .joints
                .iter()
                .find(|j| j.name == model.joints[i])
                .expect("a model joint is a mechanism joint")
        };
        let index_of = |name: &String| {
            model
                .joints
                .iter()
                .position(|j| j == name)
                .expect("validated: a moving joint")
        };
        // The coordinates: the independent joints (mimic joints follow them).
        let order: Vec<usize> = if mechanism.order.is_empty() {
            (0..n).filter(|&i| model.follows[i].is_none()).collect()
        } else {
            mechanism.order.iter().map(index_of).collect()
        };
        let natural_order = order.len() == n && order.iter().enumerate().all(|(k, &i)| k == i);
        let mimics: Vec<usize> = (0..n).filter(|&i| model.follows[i].is_some()).collect();
        let floating = model.free_base.is_some();
        if floating && !mechanism.closures.is_empty() {
            return Err(Error::new(
                robot(),
                "has loop closures and a floating base: closures are for mechanisms bolted to the world".into(),
            ));
        }
        if model.has_dampers() && (floating || !mimics.is_empty()) {
            return Err(Error::new(
                robot(),
                "has a spring-damper and a floating base or mimic joints: dampers are for fixed-base mechanisms without mimic joints".into(),
            ));
        }
        if order.is_empty() && !floating {
            return Err(Error::new(
                robot(),
                "has no moving joint: its FMU would have no state, nothing to simulate (every joint is fixed, or there is none)".into(),
            ));
        }
        // Model order from here to the variables.
        let dependent_model: Vec<usize> = mechanism.dependent.iter().map(index_of).collect();
        let mut start = vec![0.0; n];
        let mut limits = Vec::new();
        let mut effort = vec![None; n];
        for (i, s) in start.iter_mut().enumerate() {
            let j = joint_of(i);
            effort[i] = j.limit.effort.filter(|e| *e > 0.0);
            if j.kind == JointKind::Continuous || model.follows[i].is_some() {
                continue;
            }
            if let (Some(lower), Some(upper)) = (j.limit.lower, j.limit.upper) {
                if lower < upper {
                    if !(lower < 0.0 && 0.0 < upper) {
                        *s = 0.5 * (lower + upper);
                    }
                    limits.push(PositionLimit {
                        coordinate: order.iter().position(|&k| k == i).expect("a permutation"),
                        lower,
                        upper,
                    });
                }
            }
        }
        for (name, v) in &mechanism.start {
            start[index_of(name)] = *v;
        }
        for &i in &mimics {
            let (d, r) = model.driver(i);
            start[i] = r * start[d] + model.follows[i].map_or(0.0, |f| f.offset);
        }
        if floating && !base_moves(&model, &start) {
            return Err(Error::new(
                robot(),
                "cannot float: its bodies together have no mass or no rotational inertia (the base's 6 × 6 articulated inertia is singular)".into(),
            ));
        }
        if let Some(i) = model.singular_joint(&start) {
            return Err(Error::joint(
                &model.joints[i],
                "moves no inertia about its axis at the start configuration: the mass matrix is singular there (a point mass on the axis, or links that carry nothing)".into(),
            ));
        }
        let m = model.closure_residuals();
        // G's columns of the dependent joints (the closures' Jacobian in them).
        let dependent_columns = |g: &[Vec<f64>]| -> Vec<Vec<f64>> {
            g.iter()
                .map(|row| dependent_model.iter().map(|&j| row[j]).collect())
                .collect()
        };
        if m > 0 {
            // Newton on the closures for the dependent coordinates, the others as set.
            let mut phi = vec![0.0; m];
            let mut converged = false;
            for _ in 0..START_ITERATIONS {
                model.closure_residuals_at(&start, &mut phi);
                if closed(&phi, &start) {
                    converged = true;
                    break;
                }
                let a = dependent_columns(&closure_jacobian(&model, &start));
                let Some(step) =
                    crate::model::lagrangian::solve_full_rank(a, phi.iter().map(|v| -v).collect())
                else {
                    break;
                };
                for (&j, d) in dependent_model.iter().zip(&step) {
                    start[j] += d;
                }
            }
            if !converged {
                // The largest residual left, by closure and axis.
                let named: Vec<String> = mechanism
                    .closures
                    .iter()
                    .flat_map(|c| c.axes.chars().map(move |a| format!("{} {a}", c.name)))
                    .collect();
                let (k, worst) = phi.iter().enumerate().fold((0, 0.0f64), |b, (k, v)| {
                    if v.abs() > b.1 {
                        (k, v.abs())
                    } else {
                        b
                    }
                });
                return Err(Error::new(
                    robot(),
                    format!(
                        "its closures cannot be met from the start positions by moving the dependent joints {} (residual {worst:.3e} m left in closure {}: no solution near them, inconsistent geometry, or the closures do not determine those joints): give start positions near a closed configuration (`.start(…)`)",
                        mechanism.dependent.join(", "),
                        named.get(k).map_or("?", String::as_str)
                    ),
                ));
            }
        }
        // The torques that hold the start at rest: τ = g(q) (gravity by RNEA, springs by
        // their gradient); with closures, τ − g = Gᵀλ with τ = 0 on the dependent joints
        // (virtual work): G_depᵀ λ = −g_dep, τ = g + Gᵀλ.
        // A floating robot at rest with no joint torques falls as one rigid body (uniform
        // gravity accelerates every body alike): nothing to hold.
        let gravity_held = if floating { 0.0 } else { 1.0 };
        let mut hold: Vec<f64> = model
            .rnea(&start, &vec![0.0; n], &vec![0.0; n])
            .iter()
            .map(|g| g * gravity_held)
            .collect::<Vec<f64>>()
            .iter()
            .zip(spring_gradient(&model, &start))
            .map(|(g, s)| g + s)
            .collect();
        // G at the closed start configuration (the holding torques and start velocities).
        let g_start = if m > 0 {
            closure_jacobian(&model, &start)
        } else {
            Vec::new()
        };
        if m > 0 {
            let g = &g_start;
            let a: Vec<Vec<f64>> = dependent_model
                .iter()
                .map(|&j| g.iter().map(|row| row[j]).collect())
                .collect();
            let lambda = crate::model::lagrangian::solve_full_rank(
                a,
                dependent_model.iter().map(|&j| -hold[j]).collect(),
            );
            let Some(lambda) = lambda else {
                return Err(Error::new(
                    robot(),
                    format!(
                        "its closures do not determine the dependent joints {} at the start configuration (their Jacobian is singular there): declare others dependent, or start elsewhere",
                        mechanism.dependent.join(", ")
                    ),
                ));
            };
            for (i, h) in hold.iter_mut().enumerate() {
                *h += g
                    .iter()
                    .zip(&lambda)
                    .map(|(row, l)| row[i] * l)
                    .sum::<f64>();
            }
            for &j in &dependent_model {
                hold[j] = 0.0; // exactly, not by rounding
            }
        }
        // A mimic joint's holding force acts on the joint it follows (virtual work).
        for &i in &mimics {
            let (d, r) = model.driver(i);
            hold[d] += r * hold[i];
            hold[i] = 0.0;
        }
        for (h, e) in hold.iter_mut().zip(&effort) {
            if let Some(e) = e {
                *h = h.clamp(-e, *e);
            }
        }
        for (name, v) in &mechanism.torques {
            hold[index_of(name)] = *v;
        }
        // The start velocities: as declared (else 0), a mimic joint's its driver's times
        // the multiplier, the dependent ones solved from the others (G_dep q̇_dep =
        // −G_ind q̇_ind) so that the modelDescription's start values are consistent.
        let mut speed = vec![0.0; n];
        for (name, v) in &mechanism.start_velocity {
            speed[index_of(name)] = *v;
        }
        for &i in &mimics {
            let (d, r) = model.driver(i);
            speed[i] = r * speed[d];
        }
        if m > 0 && speed.iter().any(|v| *v != 0.0) {
            for &j in &dependent_model {
                speed[j] = 0.0;
            }
            let rhs: Vec<f64> = g_start
                .iter()
                .map(|row| -row.iter().zip(&speed).map(|(g, v)| g * v).sum::<f64>())
                .collect();
            // (Determined: the same columns of G had full rank for the holding torques.)
            let rhs = crate::model::lagrangian::solve_full_rank(dependent_columns(&g_start), rhs)
                .unwrap_or_else(|| vec![f64::NAN; dependent_model.len()]);
            for (&j, v) in dependent_model.iter().zip(&rhs) {
                speed[j] = *v + 0.0; // (no −0 in the modelDescription)
            }
        }
        // Coordinate order from here.
        let permute = |v: &[f64]| -> Vec<f64> { order.iter().map(|&i| v[i]).collect() };
        // A mimic joint's damping acts on the joint it follows: −r² d q̇ (Q = τ − d q̇ of the
        // Lagrangian, which the articulated-body route equals).
        let mut damping_model = model.damping.clone();
        for &i in &mimics {
            let (d, r) = model.driver(i);
            damping_model[d] += r * r * model.damping[i];
            damping_model[i] = 0.0;
        }
        // A mimic joint's friction likewise: the force F against its motion is |r| F
        // against the followed joint's.
        let mut friction_model: Vec<f64> = (0..n).map(|i| joint_of(i).friction).collect();
        for &i in &mimics {
            let (d, r) = model.driver(i);
            friction_model[d] += r.abs() * friction_model[i];
            friction_model[i] = 0.0;
        }
        let model_start = start.clone();
        let (start, hold, damping) = (permute(&start), permute(&hold), permute(&damping_model));
        let speed = permute(&speed);
        let friction = if mechanism.closures.is_empty() {
            permute(&friction_model)
        } else {
            Vec::new()
        };
        let effort: Vec<Option<f64>> = order.iter().map(|&i| effort[i]).collect();
        let dependent: Vec<bool> = order.iter().map(|i| dependent_model.contains(i)).collect();
        let unit = |i: usize| match model.kinds[i] {
            Axis::Rotation => ("rad", "rad/s", "N.m", "torque"),
            Axis::Translation => ("m", "m/s", "N", "force"),
        };
        let mut coordinates = Vec::new();
        let mut velocities = Vec::new();
        let mut inputs = Vec::new();
        for (k, &i) in order.iter().enumerate() {
            let j = joint_of(i);
            let (u, v, f, what) = unit(i);
            let name = &j.name;
            let kind = j.kind.name();
            let mut q = Var::new("", Some(u), start[k], "").nominal(1.0);
            q.name = name.clone().into();
            let solved = if dependent[k] {
                " (dependent: solved from the others by the loop closures)"
            } else {
                ""
            };
            q.description = format!(
                "Position of {kind} joint {name} (link {} in {}){solved}",
                j.child, j.parent
            )
            .into();
            let mut qd = Var::new("", Some(v), speed[k], "").nominal(1.0);
            qd.name = format!("{name}_dot").into();
            qd.description = format!("Velocity of joint {name}{solved}").into();
            if dependent[k] {
                q = q.dependent();
                qd = qd.dependent();
            }
            let mut tau = Var::new("", Some(f), hold[k], "");
            tau.name = format!("tau_{name}").into();
            let bound = match effort[k] {
                Some(e) => {
                    tau = tau.min(-e).max(e);
                    format!(", within the URDF effort limit ±{e:?} {f}")
                }
                None => ", no effort limit".to_string(),
            };
            let started = if mechanism.torques.iter().any(|(t, _)| t == name) {
                "its start value is the declared drive"
            } else if floating {
                "its start value 0: released, the floating robot falls as one rigid body"
            } else if m > 0 {
                "its start value holds the start configuration against gravity and springs (by virtual work, the dependent joints unactuated)"
            } else {
                "its start value holds the start configuration against gravity"
            };
            tau.description =
                format!("Generalised {what} at joint {name} ({f}{bound}); {started}").into();
            coordinates.push(q);
            velocities.push(qd);
            inputs.push(tau);
        }
        if floating {
            let base = &model.free_base.as_ref().expect("floating").body;
            base_variables(base, &mut coordinates, &mut velocities);
        }
        let frame = if floating { "world" } else { "base" };
        let mut outputs = vec![Var::new(
            "E",
            Some("J"),
            0.0,
            "Mechanical energy T + V (V = 0 with every moving centre of mass at the base origin and every spring at its rest length)",
        )];
        for tip in &model.tips {
            let link = &tip.name;
            for c in ["x", "y", "z"] {
                let mut v = Var::new("", Some("m"), 0.0, "");
                v.name = format!("{link}_{c}").into();
                v.description = format!(
                    "Position of link {link} (an end of a branch), {c} in the {frame} frame"
                )
                .into();
                outputs.push(v);
            }
            for k in 0..4 {
                let mut v = Var::new("", None, 0.0, "");
                v.name = format!("{link}_q{k}").into();
                let part = ["w", "x", "y", "z"][k];
                v.description = format!(
                    "Orientation of link {link} in the {frame} frame: unit quaternion, {part} part"
                )
                .into();
                outputs.push(v);
            }
        }
        let tip_outputs = outputs.len();
        for c in &mechanism.closures {
            for axis in c.axes.chars() {
                let mut v = Var::new("", Some("m"), 0.0, "");
                v.name = format!("residual_{}_{axis}", c.name).into();
                v.description = format!(
                    "Residual of closure {}: {axis} of its point on {} less that of its point on {} (0 when closed)",
                    c.name, c.body_a, c.body_b
                )
                .into();
                outputs.push(v);
            }
        }
        for c in &mechanism.closures {
            for axis in c.axes.chars() {
                let mut v = Var::new("", Some("N"), 0.0, "");
                v.name = format!("force_{}_{axis}", c.name).into();
                v.description = format!(
                    "Force of closure {} on {} at its point, {axis} in the base frame (its multiplier λ; {} feels the opposite)",
                    c.name, c.body_b, c.body_a
                )
                .into();
                outputs.push(v);
            }
        }
        let closure_outputs = outputs.len();
        for &i in &mimics {
            let j = joint_of(i);
            let (u, v, ..) = unit(i);
            let f = model.follows[i].expect("a mimic");
            let of = &model.joints[f.joint];
            let mut q = Var::new("", Some(u), model_start[i], "");
            q.name = j.name.clone().into();
            q.description = format!(
                "Position of {} joint {} (link {} in {}), a mimic joint: {:?} × {of} + {:?} (no coordinate of its own)",
                j.kind.name(), j.name, j.child, j.parent, f.multiplier, f.offset
            )
            .into();
            let mut qd = Var::new("", Some(v), 0.0, "");
            qd.name = format!("{}_dot", j.name).into();
            qd.description = format!(
                "Velocity of mimic joint {}: {:?} × {of}_dot",
                j.name, f.multiplier
            )
            .into();
            outputs.push(q);
            outputs.push(qd);
        }
        let mimic_outputs = outputs.len();
        if m == 0 {
            for l in &limits {
                let i = order[l.coordinate];
                let (_, _, f, what) = unit(i);
                let name = &joint_of(i).name;
                let mut v = Var::new("", Some(f), 0.0, "");
                v.name = format!("tau_stop_{name}").into();
                v.description = format!(
                    "Generalised {what} of joint {name}'s end stops on it ({f}): not 0 only while it rests on a stop (limit_events = stops)"
                )
                .into();
                outputs.push(v);
            }
        }
        let stop_outputs = outputs.len();
        for (k, _) in friction.iter().enumerate().filter(|(_, &f)| f > 0.0) {
            let i = order[k];
            let (_, _, f, what) = unit(i);
            let name = &joint_of(i).name;
            let mut v = Var::new("", Some(f), 0.0, "");
            v.name = format!("tau_friction_{name}").into();
            v.description = format!(
                "Generalised {what} of Coulomb friction on joint {name} ({f}, |·| ≤ {:?}): −F sign(q̇) while it slips, the force that holds it while it sticks (q̇ = 0)",
                friction[k]
            )
            .into();
            outputs.push(v);
        }
        // Every name once, none of the FMU's own.
        let mut seen: std::collections::HashMap<String, String> = RESERVED
            .iter()
            .map(|r| (r.to_string(), "a variable of the FMU itself".to_string()))
            .collect();
        seen.insert("E".into(), "the energy output".into());
        let joints = order.len();
        for v in coordinates
            .iter()
            .skip(joints)
            .chain(velocities.iter().skip(joints))
        {
            seen.insert(v.name.to_string(), "a state of the floating base".into());
        }
        for (i, vars) in [&coordinates, &velocities, &inputs].iter().enumerate() {
            for (k, v) in vars.iter().enumerate().take(joints) {
                let joint = &joint_of(order[k]).name;
                let what = ["position", "velocity", "input"][i];
                if let Some(other) = seen.insert(
                    v.name.to_string(),
                    format!("the {what} of joint \"{joint}\""),
                ) {
                    return Err(Error::joint(
                        joint,
                        format!(
                            "its {what} variable \"{}\" would also be {other}: rename the joint",
                            v.name
                        ),
                    ));
                }
            }
        }
        for (k, v) in outputs.iter().enumerate().take(tip_outputs).skip(1) {
            let link = &model.tips[(k - 1) / 7].name;
            if let Some(other) =
                seen.insert(v.name.to_string(), format!("an output of link \"{link}\""))
            {
                return Err(Error::link(
                    link,
                    format!(
                        "its output \"{}\" would also be {other}: rename the link",
                        v.name
                    ),
                ));
            }
        }
        for (k, v) in outputs
            .iter()
            .enumerate()
            .take(mimic_outputs)
            .skip(closure_outputs)
        {
            let joint = &model.joints[mimics[(k - closure_outputs) / 2]];
            let what = format!("an output of mimic joint \"{joint}\"");
            if let Some(other) = seen.insert(v.name.to_string(), what) {
                return Err(Error::joint(
                    joint,
                    format!(
                        "its output \"{}\" would also be {other}: rename the joint",
                        v.name
                    ),
                ));
            }
        }
        for (k, v) in outputs.iter().enumerate().skip(mimic_outputs) {
            let what = if k < stop_outputs {
                "an end-stop output"
            } else {
                "a friction output"
            };
            if let Some(other) = seen.insert(v.name.to_string(), what.into()) {
                return Err(Error::new(
                    robot(),
                    format!(
                        "the {what} \"{}\" would also be {other}: rename the joint",
                        v.name
                    ),
                ));
            }
        }
        for v in outputs.iter().take(closure_outputs).skip(tip_outputs) {
            if let Some(other) = seen.insert(v.name.to_string(), "a closure output".into()) {
                return Err(Error::new(
                    robot(),
                    format!(
                        "the closure output \"{}\" would also be {other}: rename the closure",
                        v.name
                    ),
                ));
            }
        }
        let all_outputs = outputs.len();
        let kept_outputs = if mechanism.outputs.is_empty() {
            None
        } else {
            let mut kept = Vec::with_capacity(mechanism.outputs.len());
            for name in &mechanism.outputs {
                match outputs.iter().position(|v| v.name == name.as_str()) {
                    Some(k) if !kept.contains(&k) => kept.push(k),
                    Some(_) => {
                        return Err(Error::new(
                            robot(),
                            format!("the output \"{name}\" is named twice"),
                        ))
                    }
                    None => {
                        let names: Vec<&str> = outputs.iter().map(|v| v.name.as_ref()).collect();
                        return Err(Error::new(
                            robot(),
                            format!(
                                "no output is named \"{name}\" (there are {})",
                                names.join(", ")
                            ),
                        ));
                    }
                }
            }
            outputs = kept.iter().map(|&k| outputs[k].clone()).collect();
            Some(kept)
        };
        let parameters = limit_parameters(m > 0, !limits.is_empty());
        let scenes = scenes(
            &start,
            &hold,
            &effort,
            &dependent,
            &coordinates[..joints],
            &velocities[..joints],
            &inputs,
            floating,
        );
        Ok(Built {
            damping,
            friction,
            fingerprint: super::codegen::fingerprint(&model),
            closed_fingerprint: if model.closures.is_empty() {
                0
            } else {
                super::codegen::loops::closed_fingerprint(&model, &order)
            },
            structure: closed::Structure::of(&model, &order),
            model,
            mechanism,
            order,
            natural_order,
            dependent,
            start,
            hold,
            limits,
            parameters,
            coordinates,
            velocities,
            inputs,
            outputs,
            kept_outputs,
            all_outputs,
            scenes,
        })
    }

    /// Positions per coordinate as every model joint's (a mimic joint's from the joint it
    /// follows): borrowed when the coordinates are the model's joints in its order.
    pub fn positions_to_model<'a, S: Scalar>(&self, q: &'a [S]) -> std::borrow::Cow<'a, [S]> {
        self.to_model(q, |f, v| v * f.multiplier + f.offset)
    }

    /// Velocities per coordinate as every model joint's (a mimic's: multiplier × q̇).
    pub fn velocities_to_model<'a, S: Scalar>(&self, qd: &'a [S]) -> std::borrow::Cow<'a, [S]> {
        self.to_model(qd, |f, v| v * f.multiplier)
    }

    /// Joint forces per coordinate as every model joint's (none on a mimic joint).
    pub fn forces_to_model<'a, S: Scalar>(&self, u: &'a [S]) -> std::borrow::Cow<'a, [S]> {
        self.to_model(u, |_, _| S::zero())
    }

    fn to_model<'a, S: Scalar>(
        &self,
        v: &'a [S],
        mimic: impl Fn(&super::dynamics::Follows, S) -> S,
    ) -> std::borrow::Cow<'a, [S]> {
        if self.natural_order {
            return std::borrow::Cow::Borrowed(v);
        }
        let mut out = vec![S::zero(); self.model.nq()];
        for (k, &i) in self.order.iter().enumerate() {
            out[i] = v[k];
        }
        for (i, f) in self.model.follows.iter().enumerate() {
            if let Some(f) = f {
                out[i] = mimic(f, out[f.joint]);
            }
        }
        std::borrow::Cow::Owned(out)
    }

    /// The signed distance to the nearest position limit (in the coordinate's unit):
    /// positive inside every limit; `None` without limits.
    pub fn limit_distance(&self, q: &[f64]) -> Option<f64> {
        self.limits
            .iter()
            .map(|l| l.distance(q[l.coordinate]))
            .min_by(f64::total_cmp)
    }

    /// The joint at its nearest limit, and which one, as a log line.
    pub fn limit_reached(&self, t: f64, q: &[f64]) -> String {
        let nearest = self.limits.iter().min_by(|a, b| {
            let d = |l: &PositionLimit| l.distance(q[l.coordinate]);
            d(a).total_cmp(&d(b))
        });
        let Some(l) = nearest else {
            return format!("t = {t}: no joint has a position limit");
        };
        let i = l.coordinate;
        let (side, value) = if q[i] - l.lower < l.upper - q[i] {
            ("lower", l.lower)
        } else {
            ("upper", l.upper)
        };
        let unit = self.coordinates[i].unit.as_deref().unwrap_or("");
        format!(
            "joint {} reached its {side} limit {value:?} {unit} at t = {t} s (limit_events = 1, discard: set it to 2 for end stops, 0 to run through the limits)",
            self.coordinates[i].name
        )
    }
}

/// The floating base's states, after the joints': its origin `base_x base_y base_z` (m,
/// world frame), its orientation `base_q0 … base_q3` (unit quaternion world ← base, scalar
/// first), then its velocity `base_vx base_vy base_vz` and `base_wx base_wy base_wz`
/// (linear and angular, in the base frame: Pinocchio's free-flyer velocity).
fn base_variables(body: &str, coordinates: &mut Vec<Var>, velocities: &mut Vec<Var>) {
    for c in ["x", "y", "z"] {
        let mut v = Var::new("", Some("m"), 0.0, "").nominal(1.0);
        v.name = format!("base_{c}").into();
        v.description =
            format!("Position of the floating base (link {body}'s origin), {c} in the world frame")
                .into();
        coordinates.push(v);
    }
    for (k, part) in ["w", "x", "y", "z"].iter().enumerate() {
        let mut v = Var::new("", None, if k == 0 { 1.0 } else { 0.0 }, "").nominal(1.0);
        v.name = format!("base_q{k}").into();
        v.description = format!(
            "Orientation of the floating base (world ← link {body}): unit quaternion, {part} part (normalised after every step; a set value of any non-zero norm means the same rotation)"
        )
        .into();
        coordinates.push(v);
    }
    for (c, what, unit) in [
        ("vx", "Linear", "m/s"),
        ("vy", "Linear", "m/s"),
        ("vz", "Linear", "m/s"),
        ("wx", "Angular", "rad/s"),
        ("wy", "Angular", "rad/s"),
        ("wz", "Angular", "rad/s"),
    ] {
        let mut v = Var::new("", Some(unit), 0.0, "").nominal(1.0);
        v.name = format!("base_{c}").into();
        v.description = format!(
            "{what} velocity of the floating base (link {body}'s origin), {} in the base frame",
            &c[1..]
        )
        .into();
        velocities.push(v);
    }
}

/// Whether a floating base can move at `q`: the forward dynamics from rest gives finite
/// accelerations (its articulated inertia, the whole robot's, is positive definite).
fn base_moves(model: &Model, q: &[f64]) -> bool {
    let n = model.nq();
    let mut qdd = vec![0.0; n];
    let identity = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let a0 = model.aba_free_in(
        &mut super::dynamics::Data::new(model),
        &identity,
        &super::spatial::Motion::zero(),
        q,
        &vec![0.0; n],
        &vec![0.0; n],
        &mut qdd,
    );
    a0.ang
        .iter()
        .chain(&a0.lin)
        .chain(&qdd)
        .all(|v| v.is_finite())
}

/// The parameters of a mechanism: `limit_events` (end stops by default; a mechanism with
/// loop closures has none, and discards at a limit) and, where there are end stops (a tree
/// with limits), `restitution`.
fn limit_parameters(closures: bool, limited: bool) -> Vec<Var> {
    // A mechanism with closures has no end stops: its last item, and default, is discard.
    let default = if closures {
        LimitMode::Discard
    } else {
        LimitMode::Stops
    };
    let mode = Var::new(
        "limit_events",
        None,
        default as i32 as f64,
        "What a joint reaching a position limit does",
    )
    .enumeration(&LimitMode::ITEMS[..=default as usize]);
    let restitution = Var::new(
        "restitution",
        None,
        0.0,
        "Coefficient of restitution e of the end stops: a joint hitting one rebounds with −e times its velocity (0: it stays on the stop; 1: elastic)",
    )
    .min(0.0)
    .max(1.0);
    if closures || !limited {
        return vec![mode];
    }
    vec![mode, restitution]
}

/// The scenes: released at rest from the start configuration with no torque (it falls);
/// held by the gravity torques, the first joint's stepped by a tenth of its effort limit
/// (1 N.m or 1 N without one).
#[allow(clippy::too_many_arguments)]
fn scenes(
    start: &[f64],
    hold: &[f64],
    effort: &[Option<f64>],
    dependent: &[bool],
    coordinates: &[Var],
    velocities: &[Var],
    inputs: &[Var],
    floating: bool,
) -> Vec<Scene> {
    let n = coordinates.len();
    if n == 0 {
        return Vec::new();
    }
    // The independent states only: initialisation solves the dependent ones.
    let at_rest = |mut s: Scene| {
        for i in (0..n).filter(|&i| !dependent[i]) {
            s = s
                .set(leak(coordinates[i].name.to_string()), start[i])
                .set(leak(velocities[i].name.to_string()), 0.0);
        }
        s
    };
    let mut released = at_rest(Scene::new(
        "released",
        if floating {
            "Released at rest from the start configuration with no joint torques: the floating robot falls freely as one rigid body (there is no ground)"
        } else {
            "Released at rest from the start configuration with no joint torques: it falls under gravity (a joint reaching a position limit meets its end stop)"
        },
        2.0,
    ));
    for input in inputs {
        released = released.set(leak(input.name.to_string()), 0.0);
    }
    let first = (0..n).find(|&i| !dependent[i]).unwrap_or(0);
    let step = effort[first].map_or(1.0, |e| 0.1 * e);
    let unit = inputs[first].unit.as_deref().unwrap_or("");
    let mut stepped = at_rest(Scene::new(
        "step",
        leak(if floating {
            format!(
                "Released falling at rest, joint {}'s input stepped by {step:?} {unit} at t = 0: the limbs move against the floating base, its momentum about the centre of mass kept",
                coordinates[first].name
            )
        } else {
            format!(
                "Held at rest by the gravity torques, joint {}'s input stepped by {step:?} {unit} at t = 0",
                coordinates[first].name
            )
        }),
        2.0,
    ));
    for (i, input) in inputs.iter().enumerate() {
        let mut value = hold[i] + if i == first { step } else { 0.0 };
        if let Some(e) = effort[i] {
            value = value.clamp(-e, e);
        }
        stepped = stepped.set(leak(input.name.to_string()), value);
    }
    vec![released, stepped]
}

/// What the mechanism's URDF data say and the model does not hold, one line each naming
/// the joints (the build warnings): Coulomb friction, velocity limits, limits that raise
/// no event (lower ≥ upper, or on a continuous joint).
///
/// Then the inertias accepted with a warning ([`Mechanism::inertia_warnings`]).
pub fn unmodelled(mechanism: &Mechanism) -> Vec<String> {
    unmodelled_by_joint(mechanism)
        .into_iter()
        .map(|(what, joints, source)| format!("{what}: joints {} ({source})", joints.join(", ")))
        .chain(mechanism.inertia_warnings())
        .collect()
}

/// [`unmodelled`] counted, for the documentation page (whose equation lines typeset
/// names with `_` as subscripts): "Coulomb friction of 2 joints is not modelled".
pub fn unmodelled_notes(mechanism: &Mechanism) -> Vec<String> {
    unmodelled_by_joint(mechanism)
        .into_iter()
        .map(|(what, joints, _)| {
            let n = joints.len();
            let what = what.replacen(
                " is ",
                &format!(" of {n} joint{} is ", if n == 1 { "" } else { "s" }),
                1,
            );
            let what = what.replacen(
                " are ",
                &format!(" of {n} joint{} are ", if n == 1 { "" } else { "s" }),
                1,
            );
            let mut c = what.chars();
            let first = c
                .next()
                .map(|f| f.to_uppercase().collect::<String>())
                .unwrap_or_default();
            format!("{first}{} (the build warning names them)", c.as_str())
        })
        .collect()
}

/// (what, the joints with their values, the URDF element it comes from).
fn unmodelled_by_joint(mechanism: &Mechanism) -> Vec<(&'static str, Vec<String>, &'static str)> {
    let list = |pick: &dyn Fn(&super::Joint) -> Option<f64>| {
        mechanism
            .joints
            .iter()
            .filter(|j| j.moves())
            .filter_map(|j| pick(j).map(|v| format!("\"{}\" ({v:?})", j.name)))
            .collect::<Vec<_>>()
    };
    let mut lines = Vec::new();
    let friction = list(&|j| (j.friction > 0.0).then_some(j.friction));
    if !friction.is_empty() && !mechanism.closures.is_empty() {
        lines.push((
            "Coulomb friction is not modelled in a mechanism with loop closures",
            friction,
            "URDF <dynamics friction>",
        ));
    }
    let velocity = list(&|j| j.limit.velocity.filter(|v| *v > 0.0));
    if !velocity.is_empty() {
        lines.push((
            "velocity limits are not enforced",
            velocity,
            "URDF <limit velocity>",
        ));
    }
    let no_event: Vec<String> = mechanism
        .joints
        .iter()
        .filter(|j| j.moves())
        .filter(|j| match (j.limit.lower, j.limit.upper) {
            (Some(lo), Some(hi)) => {
                j.kind == JointKind::Continuous || lo >= hi || j.mimic.is_some()
            }
            _ => false,
        })
        .map(|j| format!("\"{}\"", j.name))
        .collect();
    let fixed_mimic: Vec<String> = mechanism
        .joints
        .iter()
        .filter(|j| !j.moves() && j.mimic.is_some())
        .map(|j| format!("\"{}\"", j.name))
        .collect();
    if !fixed_mimic.is_empty() {
        lines.push((
            "a mimic element is ignored on a fixed joint, where it means nothing",
            fixed_mimic,
            "URDF <mimic> on a fixed joint",
        ));
    }
    if !no_event.is_empty() {
        lines.push((
            "position limits that raise no event (continuous joint, lower ≥ upper, or a mimic joint, which moves with the joint it follows) are ignored",
            no_event,
            "URDF <limit lower upper>",
        ));
    }
    lines
}

/// Whether `D`'s [`Declared::generated_aba`] may run: it was generated from the model `D`
/// declares (or does not say from which, [`Declared::GENERATED_FROM`] `None`).
pub fn generated_is_current<D: Declared>() -> bool {
    !matches!(D::GENERATED_FROM, Some(f) if f != D::built().fingerprint)
}

/// [`Model::aba_in`] with a workspace kept per thread and scalar type (f64, and each dual
/// number the Jacobians use): after the first call on a thread, q̈ allocates nothing.
fn aba_reusing<S: Scalar + 'static>(model: &Model, q: &[S], qd: &[S], tau: &[S], qdd: &mut [S]) {
    with_workspace(model, |data| model.aba_in(data, q, qd, tau, qdd));
}

/// `f`, every forward dynamics in it at the q of the call just made (the held solve's
/// inverse-mass columns): the workspace's factored mass matrix is reused, not formed and
/// factored again per column ([`Data::mass_is_current`](super::dynamics::Data)), and
/// marked stale again after `f`, however `f` ends. Only the mimic joints' reduced path
/// factors a mass matrix: without mimics `f` runs as it is (no workspace lookups on the
/// per-evaluation path).
fn at_the_same_q<S: Scalar + 'static, R>(model: &Model, f: impl FnOnce() -> R) -> R {
    if !model.has_mimics() {
        return f();
    }
    struct Stale<'a, S: Scalar + 'static>(&'a Model, PhantomData<S>);
    impl<S: Scalar + 'static> Drop for Stale<'_, S> {
        fn drop(&mut self) {
            with_workspace::<S, _>(self.0, |d| d.mass_is_current = false);
        }
    }
    with_workspace::<S, _>(model, |d| d.mass_is_current = true);
    let _stale = Stale::<S>(model, PhantomData);
    f()
}

/// `f` with this thread's workspace for `model` and the scalar type `S`.
fn with_workspace<S: Scalar + 'static, R>(
    model: &Model,
    f: impl FnOnce(&mut super::dynamics::Data<S>) -> R,
) -> R {
    use super::dynamics::Data;
    use std::any::Any;
    use std::cell::RefCell;
    thread_local! {
        static WORKSPACES: RefCell<Vec<Box<dyn Any>>> = const { RefCell::new(Vec::new()) };
    }
    WORKSPACES.with(|w| {
        let mut w = w.borrow_mut();
        let at = match w.iter().position(|d| d.is::<Data<S>>()) {
            Some(at) => at,
            None => {
                w.push(Box::new(Data::<S>::new(model)));
                w.len() - 1
            }
        };
        let data = w[at].downcast_mut::<Data<S>>().expect("found by its type");
        f(data)
    })
}

/// `xml` with every ` start="…"` attribute left out.
fn without_start_values(xml: &str) -> String {
    let mut out = String::with_capacity(xml.len());
    let mut rest = xml;
    while let Some(at) = rest.find(" start=\"") {
        out.push_str(&rest[..at]);
        let value = &rest[at + " start=\"".len()..];
        rest = match value.find('"') {
            Some(end) => &value[end + 1..],
            None => "",
        };
    }
    out.push_str(rest);
    out
}

/// q̈ of a tree mechanism without end stops: by the articulated-body algorithm
/// ([`Declared::generated_aba`]'s straight-line code where current), springs as joint
/// forces `τ − ∂V_springs/∂q`.
fn free_accelerations<D: Declared, S: Scalar>(q: &[S], qd: &[S], u: &[S], qdd: &mut [S]) {
    let b = D::built();
    if b.model.free_base.is_some() {
        floating_accelerations::<D, S>(q, qd, u, qdd);
        return;
    }
    let generated = generated_is_current::<D>();
    if b.natural_order && b.model.springs.is_empty() {
        if !(generated && D::generated_aba(q, qd, u, qdd)) {
            aba_reusing(&b.model, q, qd, u, qdd);
        }
        return;
    }
    let (q, qd, u) = (
        b.positions_to_model(q),
        b.velocities_to_model(qd),
        b.forces_to_model(u),
    );
    let mut dampers = vec![S::zero(); q.len()];
    b.model.damper_forces(&q, &qd, &mut dampers);
    let tau: Vec<S> = u
        .iter()
        .zip(spring_gradient(&b.model, &q))
        .zip(&dampers)
        .map(|((&t, g), &d)| t - g - d)
        .collect();
    let mut a = vec![S::zero(); q.len()];
    if !(generated && D::generated_aba(&q, &qd, &tau, &mut a)) {
        aba_reusing(&b.model, &q, &qd, &tau, &mut a);
    }
    for (k, &i) in b.order.iter().enumerate() {
        qdd[k] = a[i];
    }
}

/// q̈ of a tree mechanism: [`free_accelerations`] with the slipping joints' friction
/// ([`friction::slip`]), then the joints held by their end stops (`limit_events` = stops)
/// or stuck by friction ([`stops::hold`]); the stops' reactions and every coordinate's
/// friction force into `out` when given. `u` the inputs, `p` the parameters.
fn accelerations<D: Declared, S: Scalar>(
    (q, qd, u, p): (&[S], &[S], &[S], &[S]),
    qdd: &mut [S],
    out: (Option<&mut [S]>, Option<&mut [S]>),
) {
    let b = D::built();
    let stops = LimitMode::of(p[LIMIT_EVENTS].re()) == LimitMode::Stops;
    let limits: &[PositionLimit] = if stops { &b.limits } else { &[] };
    let free = |v: &[S], tau: &[S], out: &mut [S]| free_accelerations::<D, S>(q, v, tau, out);
    if !friction::any(&b.friction) {
        free_accelerations::<D, S>(q, qd, u, qdd);
        at_the_same_q::<S, _>(&b.model, || {
            stops::hold((limits, &[]), (q, qd), qdd, out, free)
        });
        return;
    }
    let mut forces = u.to_vec();
    friction::slip(&b.friction, qd, &mut forces);
    free_accelerations::<D, S>(q, qd, &forces, qdd);
    let (stop_out, mut friction_out) = out;
    let held_out = friction_out.as_deref_mut();
    at_the_same_q::<S, _>(&b.model, || {
        stops::hold(
            (limits, &b.friction),
            (q, qd),
            qdd,
            (stop_out, held_out),
            free,
        )
    });
    // The held solve wrote the stuck joints' friction (and the breakaways'); the slipping
    // ones' is what `slip` took off.
    if let Some(force) = friction_out {
        for ((out, &f), v) in force.iter_mut().zip(&b.friction).zip(qd) {
            if f > 0.0 && !friction::at_rest(f, v.re()) {
                *out = S::from(-f * v.re().signum());
            }
        }
    }
}

/// The floating base's pose and velocity from the states after the joints' (`q`: position
/// then quaternion, `v`: linear then angular velocity): `(R world ← base, p, (ω, v))`.
fn base_state<S: Scalar>(q: &[S], v: &[S]) -> super::dynamics::BaseState<S> {
    use super::spatial::{quat_to_matrix, Motion};
    super::dynamics::BaseState {
        rotation: quat_to_matrix(&[q[3], q[4], q[5], q[6]]),
        position: [q[0], q[1], q[2]],
        velocity: Motion {
            ang: [v[3], v[4], v[5]],
            lin: [v[0], v[1], v[2]],
        },
    }
}

/// `(q̈, base acceleration)` of a floating-base robot into `a` (joints', then the base's
/// `v̇` and `ω̇`): by [`Declared::generated_aba`]'s straight-line code where current (its
/// layout: [`codegen::floating_dynamics`](super::codegen::floating_dynamics)), else by the
/// articulated-body algorithm with the base solved from its articulated inertia
/// ([`Model::aba_free_in`]); springs as joint forces. `u` may be longer than the joints (a
/// generalised force on every velocity, as the end stops pass it): the base's part is 0
/// and left out.
fn floating_accelerations<D: Declared, S: Scalar>(q: &[S], v: &[S], u: &[S], a: &mut [S]) {
    let b = D::built();
    let n = b.order.len();
    let (qm, vm, um) = (
        b.positions_to_model(&q[..n]),
        b.velocities_to_model(&v[..n]),
        b.forces_to_model(&u[..n]),
    );
    let tau: Vec<S> = if b.model.springs.is_empty() {
        um.into_owned()
    } else {
        um.iter()
            .zip(spring_gradient(&b.model, &qm))
            .map(|(&t, g)| t - g)
            .collect()
    };
    // Every model joint's q̈ (mimic joints included), then the base's v̇ and ω̇.
    let nm = b.model.nq();
    let mut am = vec![S::zero(); nm + 6];
    let generated = generated_is_current::<D>() && {
        let whole = |joints: &[S], base: &[S]| -> Vec<S> { [joints, base].concat() };
        D::generated_aba(
            &whole(&qm, &q[n..n + 7]),
            &whole(&vm, &v[n..n + 6]),
            &tau,
            &mut am,
        )
    };
    if !generated {
        let base = base_state(&q[n..], &v[n..]);
        let (joints, rest) = am.split_at_mut(nm);
        let a0 = with_workspace(&b.model, |data| {
            b.model
                .aba_free_in(data, &base.rotation, &base.velocity, &qm, &vm, &tau, joints)
        });
        rest[..3].copy_from_slice(&a0.lin);
        rest[3..].copy_from_slice(&a0.ang);
    }
    for (k, &i) in b.order.iter().enumerate() {
        a[k] = am[i];
    }
    a[n..n + 6].copy_from_slice(&am[nm..]);
}

/// Whether a mechanism's loop closures run on its tree's dynamics ([`closed`]): a fixed
/// base without mimic joints (the others keep the λ-method on the energies).
fn closes_on_the_tree(model: &Model) -> bool {
    model.free_base.is_none() && !model.has_mimics()
}

/// The mass matrix in the coordinates' order (row-major), by CRBA.
fn coordinate_mass<S: Scalar>(b: &Built, q: &[S]) -> Vec<S> {
    let n = b.order.len();
    let qm = b.positions_to_model(q);
    let mut full = vec![S::zero(); n * n];
    with_workspace(&b.model, |data| b.model.crba_in(data, &qm, &mut full));
    if b.natural_order {
        return full;
    }
    let mut m = vec![S::zero(); n * n];
    for (k, &i) in b.order.iter().enumerate() {
        for (l, &j) in b.order.iter().enumerate() {
            m[k * n + l] = full[i * n + j];
        }
    }
    m
}

/// The closures' residuals Φ, G (columns in the coordinates' order) and curvature Ġ q̇ at
/// the model's `(q, q̇)`, analytically ([`closed::kinematics`]).
fn coordinate_closures<S: Scalar>(b: &Built, qm: &[S], qdm: &[S]) -> (Vec<S>, Vec<Vec<S>>, Vec<S>) {
    let (n, k) = (b.model.nq(), b.model.closure_residuals());
    let (mut phi, mut g, mut curvature) = (
        vec![S::zero(); k],
        vec![vec![S::zero(); n]; k],
        vec![S::zero(); k],
    );
    closed::kinematics(&b.model, qm, qdm, &mut phi, &mut g, &mut curvature);
    if b.natural_order {
        return (phi, g, curvature);
    }
    let g = g
        .iter()
        .map(|row| b.order.iter().map(|&i| row[i]).collect())
        .collect();
    (phi, g, curvature)
}

/// q̈ and the closures' multipliers λ (`M q̈ + Gᵀ λ = f`, as the λ-method's) of a tree
/// mechanism with loop closures: M by CRBA, `G` of the closures analytically
/// ([`closed::kinematics`]), both factored ([`closed::Factored`]); the velocity taken onto
/// `G q̇ = 0` first (a no-op on the closures; off them by an integrator's rounding, near a
/// singular position, what keeps the accelerations the branch's), then the bias by RNEA,
/// springs as joint forces and `γ` at that velocity, solved (redundant or singular
/// closures included).
fn closed_accelerations<D: Declared, S: Scalar>(
    t: f64,
    (q, qd, u, p): (&[S], &[S], &[S], &[S]),
    qdd: &mut [S],
    lambda: &mut [S],
) {
    if D::CLOSED_GENERATED_FROM.is_some_and(|f| f == D::built().closed_fingerprint)
        && D::generated_closed(t, (q, qd, u, p), qdd, lambda)
    {
        return;
    }
    interpreted_closed_accelerations::<D, S>(t, (q, qd, u, p), qdd, lambda);
}

/// [`closed_accelerations`] by the interpreted algorithms (a mechanism without generated
/// closed terms; the oracle of those that have them).
pub(crate) fn interpreted_closed_accelerations<D: Declared, S: Scalar>(
    t: f64,
    (q, qd, u, p): (&[S], &[S], &[S], &[S]),
    qdd: &mut [S],
    lambda: &mut [S],
) {
    let b = D::built();
    let n = b.order.len();
    let qm = b.positions_to_model(q);
    let (_, g, _) = coordinate_closures(b, &qm, &vec![S::zero(); n]);
    let factored = closed::Factored::new(coordinate_mass(b, q), &b.structure, &g);
    let mut qd = qd.to_vec();
    factored.tangent(&mut qd);
    let qdm = b.velocities_to_model(&qd);
    let mut bias = vec![S::zero(); n];
    with_workspace(&b.model, |data| {
        b.model
            .rnea_in(data, &qm, &qdm, &vec![S::zero(); n], &mut bias)
    });
    let springs = spring_gradient(&b.model, &qm);
    let mut f = vec![S::zero(); n];
    <Robot<D> as Lagrangian>::forces(t, q, &qd, u, p, &mut f);
    for (k, &i) in b.order.iter().enumerate() {
        f[k] -= bias[i] + springs[i];
    }
    let (_, _, curvature) = coordinate_closures(b, &qm, &qdm);
    let c: Vec<S> = curvature.into_iter().map(|x| -x).collect();
    let mut mu = vec![S::zero(); g.len()];
    factored.accelerations(&f, &c, qdd, &mut mu);
    for (l, m) in lambda.iter_mut().zip(&mu) {
        *l = -*m;
    }
}

/// [`closed_accelerations`] on generated terms ([`Declared::generated_closed`]): the same
/// steps (q̇ onto `G q̇ = 0`, then the bias, springs and γ at that velocity, the
/// rank-revealing solve) on the generated module's [`closed::Code`], in [`closed::Terms`]
/// of the mechanism's fixed sizes on the stack: no allocation.
pub fn generated_closed_accelerations<
    D: Declared,
    S: Scalar,
    C: closed::Code<N, K>,
    const N: usize,
    const K: usize,
>(
    t: f64,
    (q, qd, u, p): (&[S], &[S], &[S], &[S]),
    qdd: &mut [S],
    lambda: &mut [S],
) {
    let mut terms = C::position(q);
    terms.factor();
    let mut v: [S; N] = qd[..N].try_into().expect("N velocities");
    terms.tangent::<C>(&mut v);
    (terms.bias, terms.gamma) = C::velocity(q, &terms.sc, &v);
    let mut f = [S::zero(); N];
    <Robot<D> as Lagrangian>::forces(t, q, &v, u, p, &mut f);
    for ((f, &b), &s) in f.iter_mut().zip(&terms.bias).zip(&terms.springs) {
        *f -= b + s;
    }
    let mut a = [S::zero(); N];
    let mu = terms.accelerations::<C>(&f, &mut a);
    qdd[..N].copy_from_slice(&a);
    for (l, m) in lambda.iter_mut().zip(&mu) {
        *l = -*m;
    }
}

/// [`closed::project`] on generated terms ([`Declared::generated_closed_project`]): the same
/// Newton steps of least kinetic metric onto Φ = 0 (Φ by the model's closure residuals,
/// which the generated terms do not carry), each solved on [`closed::Terms`] (M⁻¹, G,
/// `M⁻¹ Gᵀ` and S generated, S factored as the accelerations factor it), then q̇ onto
/// `G q̇ = 0`: no CRBA, no closure kinematics, no factorisation of M at run time
/// (AndrewsSqueezer's doStep by RK4: 13.6 → 4.4 µs, docs/benchmarks.md). Leaves the state
/// as it is where a step is not finite. Tests: equal to [`closed::project`] to rounding
/// ([`crate::systems::check_generated_closed`]).
pub fn generated_closed_projection<
    D: Declared,
    C: closed::Code<N, K>,
    const N: usize,
    const K: usize,
>(
    q: &mut [f64],
    qd: &mut [f64],
    p: &[f64],
) {
    let mut phi = [0.0; K];
    for _ in 0..closed::PROJECTION_ITERATIONS {
        <Robot<D> as Lagrangian>::constraints(0.0, q, p, &mut phi);
        let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        if phi.iter().all(|v| v.abs() <= 4.0 * f64::EPSILON * scale) {
            break;
        }
        let mut terms = C::position(&q[..N]);
        terms.factor();
        let dq = terms.solve::<C>(&phi.map(|v| -v));
        if !dq.iter().all(|v| v.is_finite()) {
            return;
        }
        q.iter_mut().zip(&dq).for_each(|(x, d)| *x += d);
    }
    let mut terms = C::position(&q[..N]);
    terms.factor();
    let mut v: [f64; N] = qd[..N].try_into().expect("N velocities");
    terms.tangent::<C>(&mut v);
    if v.iter().all(|x| x.is_finite()) {
        qd[..N].copy_from_slice(&v);
    }
}

/// [`closed::project`] by the interpreted algorithms (CRBA, the closures' kinematics): a
/// mechanism without generated closed terms; the oracle of those that have them.
pub(crate) fn interpreted_closed_projection<D: Declared>(q: &mut [f64], qd: &mut [f64], p: &[f64]) {
    let b = D::built();
    closed::project(
        q,
        qd,
        &b.structure,
        |q| coordinate_mass(b, q),
        |q| {
            let phi = crate::model::lagrangian::constraint_values::<Robot<D>, f64>(0.0, q, p);
            let qm = b.positions_to_model(q);
            let (_, g, _) = coordinate_closures(b, &qm, &vec![0.0; qm.len()]);
            (phi, g)
        },
    );
}

/// A declared mechanism as a [`Lagrangian`] (hence a `System` and an FMU).
pub struct Robot<D>(PhantomData<D>);

/// The declaration a [`Robot`] is made from (what `export_fmu!(mechanism …)`'s describe
/// answer reaches through the model type).
pub trait OfMechanism: Lagrangian {
    type Declared: Declared;
}

/// Every output of the mechanism, in their order, into `y` ([`Built::all_outputs`] long):
/// E, the tips' poses, the closures' residuals and forces (left 0 where none is declared),
/// the mimic joints, the end stops' and friction's forces.
fn all_outputs<D: Declared, S: Scalar>(
    t: f64,
    (q, qd, u, p): (&[S], &[S], &[S], &[S]),
    y: &mut [S],
) {
    let b = D::built();
    let model = &b.model;
    let n = b.order.len();
    let (qm, qdm) = (
        b.positions_to_model(&q[..n]),
        b.velocities_to_model(&qd[..n]),
    );
    y[0] = Robot::<D>::kinetic(S::zero(), q, qd, p) + Robot::<D>::potential(S::zero(), q, p);
    let tips = model.tips.len();
    // A floating robot's tips in the world: the base's pose composed with theirs.
    let world = model.free_base.as_ref().map(|_| {
        let base = base_state(&q[n..], &qd[n..]);
        let quat = [q[n + 3], q[n + 4], q[n + 5], q[n + 6]];
        let norm =
            (quat[0] * quat[0] + quat[1] * quat[1] + quat[2] * quat[2] + quat[3] * quat[3]).sqrt();
        (base, quat.map(|c| c / norm))
    });
    for (k, (p, quat)) in model.tip_poses(&qm).into_iter().enumerate() {
        let out = &mut y[1 + 7 * k..8 + 7 * k];
        let (p, quat) = match &world {
            None => (p, quat),
            Some((base, q0)) => (
                super::spatial::add(&base.position, &super::spatial::mat_vec(&base.rotation, &p)),
                super::spatial::quat_mul(q0, &quat),
            ),
        };
        out[..3].copy_from_slice(&p);
        out[3..].copy_from_slice(&quat);
    }
    let m = D::CONSTRAINTS;
    if m > 0 {
        let at = 1 + 7 * tips;
        model.closure_residuals_at(&qm, &mut y[at..at + m]);
    }
    // The closures' forces cost a solve of the dynamics: only where one is declared.
    let declared = |i: usize| b.kept_outputs.as_ref().is_none_or(|kept| kept.contains(&i));
    let forces = 1 + 7 * tips + m..1 + 7 * tips + 2 * m;
    if forces.clone().any(declared) {
        let mut qdd = vec![S::zero(); q.len()];
        let mut lambda = vec![S::zero(); m];
        crate::model::lagrangian::accelerations_and_multipliers_into::<Robot<D>, S>(
            t,
            q,
            qd,
            u,
            p,
            &mut qdd,
            &mut lambda,
        );
        y[forces].copy_from_slice(&lambda);
    }
    // The mimic joints' positions and velocities.
    let mut at = 1 + 7 * tips + 2 * m;
    for (i, f) in model.follows.iter().enumerate() {
        if f.is_some() {
            y[at] = qm[i];
            y[at + 1] = qdm[i];
            at += 2;
        }
    }
    // The end stops' reactions, then the friction forces, last (a tree's only).
    let stops = if m == 0 { b.limits.len() } else { 0 };
    let frictions = b.friction.iter().filter(|&&f| f > 0.0).count();
    if stops + frictions > 0 {
        let mut qdd = vec![S::zero(); qd.len()];
        let mut force = vec![S::zero(); qd.len()];
        let (reaction, rest) = y[at..].split_at_mut(stops);
        accelerations::<D, S>((q, qd, u, p), &mut qdd, (Some(reaction), Some(&mut force)));
        let friction = b.friction.iter().zip(&force).filter(|(&f, _)| f > 0.0);
        for (out, (_, &f)) in rest.iter_mut().zip(friction) {
            *out = f;
        }
    }
}

impl<D: Declared> OfMechanism for Robot<D> {
    type Declared = D;
}

impl<D: Declared> Lagrangian for Robot<D> {
    const NAME: &'static str = D::NAME;

    fn name() -> &'static str {
        D::name()
    }

    fn equations() -> &'static [&'static str] {
        D::equations()
    }

    fn token_text(model_description: String) -> String {
        D::token_text(model_description)
    }

    const DESCRIPTION: &'static str = D::DESCRIPTION;
    const EQUATIONS: &'static [&'static str] = D::EQUATIONS;
    /// Neither Q nor the outputs read t.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    /// One per loop-closure axis.
    const CONSTRAINTS: usize = D::CONSTRAINTS;
    const DEFAULT_METHOD: crate::integrators::Method = D::DEFAULT_METHOD;

    /// A floating base's quaternion: 7 coordinates, 6 velocities.
    fn surplus_coordinates() -> usize {
        D::built().model.free_base.is_some() as usize
    }

    /// The joints' `dq/dt = q̇`; the base's `ṗ = R v`, `dq/dt = ½ q ⊗ (0, ω)` (which keeps
    /// |q| in exact arithmetic; [`normalize`](Lagrangian::normalize) takes off the drift).
    fn coordinate_rates<S: Scalar>(q: &[S], v: &[S], dq: &mut [S]) {
        let n = D::built().order.len();
        dq[..n].copy_from_slice(&v[..n]);
        let base = base_state(&q[n..], &v[n..]);
        let rate = super::spatial::mat_vec(&base.rotation, &base.velocity.lin);
        dq[n..n + 3].copy_from_slice(&rate);
        let quat = [q[n + 3], q[n + 4], q[n + 5], q[n + 6]];
        let w = base.velocity.ang;
        let spin = super::spatial::quat_mul(&quat, &[S::zero(), w[0], w[1], w[2]]);
        for k in 0..4 {
            dq[n + 3 + k] = spin[k] * 0.5;
        }
    }

    /// The base's quaternion back on the unit sphere.
    fn normalize(q: &mut [f64]) {
        let n = D::built().order.len();
        if let Some(quat) = q.get_mut(n + 3..n + 7) {
            let norm = quat.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm.is_finite() && norm > 0.0 {
                quat.iter_mut().for_each(|v| *v /= norm);
            }
        }
    }

    fn parameters() -> Vec<Var> {
        D::built().parameters.clone()
    }

    fn inputs() -> Vec<Var> {
        D::built().inputs.clone()
    }

    fn coordinates() -> Vec<Var> {
        D::built().coordinates.clone()
    }

    fn velocities() -> Vec<Var> {
        D::built().velocities.clone()
    }

    fn outputs() -> Vec<Var> {
        D::built().outputs.clone()
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], _p: &[S]) -> S {
        let b = D::built();
        let n = b.order.len();
        let (qm, qdm) = (
            b.positions_to_model(&q[..n]),
            b.velocities_to_model(&qd[..n]),
        );
        match b.model.free_base {
            None => b.model.kinetic_energy(&qm, &qdm),
            Some(_) => {
                let base = base_state(&q[n..], &qd[n..]);
                b.model.kinetic_energy_free(&base.velocity, &qm, &qdm)
            }
        }
    }

    fn potential<S: Scalar>(_t: S, q: &[S], _p: &[S]) -> S {
        let b = D::built();
        let n = b.order.len();
        let qm = b.positions_to_model(&q[..n]);
        let gravity = match b.model.free_base {
            None => b.model.potential_energy(&qm),
            Some(_) => {
                let base = base_state(&q[n..], &[S::zero(); 6]);
                b.model
                    .potential_energy_free(&base.rotation, &base.position, &qm)
            }
        };
        gravity + b.model.spring_energy(&qm)
    }

    /// `Q = τ − d q̇`, less the slipping joints' friction ([`friction::slip`]; a stuck
    /// joint's is a reaction, which only the generated path's held solve has).
    fn forces<S: Scalar>(_t: f64, q: &[S], qd: &[S], u: &[S], _p: &[S], out: &mut [S]) {
        let b = D::built();
        out.fill(S::zero());
        for ((o, (&tau, &v)), &d) in out.iter_mut().zip(u.iter().zip(qd)).zip(&b.damping) {
            *o = tau - v * d;
        }
        friction::slip(&b.friction, qd, out);
        if b.model.has_dampers() {
            let mut dampers = vec![S::zero(); b.model.nq()];
            let (qm, qdm) = (b.positions_to_model(q), b.velocities_to_model(qd));
            b.model.damper_forces(&qm, &qdm, &mut dampers);
            for (o, &i) in out.iter_mut().zip(&b.order) {
                *o -= dampers[i];
            }
        }
    }

    fn integrals() -> Vec<Var> {
        if !D::DISSIPATED_ENERGY {
            return Vec::new();
        }
        vec![Var::new(
            "E_dissipated",
            Some("J"),
            0.0,
            "Energy the viscous dampers (the springs' and the joints') took out since the start: ∫ (Σ C (dℓ/dt)² + Σ d (dq/dt)²) dt, so that E + E_dissipated is kept where no input does work",
        )]
    }

    fn integral_count() -> usize {
        usize::from(D::DISSIPATED_ENERGY)
    }

    /// `Ė_dissipated = Σ C ℓ̇² + Σ d q̇²` (the springs' dampers, the joints' damping).
    fn integral_rates<S: Scalar>(_t: f64, q: &[S], qd: &[S], _u: &[S], _p: &[S], out: &mut [S]) {
        let b = D::built();
        let mut dampers = vec![S::zero(); b.model.nq()];
        let (qm, qdm) = (b.positions_to_model(q), b.velocities_to_model(qd));
        let springs = b.model.damper_forces(&qm, &qdm, &mut dampers);
        out[0] = b
            .damping
            .iter()
            .zip(qd)
            .fold(springs, |s, (&d, &v)| s + v * v * d);
    }

    /// The loop closures by forward kinematics ([`Model::closure_residuals_at`]).
    fn constraints<S: Scalar>(_t: S, q: &[S], _p: &[S], phi: &mut [S]) {
        let b = D::built();
        if !phi.is_empty() {
            let n = b.order.len();
            b.model
                .closure_residuals_at(&b.positions_to_model(&q[..n]), phi);
        }
    }

    /// A tree: q̈ by the articulated-body algorithm (springs as joint forces
    /// `τ − ∂V_springs/∂q`). With loop closures, on a fixed base without mimic joints: the
    /// tree's M and bias with the closures' rank-revealing solve ([`closed_accelerations`]);
    /// otherwise `false`, so that the λ-method runs on the energies and the constraints.
    fn generated_eom<S: Scalar>(
        t: f64,
        q: &[S],
        qd: &[S],
        u: &[S],
        p: &[S],
        qdd: &mut [S],
        lambda: &mut [S],
    ) -> bool {
        if D::CONSTRAINTS > 0 {
            if !closes_on_the_tree(&D::built().model) {
                return false;
            }
            closed_accelerations::<D, S>(t, (q, qd, u, p), qdd, lambda);
            return true;
        }
        accelerations::<D, S>((q, qd, u, p), qdd, (None, None));
        true
    }

    /// With loop closures on the tree: the projection below moves the state, and its
    /// singular positions (the N four-bar's) amplify rounding off the closures.
    fn error_on_manifold() -> bool {
        D::CONSTRAINTS > 0 && closes_on_the_tree(&D::built().model)
    }

    /// On a fixed base without mimic joints ([`closes_on_the_tree`]): M by CRBA.
    fn mass_matrix_by_algorithm(q: &[f64], _p: &[f64], m: &mut [f64]) -> bool {
        let b = D::built();
        if !closes_on_the_tree(&b.model) {
            return false;
        }
        m.copy_from_slice(&coordinate_mass(b, &q[..b.order.len()]));
        true
    }

    /// On a fixed base without mimic joints: `F = Q + Ṁ q̇ − RNEA(q, q̇, 0) − ∂V_springs/∂q`.
    /// Lagrange's `M q̈ + Ṁ q̇ − ∂T/∂q + ∂V/∂q = Q` against RNEA's `M q̈ + C q̇ + g` gives
    /// `∂T/∂q = Ṁ q̇ − C q̇`; Ṁ is one CRBA on dual numbers along q̇ (O(bodies · depth)
    /// against one dual pass of L per coordinate).
    fn force_by_algorithm(
        t: f64,
        q: &[f64],
        qd: &[f64],
        u: &[f64],
        p: &[f64],
        f: &mut [f64],
    ) -> bool {
        let b = D::built();
        if !closes_on_the_tree(&b.model) {
            return false;
        }
        Self::forces(t, q, qd, u, p, f);
        let (qm, qdm) = (b.positions_to_model(q), b.velocities_to_model(qd));
        let nm = b.model.nq();
        let along: Vec<Dual64> = qm
            .iter()
            .zip(qdm.iter())
            .map(|(&x, &v)| Dual64::new(x, v))
            .collect();
        let mut m_dot = vec![Dual64::from(0.0); nm * nm];
        with_workspace(&b.model, |data| b.model.crba_in(data, &along, &mut m_dot));
        let mut bias = vec![0.0; nm];
        with_workspace(&b.model, |data| {
            b.model.rnea_in(data, &qm, &qdm, &vec![0.0; nm], &mut bias)
        });
        let springs = spring_gradient(&b.model, &qm);
        for (k, &i) in b.order.iter().enumerate() {
            let row = &m_dot[i * nm..(i + 1) * nm];
            let m_dot_qd: f64 = row.iter().zip(qdm.iter()).map(|(m, v)| m.eps * v).sum();
            f[k] += m_dot_qd - bias[i] - springs[i];
        }
        true
    }

    /// A fixed base's T is ½ q̇ᵀ M q̇ (a floating base's too, but its velocities are not
    /// its coordinates' rates, and mimic joints' T is over the model's coordinates).
    fn kinetic_is_quadratic() -> bool {
        closes_on_the_tree(&D::built().model)
    }

    /// Fewer dependent joints than closure residuals: the closures are redundant.
    fn redundant_constraints() -> bool {
        D::built().dependent.iter().filter(|&&d| d).count() < D::CONSTRAINTS
    }

    /// On a fixed base without mimic joints: the closures' Φ and G by their kinematics
    /// ([`coordinate_closures`]).
    fn constraint_rows_by_algorithm(q: &[f64], _p: &[f64], g: &mut [f64], jac: &mut [f64]) -> bool {
        let b = D::built();
        if !closes_on_the_tree(&b.model) {
            return false;
        }
        if g.is_empty() {
            return true;
        }
        let qm = b.positions_to_model(q);
        let (phi, rows, _) = coordinate_closures(b, &qm, &vec![0.0; qm.len()]);
        g.copy_from_slice(&phi);
        for (row, out) in rows.iter().zip(jac.chunks_exact_mut(q.len())) {
            out.copy_from_slice(row);
        }
        true
    }

    /// With loop closures on the tree ([`closes_on_the_tree`]): onto the closures by the
    /// rank-revealing solve ([`closed::project`]), which a redundant or singular G does not
    /// stop.
    fn generated_projection(p: &[f64], x: &mut [f64]) -> bool {
        let b = D::built();
        if D::CONSTRAINTS == 0 || !closes_on_the_tree(&b.model) {
            return false;
        }
        let n = b.order.len();
        let (q, rest) = x.split_at_mut(n);
        let qd = &mut rest[..n];
        if !(D::CLOSED_GENERATED_FROM.is_some_and(|f| f == b.closed_fingerprint)
            && D::generated_closed_project(q, qd, p))
        {
            interpreted_closed_projection::<D>(q, qd, p);
        }
        true
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], y: &mut [S]) {
        match &D::built().kept_outputs {
            None => all_outputs::<D, S>(t, (q, qd, u, p), y),
            Some(kept) => {
                let mut all = vec![S::zero(); D::built().all_outputs];
                all_outputs::<D, S>(t, (q, qd, u, p), &mut all);
                for (out, &k) in y.iter_mut().zip(kept) {
                    *out = all[k];
                }
            }
        }
    }

    fn scenes() -> Vec<Scene> {
        D::scenes(D::built().scenes.clone())
    }

    fn linearization_point() -> Vec<(String, f64)> {
        D::linearization_point()
    }

    /// [`Declared::DEFAULT_EXPERIMENT`]: by default two seconds held by the gravity
    /// torques (the start values: an equilibrium).
    fn default_experiment() -> (f64, f64, f64) {
        D::DEFAULT_EXPERIMENT
    }

    /// The distance to the nearest limit ([`LimitMode::Discard`]), or to the nearest
    /// stop a joint is not on ([`stops::indicator`]); with friction, each slipping joint's
    /// velocity too ([`friction::factors`], all in [`friction::one_indicator`]).
    fn event_indicator(_t: f64, q: &[f64], qd: &[f64], u: &[f64], p: &[f64]) -> Option<f64> {
        let b = D::built();
        let limits = match LimitMode::of(p[LIMIT_EVENTS]) {
            LimitMode::Ignore => None,
            LimitMode::Discard => b.limit_distance(q),
            LimitMode::Stops => stops::indicator(&b.limits, q, qd),
        };
        if !friction::any(&b.friction) {
            return limits;
        }
        // With friction there is an indicator even while no joint slips (1: no event).
        let qdd = friction::any_in_band(&b.friction, qd).then(|| {
            let mut qdd = vec![0.0; qd.len()];
            accelerations::<D, f64>((q, qd, u, p), &mut qdd, (None, None));
            qdd
        });
        let factors = friction::factors(&b.friction, qd, qdd.as_deref());
        Some(friction::one_indicator(limits.into_iter().chain(factors)).unwrap_or(1.0))
    }

    /// A tree with limits has end stops, whose impacts change every state; friction's
    /// events put a joint at rest.
    fn impacts() -> bool {
        let b = D::built();
        D::CONSTRAINTS == 0 && (!b.limits.is_empty() || friction::any(&b.friction))
    }

    /// End stops: the impact ([`stops::impact`]); else the doStep ends at the limit
    /// ([`LimitMode::Discard`]). Then a joint slowing to rest under friction sticks
    /// ([`friction::stick`]).
    fn on_event(t: f64, q: &mut [f64], qd: &mut [f64], u: &[f64], p: &[f64]) -> Result<(), String> {
        let b = D::built();
        match LimitMode::of(p[LIMIT_EVENTS]) {
            LimitMode::Ignore => {}
            LimitMode::Discard => {
                if b.limit_distance(q).is_some_and(|d| d <= 0.0) {
                    return Err(b.limit_reached(t, q));
                }
            }
            LimitMode::Stops => {
                let free = |q: &[f64], v: &[f64], tau: &[f64], out: &mut [f64]| {
                    free_accelerations::<D, f64>(q, v, tau, out)
                };
                let restitution = p.get(RESTITUTION).copied().unwrap_or(0.0);
                stops::impact(&b.limits, (q, qd, u), restitution, free);
            }
        }
        if friction::any(&b.friction) {
            let mut qdd = vec![0.0; qd.len()];
            accelerations::<D, f64>((q, qd, u, p), &mut qdd, (None, None));
            friction::stick(&b.friction, qd, &qdd);
        }
        Ok(())
    }
}

#[cfg(test)]
mod token_tests {
    use super::without_start_values;

    #[test]
    fn start_values_are_left_out_of_a_mechanisms_token() {
        let xml = r#"<A name="q" start="0.25"/><B start="1e-3" unit="m"/><C/>"#;
        assert_eq!(
            without_start_values(xml),
            r#"<A name="q"/><B unit="m"/><C/>"#
        );
    }
}
