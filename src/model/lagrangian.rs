//! Lagrangian systems: write the energies, get the equations of motion.
//!
//! A [`Lagrangian`] declares generalised coordinates `q`, the kinetic energy
//! `T(q, q̇, p)`, the potential `V(q, p)` and the generalised forces `Q(t, q, q̇, u, p)`,
//! all generic over the scalar type. The Euler–Lagrange equations
//!
//! ```text
//! d/dt ∂L/∂q̇ − ∂L/∂q = Q,   L = T − V
//! ⇔  M(q, q̇) q̈ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇,   M = ∂²T/∂q̇²
//! ```
//!
//! are then formed exactly, by automatic differentiation, at every evaluation: no
//! hand-derived equations to get wrong. Every `Lagrangian` is a [`System`] (blanket
//! implementation below) with the states `(q, q̇)` and `ẋ = (q̇, q̈)`. A system whose
//! equations were generated ([`symbolic`](super::symbolic), one `generated_eom!` line in
//! its impl) runs that straight-line code instead, ~20× fewer instructions; the
//! automatic differentiation here stays the fallback and the oracle ([`AutoDiff`]).
//! Still on it for every system: RATTLE's [`LagrangianMechanics`] and
//! `state_constraints` (once, at fmi2ExitInitializationMode).
//!
//! # Why nested dual numbers
//!
//! The derivatives `∂²T/∂q̇ᵢ∂q̇ⱼ`, `∂L/∂qᵢ` and `Σⱼ ∂²L/∂q̇ᵢ∂qⱼ q̇ⱼ` are taken with
//! hyper-dual numbers (`HyperDual<S>`, second derivatives) and dual numbers (`Dual<S>`,
//! first derivatives) whose components are themselves of the caller's scalar type `S`.
//! With `S = f64` that is plain forward-mode AD. With `S = Dual64` (what
//! [`jacobian`](super::jacobian), the ModelStructure, the implicit integrators and
//! linearisation use) the nesting carries the outer derivative through the inner
//! one, so the Jacobian of `q̈` with respect to states, inputs and parameters is still
//! exact: the right-hand side is one generic function of `S`, like a hand-written one.
//!
//! # Why a hand-written linear solve
//!
//! `M q̈ = rhs` is solved by Gaussian elimination with partial pivoting written over
//! `S` ([`solve`]): nalgebra's decompositions need `ComplexField`, which num-dual only
//! provides with its `nalgebra` feature (off here), and for n ≤ 6 a dozen lines are
//! clearer anyway. Pivots are chosen by the real part, so a dual-number evaluation takes
//! the same pivot sequence as the `f64` one and differentiates the same formula.

use super::{Scalar, Scene, System, Var};
use crate::integrators::problem::Mechanics;
use num_dual::{Dual, HyperDual};

/// A mechanical system given by its energies in generalised coordinates.
///
/// `coordinates()` and `velocities()` must have the same length n; the states of the
/// resulting [`System`] are the coordinates then the velocities.
///
/// Because every `Lagrangian` is also a `System`, the associated items with the same
/// names (`NAME`, `parameters`, `scenes`, …) exist twice on the type; they agree. With
/// both traits imported, name the one meant: `<CompoundPendulum as System>::scenes()`.
pub trait Lagrangian: 'static {
    /// The FMU's modelIdentifier.
    const NAME: &'static str;
    /// One line: what the system is.
    const DESCRIPTION: &'static str;
    /// Equations and notes for the FMU's documentation (plain text, one per line).
    const EQUATIONS: &'static [&'static str];

    /// [`System::name`].
    fn name() -> &'static str {
        Self::NAME
    }

    /// [`System::token_text`].
    fn token_text(model_description: String) -> String {
        model_description
    }

    /// [`System::equations`].
    fn equations() -> &'static [&'static str] {
        Self::EQUATIONS
    }

    fn parameters() -> Vec<Var>;
    fn inputs() -> Vec<Var>;
    /// The generalised coordinates q (their start values are the initial state).
    fn coordinates() -> Vec<Var>;
    /// The generalised velocities q̇, in the order of `coordinates` (e.g. `theta_dot`).
    fn velocities() -> Vec<Var>;
    /// Extra outputs (energy, constraint forces, …), beyond the states.
    fn outputs() -> Vec<Var>;

    /// Whether time enters T, V or the constraints (rheonomic: a prescribed motion). Then
    /// RATTLE, whose mechanics are time-free, refuses the system, and the projection runs
    /// on automatic differentiation (the generated one has no ∂Φ/∂t). The time derivatives
    /// themselves need no declaration: `t` is a scalar (dual numbers) or a leaf (tracer).
    const RHEONOMIC: bool = false;

    /// Whether the generalised forces or the extra outputs use `t` (an `f64` there, unlike
    /// in T, V and the constraints, whose time is declared by `RHEONOMIC`). Default: true,
    /// so a system that does not say gets no output derivative that would need ∂/∂t
    /// ([`System::explicit_time`]).
    const TIME_IN_FORCES_OR_OUTPUTS: bool = true;

    /// See [`System::DEFAULT_METHOD`].
    const DEFAULT_METHOD: crate::integrators::Method = crate::integrators::Method::Dopri5;

    /// How many coordinates more than velocities there are: 1 for a free-flying base,
    /// whose orientation is a unit quaternion (4 coordinates) but whose angular velocity
    /// has 3 components; 0 (the default) when `dq/dt = q̇`. With surplus coordinates the
    /// states are `(q, v)`, `dq/dt` comes from [`coordinate_rates`](Self::coordinate_rates),
    /// the symplectic methods and RATTLE (which need `dq/dt = q̇`) refuse the system, and
    /// the energies and accelerations must be given by the system itself
    /// ([`generated_eom`](Self::generated_eom)): the automatic differentiation of T and V
    /// here assumes as many velocities as coordinates.
    fn surplus_coordinates() -> usize {
        0
    }

    /// `dq/dt` from `(q, v)` when there are [`surplus_coordinates`](Self::surplus_coordinates)
    /// (`dq` has q's length); the default copies v.
    fn coordinate_rates<S: Scalar>(_q: &[S], v: &[S], dq: &mut [S]) {
        dq.copy_from_slice(v);
    }

    /// Puts the coordinates back on their manifold after a step (a quaternion back on the
    /// unit sphere); the default does nothing.
    fn normalize(_q: &mut [f64]) {}

    /// First-order states integrated beside `(q, q̇)`, after them: what a scene needs as
    /// an integral over time (`E_dissipated`, the energy the dampers took out, so that
    /// `E + E_dissipated` is kept). Their rates are [`integral_rates`](Self::integral_rates);
    /// the symplectic methods and RATTLE, which step `(q, q̇)` only, refuse the system.
    /// Default: none.
    fn integrals() -> Vec<Var> {
        Vec::new()
    }

    /// How many [`integrals`](Self::integrals) (read on every evaluation: no allocation).
    fn integral_count() -> usize {
        0
    }

    /// The [`integrals`](Self::integrals)' rates at `(t, q, q̇, u, p)` into `out`.
    fn integral_rates<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], _u: &[S], _p: &[S], _out: &mut [S]) {
    }

    /// Kinetic energy `T(t, q, q̇, p)`. `t` is a scalar (not `f64`) so that the dual
    /// numbers carry ∂/∂t through it (rheonomic systems); most systems ignore it.
    fn kinetic<S: Scalar>(t: S, q: &[S], qd: &[S], p: &[S]) -> S;

    /// Potential energy `V(t, q, p)`.
    fn potential<S: Scalar>(t: S, q: &[S], p: &[S]) -> S;

    /// Generalised forces `Q(t, q, q̇, u, p)` (non-conservative: inputs, damping).
    /// Default: none.
    fn forces<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], _u: &[S], _p: &[S], out: &mut [S]) {
        out.fill(S::from(0.0));
    }

    /// The extra outputs `y`. [`accelerations`] gives q̈ when an output needs it.
    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], y: &mut [S]);

    /// The configured experiments of this system.
    fn scenes() -> Vec<Scene>;

    /// [`System::linearization_point`]. Default: none.
    fn linearization_point() -> Vec<(String, f64)> {
        Vec::new()
    }

    /// How many holonomic constraints `Φ(q) = 0` [`constraints`](Lagrangian::constraints)
    /// returns: 0 (the default) for minimal coordinates. With m > 0 the coordinates are
    /// surplus and the equations of motion carry m multipliers λ (the λ-method):
    /// `M q̈ + Gᵀ λ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇`, `G q̈ = −q̇ᵀ ∇²Φ q̇`, `G = ∂Φ/∂q`;
    /// `−Gᵀ λ` is the constraint force. The states are projected back onto `Φ = 0`,
    /// `G q̇ = 0` after every step (see [`project`]).
    const CONSTRAINTS: usize = 0;

    /// The constraint functions `Φ(t, q, p)` (length [`CONSTRAINTS`](Lagrangian::CONSTRAINTS)).
    /// With t in them (rheonomic) the velocity level is `G q̇ + ∂Φ/∂t = 0` and γ gains
    /// `2 (∂G/∂t) q̇ + ∂²Φ/∂t²`, both by the same dual numbers.
    fn constraints<S: Scalar>(_t: S, _q: &[S], _p: &[S], _phi: &mut [S]) {}

    /// How many velocity constraints `A(q) q̇ = 0` (need not be integrable: rolling
    /// without slip) [`velocity_constraints`](Lagrangian::velocity_constraints) returns;
    /// their multipliers follow those of the holonomic constraints, and `−Aᵀ λ` is their
    /// force. Velocities are projected onto `A q̇ = 0` after every step.
    const VELOCITY_CONSTRAINTS: usize = 0;

    /// `A(t, q) q̇ + b(t, q)`, which must be affine in q̇ (length
    /// [`VELOCITY_CONSTRAINTS`](Lagrangian::VELOCITY_CONSTRAINTS)); b = 0 unless rheonomic.
    fn velocity_constraints<S: Scalar>(_t: S, _q: &[S], _qd: &[S], _p: &[S], _out: &mut [S]) {}

    /// DefaultExperiment: stop time, relative tolerance, communication step size.
    fn default_experiment() -> (f64, f64, f64) {
        (10.0, 1e-8, 1e-2)
    }

    /// An event indicator on `(t, q, q̇)`, as [`System::event_indicator`]. Default: none.
    fn event_indicator(_t: f64, _q: &[f64], _qd: &[f64], _u: &[f64], _p: &[f64]) -> Option<f64> {
        None
    }

    /// At an event, as [`System::on_event`]: `Err(why)` stops the integration there.
    fn on_event(
        _t: f64,
        _q: &mut [f64],
        _qd: &mut [f64],
        _u: &[f64],
        _p: &[f64],
    ) -> Result<(), String> {
        Ok(())
    }

    /// [`System::impacts`].
    fn impacts() -> bool {
        false
    }

    /// `(q̈, λ)` by the equations generated from this Lagrangian (`mbfmu symbolic`, under
    /// `model/symbolic/generated/`) into `qdd` and the first `lambda.len()` multipliers,
    /// returning `true`; `false` (the default): none, automatic differentiation instead.
    /// Never written by hand: `crate::generated_eom!(DoublePendulumEom);` in the impl
    /// (see [`generated_eom!`](crate::generated_eom) for why there).
    fn generated_eom<S: Scalar>(
        _t: f64,
        _q: &[S],
        _qd: &[S],
        _u: &[S],
        _p: &[S],
        _qdd: &mut [S],
        _lambda: &mut [S],
    ) -> bool {
        false
    }

    /// RATTLE's mass matrix M(q) (n × n, row-major, into `m`) by the system's own
    /// algorithm (a tree's CRBA), returning `true` when it has one. `false` (the default):
    /// M by automatic differentiation of T, one hyper-dual evaluation per entry (n²/2
    /// passes of T: seconds a RATTLE step for 81 coordinates).
    fn mass_matrix_by_algorithm(_q: &[f64], _p: &[f64], _m: &mut [f64]) -> bool {
        false
    }

    /// RATTLE's generalised force `F = Q + ∂L/∂q` (into `f`) by the system's own
    /// algorithm (a tree's RNEA), returning `true` when it has one; `false` (the default):
    /// ∂L/∂q by one dual evaluation of L per coordinate.
    fn force_by_algorithm(
        _t: f64,
        _q: &[f64],
        _qd: &[f64],
        _u: &[f64],
        _p: &[f64],
        _f: &mut [f64],
    ) -> bool {
        false
    }

    /// True when some of the [`Lagrangian::CONSTRAINTS`] are redundant (combinations of the
    /// others: Bricard's loop, five residuals of rank four). RATTLE's Newton matrix is then
    /// singular: it is refused for such a system (fmi2SetInteger names why). Default: false.
    fn redundant_constraints() -> bool {
        false
    }

    /// True when T = ½ q̇ᵀ M(q) q̇ exactly, with no term linear in q̇: RATTLE's momentum
    /// offset `b(q)` is then 0 without n evaluations of T. Default: false.
    fn kinetic_is_quadratic() -> bool {
        false
    }

    /// RATTLE's constraint values `g(q)` and rows `G = ∂g/∂q` (m × n, row-major) by the
    /// system's own algorithm (a tree's closure kinematics), returning `true` when it has
    /// one; `false` (the default): G by automatic differentiation of
    /// [`constraints`](Lagrangian::constraints).
    fn constraint_rows_by_algorithm(
        _q: &[f64],
        _p: &[f64],
        _g: &mut [f64],
        _jac: &mut [f64],
    ) -> bool {
        false
    }

    /// [`System::error_on_manifold`]. Default: false.
    fn error_on_manifold() -> bool {
        false
    }

    /// The projection after each step ([`project_onto_constraints`]) on the generated M
    /// and constraint rows, without heap; `false` (the default): none, automatic
    /// differentiation instead. Written by the same `generated_eom!` line.
    fn generated_projection(_p: &[f64], _x: &mut [f64]) -> bool {
        false
    }
}

/// `q̈` into `qdd`: the generated equations when the system has them, else automatic
/// differentiation ([`accelerations`]). No heap on the generated path. (Always inlined:
/// called, the accelerations come back through memory, and reading them as a pair right
/// after the call stalls store forwarding, ~15 cycles a stage of the fixed-step doStep.)
#[inline(always)]
pub fn accelerations_into<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    qd: &[S],
    u: &[S],
    p: &[S],
    qdd: &mut [S],
) {
    if !L::generated_eom(t, q, qd, u, p, qdd, &mut []) {
        qdd.copy_from_slice(&accelerations::<L, S>(t, q, qd, u, p));
    }
}

/// `(q̈, λ)` into `qdd` and `lambda` (all the multipliers, holonomic then velocity
/// constraints'): generated when the system has it, else [`accelerations_and_multipliers`].
pub fn accelerations_and_multipliers_into<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    qd: &[S],
    u: &[S],
    p: &[S],
    qdd: &mut [S],
    lambda: &mut [S],
) {
    if !L::generated_eom(t, q, qd, u, p, qdd, lambda) {
        let (a, l) = accelerations_and_multipliers::<L, S>(t, q, qd, u, p);
        qdd.copy_from_slice(&a);
        lambda.copy_from_slice(&l);
    }
}

/// A Lagrangian on automatic differentiation only, whatever generated code it has: the
/// oracle the generated path is tested against (same name, variables and everything else).
pub struct AutoDiff<L>(std::marker::PhantomData<L>);

impl<L: Lagrangian> Lagrangian for AutoDiff<L> {
    const NAME: &'static str = L::NAME;
    fn name() -> &'static str {
        L::name()
    }
    fn token_text(model_description: String) -> String {
        L::token_text(model_description)
    }
    fn equations() -> &'static [&'static str] {
        L::equations()
    }
    const DESCRIPTION: &'static str = L::DESCRIPTION;
    const EQUATIONS: &'static [&'static str] = L::EQUATIONS;
    const CONSTRAINTS: usize = L::CONSTRAINTS;
    const VELOCITY_CONSTRAINTS: usize = L::VELOCITY_CONSTRAINTS;
    const RHEONOMIC: bool = L::RHEONOMIC;
    const TIME_IN_FORCES_OR_OUTPUTS: bool = L::TIME_IN_FORCES_OR_OUTPUTS;
    fn parameters() -> Vec<Var> {
        L::parameters()
    }
    fn inputs() -> Vec<Var> {
        L::inputs()
    }
    fn coordinates() -> Vec<Var> {
        L::coordinates()
    }
    fn velocities() -> Vec<Var> {
        L::velocities()
    }
    fn outputs() -> Vec<Var> {
        <L as Lagrangian>::outputs()
    }
    fn kinetic<S: Scalar>(t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        L::kinetic(t, q, qd, p)
    }
    fn potential<S: Scalar>(t: S, q: &[S], p: &[S]) -> S {
        L::potential(t, q, p)
    }
    fn forces<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], out: &mut [S]) {
        L::forces(t, q, qd, u, p, out)
    }
    /// The system's own outputs (they may use its generated accelerations).
    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], y: &mut [S]) {
        <L as Lagrangian>::extra_outputs(t, q, qd, u, p, y)
    }
    fn scenes() -> Vec<Scene> {
        <L as Lagrangian>::scenes()
    }
    fn linearization_point() -> Vec<(String, f64)> {
        <L as Lagrangian>::linearization_point()
    }
    fn constraints<S: Scalar>(t: S, q: &[S], p: &[S], phi: &mut [S]) {
        L::constraints(t, q, p, phi)
    }
    fn velocity_constraints<S: Scalar>(t: S, q: &[S], qd: &[S], p: &[S], out: &mut [S]) {
        L::velocity_constraints(t, q, qd, p, out)
    }
    fn default_experiment() -> (f64, f64, f64) {
        <L as Lagrangian>::default_experiment()
    }
    fn event_indicator(t: f64, q: &[f64], qd: &[f64], u: &[f64], p: &[f64]) -> Option<f64> {
        <L as Lagrangian>::event_indicator(t, q, qd, u, p)
    }
    fn on_event(t: f64, q: &mut [f64], qd: &mut [f64], u: &[f64], p: &[f64]) -> Result<(), String> {
        <L as Lagrangian>::on_event(t, q, qd, u, p)
    }

    fn impacts() -> bool {
        <L as Lagrangian>::impacts()
    }
    fn surplus_coordinates() -> usize {
        L::surplus_coordinates()
    }
    fn coordinate_rates<S: Scalar>(q: &[S], v: &[S], dq: &mut [S]) {
        L::coordinate_rates(q, v, dq)
    }
    fn normalize(q: &mut [f64]) {
        L::normalize(q)
    }
}

/// Where the states `(q, v, integrals)` split: after the coordinates,
/// `(len − integrals + surplus) / 2`.
#[inline(always)]
fn split<L: Lagrangian>(len: usize) -> usize {
    (len - L::integral_count() + L::surplus_coordinates()) / 2
}

/// The state's `(q, v)` and its [`Lagrangian::integrals`].
#[inline(always)]
fn parts<L: Lagrangian, S>(x: &[S]) -> (&[S], &[S], &[S]) {
    let n = split::<L>(x.len());
    let (q, rest) = x.split_at(n);
    let (v, integrals) = rest.split_at(rest.len() - L::integral_count());
    (q, v, integrals)
}

/// `L = T − V` at a point of any scalar type.
fn lagrangian<L: Lagrangian, S: Scalar>(t: S, q: &[S], qd: &[S], p: &[S]) -> S {
    L::kinetic(t, q, qd, p) - L::potential(t, q, p)
}

fn lift_hyper<S: Scalar>(v: &[S]) -> Vec<HyperDual<S>> {
    v.iter().map(|&x| HyperDual::from_re(x)).collect()
}

fn lift_dual<S: Scalar>(v: &[S]) -> Vec<Dual<S>> {
    v.iter().map(|&x| Dual::from_re(x)).collect()
}

/// The mass matrix `M = ∂²T/∂q̇²` (n × n, symmetric), one hyper-dual evaluation of T
/// per entry of the upper triangle. It may depend on q̇ for a general T; for the usual
/// T quadratic in q̇ it does not.
pub fn mass_matrix<L: Lagrangian, S: Scalar>(t: f64, q: &[S], qd: &[S], p: &[S]) -> Vec<Vec<S>> {
    let n = q.len();
    let (qh, ph) = (lift_hyper(q), lift_hyper(p));
    let th = HyperDual::from_re(S::from(t));
    let mut m = vec![vec![S::from(0.0); n]; n];
    for i in 0..n {
        for j in i..n {
            let mut qdh = lift_hyper(qd);
            qdh[i].eps1 = S::from(1.0);
            qdh[j].eps2 = S::from(1.0);
            let mij = L::kinetic(th, &qh, &qdh, &ph).eps1eps2;
            m[i][j] = mij;
            m[j][i] = mij;
        }
    }
    m
}

/// The right-hand side `Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇` of `M q̈ = …`.
///
/// `∂L/∂qᵢ`: one dual evaluation with `qᵢ + ε`. The mixed term, contracted with q̇ so it
/// costs n evaluations rather than n²: one hyper-dual evaluation with `q̇ᵢ + ε₁` and
/// `q + ε₂ q̇`, `t + ε₂` gives `Σⱼ ∂²L/∂q̇ᵢ∂qⱼ q̇ⱼ + ∂²L/∂q̇ᵢ∂t` (the rest of
/// `d/dt ∂L/∂q̇ᵢ`) in its ε₁ε₂ part.
pub fn generalized_rhs<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    qd: &[S],
    u: &[S],
    p: &[S],
) -> Vec<S> {
    let n = q.len();
    let mut rhs = vec![S::from(0.0); n];
    L::forces(t, q, qd, u, p, &mut rhs);
    let (qdd, pd) = (lift_dual(qd), lift_dual(p));
    let ph = lift_hyper(p);
    let td = Dual::from_re(S::from(t));
    let th = HyperDual::new(S::from(t), S::from(0.0), S::from(1.0), S::from(0.0));
    for i in 0..n {
        // ∂L/∂qᵢ
        let mut qdual = lift_dual(q);
        qdual[i].eps = S::from(1.0);
        rhs[i] += lagrangian::<L, _>(td, &qdual, &qdd, &pd).eps;
        // Σⱼ ∂²L/∂q̇ᵢ∂qⱼ q̇ⱼ
        let qh: Vec<HyperDual<S>> = q
            .iter()
            .zip(qd)
            .map(|(&qj, &vj)| HyperDual::new(qj, S::from(0.0), vj, S::from(0.0)))
            .collect();
        let mut qdh = lift_hyper(qd);
        qdh[i].eps1 = S::from(1.0);
        rhs[i] -= lagrangian::<L, _>(th, &qh, &qdh, &ph).eps1eps2;
    }
    rhs
}

/// The accelerations q̈ of the Euler–Lagrange equations: `M q̈ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇`
/// (with constraints, of the λ-method: see [`accelerations_and_multipliers`]), by automatic
/// differentiation always (the oracle of the generated code; [`accelerations_into`] takes
/// the generated path where there is one).
pub fn accelerations<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    qd: &[S],
    u: &[S],
    p: &[S],
) -> Vec<S> {
    let (mut qdd, _) = accelerations_and_multipliers::<L, S>(t, q, qd, u, p);
    qdd.truncate(q.len());
    qdd
}

/// `(q̈, λ)` of the λ-method: one solve of the augmented system
///
/// ```text
/// [ M  Gᵀ ] [ q̈ ]   [ Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇ ]
/// [ G  0  ] [ λ  ] = [ −γ                         ]
/// ```
///
/// with `γ = q̇ᵀ ∇²Φ q̇ + 2 (∂G/∂t) q̇ + ∂²Φ/∂t²` (and `Ȧ q̇ + ḃ` for velocity constraints)
///
/// ```text
/// ```
///
/// (the constraints differentiated twice: index 1). λ is empty without constraints.
pub fn accelerations_and_multipliers<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    qd: &[S],
    u: &[S],
    p: &[S],
) -> (Vec<S>, Vec<S>) {
    let n = q.len();
    let mut m = mass_matrix::<L, S>(t, q, qd, p);
    let mut rhs = generalized_rhs::<L, S>(t, q, qd, u, p);
    if L::CONSTRAINTS + L::VELOCITY_CONSTRAINTS == 0 {
        solve(&mut m, &mut rhs);
        return (rhs, Vec::new());
    }
    let g = all_constraint_rows::<L, S>(t, q, p);
    let mut a = augmented(&m, &g);
    rhs.extend(
        constraint_curvature::<L, S>(t, q, qd, p)
            .into_iter()
            .map(|c| -c),
    );
    rhs.extend(
        velocity_constraint_drift::<L, S>(t, q, qd, p)
            .into_iter()
            .map(|c| -c),
    );
    solve(&mut a, &mut rhs);
    let lambda = rhs.split_off(n);
    (rhs, lambda)
}

/// The generalized force `F = Q + ∂L/∂q` of RATTLE's momentum equation `ṗ = F − Gᵀλ`:
/// one dual evaluation of L per coordinate.
pub fn generalized_force<L: Lagrangian>(
    t: f64,
    q: &[f64],
    qd: &[f64],
    u: &[f64],
    p: &[f64],
) -> Vec<f64> {
    let mut f = vec![0.0; q.len()];
    L::forces(t, q, qd, u, p, &mut f);
    let (qdd, pd) = (lift_dual(qd), lift_dual(p));
    for (i, fi) in f.iter_mut().enumerate() {
        let mut qdual = lift_dual(q);
        qdual[i].eps = 1.0;
        *fi += lagrangian::<L, _>(Dual::from_re(t), &qdual, &qdd, &pd).eps;
    }
    f
}

/// `b(q) = ∂T/∂q̇` at `q̇ = 0`, so that `p = ∂L/∂q̇ = M q̇ + b` for T quadratic in q̇
/// (at t = 0: RATTLE's mechanics are time-free, and rheonomic systems refuse RATTLE).
pub fn momentum_offset<L: Lagrangian>(q: &[f64], p: &[f64]) -> Vec<f64> {
    let (qd, pd) = (lift_dual(q), lift_dual(p));
    (0..q.len())
        .map(|i| {
            let mut v = vec![Dual::from_re(0.0); q.len()];
            v[i].eps = 1.0;
            L::kinetic(Dual::from_re(0.0), &qd, &v, &pd).eps
        })
        .collect()
}

/// A Lagrangian with its inputs and parameters, as RATTLE sees it.
pub struct LagrangianMechanics<'a, L> {
    u: &'a [f64],
    p: &'a [f64],
    system: std::marker::PhantomData<L>,
}

impl<'a, L: Lagrangian> LagrangianMechanics<'a, L> {
    pub fn new(u: &'a [f64], p: &'a [f64]) -> Self {
        LagrangianMechanics {
            u,
            p,
            system: std::marker::PhantomData,
        }
    }
}

impl<L: Lagrangian> Mechanics for LagrangianMechanics<'_, L> {
    fn dims(&self) -> (usize, usize) {
        (L::coordinates().len(), L::CONSTRAINTS)
    }

    fn mass_matrix(&mut self, q: &[f64], m: &mut [f64]) {
        if L::mass_matrix_by_algorithm(q, self.p, m) {
            return;
        }
        let n = q.len();
        // T quadratic in q̇: M does not depend on q̇.
        for (i, row) in mass_matrix::<L, f64>(0.0, q, &vec![0.0; n], self.p)
            .iter()
            .enumerate()
        {
            m[i * n..(i + 1) * n].copy_from_slice(row);
        }
    }

    fn momentum_offset(&mut self, q: &[f64], b: &mut [f64]) {
        if L::kinetic_is_quadratic() {
            b.fill(0.0);
            return;
        }
        b.copy_from_slice(&momentum_offset::<L>(q, self.p));
    }

    fn force(&mut self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) {
        if L::force_by_algorithm(t, q, qd, self.u, self.p, f) {
            return;
        }
        f.copy_from_slice(&generalized_force::<L>(t, q, qd, self.u, self.p));
    }

    fn constraints(&mut self, q: &[f64], g: &mut [f64], jac: &mut [f64]) {
        constraint_rows::<L>(q, self.p, g, jac);
    }
}

/// `g(q)` and `G = ∂g/∂q` (row-major, m × n) of time-independent constraints: by the
/// system's own algorithm ([`Lagrangian::constraint_rows_by_algorithm`]) where it has one,
/// else by automatic differentiation (at t = 0).
fn constraint_rows<L: Lagrangian>(q: &[f64], p: &[f64], g: &mut [f64], jac: &mut [f64]) {
    if L::constraint_rows_by_algorithm(q, p, g, jac) {
        return;
    }
    let n = q.len();
    g.copy_from_slice(&constraint_values::<L, f64>(0.0, q, p));
    for (i, row) in constraint_jacobian::<L, f64>(0.0, q, p).iter().enumerate() {
        jac[i * n..(i + 1) * n].copy_from_slice(row);
    }
}

/// The constraint values `Φ(t, q)`.
pub fn constraint_values<L: Lagrangian, S: Scalar>(t: f64, q: &[S], p: &[S]) -> Vec<S> {
    let mut phi = vec![S::from(0.0); L::CONSTRAINTS];
    L::constraints(S::from(t), q, p, &mut phi);
    phi
}

/// `G = ∂Φ/∂q` (m × n), one dual evaluation of Φ per column.
pub fn constraint_jacobian<L: Lagrangian, S: Scalar>(t: f64, q: &[S], p: &[S]) -> Vec<Vec<S>> {
    let (n, m) = (q.len(), L::CONSTRAINTS);
    let pd = lift_dual(p);
    let td = Dual::from_re(S::from(t));
    let mut g = vec![vec![S::from(0.0); n]; m];
    for j in 0..n {
        let mut qd = lift_dual(q);
        qd[j].eps = S::from(1.0);
        let mut phi = vec![Dual::from_re(S::from(0.0)); m];
        L::constraints(td, &qd, &pd, &mut phi);
        for (row, v) in g.iter_mut().zip(&phi) {
            row[j] = v.eps;
        }
    }
    g
}

/// `A(t, q)` (k × n) of the velocity constraints: column j is `(A e_j + b) − b` (affine).
pub fn velocity_constraint_matrix<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    p: &[S],
) -> Vec<Vec<S>> {
    let (n, k) = (q.len(), L::VELOCITY_CONSTRAINTS);
    let mut a = vec![vec![S::from(0.0); n]; k];
    let mut column = vec![S::from(0.0); k];
    let mut offset = vec![S::from(0.0); k];
    L::velocity_constraints(S::from(t), q, &vec![S::from(0.0); n], p, &mut offset);
    for j in 0..n {
        let mut e = vec![S::from(0.0); n];
        e[j] = S::from(1.0);
        L::velocity_constraints(S::from(t), q, &e, p, &mut column);
        for ((row, v), b) in a.iter_mut().zip(&column).zip(&offset) {
            row[j] = *v - *b;
        }
    }
    a
}

/// The rows of every constraint on the velocities: `G = ∂Φ/∂q` then `A(q)`.
pub fn all_constraint_rows<L: Lagrangian, S: Scalar>(t: f64, q: &[S], p: &[S]) -> Vec<Vec<S>> {
    let mut rows = constraint_jacobian::<L, S>(t, q, p);
    rows.extend(velocity_constraint_matrix::<L, S>(t, q, p));
    rows
}

/// The velocity-level residuals: `G q̇ + ∂Φ/∂t` (one dual evaluation of Φ at
/// `(q + ε q̇, t + ε)`), then `A q̇ + b`. Zero on the constraint manifold.
pub fn velocity_residuals<L: Lagrangian, S: Scalar>(t: f64, q: &[S], qd: &[S], p: &[S]) -> Vec<S> {
    let (m, k) = (L::CONSTRAINTS, L::VELOCITY_CONSTRAINTS);
    let qdual: Vec<Dual<S>> = q.iter().zip(qd).map(|(&a, &b)| Dual::new(a, b)).collect();
    let mut phi = vec![Dual::from_re(S::from(0.0)); m];
    L::constraints(
        Dual::new(S::from(t), S::from(1.0)),
        &qdual,
        &lift_dual(p),
        &mut phi,
    );
    let mut r: Vec<S> = phi.into_iter().map(|v| v.eps).collect();
    let mut aqd = vec![S::from(0.0); k];
    L::velocity_constraints(S::from(t), q, qd, p, &mut aqd);
    r.extend(aqd);
    r
}

/// `Ȧ q̇ + ḃ = d/dt (A v + b)` at `v = q̇`: one dual evaluation with `q + ε q̇`, `t + ε`.
fn velocity_constraint_drift<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    qd: &[S],
    p: &[S],
) -> Vec<S> {
    let qdual: Vec<Dual<S>> = q.iter().zip(qd).map(|(&a, &b)| Dual::new(a, b)).collect();
    let td = Dual::new(S::from(t), S::from(1.0));
    let mut out = vec![Dual::from_re(S::from(0.0)); L::VELOCITY_CONSTRAINTS];
    L::velocity_constraints(td, &qdual, &lift_dual(qd), &lift_dual(p), &mut out);
    out.into_iter().map(|v| v.eps).collect()
}

/// `γ = q̇ᵀ ∇²Φᵢ q̇ + 2 (∂Gᵢ/∂t) q̇ + ∂²Φᵢ/∂t²` for each constraint (the second derivative
/// of Φ along the motion, less G q̈): one hyper-dual evaluation of Φ at
/// `(q + (ε₁ + ε₂) q̇, t + ε₁ + ε₂)`.
pub fn constraint_curvature<L: Lagrangian, S: Scalar>(
    t: f64,
    q: &[S],
    qd: &[S],
    p: &[S],
) -> Vec<S> {
    let qh: Vec<HyperDual<S>> = q
        .iter()
        .zip(qd)
        .map(|(&qj, &vj)| HyperDual::new(qj, vj, vj, S::from(0.0)))
        .collect();
    let one = S::from(1.0);
    let th = HyperDual::new(S::from(t), one, one, S::from(0.0));
    let mut phi = vec![HyperDual::from_re(S::from(0.0)); L::CONSTRAINTS];
    L::constraints(th, &qh, &lift_hyper(p), &mut phi);
    phi.into_iter().map(|v| v.eps1eps2).collect()
}

/// `[M Gᵀ; G 0]`.
fn augmented<S: Scalar>(m: &[Vec<S>], g: &[Vec<S>]) -> Vec<Vec<S>> {
    let (n, k) = (m.len(), g.len());
    let zero = S::from(0.0);
    let mut a = vec![vec![zero; n + k]; n + k];
    for i in 0..n {
        a[i][..n].copy_from_slice(&m[i]);
        for (r, gr) in g.iter().enumerate() {
            a[i][n + r] = gr[i];
            a[n + r][i] = gr[i];
        }
    }
    a
}

/// Most Newton iterations of the position projection (it converges quadratically from
/// the O(tolerance) violation one step leaves; more means the constraints are singular).
pub const PROJECTION_ITERATIONS: usize = 8;

/// Coordinate projection (Hairer, Lubich, Wanner, *Geometric Numerical Integration*,
/// IV.4; Eich 1993): moves `q` onto `Φ(t, q) = 0` by Newton steps of the smallest kinetic
/// metric change, `[M Gᵀ; G 0] [Δq; μ] = [0; −Φ]`, then `q̇` onto `G q̇ + Φ_t = 0` and
/// `A q̇ + b = 0` the same way, all at the state's time t.
/// The M-metric makes the velocity correction the one that changes the kinetic energy
/// least. Leaves the state alone if a solve fails (non-finite result).
pub fn project_onto_constraints<L: Lagrangian>(t: f64, x: &mut [f64], p: &[f64]) {
    let n = split::<L>(x.len());
    let (q, rest) = x.split_at_mut(n);
    let qd = &mut rest[..n - L::surplus_coordinates()];
    let correct = |q: &[f64], qd: &[f64], rows: &[Vec<f64>], defect: Vec<f64>| {
        let m = mass_matrix::<L, f64>(t, q, qd, p);
        let mut a = augmented(&m, rows);
        let mut b = vec![0.0; n];
        b.extend(defect.into_iter().map(|d| -d));
        solve(&mut a, &mut b);
        b.truncate(n);
        b.iter().all(|v| v.is_finite()).then_some(b)
    };
    for _ in 0..PROJECTION_ITERATIONS {
        if L::CONSTRAINTS == 0 {
            break;
        }
        let phi = constraint_values::<L, f64>(t, q, p);
        let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        if phi.iter().all(|v| v.abs() <= 4.0 * f64::EPSILON * scale) {
            break;
        }
        let g = constraint_jacobian::<L, f64>(t, q, p);
        let Some(dq) = correct(q, qd, &g, phi) else {
            return;
        };
        q.iter_mut().zip(&dq).for_each(|(qi, d)| *qi += d);
    }
    let rows = all_constraint_rows::<L, f64>(t, q, p);
    let velocity_defect = velocity_residuals::<L, f64>(t, q, qd, p);
    if let Some(dv) = correct(q, qd, &rows, velocity_defect) {
        qd.iter_mut().zip(&dv).for_each(|(v, d)| *v += d);
    }
}

/// How far `x` is off the holonomic constraints, as a displacement of the state into
/// `defect` (zero on them): `Σᵢ Φᵢ gᵢ / max‖gᵢ‖²` over the positions and `Σᵢ (gᵢ·q̇) gᵢ /
/// max‖gᵢ‖²` over the velocities (gᵢ the rows of G). It reads the residuals without
/// inverting the constraints' Gram matrix, so at a singular position it stays their size,
/// where the projection's correction carries rounding amplified by 1/distance²
/// ([`crate::integrators::Problem::defect`]). Each row is scaled by the largest row's
/// norm, not its own: rows that vanish at a singular position (the N four-bar's vertical
/// closure rows when its rods lie flat) would divide their residuals' rounding by their
/// vanishing norm. `false` (nothing written) for what closed loops on a tree do not have:
/// time in the constraints, velocity constraints, surplus coordinates.
pub fn constraint_defect<L: Lagrangian>(x: &[f64], p: &[f64], defect: &mut [f64]) -> bool {
    if L::RHEONOMIC || L::VELOCITY_CONSTRAINTS > 0 || L::surplus_coordinates() > 0 {
        return false;
    }
    let n = split::<L>(x.len());
    let (q, qd) = (&x[..n], &x[n..2 * n]);
    let m = L::CONSTRAINTS;
    let (mut phi, mut g) = (vec![0.0; m], vec![0.0; m * n]);
    constraint_rows::<L>(q, p, &mut phi, &mut g);
    defect.fill(0.0);
    let norm2 = (g.chunks(n)).fold(0.0f64, |m, row| m.max(row.iter().map(|v| v * v).sum()));
    if norm2 > 0.0 {
        for (row, &phi) in g.chunks(n).zip(&phi) {
            let rate: f64 = row.iter().zip(qd).map(|(a, b)| a * b).sum();
            for (j, &gj) in row.iter().enumerate() {
                defect[j] += phi * gj / norm2;
                defect[n + j] += rate * gj / norm2;
            }
        }
    }
    true
}

/// Mechanical energy `E = T + V` at time t.
pub fn energy<L: Lagrangian, S: Scalar>(t: f64, q: &[S], qd: &[S], p: &[S]) -> S {
    L::kinetic(S::from(t), q, qd, p) + L::potential(S::from(t), q, p)
}

/// Solves `a x = b` in place (`b` becomes x) by Gaussian elimination with partial
/// pivoting, for small dense systems over any scalar. The pivot is the largest entry by
/// the absolute value of its real part, so dual-number evaluations follow the `f64`
/// path. A singular matrix (zero pivot) gives non-finite results, which the integrators
/// report as a failed step.
pub fn solve<S: Scalar>(a: &mut [Vec<S>], b: &mut [S]) {
    let n = b.len();
    for k in 0..n {
        let pivot = (k..n)
            .max_by(|&i, &j| a[i][k].re().abs().total_cmp(&a[j][k].re().abs()))
            .expect("k < n");
        a.swap(k, pivot);
        b.swap(k, pivot);
        let (upper, lower) = a.split_at_mut(k + 1);
        let row_k = &upper[k];
        let bk = b[k];
        for (row, bi) in lower.iter_mut().zip(&mut b[k + 1..]) {
            let f = row[k] / row_k[k];
            for (aij, &akj) in row[k + 1..].iter_mut().zip(&row_k[k + 1..]) {
                *aij -= f * akj;
            }
            *bi -= f * bk;
        }
    }
    for k in (0..n).rev() {
        let s = a[k][k + 1..]
            .iter()
            .zip(&b[k + 1..])
            .fold(b[k], |s, (&akj, &xj)| s - akj * xj);
        b[k] = s / a[k][k];
    }
}

/// A singular value below this fraction of the largest is taken as 0 by
/// [`least_squares`]: a redundant row's is rounding (~1e-16 of the largest at a closed
/// configuration), a genuine one is not within many orders of it.
pub const LEAST_SQUARES_RANK_RTOL: f64 = 1e-10;

/// The least-squares solution of least norm of `a x = b` (`a` by rows, any shape; empty
/// when `a` has no row) by the SVD, and `a`'s rank. What the square [`solve`] cannot do:
/// redundant loop closures (Bricard's five residuals of rank four) give more equations
/// than the unknowns they determine, and fewer independent ones than their multipliers.
pub fn least_squares(a: &[Vec<f64>], b: &[f64]) -> (Vec<f64>, usize) {
    let cols = a.first().map_or(0, Vec::len);
    if a.is_empty() || cols == 0 {
        return (vec![0.0; cols], 0);
    }
    let m = nalgebra::DMatrix::from_fn(a.len(), cols, |i, j| a[i][j]);
    let svd = m.svd(true, true);
    let eps = LEAST_SQUARES_RANK_RTOL * svd.singular_values.max();
    let rank = svd.rank(eps);
    match svd.solve(&nalgebra::DVector::from_column_slice(b), eps) {
        Ok(x) => (x.iter().copied().collect(), rank),
        Err(_) => (vec![f64::NAN; cols], rank),
    }
}

/// `a x = b` (`a` by rows) where `a` has full rank in its smaller dimension: square by
/// [`solve`] (Gaussian elimination, as every independent set of constraints), otherwise
/// (redundant constraints: more rows than unknowns, or the transpose for their
/// multipliers) by [`least_squares`]. `None` where `a` is short of that rank or the
/// result is not finite.
pub fn solve_full_rank(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let (rows, cols) = (a.len(), a.first().map_or(0, Vec::len));
    if rows == cols {
        solve(&mut a, &mut b);
        return b.iter().all(|v| v.is_finite()).then_some(b);
    }
    let (x, rank) = least_squares(&a, &b);
    (rank == rows.min(cols) && x.iter().all(|v| v.is_finite())).then_some(x)
}

/// Every Lagrangian is a second-order [`System`] with states `(q, q̇)`.
impl<L: Lagrangian> System for L {
    const NAME: &'static str = <L as Lagrangian>::NAME;
    const DESCRIPTION: &'static str = <L as Lagrangian>::DESCRIPTION;
    const EQUATIONS: &'static [&'static str] = <L as Lagrangian>::EQUATIONS;
    const DEFAULT_METHOD: crate::integrators::Method = L::DEFAULT_METHOD;

    /// `(q, q̇)` halves unless there are surplus coordinates or integrals.
    fn second_order() -> bool {
        L::surplus_coordinates() == 0 && L::integral_count() == 0
    }

    fn error_on_manifold() -> bool {
        <L as Lagrangian>::error_on_manifold()
    }

    fn constraint_defect(_t: f64, p: &[f64], x: &[f64], defect: &mut [f64]) -> bool {
        <L as Lagrangian>::error_on_manifold() && constraint_defect::<L>(x, p, defect)
    }

    fn name() -> &'static str {
        <L as Lagrangian>::name()
    }

    fn token_text(model_description: String) -> String {
        <L as Lagrangian>::token_text(model_description)
    }

    fn equations() -> &'static [&'static str] {
        <L as Lagrangian>::equations()
    }

    fn parameters() -> Vec<Var> {
        <L as Lagrangian>::parameters()
    }

    fn inputs() -> Vec<Var> {
        <L as Lagrangian>::inputs()
    }

    fn states() -> Vec<Var> {
        let (q, qd) = (L::coordinates(), L::velocities());
        assert_eq!(
            q.len(),
            qd.len() + L::surplus_coordinates(),
            "{}: as many velocities as coordinates (less the surplus ones)",
            <L as Lagrangian>::NAME
        );
        q.into_iter().chain(qd).chain(L::integrals()).collect()
    }

    fn outputs() -> Vec<Var> {
        <L as Lagrangian>::outputs()
    }

    // (Always inlined: the fixed-step doStep then has the equations in its stages.)
    #[inline(always)]
    fn derivatives<S: Scalar>(t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let n = split::<L>(x.len());
        let (q, qd, _) = parts::<L, S>(x);
        let (velocities, rest) = dx.split_at_mut(n);
        let (qdd, integrals) = rest.split_at_mut(qd.len());
        if L::surplus_coordinates() == 0 {
            velocities.copy_from_slice(qd);
        } else {
            L::coordinate_rates(q, qd, velocities);
        }
        accelerations_into::<L, S>(t, q, qd, u, p, qdd);
        if !integrals.is_empty() {
            L::integral_rates(t, q, qd, u, p, integrals);
        }
    }

    #[inline(always)]
    fn extra_outputs<S: Scalar>(t: f64, x: &[S], u: &[S], p: &[S], y: &mut [S]) {
        let (q, qd, _) = parts::<L, S>(x);
        <L as Lagrangian>::extra_outputs(t, q, qd, u, p, y);
    }

    fn scenes() -> Vec<Scene> {
        <L as Lagrangian>::scenes()
    }
    fn linearization_point() -> Vec<(String, f64)> {
        <L as Lagrangian>::linearization_point()
    }

    /// Time enters f and g through T, V, the constraints (rheonomic), or the forces and
    /// outputs when they say so.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        let t = L::RHEONOMIC || L::TIME_IN_FORCES_OR_OUTPUTS;
        (t, t)
    }

    fn default_experiment() -> (f64, f64, f64) {
        <L as Lagrangian>::default_experiment()
    }

    /// RATTLE handles holonomic, time-independent constraints only, on `(q, q̇)` only.
    fn mechanics<'a>(u: &'a [f64], p: &'a [f64]) -> Option<Box<dyn Mechanics + 'a>> {
        (L::VELOCITY_CONSTRAINTS == 0
            && !L::RHEONOMIC
            && L::surplus_coordinates() == 0
            && L::integral_count() == 0
            && !L::redundant_constraints())
        .then(|| Box::new(LagrangianMechanics::<L>::new(u, p)) as Box<dyn Mechanics + 'a>)
    }

    fn event_indicator(t: f64, x: &[f64], u: &[f64], p: &[f64]) -> Option<f64> {
        let (q, qd, _) = parts::<L, f64>(x);
        <L as Lagrangian>::event_indicator(t, q, qd, u, p)
    }

    fn on_event(t: f64, x: &mut [f64], u: &[f64], p: &[f64]) -> Result<(), String> {
        let n = split::<L>(x.len());
        let (q, rest) = x.split_at_mut(n);
        let qd = &mut rest[..n - L::surplus_coordinates()];
        <L as Lagrangian>::on_event(t, q, qd, u, p)
    }

    fn impacts() -> bool {
        <L as Lagrangian>::impacts()
    }

    fn project(t: f64, p: &[f64], x: &mut [f64]) {
        if L::surplus_coordinates() > 0 {
            let n = split::<L>(x.len());
            L::normalize(&mut x[..n]);
        }
        if L::CONSTRAINTS + L::VELOCITY_CONSTRAINTS > 0
            && (L::RHEONOMIC || !L::generated_projection(p, x))
        {
            project_onto_constraints::<L>(t, x, p);
        }
    }

    /// Φ(t, q), G q̇ + Φ_t and A q̇ + b at the time t (the start time at initialisation):
    /// the coordinates and velocities a user sets must satisfy all three; the dependent
    /// ones are declared on `coordinates` and `velocities`.
    const STATE_CONSTRAINTS: usize = 2 * L::CONSTRAINTS + L::VELOCITY_CONSTRAINTS;

    fn state_constraints<S: Scalar>(t: f64, x: &[S], p: &[S], residual: &mut [S]) -> bool {
        let (q, qd, _) = parts::<L, S>(x);
        let m = L::CONSTRAINTS;
        L::constraints(S::from(t), q, p, &mut residual[..m]);
        residual[m..].copy_from_slice(&velocity_residuals::<L, S>(t, q, qd, p));
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    #[test]
    fn solve_pivots_and_differentiates() {
        // [[0, 2], [3, 1]] x = [4, 5] needs a row swap: x = (1, 2).
        let mut a = vec![vec![0.0, 2.0], vec![3.0, 1.0]];
        let mut b = vec![4.0f64, 5.0];
        solve(&mut a, &mut b);
        assert!((b[0] - 1.0).abs() < 1e-15 && (b[1] - 2.0).abs() < 1e-15);
        // d/ds of the solution of [[s, 1], [1, 2]] x = [1, 0] at s = 1:
        // x = (2, −1)/(2s − 1), dx/ds = −2 (2, −1)/(2s − 1)² = (−4, 2).
        let s = Dual64::new(1.0, 1.0);
        let one = Dual64::from(1.0);
        let mut a = vec![vec![s, one], vec![one, Dual64::from(2.0)]];
        let mut b = vec![one, Dual64::from(0.0)];
        solve(&mut a, &mut b);
        assert!((b[0].eps + 4.0).abs() < 1e-14 && (b[1].eps - 2.0).abs() < 1e-14);
    }
}
