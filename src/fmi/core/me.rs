//! The Model Exchange front-end: the importer's solver sets the time and the continuous
//! states and reads the derivatives and the event indicator; events are handled in event
//! mode (fmi2NewDiscreteStates), on the shared [`Instance`] core.
//!
//! Events. A system with an [`event_indicator`](System::event_indicator) has one indicator;
//! where the model returns `None` (no event possible in this mode: SphereSlide in free
//! flight) the FMU reports the constant [`NO_EVENT_INDICATOR`], which never crosses zero.
//! fmi2NewDiscreteStates applies [`System::on_event`] when the indicator changed sign since
//! the last event (the importer located the crossing); `Err(why)` from it (a bicycle that
//! has fallen) sets terminateSimulation with a line.
//!
//! Step events. A constrained system ([`System::project`] does something) leaves its
//! constraints under any importer's integration: with `me_projection` = 1 (the default)
//! fmi2CompletedIntegratorStep asks for event mode when the state has left them by more
//! than ten times the experiment's tolerance, and fmi2NewDiscreteStates projects it back
//! (valuesOfContinuousStatesChanged); at any event it projects what is off by more than
//! rounding.

use super::info::Status;
use super::mode::Mode;
use super::{crossed, Instance, Res};
use crate::integrators::all_finite;
use crate::model::{System, VarKind};

/// The event indicator's value where the model has none (a mode without events): positive
/// and constant, so that it never changes sign.
pub const NO_EVENT_INDICATOR: f64 = 1.0;

/// What fmi2NewDiscreteStates answers (fmi2EventInfo). The models here have no time
/// events and no discrete states that need another iteration.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EventInfo {
    pub new_discrete_states_needed: bool,
    pub terminate_simulation: bool,
    pub nominals_of_continuous_states_changed: bool,
    pub values_of_continuous_states_changed: bool,
    pub next_event_time: Option<f64>,
}

/// Relative move below which a projection is rounding, not a return to the constraints
/// (per component, against the larger of its magnitude and its nominal).
const PROJECTION_ROUNDING: f64 = 1e-13;

/// fmi2/fmi3CompletedIntegratorStep asks for a step event only when the projection would
/// move a component by more than this many times the experiment's tolerance (of its scale,
/// as [`PROJECTION_ROUNDING`]). An event costs the importer a restart of its solver (fmpy
/// re-initialises CVODE after every event, which restarts at order 1), and the restarts,
/// not the projection, cost accuracy: SphereSlide at CVODE rtol 1e-9, asked at rounding
/// level, had 238 restarts and θ ten times further from the reference than without the
/// projection; the same restarts with no projection did the same harm. At 10 × the
/// default tolerance it has 2 and is as accurate as without (docs/interfaces.md).
const STEP_EVENT_DRIFT: f64 = 10.0;

impl<M: System> Instance<M> {
    /// A count the importer passed (nx, ni) against the model's.
    fn require_count(what: &str, given: usize, model: usize) -> Res {
        if given != model {
            return Err(format!("{what} = {given}, this model has {model}"));
        }
        Ok(())
    }

    pub fn number_of_event_indicators(&self) -> usize {
        self.info.probe.event_indicators
    }

    fn nominal(&self, i: usize) -> f64 {
        let vr = self.info.layout.vr_of_slot(VarKind::State, i);
        self.info.layout.vars[vr as usize].1.nominal.unwrap_or(1.0)
    }

    /// fmi2SetTime: any finite time (a solver evaluates at times inside and past its step).
    pub fn set_time(&mut self, time: f64) -> Res {
        if !time.is_finite() {
            return Err(format!("time {time} is not finite"));
        }
        self.data.time = time;
        Ok(())
    }

    /// fmi2SetContinuousStates: exactly the model's number of states, every one finite.
    pub fn set_continuous_states(&mut self, x: &[f64]) -> Res {
        Self::require_count("nx", x.len(), self.data.x.len())?;
        // Finite only: a solver's iterates and finite-difference Jacobian step past a
        // declared [min, max] (CVODE perturbs SphereSlide's mode on_surface = 1 to 1 + 1.5e-8),
        // as Co-Simulation's integration may after initialisation.
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(format!(
                "x[{i}] = {} for {} is not finite",
                x[i],
                self.state_name(i)
            ));
        }
        self.data.x.copy_from_slice(x);
        Ok(())
    }

    /// The continuous states.
    pub fn get_continuous_states(&self, x: &mut [f64]) -> Res {
        Self::require_count("nx", x.len(), self.data.x.len())?;
        x.copy_from_slice(&self.data.x);
        Ok(())
    }

    /// fmi2GetNominalsOfContinuousStates: the states' declared nominals (1 where none).
    pub fn get_nominals(&self, nominals: &mut [f64]) -> Res {
        Self::require_count("nx", nominals.len(), self.data.x.len())?;
        for (i, v) in nominals.iter_mut().enumerate() {
            *v = self.nominal(i);
        }
        Ok(())
    }

    /// fmi2GetDerivatives: `f(t, x, u, p)` at the time and states set. Where it is not finite
    /// (a singular configuration the solver stepped into) fmi2Discard with a line: the
    /// standard's answer for "retry with a smaller step".
    pub fn get_derivatives(&self, dx: &mut [f64]) -> Res<Status> {
        let d = &self.data;
        Self::require_count("nx", dx.len(), d.x.len())?;
        M::derivatives(d.time, &d.x, &d.u, &d.params, dx);
        if let Some(i) = dx.iter().position(|v| !v.is_finite()) {
            return Ok(self.discard(&format!("der({})", self.state_name(i)), dx[i]));
        }
        Ok(Status::Ok)
    }

    /// fmi2GetEventIndicators: the model's indicator ([`NO_EVENT_INDICATOR`] where it has
    /// none in this mode); fmi2Discard with a line where it is not finite.
    pub fn get_event_indicators(&self, z: &mut [f64]) -> Res<Status> {
        Self::require_count("ni", z.len(), self.number_of_event_indicators())?;
        if let Some(z) = z.first_mut() {
            let d = &self.data;
            *z = M::event_indicator(d.time, &d.x, &d.u, &d.params).unwrap_or(NO_EVENT_INDICATOR);
            if !z.is_finite() {
                return Ok(self.discard("the event indicator", *z));
            }
        }
        Ok(Status::Ok)
    }

    /// The event indicator at the held time and states, as fmi2GetEventIndicators gives it
    /// (FMI 3.0 also reads it as a variable, in either interface).
    pub fn event_indicator_value(&self) -> f64 {
        let d = &self.data;
        M::event_indicator(d.time, &d.x, &d.u, &d.params).unwrap_or(NO_EVENT_INDICATOR)
    }

    /// Logs why the call answers Discard: `what` = `value` is not finite here.
    #[cold]
    fn discard(&self, what: &str, value: f64) -> Status {
        let states = (0..self.data.x.len())
            .map(|i| format!("{} = {}", self.state_name(i), self.data.x[i]))
            .collect::<Vec<_>>()
            .join(", ");
        self.logger.failure(
            Status::Discard,
            &format!(
                "{what} = {value} is not finite at t = {}, {states} (a singular configuration: retry with a smaller step)",
                self.data.time
            ),
        );
        Status::Discard
    }

    pub fn enter_event_mode(&mut self) -> Res {
        self.data.mode = Mode::Event;
        Ok(())
    }

    pub fn enter_continuous_time_mode(&mut self) -> Res {
        self.data.mode = Mode::ContinuousTime;
        Ok(())
    }

    /// fmi2NewDiscreteStates: the event at the time and states set. When the indicator
    /// changed sign since the last event, [`System::on_event`] (its `Err`: terminateSimulation,
    /// with a warning line); then, with `me_projection`, the projection onto the constraints
    /// where the state has left them by more than rounding.
    /// valuesOfContinuousStatesChanged tells whether either changed the states.
    pub fn new_discrete_states(&mut self) -> Res<EventInfo> {
        let mut info = EventInfo::default();
        let d = &self.data;
        let mut x = d.x.clone();
        let now = M::event_indicator(d.time, &x, &d.u, &d.params);
        if crossed(d.event_reference, now) {
            if let Err(why) = M::on_event(d.time, &mut x, &d.u, &d.params) {
                x.copy_from_slice(&d.x);
                info.terminate_simulation = true;
                self.logger.failure(
                    Status::Warning,
                    &format!(
                        "{why}; terminateSimulation = {} (call {})",
                        self.logger.words.true_, self.logger.words.terminate
                    ),
                );
            }
        }
        // Back onto the constraints where the state has left them (not after an event the
        // model cannot pass: the state stays where it stopped holding).
        if d.me_projection && !info.terminate_simulation {
            let mut y = x.clone();
            M::project(d.time, &d.params, &mut y);
            if self.off_constraints(&x, &y, PROJECTION_ROUNDING) {
                x = y;
            }
        }
        if !all_finite(&x) {
            return Err(format!(
                "the state after the event at t = {} is not finite (the projection failed at this configuration); state kept",
                d.time
            ));
        }
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        info.values_of_continuous_states_changed = bits(&x) != bits(&d.x);
        let d = &mut self.data;
        d.x = x;
        d.event_reference = M::event_indicator(d.time, &d.x, &d.u, &d.params);
        Ok(info)
    }

    /// fmi2CompletedIntegratorStep: (enterEventMode, terminateSimulation). enterEventMode is
    /// true when `me_projection` is on and the state has left the constraints by more than
    /// [`STEP_EVENT_DRIFT`] × the tolerance (fmi2NewDiscreteStates then projects it).
    pub fn completed_integrator_step(&mut self) -> Res<(bool, bool)> {
        let d = &self.data;
        if !(d.me_projection && self.info.probe.projects) {
            return Ok((false, false));
        }
        let mut work = self.work.borrow_mut();
        let y = crate::integrators::copied(&mut work.x, &d.x);
        M::project(d.time, &d.params, y);
        let drift = STEP_EVENT_DRIFT * d.tolerance;
        Ok((self.off_constraints(&d.x, y, drift), false))
    }

    /// Whether the projection `y` of `x` moves some component by more than `relative` of
    /// its scale: the state has left its constraints by that much. (A projection that
    /// fails, non-finite, is not a return to them.)
    fn off_constraints(&self, x: &[f64], y: &[f64], relative: f64) -> bool {
        (0..y.len()).any(|i| {
            let scale = x[i].abs().max(self.nominal(i));
            y[i].is_finite() && (y[i] - x[i]).abs() > relative * scale
        })
    }
}
