//! Runs of a system through the FMU's own [`Instance`] API (start values, solver, setup,
//! initialisation, doStep), recording every output at every communication point: the
//! reference result and the scene plots are what an importer would see, not a side path.

use crate::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use crate::integrators::Method;
use crate::model::{System, VarKind};
use crate::xml::fmi_attributes;

/// Every output (causality `output`: the states, then the extra outputs) of one run.
#[derive(Clone, Debug)]
pub struct Trajectory {
    pub names: Vec<String>,
    pub units: Vec<String>,
    /// Whether the column is a state (else an extra output).
    pub is_state: Vec<bool>,
    /// The variable's nominal value (FMI's default 1 when it declares none).
    pub nominal: Vec<f64>,
    pub t: Vec<f64>,
    /// `columns[j][k]`: output `j` at time `t[k]`.
    pub columns: Vec<Vec<f64>>,
    /// Why the run stopped before its stop time (a doStep discarded: a bicycle that fell).
    pub failure: Option<String>,
}

/// How to integrate.
#[derive(Clone, Copy, Debug)]
pub struct RunSettings {
    pub method: Method,
    /// Relative tolerance (adaptive methods; `fmi2SetupExperiment`'s).
    pub tol: f64,
    /// `solver_step` of a fixed-step method (ignored by adaptive ones).
    pub step: f64,
    /// Communication step (s): the sampling of the trajectory.
    pub comm_step: f64,
    pub stop: f64,
}

/// Runs `M` from its start values overridden by `start_values` (by variable name).
/// An error when a start value is refused or initialisation fails; a doStep that does not
/// complete ends the trajectory there, with [`Trajectory::failure`] saying why.
pub fn simulate<M: System>(
    start_values: &[(&str, f64)],
    s: RunSettings,
) -> Result<Trajectory, String> {
    // The instance wants a 'static ModelInfo, as in the FMU: one small leak per run, at
    // package time only.
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<M>()));
    let layout = &info.layout;
    let mut vrs = Vec::new();
    let mut traj = Trajectory {
        names: Vec::new(),
        units: Vec::new(),
        is_state: Vec::new(),
        nominal: Vec::new(),
        t: Vec::new(),
        columns: Vec::new(),
        failure: None,
    };
    for (vr, (slot, var)) in layout.vars.iter().enumerate() {
        if fmi_attributes(*slot).0 == "output" {
            vrs.push(vr as u32);
            traj.names.push(var.name.to_string());
            traj.units
                .push(var.unit.as_deref().unwrap_or("").to_string());
            traj.is_state.push(slot.kind == VarKind::State);
            traj.nominal.push(var.nominal.unwrap_or(1.0).abs());
            traj.columns.push(Vec::new());
        }
    }
    let mut fmu = Instance::<M>::new(info, Logger::silent("mbfmu-docs"));
    for (name, value) in start_values {
        let vr = layout
            .vr_of(name)
            .ok_or_else(|| format!("{}: no variable {name}", M::NAME))?;
        // An Integer or Enumeration through fmi2SetInteger's path, as an importer sets it.
        fmu.set_value(vr, *value)?;
    }
    let vr = |name: &str| {
        layout
            .vr_of(name)
            .ok_or_else(|| format!("{}: no variable {name}", M::NAME))
    };
    fmu.set_integer(&[vr("solver")?], &[s.method.code()])?;
    if !s.method.is_adaptive() {
        fmu.set_real(&[vr("solver_step")?], &[s.step])?;
    }
    fmu.set_integer(&[vr("solver_max_steps")?], &[i32::MAX])?;
    fmu.setup_experiment(Some(s.tol), 0.0, Some(s.stop))?;
    fmu.enter_initialization_mode()?;
    fmu.exit_initialization_mode()?;
    let n_comm = (s.stop / s.comm_step).round().max(1.0) as usize;
    let mut values = vec![0.0; vrs.len()];
    let mut record = |fmu: &Instance<M>, traj: &mut Trajectory| -> Result<(), String> {
        fmu.get_real(&vrs, &mut values)?;
        traj.t.push(fmu.time());
        for (c, v) in traj.columns.iter_mut().zip(&values) {
            c.push(*v);
        }
        Ok(())
    };
    record(&fmu, &mut traj)?;
    for k in 0..n_comm {
        let now = fmu.time();
        // The grid k·h, not a sum of steps; the last step lands on the stop time exactly.
        let next = if k + 1 == n_comm {
            s.stop
        } else {
            (k + 1) as f64 * s.comm_step
        };
        match fmu.do_step(now, next - now)? {
            StepOutcome::Completed => record(&fmu, &mut traj)?,
            StepOutcome::Discarded(why) => {
                traj.failure = Some(format!("{} stopped at t = {now}: {why}", s.method.name()));
                break;
            }
        }
    }
    Ok(traj)
}

impl Trajectory {
    /// The largest difference to `other` (same grid) of column `j`.
    pub fn max_abs_diff(&self, other: &Trajectory, j: usize) -> f64 {
        self.columns[j]
            .iter()
            .zip(&other.columns[j])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
    }

    /// max − min of column `j`.
    pub fn range(&self, j: usize) -> f64 {
        let c = &self.columns[j];
        let max = c.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let min = c.iter().cloned().fold(f64::INFINITY, f64::min);
        max - min
    }

    /// max |y| of column `j`.
    pub fn magnitude(&self, j: usize) -> f64 {
        self.columns[j].iter().map(|v| v.abs()).fold(0.0, f64::max)
    }

    /// The scale of column `j`: the largest of its range, its largest magnitude and its
    /// nominal (so a quantity that stays at 0 to rounding, a constraint residual or a
    /// conserved energy of 0, is measured in absolute terms, as rtol·nominal is an atol).
    pub fn scale(&self, j: usize) -> f64 {
        self.range(j).max(self.magnitude(j)).max(self.nominal[j])
    }

    /// CSV: `time` then the columns `keep`, values in Rust's shortest round-trip form.
    pub fn to_csv(&self, keep: &[usize]) -> String {
        let mut s = String::from("time");
        for &j in keep {
            s.push(',');
            s.push_str(&self.names[j]);
        }
        s.push('\n');
        for (k, t) in self.t.iter().enumerate() {
            s.push_str(&format!("{t:?}"));
            for &j in keep {
                s.push_str(&format!(",{:?}", self.columns[j][k]));
            }
            s.push('\n');
        }
        s
    }
}
