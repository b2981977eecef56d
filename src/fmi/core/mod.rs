//! The instance core, shared by the interfaces: one FMU instance with what Co-Simulation
//! and Model Exchange have in common — the modes, variables get/set and
//! their checks, parameters and the states' start values, initialisation (consistent
//! states, projection), directional derivatives from the model's f and g, and the FMU
//! state (snapshot, its checks and its blob). The interfaces add their own calls in
//! [`cs`] (doStep around an integrator) and [`me`] (time, states,
//! derivatives and events set and read by the importer's solver). Safe code: pointers were
//! checked by the front-ends ([`boundary`](crate::fmi::boundary)).
//!
//! A rejected call has no effect: every argument is checked before anything changes.

pub mod cs;
pub mod info;
pub mod inputs;
pub mod logger;
pub mod me;
pub mod mode;
pub mod snapshot;

use crate::integrators::problem::Problem;
use crate::integrators::{self, finite, zeroed, Memory, Method, Settings, Workspace};
use crate::model::consistent;
use crate::model::jacobian::{Direction, Duals};
use crate::model::{Slot, System, Var, VarKind, VarType};
use info::{ModelInfo, Status};
use logger::Logger;
use mode::{Interface, Mode};
use snapshot::Snapshot;
use std::cell::RefCell;
use std::marker::PhantomData;

pub struct Instance<M: System> {
    pub info: &'static ModelInfo,
    pub logger: Logger,
    pub(super) data: Snapshot,
    /// The values at instantiation, restored by fmi2Reset.
    initial: Snapshot,
    /// Bound on the adaptive methods' step (∞: none). Rust API only, for reference runs
    /// ([`Instance::cap_adaptive_step`]); not an FMU variable, not part of the FMU state.
    pub(super) adaptive_max_step: f64,
    /// Which states the user set since instantiation (or fmi2Reset): a dependent state
    /// set to a value the constraints contradict is reported at initialisation.
    states_set: Vec<bool>,
    /// The scratch of doStep and the getters (see [`Work`]); not part of the FMU state.
    pub(super) work: RefCell<Work>,
    _model: PhantomData<M>,
}

/// What doStep and the getters work in: capacity kept between calls, so that a call in
/// steady state allocates nothing. It holds no information: the settings are derived from
/// the instance's values (and refreshed when they change), every buffer is written before
/// it is read, and a restored FMU state runs the same with a fresh one.
#[derive(Default)]
pub(super) struct Work {
    /// The integrators' settings for the running experiment, absolute tolerances included
    /// (recomputed only when the tolerance changes).
    pub(super) settings: Option<Settings>,
    /// The state under integration, and its start (the event search's).
    pub(super) x: Vec<f64>,
    pub(super) x0: Vec<f64>,
    /// The extra outputs, the state derivatives (fmi2GetReal), and the directional
    /// derivative's seeds (states, inputs, parameters) and results (f, extra outputs).
    pub(super) y: Vec<f64>,
    pub(super) dx: Vec<f64>,
    pub(super) seeds: [Vec<f64>; 3],
    pub(super) sensitivities: [Vec<f64>; 2],
    /// Dual numbers for the Jacobian and the directional derivatives.
    pub(super) duals: Duals,
    /// The inputs at a time inside doStep when they move (input derivatives set): one
    /// buffer each for the right-hand side, the Jacobian and the event indicator.
    pub(super) u_at: [Vec<f64>; 3],
    pub(super) integrators: Workspace,
    /// doStep ends right after the first event inside it (FMI 3.0's early return,
    /// [`Instance::do_step_until_event`]).
    pub(super) stop_at_event: bool,
}

pub(super) type Res<T = ()> = Result<T, String>;

impl<M: System> Instance<M> {
    /// A Co-Simulation instance (what fmi2Instantiate with fmi2CoSimulation makes).
    pub fn new(info: &'static ModelInfo, logger: Logger) -> Self {
        Self::for_interface(info, logger, Interface::CoSimulation)
    }

    /// A Model Exchange instance (fmi2Instantiate with fmi2ModelExchange).
    pub fn new_model_exchange(info: &'static ModelInfo, logger: Logger) -> Self {
        Self::for_interface(info, logger, Interface::ModelExchange)
    }

    pub fn for_interface(info: &'static ModelInfo, logger: Logger, interface: Interface) -> Self {
        let layout = &info.layout;
        let start = |kind: VarKind| -> Vec<f64> {
            layout
                .vars
                .iter()
                .filter(|(s, _)| s.kind == kind)
                .map(|(_, v)| v.start)
                .collect()
        };
        let data = Snapshot {
            params: start(VarKind::Parameter),
            x: start(VarKind::State),
            u: start(VarKind::Input),
            u_der: [vec![0.0; layout.n_inputs], vec![0.0; layout.n_inputs]],
            method: Method::from_code(start(VarKind::SolverMethod)[0] as i32)
                .expect("default method exists"),
            solver_step: start(VarKind::SolverStep)[0],
            max_steps: start(VarKind::SolverMaxSteps)[0] as u64,
            time: 0.0,
            start_time: 0.0,
            stop_time: None,
            tolerance: info.default_tolerance,
            memory: Memory::default(),
            mode: Mode::Instantiated,
            interface,
            me_projection: start(VarKind::MeProjection)[0] != 0.0,
            event_reference: None,
        };
        Instance {
            info,
            logger,
            initial: data.clone(),
            data,
            adaptive_max_step: f64::INFINITY,
            states_set: vec![false; layout.n_states],
            work: RefCell::default(),
            _model: PhantomData,
        }
    }

    pub fn mode(&self) -> Mode {
        self.data.mode
    }

    pub fn interface(&self) -> Interface {
        self.data.interface
    }

    /// Moves to the error state (after a panic was caught: nothing can be trusted).
    pub fn poison(&mut self) {
        self.data.mode = Mode::Error;
    }

    pub fn time(&self) -> f64 {
        self.data.time
    }

    pub fn stats(&self) -> integrators::Stats {
        self.data.memory.stats
    }

    /// Bounds the adaptive methods' step by `h_max` (> 0; ∞ removes the bound). For
    /// reference runs that must be more accurate than their tolerance alone makes them
    /// (`mbfmu bench`); importers have no such variable: the adaptive step is the
    /// controller's.
    pub fn cap_adaptive_step(&mut self, h_max: f64) {
        assert!(h_max > 0.0, "a step bound is positive");
        self.adaptive_max_step = h_max;
    }

    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Res {
        check_experiment(tolerance, start_time, stop_time)?;
        self.data.tolerance = tolerance.unwrap_or(self.info.default_tolerance);
        self.data.start_time = start_time;
        self.data.time = start_time;
        self.data.stop_time = stop_time;
        Ok(())
    }

    pub fn enter_initialization_mode(&mut self) -> Res {
        self.data.mode = Mode::Initializing;
        Ok(())
    }

    /// fmi2Warning when a value the user set had to give way to the constraints (logged).
    pub fn exit_initialization_mode(&mut self) -> Res<Status> {
        let d = &self.data;
        let mut x = d.x.clone();
        // A constrained system keeps the independent states as set and solves the
        // constraints for the dependent ones; a dependent value set that the constraints
        // contradict is reported (a warning), never silently replaced.
        let mut adjusted = Vec::new();
        if M::STATE_CONSTRAINTS > 0 {
            consistent::solve::<M>(d.time, &d.params, &mut x)?;
            adjusted = consistent::overridden::<M>(
                &self.info.layout,
                d.time,
                &d.params,
                &self.states_set,
                &d.x,
                &x,
            );
        } else {
            M::project(d.time, &d.params, &mut x);
        }
        let mut dx = vec![0.0; x.len()];
        M::derivatives(d.time, &x, &d.u, &d.params, &mut dx);
        let mut y = vec![0.0; self.info.layout.n_outputs];
        M::extra_outputs(d.time, &x, &d.u, &d.params, &mut y);
        if let Some(i) = x.iter().chain(&dx).chain(&y).position(|v| !v.is_finite()) {
            let n = x.len();
            let name = if i < n {
                self.state_name(i).to_string()
            } else if i < 2 * n {
                format!("der({})", self.state_name(i - n))
            } else {
                let vr = self.info.layout.vr_of_slot(VarKind::Output, i - 2 * n);
                self.name(vr).to_string()
            };
            return Err(format!(
                "{name} is not finite at the initial point (check the parameters and start values)"
            ));
        }
        if d.method.needs_linear_time_invariant() && !M::linear_time_invariant(&d.params) {
            return Err(format!(
                "solver {} needs a linear time-invariant system; {} with these parameters is not",
                d.method.name(),
                M::name()
            ));
        }
        for line in &adjusted {
            self.logger.failure(Status::Warning, line);
        }
        self.data.x = x;
        self.data.memory = Memory::default();
        match self.data.interface {
            Interface::CoSimulation => {
                self.data.mode = Mode::Stepping;
                self.prepare_steps();
            }
            // Model Exchange: event mode, where fmi2NewDiscreteStates may be called; a sign
            // change of the indicator from here on is an event.
            Interface::ModelExchange => {
                let d = &mut self.data;
                d.event_reference = M::event_indicator(d.time, &d.x, &d.u, &d.params);
                d.mode = Mode::Event;
            }
        }
        Ok(if adjusted.is_empty() {
            Status::Ok
        } else {
            Status::Warning
        })
    }

    pub fn terminate(&mut self) -> Res {
        self.data.mode = Mode::Terminated;
        Ok(())
    }

    pub fn reset(&mut self) -> Res {
        self.data = self.initial.clone();
        self.states_set.fill(false);
        Ok(())
    }

    pub(super) fn state_name(&self, i: usize) -> &str {
        let vr = self.info.layout.vr_of_slot(VarKind::State, i);
        &self.info.layout.vars[vr as usize].1.name
    }

    pub(super) fn slot(&self, vr: u32) -> Res<Slot> {
        self.info.layout.slot(vr).ok_or_else(|| {
            format!(
                "unknown value reference {vr} (this model has 0 … {})",
                self.info.layout.vars.len() - 1
            )
        })
    }

    pub(super) fn name(&self, vr: u32) -> &str {
        &self.info.layout.vars[vr as usize].1.name
    }

    /// The declaration of a value reference already checked ([`Instance::slot`]).
    fn var(&self, vr: u32) -> &Var {
        &self.info.layout.vars[vr as usize].1
    }

    /// Sets one variable from an `f64`, whatever its FMI type: an Integer or Enumeration
    /// (`solver`, `solver_max_steps`, `me_projection`, a parameter declared
    /// [`Var::integer`] or [`Var::enumeration`]) through [`Instance::set_integer`], every
    /// other through [`Instance::set_real`], so that it meets that setter's checks. What a
    /// scene's start values and the Rust callers that hold numbers use.
    pub fn set_value(&mut self, vr: u32, value: f64) -> Res {
        let slot = self.slot(vr)?;
        if integer_kind(slot, self.var(vr)).is_none() {
            return self.set_real(&[vr], &[value]);
        }
        if value.fract() != 0.0 || !(i32::MIN as f64..=i32::MAX as f64).contains(&value) {
            return Err(format!(
                "{} (value reference {vr}) is an Integer or Enumeration: {value} is not one of its values",
                self.name(vr)
            ));
        }
        self.set_integer(&[vr], &[value as i32])
    }

    /// Reads one variable as an `f64`, whatever its FMI type ([`Instance::set_value`]'s
    /// twin).
    pub fn get_value(&self, vr: u32) -> Res<f64> {
        let slot = self.slot(vr)?;
        if integer_kind(slot, self.var(vr)).is_none() {
            let mut v = [0.0];
            self.get_real(&[vr], &mut v)?;
            return Ok(v[0]);
        }
        let mut v = [0];
        self.get_integer(&[vr], &mut v)?;
        Ok(v[0] as f64)
    }

    pub fn get_real(&self, vrs: &[u32], values: &mut [f64]) -> Res {
        for &vr in vrs {
            let s = self.slot(vr)?;
            if let Some(kind) = integer_kind(s, self.var(vr)) {
                return Err(format!(
                    "value reference {vr} ({}) is an {kind}, read it with {}",
                    self.name(vr),
                    self.logger.words.get_integer
                ));
            }
        }
        let d = &self.data;
        let mut work = self.work.borrow_mut();
        let Work { dx, y, .. } = &mut *work;
        let (mut have_dx, mut have_y) = (false, false);
        for (value, &vr) in values.iter_mut().zip(vrs) {
            let slot = self.info.layout.vars[vr as usize].0;
            *value = match slot.kind {
                VarKind::Parameter => d.params[slot.index],
                VarKind::SolverStep => d.solver_step,
                VarKind::State => d.x[slot.index],
                VarKind::Input => d.u[slot.index],
                VarKind::Derivative => {
                    if !have_dx {
                        M::derivatives(d.time, &d.x, &d.u, &d.params, zeroed(dx, d.x.len()));
                        have_dx = true;
                    }
                    dx[slot.index]
                }
                VarKind::Output => {
                    if !have_y {
                        let y = zeroed(y, self.info.layout.n_outputs);
                        M::extra_outputs(d.time, &d.x, &d.u, &d.params, y);
                        have_y = true;
                    }
                    y[slot.index]
                }
                VarKind::SolverMethod | VarKind::SolverMaxSteps | VarKind::MeProjection => {
                    unreachable!("rejected above")
                }
            };
        }
        if let Some(i) = values.iter().position(|v| !finite(*v)) {
            return Err(self.not_finite(vrs[i], values[i]));
        }
        Ok(())
    }

    /// Why `value` cannot be returned for `vr`: it is not finite at this configuration (a
    /// dead centre, a singular constraint Jacobian, values set that do not fit together).
    #[cold]
    pub(super) fn not_finite(&self, vr: u32, value: f64) -> String {
        format!(
            "{} = {value} is not finite at {} (a singular configuration, or values set that do not fit together)",
            self.name(vr),
            self.configuration()
        )
    }

    /// The time and the states, as a log line names a configuration.
    fn configuration(&self) -> String {
        let d = &self.data;
        let states = (0..d.x.len())
            .map(|i| format!("{} = {}", self.state_name(i), d.x[i]))
            .collect::<Vec<_>>()
            .join(", ");
        format!("t = {}, {states}", d.time)
    }

    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Res {
        let mut slots = Vec::with_capacity(vrs.len());
        for (&vr, &value) in vrs.iter().zip(values) {
            let slot = self.slot(vr)?;
            let (_, var) = &self.info.layout.vars[vr as usize];
            let name = &var.name;
            if let Some(kind) = integer_kind(slot, var) {
                return Err(format!(
                    "{name} (value reference {vr}) is an {kind}, set it with {}",
                    self.logger.words.set_integer
                ));
            }
            match slot.kind {
                VarKind::Derivative | VarKind::Output => {
                    return Err(format!(
                        "{name} (value reference {vr}) is calculated by the model and cannot be set"
                    ))
                }
                VarKind::SolverMethod | VarKind::SolverMaxSteps | VarKind::MeProjection => {
                    unreachable!("an Integer, refused above")
                }
                VarKind::State if var.dependent => {
                    if self.data.mode != Mode::Instantiated {
                        return Err(format!(
                            "{name} (value reference {vr}) is computed from the constraints (initial=\"approx\": its value is only the starting guess) and can only be set before {}",
                            self.logger.words.enter_initialization_mode
                        ));
                    }
                }
                VarKind::Parameter | VarKind::SolverStep | VarKind::State => {
                    if !self.data.mode.before_init_done() {
                        return Err(format!(
                            "{name} (value reference {vr}) can only be set before {}",
                            self.logger.words.exit_initialization_mode
                        ));
                    }
                }
                VarKind::Input => {}
            }
            check_real(var, vr, value)?;
            slots.push(slot);
        }
        let d = &mut self.data;
        for (slot, &value) in slots.into_iter().zip(values) {
            match slot.kind {
                VarKind::Parameter => d.params[slot.index] = value,
                VarKind::SolverStep => d.solver_step = value,
                VarKind::State => {
                    d.x[slot.index] = value;
                    self.states_set[slot.index] = true;
                }
                VarKind::Input => {
                    // A new input value changes f: the integrator's point ahead of the
                    // communication time no longer holds. The same value keeps it.
                    if d.u[slot.index].to_bits() != value.to_bits() {
                        d.memory.drop_ahead();
                    }
                    d.u[slot.index] = value
                }
                _ => unreachable!("rejected above"),
            }
        }
        Ok(())
    }

    pub fn get_integer(&self, vrs: &[u32], values: &mut [i32]) -> Res {
        let slots = vrs
            .iter()
            .map(|&vr| self.integer_slot(vr))
            .collect::<Res<Vec<Slot>>>()?;
        for (value, slot) in values.iter_mut().zip(slots) {
            *value = match slot.kind {
                VarKind::SolverMethod => self.data.method.code(),
                VarKind::MeProjection => self.data.me_projection as i32,
                // A whole number an i32 holds: the setter's check (and a restored state's).
                VarKind::Parameter => self.data.params[slot.index] as i32,
                // At most i32::MAX: the setter's range (and a restored state's).
                _ => self.data.max_steps as i32,
            };
        }
        Ok(())
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Res {
        let (mut method, mut max_steps) = (self.data.method, self.data.max_steps);
        let mut me_projection = self.data.me_projection;
        // The Integer and Enumeration parameters set (index, value): written after every
        // check passed. Empty (no allocation) when the call sets none.
        let mut params = Vec::new();
        let mut sets_method = false;
        for (&vr, &value) in vrs.iter().zip(values) {
            let slot = self.integer_slot(vr)?;
            let (_, var) = &self.info.layout.vars[vr as usize];
            let name = &var.name;
            if !self.data.mode.before_init_done() {
                return Err(format!(
                    "{name} (value reference {vr}) can only be set before {}",
                    self.logger.words.exit_initialization_mode
                ));
            }
            if slot.kind == VarKind::SolverMaxSteps {
                check_real(var, vr, value as f64)?;
                max_steps = value as u64;
                continue;
            }
            if slot.kind == VarKind::MeProjection {
                check_real(var, vr, value as f64)?;
                me_projection = value != 0;
                continue;
            }
            if slot.kind == VarKind::Parameter {
                check_real(var, vr, value as f64)?;
                params.push((slot.index, value as f64));
                continue;
            }
            sets_method = true;
            method = Method::from_code(value).ok_or_else(|| {
                format!(
                    "{value} is not a method code for {name} (value reference {vr}); valid: {}",
                    Method::codes()
                )
            })?;
        }
        // A call that sets parameters checks the method with them only when it sets the
        // method too: a parameter set alone is not refused for the method's sake (as one set
        // with fmi2SetReal: fmi2ExitInitializationMode checks the pair).
        let d = &self.data;
        if params.is_empty() {
            check_method::<M>(method, &d.u, &d.params, true)?;
        } else {
            let mut p = d.params.clone();
            for &(i, v) in &params {
                p[i] = v;
            }
            if sets_method {
                check_method::<M>(method, &d.u, &p, true)?;
            }
            self.data.params = p;
        }
        self.data.method = method;
        self.data.max_steps = max_steps;
        self.data.me_projection = me_projection;
        Ok(())
    }

    fn integer_slot(&self, vr: u32) -> Res<Slot> {
        let slot = self.slot(vr)?;
        if integer_kind(slot, self.var(vr)).is_none() {
            return Err(format!(
                "value reference {vr} ({}) is a Real, not an Integer/Enumeration",
                self.name(vr)
            ));
        }
        Ok(slot)
    }

    /// Get/set of a type this model has no variables of (FMI 2.0's Boolean and String).
    pub fn no_variables_of_type(&self, vrs: &[u32]) -> Res {
        if let Some(vr) = vrs.first() {
            return Err(format!(
                "value reference {vr} is not a variable of this type (the model has none)"
            ));
        }
        Ok(())
    }

    /// fmi2GetDirectionalDerivative: `dv_unknown = J · dv_known`, exact (dual numbers).
    /// Unknowns: state derivatives and outputs (an output that is a state gives the seed
    /// of that state); knowns: states and inputs (standard, 2.1.9).
    pub fn directional_derivative(
        &self,
        unknowns: &[u32],
        knowns: &[u32],
        dv_known: &[f64],
        dv_unknown: &mut [f64],
    ) -> Res {
        let d = &self.data;
        let mut work = self.work.borrow_mut();
        let Work {
            seeds: [dx, du, zeros_p],
            sensitivities: [df, dg],
            duals,
            ..
        } = &mut *work;
        let (dx, du) = (zeroed(dx, d.x.len()), zeroed(du, d.u.len()));
        for (&vr, &dv) in knowns.iter().zip(dv_known) {
            let slot = self.slot(vr)?;
            if !dv.is_finite() {
                return Err(format!("seed {dv} for {} is not finite", self.name(vr)));
            }
            match slot.kind {
                VarKind::State => dx[slot.index] += dv,
                VarKind::Input => du[slot.index] += dv,
                _ => {
                    return Err(format!(
                        "{} (value reference {vr}) is not a known: use states or inputs",
                        self.name(vr)
                    ))
                }
            }
        }
        self.check_unknowns(unknowns)?;
        let zeros_p = zeroed(zeros_p, d.params.len());
        let (df, dg) = (
            zeroed(df, d.x.len()),
            zeroed(dg, self.info.layout.n_outputs),
        );
        let direction = Direction {
            t: d.time,
            x: (&d.x, dx),
            u: (&d.u, du),
            p: (&d.params, zeros_p),
        };
        duals.directional::<M>(&direction, df, dg);
        for (out, &vr) in dv_unknown.iter_mut().zip(unknowns) {
            let slot = self.info.layout.vars[vr as usize].0;
            *out = match slot.kind {
                VarKind::State => dx[slot.index],
                VarKind::Derivative => df[slot.index],
                _ => dg[slot.index],
            };
        }
        if let Some(i) = dv_unknown.iter().position(|v| !finite(*v)) {
            let (vr, v) = (unknowns[i], dv_unknown[i]);
            drop(work);
            return Err(self.not_finite(vr, v));
        }
        Ok(())
    }

    /// Every unknown of a derivative request is a state, a state derivative or an output;
    /// checked whatever the counts (an adjoint with no knowns still names its unknowns).
    pub fn check_unknowns(&self, unknowns: &[u32]) -> Res {
        for &vr in unknowns {
            let slot = self.slot(vr)?;
            if !matches!(
                slot.kind,
                VarKind::State | VarKind::Derivative | VarKind::Output
            ) {
                return Err(format!(
                    "{} (value reference {vr}) is not an unknown: use outputs or state derivatives",
                    self.name(vr)
                ));
            }
        }
        Ok(())
    }

    pub fn snapshot(&self) -> Snapshot {
        self.data.clone()
    }

    /// fmi2SetFMUstate: the instance becomes `snapshot`, after the checks of
    /// [`Instance::check_snapshot`].
    pub fn restore(&mut self, snapshot: &Snapshot) -> Res {
        let l = &self.info.layout;
        if snapshot.params.len() != l.n_params
            || snapshot.x.len() != l.n_states
            || snapshot.u.len() != l.n_inputs
            || snapshot.u_der.iter().any(|d| d.len() != l.n_inputs)
        {
            return Err("the FMU state belongs to another model".into());
        }
        self.check_snapshot(snapshot)
            .map_err(|e| format!("refused, in the FMU state: {e}"))?;
        self.data = snapshot.clone();
        Ok(())
    }

    pub fn serialize(&self, snapshot: &Snapshot) -> Vec<u8> {
        snapshot.serialize(&self.info.guid)
    }

    /// fmi2DeSerializeFMUstate: the state a blob holds, refused unless its layout is
    /// intact ([`Snapshot::deserialize`]) and its values pass [`Instance::check_snapshot`].
    pub fn deserialize(&self, bytes: &[u8]) -> Res<Snapshot> {
        let l = &self.info.layout;
        let snapshot =
            Snapshot::deserialize(bytes, &self.info.guid, [l.n_params, l.n_states, l.n_inputs])?;
        self.check_snapshot(&snapshot)
            .map_err(|e| format!("refused, in the FMU state: {e}"))?;
        Ok(snapshot)
    }

    /// Whether an FMU state (of this model's counts) is one this instance could have been
    /// in: every value passes the check of its setter (fmi2SetReal: finite and inside its
    /// [min, max]; fmi2SetInteger: a method this system accepts, an Enumeration parameter
    /// one of its codes, an Integer one a whole number; fmi2SetupExperiment: the
    /// tolerance and times), the time fits the mode and the experiment, and an
    /// integrator state ahead of the communication time belongs to the method and agrees
    /// with the state (see [`Instance::check_ahead`]). A state made by fmi2GetFMUstate always
    /// passes; the message says what does not.
    pub fn check_snapshot(&self, s: &Snapshot) -> Res {
        let layout = &self.info.layout;
        if s.interface != self.data.interface {
            return Err(format!(
                "it was taken in a {} instance, this one is {}",
                s.interface.name(),
                self.data.interface.name()
            ));
        }
        if !s.interface.has(s.mode) {
            return Err(format!(
                "mode {:?} is not a mode of {}",
                s.mode,
                s.interface.name()
            ));
        }
        let me = s.interface == Interface::ModelExchange;
        if !me && s.event_reference.is_some() {
            return Err("a Co-Simulation state holds an event indicator reference".into());
        }
        let before_init = s.mode.before_init_done();
        for (vr, (slot, var)) in layout.vars.iter().enumerate() {
            let value = match slot.kind {
                VarKind::Parameter => s.params[slot.index],
                VarKind::Input => s.u[slot.index],
                VarKind::SolverStep => s.solver_step,
                VarKind::SolverMaxSteps => s.max_steps as f64,
                // After initialisation the states are the integration's (Model Exchange: the
                // importer's solver's): finite only.
                VarKind::State if before_init => s.x[slot.index],
                VarKind::State if !s.x[slot.index].is_finite() => {
                    return Err(format!(
                        "the state {} = {} is not finite",
                        var.name, s.x[slot.index]
                    ))
                }
                _ => continue,
            };
            check_real(var, vr as u32, value)?;
        }
        // Before initialisation the parameters may have changed after the method was set
        // (fmi2SetInteger checked it against the values then): a method is accepted if the
        // system takes it with the state's parameters or with its start values, so a state
        // fmi2GetFMUstate made restores while a method no parameters make valid (ExactLinear
        // on a pendulum) is refused in every mode.
        check_method::<M>(s.method, &s.u, &s.params, true).or_else(|e| {
            let start = &self.initial.params;
            match before_init && check_method::<M>(s.method, &s.u, start, true).is_ok() {
                true => Ok(()),
                false => Err(e),
            }
        })?;
        for (order, der) in s.u_der.iter().enumerate() {
            if let Some(v) = der.iter().find(|v| !v.is_finite()) {
                return Err(format!(
                    "an input derivative of order {} is not finite ({v})",
                    order + 1
                ));
            }
        }
        check_experiment(Some(s.tolerance), s.start_time, s.stop_time)?;
        let (time, start) = (s.time, s.start_time);
        if before_init {
            if time != start || s.memory != Memory::default() || s.event_reference.is_some() {
                return Err(format!(
                    "mode {:?} (before initialisation) goes with the time at startTime = {start} and no integrator memory; found time {time}",
                    s.mode
                ));
            }
            return Ok(());
        }
        if me {
            // The importer's solver sets the time and the states: any finite ones.
            if !time.is_finite() {
                return Err(format!("the time {time} is not finite"));
            }
            if s.memory != Memory::default() || inputs::moving(&s.u_der) {
                return Err("a Model Exchange state holds integrator memory or input derivatives (Co-Simulation's)".into());
            }
            return Ok(());
        }
        let beyond_stop = s
            .stop_time
            .is_some_and(|stop| time > stop + 1e-9 * stop.abs().max(1.0));
        if !time.is_finite() || time < start || beyond_stop {
            return Err(format!(
                "the time {time} is outside the experiment [{start}, {}]",
                s.stop_time.unwrap_or(f64::INFINITY)
            ));
        }
        // The outputs an importer reads next must be finite, as after any doStep.
        let mut y = vec![0.0; layout.n_outputs];
        M::extra_outputs(time, &s.x, &s.u, &s.params, &mut y);
        if let Some(i) = y.iter().position(|v| !v.is_finite()) {
            let vr = layout.vr_of_slot(VarKind::Output, i);
            return Err(format!(
                "the output {} is not finite in this state",
                layout.vars[vr as usize].1.name
            ));
        }
        let m = &s.memory;
        if !(m.h.is_finite() && m.h >= 0.0) {
            return Err(format!("the step-size proposal {} is not a step", m.h));
        }
        if inputs::moving(&s.u_der) && m.ahead.is_some() {
            return Err(
                "an integrator state ahead is kept while input derivatives are set (doStep lands on each communication point then)".into(),
            );
        }
        self.check_ahead(s)
    }

    /// An integrator state ahead of the communication time (dense output) is kept only by
    /// the running method, and only while it agrees with the instance: its last step covers
    /// the time, the communication point it gives there (projected, as doStep projects it)
    /// is the state, bit for bit, and its f(t, x) is the model's with the state's inputs and
    /// parameters (so neither changed under it). Costs one evaluation of f (DOP853: up to 3
    /// more, for an extension not yet built).
    fn check_ahead(&self, s: &Snapshot) -> Res {
        let Some(ahead) = &s.memory.ahead else {
            return Ok(());
        };
        let owner = ahead.method();
        if owner != s.method {
            return Err(format!(
                "an integrator state ahead of {} is kept for solver {}",
                owner.name(),
                s.method.name()
            ));
        }
        let (u, p, time, n) = (&s.u, &s.params, s.time, s.x.len());
        let mut rhs = |t: f64, x: &[f64], dx: &mut [f64]| M::derivatives(t, x, u, p, dx);
        let mut point = vec![0.0; n];
        let covers = ahead.point_at(&mut Problem::new(&mut rhs), time, &mut point);
        let (t_ahead, x_ahead, f_ahead) = ahead.end();
        if !covers {
            return Err(format!(
                "the {} state ahead (at t = {t_ahead}) does not cover the time {time}",
                owner.name()
            ));
        }
        M::project(time, p, &mut point);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        if bits(&point) != bits(&s.x) {
            return Err(format!(
                "the {} state ahead gives another state at t = {time} than the one held",
                owner.name()
            ));
        }
        let mut f = vec![0.0; n];
        rhs(t_ahead, x_ahead, &mut f);
        if f_ahead.is_some_and(|f_ahead| bits(&f) != bits(f_ahead)) {
            return Err(format!(
                "the {} state ahead was computed with other inputs or parameters than the ones held",
                owner.name()
            ));
        }
        Ok(())
    }
}

/// The FMI type of a variable read with fmi2GetInteger (None: a Real): the FMU's own
/// `solver` (Enumeration), `solver_max_steps` and `me_projection` (Integer), and a
/// parameter its system declared an Integer or an Enumeration.
fn integer_kind(slot: Slot, var: &Var) -> Option<&'static str> {
    match (slot.kind, var.ty) {
        (VarKind::SolverMethod, _) | (VarKind::Parameter, VarType::Enumeration(_)) => {
            Some("Enumeration")
        }
        (VarKind::SolverMaxSteps | VarKind::MeProjection, _)
        | (VarKind::Parameter, VarType::Integer) => Some("Integer"),
        _ => None,
    }
}

/// The check fmi2SetReal makes of a value for `var` (value reference `vr`), shared with a
/// restored FMU state: finite and inside [min, max].
fn check_real(var: &Var, vr: u32, value: f64) -> Res {
    var.check(value)
        .map_err(|e| format!("{e} (value reference {vr})"))
}

/// The checks of fmi2SetupExperiment, shared with a restored FMU state.
fn check_experiment(tolerance: Option<f64>, start_time: f64, stop_time: Option<f64>) -> Res {
    if let Some(tol) = tolerance {
        if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
            return Err(format!("tolerance must be in (0, 1), got {tol}"));
        }
    }
    if !start_time.is_finite() {
        return Err(format!("startTime must be finite, got {start_time}"));
    }
    if let Some(stop) = stop_time {
        if !(stop.is_finite() && stop >= start_time) {
            return Err(format!(
                "stopTime must be finite and ≥ startTime = {start_time}, got {stop}"
            ));
        }
    }
    Ok(())
}

/// Whether system `M` accepts `method` with inputs `u` and parameters `p` (fmi2SetInteger,
/// shared with a restored FMU state): the structure it needs, and with `lti` a linear
/// time-invariant system for ExactLinear (before initialisation parameters may still
/// change; fmi2ExitInitializationMode checks that again).
fn check_method<M: System>(method: Method, u: &[f64], p: &[f64], lti: bool) -> Res {
    let name = method.name();
    if lti && method.needs_linear_time_invariant() && !M::linear_time_invariant(p) {
        return Err(format!(
            "solver {name} needs a linear time-invariant system; {} is not (with these parameters)",
            M::name()
        ));
    }
    if method.needs_mechanics() && M::mechanics(u, p).is_none() {
        return Err(format!(
            "solver {name} needs a system written as a Lagrangian whose states are q and q̇ alone with time-independent and non-redundant holonomic constraints only; {} is not",
            M::name()
        ));
    }
    if method.needs_second_order() && !M::second_order() {
        return Err(format!(
            "solver {name} needs states of the form (q, q̇); {} has none",
            M::name()
        ));
    }
    Ok(())
}

/// Whether an event indicator changed sign from `before` to `after` (`None`: the model has
/// no indicator at that state, so no crossing).
pub(super) fn crossed(before: Option<f64>, after: Option<f64>) -> bool {
    matches!((before, after), (Some(a), Some(b)) if (a > 0.0 && b <= 0.0) || (a < 0.0 && b >= 0.0))
}
