//! The reference result of the default experiment, shipped in every FMU under the
//! FMI-LS-REF layered standard (`extra/org.fmi-standard.fmi-ls-ref/`): every output at
//! every communication point, computed independently of the default solver, so an importer
//! can check its own run of the FMU against it.
//!
//! Independent means another method than the default (DOPRI5): the exact propagator e^{Ah}
//! (`ExactLinear`, the closed form) where the system is linear time-invariant, else DOP853 at
//! [`REFERENCE_TOL`]. Its error is estimated by a second run of yet another method, Gauss6
//! with [`CHECK_SUBSTEPS`] fixed steps per communication step (RADAU5 at the experiment's
//! tolerance where Gauss6's Newton iteration fails, a stiff mechanism) (order 6, another step
//! sequence: a DOP853 run at a looser tolerance would take the same steps, all capped by the
//! communication step, and show no difference), and stated in the manifest: the difference
//! is the larger of the two runs' errors, an upper estimate of the reference's.

use super::rough;
use super::run::{simulate, RunSettings, Trajectory};
use crate::integrators::Method;
use crate::model::{Layout, System};

/// Where FMI-LS-REF files live in the archive.
pub const LS_REF_DIR: &str = "extra/org.fmi-standard.fmi-ls-ref";
/// The reference CSV's file name in [`LS_REF_DIR`].
pub const REFERENCE_CSV: &str = "reference.csv";
/// Tolerance of a DOP853 reference.
pub const REFERENCE_TOL: f64 = 1e-12;
/// Gauss6 steps per communication step in the run that estimates the reference's error.
pub const CHECK_SUBSTEPS: usize = 8;
/// A check confirms the reference when they differ by at most this × the tolerance, in
/// units of each column's scale: 1 % of what tests/python/test_reference_result.py holds a
/// run of the default experiment to (1e4 × tolerance).
pub const CONCLUSIVE: f64 = 100.0;

/// A reference result and how it was made.
#[derive(Clone, Debug)]
pub struct Reference {
    pub trajectory: Trajectory,
    /// e.g. "ExactLinear (the exact propagator e^(Ah), the closed form)".
    pub how: String,
    /// The run its error was estimated against.
    pub check: String,
    /// Per column: max |reference − check| over the grid.
    pub error: Vec<f64>,
    /// (stop time, relative tolerance, communication step) of the default experiment.
    pub experiment: (f64, f64, f64),
    /// The default experiment's method ([`default_method`]).
    pub method: Method,
}

/// The method of the default experiment (the `solver` start value).
pub fn default_method<M: System>() -> Method {
    M::DEFAULT_METHOD
}

/// The reference result of `M`'s default experiment (start values of the model).
pub fn reference<M: System>() -> Result<Reference, String> {
    let (stop, tol, comm_step) = M::default_experiment();
    let p: Vec<f64> = Layout::of::<M>()
        .vars
        .iter()
        .filter(|(s, _)| s.kind == crate::model::VarKind::Parameter)
        .map(|(_, v)| v.start)
        .collect();
    // A reference of a run that stopped early would mislead: an error.
    let run = |method: Method, tol: f64, step: f64| {
        let t = simulate::<M>(
            &[],
            RunSettings {
                method,
                tol,
                step,
                comm_step,
                stop,
            },
        )?;
        match t.failure {
            Some(why) => Err(format!("{}: reference run: {why}", M::NAME)),
            None => Ok(t),
        }
    };
    let dop853 = |tol: f64| {
        format!(
            "DOP853 (Dormand-Prince 8(5,3)) at relative tolerance {tol:e}, sampled at every communication step"
        )
    };
    let (trajectory, how) = if M::linear_time_invariant(&p) {
        (
            run(Method::ExactLinear, tol, comm_step)?,
            "ExactLinear: the exact propagator e^(Ah) over each communication step (the closed form of this linear time-invariant system)".to_string(),
        )
    } else {
        (
            run(Method::Dop853, REFERENCE_TOL, comm_step)?,
            dop853(REFERENCE_TOL),
        )
    };
    // The checks, in order: Gauss6 at a fixed step (another method, another step
    // sequence). Its Newton iteration can fail at that step on a stiff mechanism (a hand:
    // light fingers with joint damping) or at a singular position (the N four-bar's
    // passages): then RADAU5 at the experiment's tolerance, adaptive and L-stable. A
    // mechanism on its end stops (impacts and releases are kinks a fixed step straddles
    // and RADAU5's Newton meets at every event) and the N four-bar (RADAU5's error at the
    // experiment's tolerance is more than the bound) are checked by DOPRI5 at a hundredth
    // of the tolerance (explicit, adaptive, located events), or where that costs more than
    // a doStep's work bound, at the tolerance. The first check that
    // confirms the reference within [`CONCLUSIVE`] × tolerance is the one stated; when
    // none does, the closest (the stated error then says so).
    let check_step = comm_step / CHECK_SUBSTEPS as f64;
    let checks = [
        (
            Method::Gauss6,
            tol,
            check_step,
            format!("Gauss6 (Gauss-Legendre order 6) with fixed step {check_step:e} s"),
        ),
        (
            Method::Radau5,
            tol,
            comm_step,
            format!("RADAU5 (Radau IIA order 5) at relative tolerance {tol:e}"),
        ),
        (
            Method::Dopri5,
            tol / 100.0,
            comm_step,
            format!(
                "DOPRI5 (Dormand-Prince 5(4)) at relative tolerance {:e}",
                tol / 100.0
            ),
        ),
        (
            Method::Dopri5,
            tol,
            comm_step,
            format!("DOPRI5 (Dormand-Prince 5(4)) at relative tolerance {tol:e}"),
        ),
    ];
    // What the checks before found (for the description), and why runs failed (the error
    // when none completes).
    let (mut tried, mut failures): (Vec<String>, Vec<String>) = (Vec::new(), Vec::new());
    let mut best: Option<(f64, Vec<f64>, String)> = None;
    for (method, check_tol, step, what) in checks {
        match run(method, check_tol, step) {
            Err(why) => {
                tried.push(format!("{what} did not converge"));
                failures.push(why);
            }
            Ok(check_run) => {
                let error: Vec<f64> = (0..trajectory.columns.len())
                    .map(|j| trajectory.max_abs_diff(&check_run, j))
                    .collect();
                let worst = (0..error.len())
                    .map(|j| error[j] / trajectory.scale(j))
                    .fold(0.0f64, f64::max);
                let said = if tried.is_empty() {
                    what.clone()
                } else {
                    format!("{what} ({})", tried.join("; "))
                };
                if best.as_ref().is_none_or(|b| worst < b.0) {
                    best = Some((worst, error, said));
                }
                if worst <= CONCLUSIVE * tol {
                    break;
                }
                tried.push(format!("{what} differed by {}", rough(worst)));
            }
        }
    }
    let Some((_, error, check)) = best else {
        return Err(failures.join("; "));
    };
    Ok(Reference {
        trajectory,
        how,
        check,
        error,
        experiment: (stop, tol, comm_step),
        method: default_method::<M>(),
    })
}

impl Reference {
    /// Every column's error over its [`Trajectory::scale`]: a relative error, as a
    /// tolerance is.
    pub fn scaled_errors(&self) -> Vec<f64> {
        let t = &self.trajectory;
        (0..t.columns.len())
            .map(|j| self.error[j] / t.scale(j))
            .collect()
    }

    /// The largest scaled error and the column it is in.
    pub fn worst(&self) -> (f64, &str) {
        let e = self.scaled_errors();
        let j = (0..e.len())
            .max_by(|a, b| e[*a].total_cmp(&e[*b]))
            .unwrap_or(0);
        (
            e.get(j).copied().unwrap_or(0.0),
            self.trajectory.names.get(j).map_or("", |s| s.as_str()),
        )
    }

    /// The reference CSV: time and every output.
    pub fn csv(&self) -> String {
        let all: Vec<usize> = (0..self.trajectory.columns.len()).collect();
        self.trajectory.to_csv(&all)
    }

    /// One sentence: what the CSV holds, how it was computed, and its estimated error.
    pub fn description(&self, model: &str) -> String {
        let (stop, tol, step) = self.experiment;
        let (worst, column) = self.worst();
        format!(
            "Reference result of {model}'s default experiment (start 0 s, stop {stop} s, tolerance {tol:e}, communication step {step} s, the modelDescription's start values): time and every output at every communication point. Computed independently of the default solver ({}) with {}. Estimated error against {}: at most {} of each column's scale, the largest of its range, its largest magnitude and its nominal (largest in {column}).",
            self.method.name(),
            self.how,
            self.check,
            rough(worst),
        )
    }

    /// `fmi-ls-manifest.xml` naming the reference result and the documentation page.
    pub fn manifest(&self, model: &str) -> String {
        let esc = |s: &str| quick_xml::escape::escape(s).into_owned();
        format!(
            r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiReferences
  xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
  fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref"
  fmi-ls:fmi-ls-version="1.0.0-alpha.1"
  fmi-ls:fmi-ls-description="Layered Standard providing information on related files included in an FMU.">
  <Related type="text/csv" source="{REFERENCE_CSV}" role="result" description="{}"/>
  <Related type="text/html" source="../../documentation/index.html" role="document" description="{}"/>
</fmiReferences>
"#,
            esc(&self.description(model)),
            esc(&format!(
                "What {model} is, its equations, variables, scenes, linearisation and solvers."
            )),
        )
    }

    /// The archive files (path in the FMU, content) of this reference.
    pub fn files(&self, model: &str) -> Vec<(String, String)> {
        vec![
            (format!("{LS_REF_DIR}/{REFERENCE_CSV}"), self.csv()),
            (
                format!("{LS_REF_DIR}/fmi-ls-manifest.xml"),
                self.manifest(model),
            ),
        ]
    }
}
