//! The one place a system is declared: its variables and its dynamics.
//!
//! A system knows nothing about FMI. It lists its parameters, inputs, states and
//! extra outputs once ([`Var`]), writes `ẋ = f(t, x, u, p)` and `y = g(t, x, u, p)`
//! generic over the scalar type ([`Scalar`]) so that exact derivatives come from
//! dual numbers, and ships its scenes. Value references, modelDescription.xml,
//! ModelStructure and the C glue are all derived from this declaration.

pub mod consistent;
pub mod jacobian;
pub mod kinematics;
pub mod lagrangian;
mod layout;
pub mod probe;
mod scene;
pub mod symbolic;

pub use layout::{Layout, Slot, VarKind, DEFAULT_SOLVER_MAX_STEPS};
pub use probe::Probe;
pub use scene::Scene;

use crate::integrators::problem::Mechanics;
use num_dual::DualNum;
use std::borrow::Cow;

/// The scalar a right-hand side is written in: `f64` for simulation, dual numbers
/// for exact Jacobians.
pub trait Scalar: DualNum<Primitive = f64> + Copy {}
impl<T: DualNum<Primitive = f64> + Copy> Scalar for T {}

/// One declared variable of a system.
#[derive(Clone, Debug, PartialEq)]
pub struct Var {
    pub name: Cow<'static, str>,
    pub description: Cow<'static, str>,
    /// SI unit symbol, as declared in UnitDefinitions (`None` for dimensionless).
    pub unit: Option<Cow<'static, str>>,
    pub start: f64,
    pub min: Option<f64>,
    pub max: Option<f64>,
    /// Typical magnitude; scales the integrator's absolute tolerance for states.
    pub nominal: Option<f64>,
    /// A state the constraints determine from the others (see [`consistent`]):
    /// initialisation solves for it, and its start value is only the guess that picks
    /// the root (FMI `initial="approx"`).
    pub dependent: bool,
    /// The FMI type: Real, unless a parameter was declared [`Var::integer`] or
    /// [`Var::enumeration`].
    pub ty: VarType,
}

/// One item of an enumeration parameter: (name, description). Its value (code) is its
/// position in the list: 0, 1, 2, …
pub type Item = (&'static str, &'static str);

/// The FMI type of a variable. Only a parameter may be other than [`VarType::Real`]; such a
/// parameter still lives in the model's `p` as an `f64` (its code: 0.0, 1.0, …), and the FMU
/// reads and writes it with fmi2Get/SetInteger (FMI 3.0: fmi3Get/SetInt32 for an Integer,
/// fmi3Get/SetInt64 for an Enumeration), never with fmi2Get/SetReal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarType {
    Real,
    /// FMI 2.0 `Integer`, FMI 3.0 `Int32`.
    Integer,
    /// FMI `Enumeration` of these items, values 0, 1, 2, … in order. Its type in the
    /// modelDescription is named [`Var::type_name`].
    Enumeration(&'static [Item]),
}

impl Var {
    pub const fn new(
        name: &'static str,
        unit: Option<&'static str>,
        start: f64,
        description: &'static str,
    ) -> Self {
        let unit = match unit {
            Some(u) => Some(Cow::Borrowed(u)),
            None => None,
        };
        Var {
            name: Cow::Borrowed(name),
            description: Cow::Borrowed(description),
            unit,
            start,
            min: None,
            max: None,
            nominal: None,
            dependent: false,
            ty: VarType::Real,
        }
    }

    pub const fn min(mut self, min: f64) -> Self {
        self.min = Some(min);
        self
    }

    pub const fn max(mut self, max: f64) -> Self {
        self.max = Some(max);
        self
    }

    pub const fn nominal(mut self, nominal: f64) -> Self {
        self.nominal = Some(nominal);
        self
    }

    /// Marks a state as dependent: computed from the independent states through the
    /// system's [`System::state_constraints`] at initialisation.
    pub const fn dependent(mut self) -> Self {
        self.dependent = true;
        self
    }

    /// Makes a parameter an FMI Integer (FMI 3.0: Int32): set and read with
    /// fmi2Set/GetInteger, its values whole numbers (inside `[min, max]` when given, and in
    /// the range of an i32). The model still reads it from `p` as an `f64`.
    pub const fn integer(mut self) -> Self {
        self.ty = VarType::Integer;
        self
    }

    /// Makes a parameter an FMI Enumeration of `items` (name, description), whose values
    /// are 0, 1, 2, … in order: only those codes are accepted (the range is the items'; no
    /// `min`/`max` is needed). The start value is a code (`Var::new(…, 1.0, …)`: the second
    /// item). Set and read with fmi2Set/GetInteger (FMI 3.0: fmi3Set/GetInt64); the model reads the code
    /// from `p` as an `f64` (0.0, 1.0, …). The modelDescription declares its type under the
    /// name [`Var::type_name`].
    pub const fn enumeration(mut self, items: &'static [Item]) -> Self {
        assert!(!items.is_empty(), "an enumeration has at least one item");
        self.ty = VarType::Enumeration(items);
        self
    }

    /// Whether the FMU reads and writes this variable as an FMI Integer or Enumeration
    /// (fmi2Get/SetInteger) rather than a Real.
    pub fn is_integer(&self) -> bool {
        self.ty != VarType::Real
    }

    /// The name of an enumeration's type in the modelDescription (FMI 2.0 `SimpleType`,
    /// FMI 3.0 `EnumerationType`): the variable's name in UpperCamelCase, each part between
    /// underscores (or other characters not letters or digits) capitalised and joined:
    /// `limit_events` → `LimitEvents`, `mode` → `Mode`. (FMI 2.0 forbids a type named as a
    /// variable, so it cannot be the name itself; [`Layout::of`] refuses a name that
    /// collides.) `None` for a variable of another type.
    pub fn type_name(&self) -> Option<String> {
        let VarType::Enumeration(_) = self.ty else {
            return None;
        };
        let mut out = String::new();
        for part in self.name.split(|c: char| !c.is_ascii_alphanumeric()) {
            let mut chars = part.chars();
            if let Some(first) = chars.next() {
                out.extend(first.to_uppercase());
                out.push_str(chars.as_str());
            }
        }
        Some(out)
    }

    /// The codes and names of an enumeration, as its messages list them: `0 = off, 1 = on`.
    pub fn items_text(&self) -> Option<String> {
        let VarType::Enumeration(items) = self.ty else {
            return None;
        };
        Some(
            items
                .iter()
                .enumerate()
                .map(|(code, (name, _))| format!("{code} = {name}"))
                .collect::<Vec<_>>()
                .join(", "),
        )
    }

    /// Whether `value` is a legal value of this variable: finite and inside
    /// `[min, max]`; for an Integer a whole number an i32 holds, for an Enumeration one of
    /// its codes. The message names the variable and is the same wherever a value comes in
    /// (fmi2SetReal, fmi2SetInteger, a restored FMU state, `mbfmu linearize --set`, a
    /// scene).
    pub fn check(&self, value: f64) -> Result<(), String> {
        if !value.is_finite() {
            return Err(format!("value {value} for {} is not finite", self.name));
        }
        if let VarType::Enumeration(items) = self.ty {
            if value < 0.0 || value.fract() != 0.0 || value >= items.len() as f64 {
                return Err(format!(
                    "value {value} for {} is not one of its codes ({})",
                    self.name,
                    self.items_text().expect("an enumeration")
                ));
            }
            return Ok(());
        }
        if self.ty == VarType::Integer
            && (value.fract() != 0.0 || value < i32::MIN as f64 || value > i32::MAX as f64)
        {
            return Err(format!(
                "value {value} for {} is not an Integer (a whole number in [{}, {}])",
                self.name,
                i32::MIN,
                i32::MAX
            ));
        }
        if self.min.is_some_and(|min| value < min) || self.max.is_some_and(|max| value > max) {
            return Err(format!(
                "value {value} for {} is outside [{:?}, {:?}]",
                self.name,
                self.min.unwrap_or(f64::NEG_INFINITY),
                self.max.unwrap_or(f64::INFINITY)
            ));
        }
        Ok(())
    }
}

/// A mechanical system in state-space form `ẋ = f(t, x, u, p)`, `y = g(t, x, u, p)`.
///
/// The states are outputs too (FMI 2.0 co-simulation sets initial states through
/// the start values of outputs); `outputs` lists only the extra ones (energy, …).
pub trait System: 'static {
    /// The FMU's modelIdentifier.
    const NAME: &'static str;
    /// One line: what the system is.
    const DESCRIPTION: &'static str;
    /// Equations and notes for the FMU's documentation (plain text, one per line).
    const EQUATIONS: &'static [&'static str];

    /// The modelIdentifier the FMU has: [`System::NAME`], but for a model whose identity is
    /// read at run time (the mechanism runtime: the robot's name from its resources).
    fn name() -> &'static str {
        Self::NAME
    }

    /// [`System::EQUATIONS`], but for a model whose notes are made at run time (the
    /// mechanism runtime: what its robot does not model).
    fn equations() -> &'static [&'static str] {
        Self::EQUATIONS
    }

    /// What the instantiation token is a hash of, given the modelDescription rendered
    /// without it: that text. The mechanism runtime's instead: its robot's URDF and name
    /// and its variables, which every platform reads alike (its XML holds start values
    /// computed with the platform's sin and cos, whose last bits differ between libms).
    fn token_text(model_description: String) -> String {
        model_description
    }

    fn parameters() -> Vec<Var>;
    fn inputs() -> Vec<Var>;
    fn states() -> Vec<Var>;
    fn outputs() -> Vec<Var>;

    /// `dx = f(t, x, u, p)`, every component of `dx` written: the integrators reuse
    /// their buffers between calls, so a component left alone holds an old value, not 0.
    /// The in-tree systems mark it `#[inline(always)]`: the fixed-step doStep then has the
    /// equations in its RK4 stages, the slices' lengths known (no call, no index checks:
    /// MassSpringDamper's doStep 545 → 449 instructions); the compiler does not inline a
    /// generic function of this size by itself.
    fn derivatives<S: Scalar>(t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]);

    /// `y = g(t, x, u, p)`, the extra outputs only, every component of `y` written (as
    /// for [`System::derivatives`]).
    fn extra_outputs<S: Scalar>(t: f64, x: &[S], u: &[S], p: &[S], y: &mut [S]);

    /// The configured experiments of this system.
    fn scenes() -> Vec<Scene>;

    /// Start values (by name) of the operating point the FMU's shipped linearisation, its
    /// page and `mbfmu linearize` without `--scene` are taken at, over the start values: a
    /// stable equilibrium where the start values are not one (a mechanism started moving).
    /// Default: none (the start values themselves).
    fn linearization_point() -> Vec<(String, f64)> {
        Vec::new()
    }

    /// Whether `f` (first) and `g` (second) depend on `t` other than through x and u, with
    /// these parameters. `t` is an `f64` in them, so dual numbers cannot carry ∂/∂t: the
    /// exact output derivatives (fmi2GetRealOutputDerivatives) that would need it are
    /// refused, never approximated. Default: both (a system that does not say).
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (true, true)
    }

    /// True when the states are (q, q̇) halves with dq/dt = q̇: the symplectic fixed-step
    /// methods (symplectic Euler, Verlet) need that split. (A function, not a constant: a
    /// mechanism loaded at run time may have a floating base, whose quaternion breaks it.)
    fn second_order() -> bool {
        false
    }

    /// True when [`System::project`] maps the state onto constraints whose neighbourhood
    /// the projection leaves: the adaptive methods then measure each step's error between
    /// projected solutions ([`crate::integrators::Problem::error_on_manifold`]). Near a
    /// singular position of a closed loop the constraint forces carry rounding amplified by
    /// 1/distance², all of it off the manifold; measured raw, it shrinks the steps until the
    /// work bound is spent. (A function: a mechanism loaded at run time decides it.)
    fn error_on_manifold() -> bool {
        false
    }

    /// With [`System::error_on_manifold`]: how far `x` is off the constraints, as a
    /// displacement of the state written into `defect` (zero on them); the adaptive methods
    /// hold what a step adds to it to the tolerance ([`crate::integrators::Problem::defect`]).
    /// `false` (the default): not measured.
    fn constraint_defect(_t: f64, _p: &[f64], _x: &[f64], _defect: &mut [f64]) -> bool {
        false
    }

    /// The `solver` start value: DOPRI5 (the default) for smooth, non-stiff motion; a
    /// stiff system's own choice (RADAU5 for the flyball governor's stiff dampers), so
    /// that its default experiment runs as it should without a setting.
    const DEFAULT_METHOD: crate::integrators::Method = crate::integrators::Method::Dopri5;

    /// DefaultExperiment: stop time, relative tolerance, communication step size.
    fn default_experiment() -> (f64, f64, f64) {
        (10.0, 1e-8, 1e-2)
    }

    /// Puts `x` back on the constraint manifold (position and velocity constraints),
    /// for systems that integrate surplus coordinates with multipliers. Called on the
    /// initial state at fmi2ExitInitializationMode and after every doStep, so drift
    /// cannot accumulate across communication steps. Unconstrained systems keep the
    /// default, which does nothing.
    fn project(_t: f64, _p: &[f64], _x: &mut [f64]) {}

    /// How many residuals [`System::state_constraints`] returns: as many as states
    /// declared [`Var::dependent`]. 0 (the default): no constraints on the state.
    const STATE_CONSTRAINTS: usize = 0;

    /// The constraints the state must satisfy, as residuals that vanish on them (position
    /// constraints Φ(q) = 0 and velocity constraints G q̇ = 0, A(q) q̇ = 0), generic over
    /// the scalar so that initialisation solves them for the dependent states with an
    /// exact Jacobian ([`consistent::solve`]). Returns false where the system holds no
    /// constraint at this state (a mode: SphereSlide in free flight). Default: none.
    fn state_constraints<S: Scalar>(_t: f64, _x: &[S], _p: &[S], _residual: &mut [S]) -> bool {
        false
    }

    /// The mechanical structure RATTLE needs (mass matrix, generalized force, holonomic
    /// constraints) with these inputs and parameters, for systems written as a
    /// [`lagrangian::Lagrangian`]; `None` (the default) for the others, which then refuse solver RATTLE.
    fn mechanics<'a>(_u: &'a [f64], _p: &'a [f64]) -> Option<Box<dyn Mechanics + 'a>> {
        None
    }

    /// Whether `ẋ = f(t, x, u, p)` is affine in x and u and independent of t with these
    /// parameters: then the exact propagator (solver `ExactLinear`) integrates it without
    /// truncation error for inputs held over a doStep. Default: no.
    fn linear_time_invariant(_p: &[f64]) -> bool {
        false
    }

    /// An event indicator: a function of the state whose sign change is an event (a
    /// one-sided constraint letting go, an impact). `None` (the default): no events.
    /// The FMU locates a sign change inside doStep to the time resolution of the
    /// integration (bisection on re-integrations from the step start), calls
    /// [`System::on_event`] there and continues: an event is never stepped over.
    fn event_indicator(_t: f64, _x: &[f64], _u: &[f64], _p: &[f64]) -> Option<f64> {
        None
    }

    /// Applies an event at time `t` (inputs `u` as they are there): changes the discrete part of the state (a mode
    /// variable the dynamics hold constant) or the state itself (an impact), and returns
    /// `Ok`; or returns `Err(why)` where the model stops holding (a bicycle that has
    /// fallen): the integration stops at the event and doStep answers fmi2Discard there.
    fn on_event(_t: f64, _x: &mut [f64], _u: &[f64], _p: &[f64]) -> Result<(), String> {
        Ok(())
    }

    /// Whether [`System::on_event`] may change every state (an impact: a position put on
    /// its stop, every velocity changed by the impulse), which probing it at the start
    /// values would not show: Model Exchange then declares every state `reinit`. Default:
    /// no (what the probe finds).
    fn impacts() -> bool {
        false
    }
}
