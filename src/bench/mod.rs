//! `mbfmu bench`: work–precision measurements of every method on every scene.
//!
//! Each run goes through the safe [`Instance`] API exactly as an importer drives the FMU:
//! start values of the scene, `solver` and `solver_step`, `fmi2SetupExperiment` with the
//! tolerance, then `fmi2DoStep` with a communication step of [`BenchConfig::comm_step`] up to
//! the scene's stop time, reading the states and `E` at every communication point.
//!
//! The error is measured against a reference run of the same scene (same `Instance` path):
//! the closed form where one exists — the exact propagator e^{Ah} (method `ExactLinear`) of
//! a linear time-invariant scene, checked by DOP853 at [`REFERENCE_TOL`] — else DOP853 at
//! [`REFERENCE_TOL`], checked by DOP853 at [`CHECK_TOL`]. `ref_error` is the difference of the
//! two in the same norm (for DOP853 references an upper estimate of the reference's error).
//! `benches/peers.py` also checks the references of the affine scenes against `expm`.
//!
//! Error norm: state `i` is scaled by `scale_i = max_t |x_ref,i(t)|` over the communication
//! grid (its `nominal`, else 1, when the reference stays at 0). `error` is the largest scaled
//! deviation over the whole grid, `error_final` the one at the stop time (the number the peers
//! are compared on, since scipy and CVODE land exactly on the stop time too).
//!
//! Timing is wall-clock time (`Instant`) of instantiation + initialisation + the doStep loop
//! (with the reads), the minimum of [`BenchConfig::reps`] repetitions (a run longer than
//! [`TIME_ONCE_ABOVE`] is timed once); it is measured, never asserted. RHS evaluations, steps
//! and rejections come from `Instance::stats()`.
//!
//! Besides the rows, a run of `mbfmu bench` writes (through [`BenchConfig::sink`]) the
//! reference of every scene at its stop time (`reference.csv`, read by `benches/peers.py`),
//! long runs of the conservative scenes ([`LongRuns`]: `longrun.csv`, `invariant.csv`) and
//! the springy-vs-rigid pendulum comparison ([`springy_rigid`]).

pub mod chain;
pub mod floors;
pub mod interpreted;
/// Needs the `cli` feature (serde_json talks to the Pinocchio child).
#[cfg(feature = "cli")]
#[cfg(feature = "cli")]
pub mod robots;
pub mod speed;
pub mod springy_rigid;
pub mod symbolic;

use crate::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use crate::integrators::Method;
use crate::model::{Scene, System, VarKind};
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Tolerance of the reference run (DOP853).
pub const REFERENCE_TOL: f64 = 1e-13;
/// Tolerance of the run that estimates the reference's error (DOP853).
pub const CHECK_TOL: f64 = 1e-12;
/// A run that takes longer than this (s) is timed once: repetitions only fight the noise of
/// short runs.
pub const TIME_ONCE_ABOVE: f64 = 0.2;
/// Communication steps of the reference per benchmark communication step.
pub const REFERENCE_SUBSTEPS: usize = 8;
/// Same, for the check run (another step sequence than the reference's).
pub const CHECK_SUBSTEPS: usize = 5;

/// What to measure.
#[derive(Clone, Debug)]
pub struct BenchConfig {
    /// `solver_step` values of the fixed-step methods.
    pub steps: Vec<f64>,
    /// Tolerances of the adaptive methods.
    pub tolerances: Vec<f64>,
    /// Repetitions per run; the time reported is the minimum.
    pub reps: usize,
    /// Communication step of the doStep loop (s).
    pub comm_step: f64,
    /// Only these methods (all when empty).
    pub methods: Vec<Method>,
    /// Only these scenes (all when empty).
    pub scenes: Vec<String>,
    /// Also run the adaptive methods with one doStep over the whole scene (comm_step = stop
    /// time): the integrator alone, unconstrained by the communication grid, as the peers run.
    pub free_run: bool,
    /// Long runs of the scenes whose energy is an invariant (None: none). Written to the sink.
    pub long_runs: Option<LongRuns>,
    /// Where the references and the long runs go (None: they are not computed).
    pub sink: Option<Arc<Mutex<Sink>>>,
}

/// Long runs of the conservative scenes: every method over `factor` × the scene's stop time,
/// the relative invariant error |E(t) − E(0)| / |E(0)| sampled at `samples` log-spaced
/// times (multiples of the communication step, which are also the doStep boundaries).
#[derive(Clone, Debug)]
pub struct LongRuns {
    pub factor: f64,
    /// Tolerances of the adaptive methods.
    pub tolerances: Vec<f64>,
    /// `solver_step` of the fixed-step methods (divisors of the communication step, so that
    /// every doStep is a whole number of steps and the symplectic methods stay symplectic).
    pub steps: Vec<f64>,
    pub samples: usize,
}

impl LongRuns {
    pub fn full() -> Self {
        LongRuns {
            factor: 10.0,
            tolerances: vec![1e-4, 1e-6, 1e-8, 1e-10, 1e-12],
            steps: vec![1e-2, 5e-3, 2e-3, 1e-3],
            samples: 60,
        }
    }

    pub fn quick() -> Self {
        LongRuns {
            factor: 10.0,
            tolerances: vec![1e-6],
            steps: vec![1e-2],
            samples: 30,
        }
    }
}

/// CSV text (without headers) that a bench run produces besides its rows.
#[derive(Debug, Default)]
pub struct Sink {
    /// `reference.csv`: one row per scene and state.
    pub reference: String,
    /// `longrun.csv`: one row per long run.
    pub long_runs: String,
    /// `invariant.csv`: one row per long run and sample time.
    pub invariant: String,
}

/// Header of `reference.csv`.
pub const REFERENCE_HEADER: &str =
    "system,scene,stop_time,state,value,scale,nominal,start,ref_error,invariant,reference,projected\n";
/// Header of `longrun.csv`.
pub const LONG_RUN_HEADER: &str = "system,scene,method,setting_kind,setting,horizon,status,max_invariant_error,final_invariant_error,cpu_s,rhs_evals,steps,rejected,message\n";
/// Header of `invariant.csv`.
pub const INVARIANT_HEADER: &str =
    "system,scene,method,setting_kind,setting,t,invariant_error,rhs_evals\n";

impl BenchConfig {
    /// The full sweep.
    pub fn full() -> Self {
        BenchConfig {
            steps: vec![1e-2, 3e-3, 1e-3, 3e-4, 1e-4],
            tolerances: (3..=12).map(|k| 10f64.powi(-k)).collect(),
            reps: 3,
            comm_step: 0.01,
            methods: Vec::new(),
            scenes: Vec::new(),
            free_run: true,
            long_runs: None,
            sink: None,
        }
    }

    /// Two settings per method: a smoke test.
    pub fn quick() -> Self {
        BenchConfig {
            steps: vec![1e-2, 1e-3],
            tolerances: vec![1e-4, 1e-8],
            ..BenchConfig::full()
        }
    }
}

/// One run of one method at one setting on one scene.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchRow {
    pub system: &'static str,
    pub scene: &'static str,
    pub method: &'static str,
    /// "tol" (adaptive) or "step" (fixed step).
    pub setting_kind: &'static str,
    pub setting: f64,
    /// Communication step of the run (s): the configured one, or the stop time for a free run.
    pub comm_step: f64,
    /// "ok", "failed" (Discard/Error during the run) or "refused" (setup rejected, e.g. a
    /// symplectic method on a system without (q, q̇)).
    pub status: &'static str,
    /// Why it failed; empty when ok.
    pub message: String,
    /// Largest scaled state error over the communication grid (None when failed).
    pub error: Option<f64>,
    /// Scaled state error at the stop time (None when failed).
    pub error_final: Option<f64>,
    /// Wall-clock seconds, minimum over the repetitions.
    pub cpu_s: f64,
    pub rhs_evals: u64,
    pub steps: u64,
    pub rejected: u64,
    /// max_t |E(t) − E(0)| / |E(0)| when E is an invariant of the scene (see
    /// [`energy_is_invariant`]), else None.
    pub invariant_error: Option<f64>,
    /// Estimated error of the reference (DOP853 1e-13 vs 1e-12), same norm as `error`.
    pub ref_error: f64,
}

/// The states and `E` of one run at every communication point.
struct Trajectory {
    t: Vec<f64>,
    x: Vec<Vec<f64>>,
    energy: Vec<f64>,
}

struct Run {
    trajectory: Trajectory,
    /// None when every doStep completed.
    failure: Option<String>,
    stats: crate::integrators::Stats,
}

/// What a run needs to know of its system.
struct Model {
    info: &'static ModelInfo,
    state_vrs: Vec<u32>,
    nominal: Vec<f64>,
    energy_vr: Option<u32>,
}

impl Model {
    fn of<M: System>() -> Model {
        // One leak per system and call: the instance wants a 'static ModelInfo, as in the FMU.
        let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<M>()));
        let layout = &info.layout;
        let state_vrs: Vec<u32> = (0..layout.n_states)
            .map(|i| layout.vr_of_slot(VarKind::State, i))
            .collect();
        let nominal = state_vrs
            .iter()
            .map(|&vr| layout.vars[vr as usize].1.nominal.unwrap_or(1.0))
            .collect();
        let energy_vr = layout
            .vars
            .iter()
            .position(|(s, v)| s.kind == VarKind::Output && v.name == "E")
            .map(|i| i as u32);
        Model {
            info,
            state_vrs,
            nominal,
            energy_vr,
        }
    }
}

/// `(tol, step)` for [`run`] of a benchmarked `method` at `setting`: the tolerance of an
/// adaptive method (its step unbounded), or the fixed step of a fixed-step one (its
/// tolerance, unused, the model's default).
fn tol_and_step<M: System>(method: Method, setting: f64) -> (f64, f64) {
    if method.is_adaptive() {
        (setting, 0.0)
    } else {
        (M::default_experiment().1, setting)
    }
}

/// An instance with the scene's start values, `method` (`tol` for adaptive methods, `step`
/// for fixed ones; a positive `step` caps an adaptive one's), set up to `stop` and
/// initialised. Setup errors are returned as `Err`.
fn start<M: System>(
    model: &Model,
    scene: &Scene,
    method: Method,
    tol: f64,
    step: f64,
    stop: f64,
) -> Result<Instance<M>, String> {
    let layout = &model.info.layout;
    let mut fmu = Instance::<M>::new(model.info, Logger::silent("bench"));
    for (name, value) in &scene.start_values {
        let vr = layout
            .vr_of(name)
            .ok_or_else(|| format!("scene {}: unknown variable {name}", scene.name))?;
        // An Integer or Enumeration through fmi2SetInteger's path, as an importer sets it.
        fmu.set_value(vr, *value)?;
    }
    let solver = layout.vr_of("solver").expect("every FMU has solver");
    let solver_step = layout
        .vr_of("solver_step")
        .expect("every FMU has solver_step");
    fmu.set_integer(&[solver], &[method.code()])?;
    // The sweeps measure the methods, not an importer's patience: a long run takes up to
    // ~10⁶ fixed steps in one doStep, above the default solver_max_steps (5·10⁴).
    let max_steps = layout
        .vr_of("solver_max_steps")
        .expect("every FMU has solver_max_steps");
    fmu.set_integer(&[max_steps], &[i32::MAX])?;
    if !method.is_adaptive() {
        fmu.set_real(&[solver_step], &[step])?;
    } else if step > 0.0 {
        fmu.cap_adaptive_step(step);
    }
    fmu.setup_experiment(Some(tol), 0.0, Some(stop))?;
    fmu.enter_initialization_mode()?;
    fmu.exit_initialization_mode()?;
    Ok(fmu)
}

/// Integrates `scene` with `method` (`tol` for adaptive methods, `step` for fixed ones) up to
/// `stop` through the Instance API. Setup errors are returned as `Err` (the run was refused).
fn run<M: System>(
    model: &Model,
    scene: &Scene,
    method: Method,
    tol: f64,
    step: f64,
    comm_step: f64,
    stop: f64,
) -> Result<Run, String> {
    let mut fmu = start::<M>(model, scene, method, tol, step, stop)?;
    let n_comm = (stop / comm_step).round().max(1.0) as usize;
    let n = model.state_vrs.len();
    let mut trajectory = Trajectory {
        t: Vec::with_capacity(n_comm + 1),
        x: Vec::with_capacity(n_comm + 1),
        energy: Vec::with_capacity(n_comm + 1),
    };
    let mut record = |fmu: &Instance<M>| -> Result<(), String> {
        let mut x = vec![0.0; n];
        fmu.get_real(&model.state_vrs, &mut x)?;
        let mut e = [f64::NAN];
        if let Some(vr) = model.energy_vr {
            fmu.get_real(&[vr], &mut e)?;
        }
        trajectory.t.push(fmu.time());
        trajectory.x.push(x);
        trajectory.energy.push(e[0]);
        Ok(())
    };
    record(&fmu)?;
    let mut failure = None;
    for k in 0..n_comm {
        let now = fmu.time();
        // The last step lands on the stop time exactly.
        let h = if k + 1 == n_comm {
            stop - now
        } else {
            comm_step
        };
        match fmu.do_step(now, h) {
            Ok(StepOutcome::Completed) => record(&fmu)?,
            Ok(StepOutcome::Discarded(why)) => {
                failure = Some(why);
                break;
            }
            Err(why) => {
                failure = Some(why);
                break;
            }
        }
    }
    Ok(Run {
        trajectory,
        failure,
        stats: fmu.stats(),
    })
}

/// Log-spaced sample times from `grid` to `horizon`: multiples of `grid` (at most `samples`
/// of them), the last one `horizon` itself.
pub fn sample_times(horizon: f64, samples: usize, grid: f64) -> Vec<f64> {
    let n = (horizon / grid).round().max(1.0) as u64;
    let last = samples.max(2) - 1;
    let mut ks: Vec<u64> = (0..=last)
        .map(|i| (n as f64).powf(i as f64 / last as f64).round().max(1.0) as u64)
        .collect();
    ks.push(n);
    ks.sort_unstable();
    ks.dedup();
    ks.into_iter()
        .map(|k| if k == n { horizon } else { k as f64 * grid })
        .collect()
}

/// A long run: (t, |E(t) − E(0)| / |E(0)|, RHS evaluations so far) at every sample time.
struct LongRun {
    samples: Vec<(f64, f64, u64)>,
    failure: Option<String>,
    stats: crate::integrators::Stats,
}

/// Integrates `scene` with doSteps ending at each of `times` (the last is the horizon),
/// reading `E` after each.
fn long_run<M: System>(
    model: &Model,
    scene: &Scene,
    method: Method,
    tol: f64,
    step: f64,
    times: &[f64],
) -> Result<LongRun, String> {
    let horizon = *times.last().ok_or("no sample times")?;
    let vr = model.energy_vr.ok_or("the model has no output E")?;
    let mut fmu = start::<M>(model, scene, method, tol, step, horizon)?;
    let energy = |fmu: &Instance<M>| -> Result<f64, String> {
        let mut e = [0.0];
        fmu.get_real(&[vr], &mut e)?;
        Ok(e[0])
    };
    let e0 = energy(&fmu)?;
    let mut samples = Vec::with_capacity(times.len());
    let mut failure = None;
    for &t in times {
        let now = fmu.time();
        match fmu.do_step(now, t - now) {
            Ok(StepOutcome::Completed) => {
                let e = energy(&fmu)?;
                samples.push((t, (e - e0).abs() / e0.abs(), fmu.stats().rhs_evals));
            }
            Ok(StepOutcome::Discarded(why)) | Err(why) => {
                failure = Some(why);
                break;
            }
        }
    }
    Ok(LongRun {
        samples,
        failure,
        stats: fmu.stats(),
    })
}

/// Every method of `config` on a conservative scene over the long horizon: rows of
/// `longrun.csv` and `invariant.csv` appended to `summary` and `history`.
fn long_runs<M: System>(
    model: &Model,
    scene: &Scene,
    config: &BenchConfig,
    long: &LongRuns,
    summary: &mut String,
    history: &mut String,
) {
    let horizon = scene.stop_time * long.factor;
    let times = sample_times(horizon, long.samples, config.comm_step);
    for method in methods_of(config) {
        let settings = if method.is_adaptive() {
            &long.tolerances
        } else {
            &long.steps
        };
        for &setting in settings {
            let (tol, step) = tol_and_step::<M>(method, setting);
            let (kind, mut best) = (
                if method.is_adaptive() { "tol" } else { "step" },
                f64::INFINITY,
            );
            let mut outcome = None;
            for _ in 0..config.reps.max(1) {
                let clock = Instant::now();
                let r = long_run::<M>(model, scene, method, tol, step, &times);
                let elapsed = clock.elapsed().as_secs_f64();
                best = best.min(elapsed);
                let again =
                    matches!(&r, Ok(run) if run.failure.is_none()) && elapsed < TIME_ONCE_ABOVE;
                outcome = Some(r);
                if !again {
                    break; // long or failed runs are timed once
                }
            }
            let head = format!(
                "{},{},{},{kind},{setting:e},{horizon:?}",
                M::NAME,
                scene.name,
                method.name()
            );
            match outcome.expect("at least one repetition") {
                Err(why) => {
                    let _ = writeln!(
                        summary,
                        "{head},refused,,,{best:e},0,0,0,\"{}\"",
                        why.replace('"', "'")
                    );
                }
                Ok(r) => {
                    let max = r.samples.iter().map(|s| s.1).fold(0.0, f64::max);
                    let (status, last, message) = match &r.failure {
                        None => ("ok", opt(r.samples.last().map(|s| s.1)), String::new()),
                        Some(why) => ("failed", String::new(), why.replace('"', "'")),
                    };
                    let _ = writeln!(
                        summary,
                        "{head},{status},{},{last},{best:e},{},{},{},\"{message}\"",
                        if status == "ok" {
                            format!("{max:e}")
                        } else {
                            String::new()
                        },
                        r.stats.rhs_evals,
                        r.stats.steps,
                        r.stats.rejected
                    );
                    for (t, e, rhs) in &r.samples {
                        let _ = writeln!(
                            history,
                            "{},{},{},{kind},{setting:e},{t:?},{e:.3e},{rhs}",
                            M::NAME,
                            scene.name,
                            method.name()
                        );
                    }
                }
            }
        }
    }
}

fn methods_of(config: &BenchConfig) -> Vec<Method> {
    if config.methods.is_empty() {
        Method::ALL.to_vec()
    } else {
        config.methods.clone()
    }
}

/// A reference run: DOP853 at `tol` with its step capped at (and its communication step)
/// `comm_step / substeps`, so its step sequence differs from every benchmarked run and its
/// error is below its tolerance's, kept at the benchmark's grid points.
fn reference_run<M: System>(
    model: &Model,
    scene: &Scene,
    tol: f64,
    substeps: usize,
    config: &BenchConfig,
) -> Result<Run, String> {
    reference_run_with::<M>(model, scene, Method::Dop853, tol, substeps, config)
}

/// The exact propagator e^{Ah} among the methods, when the build has one (found by name so
/// the bench compiles with or without it).
fn exact_method() -> Option<Method> {
    Method::ALL.into_iter().find(|m| m.name() == "ExactLinear")
}

/// [`reference_run`] with any method: an adaptive one at `tol`, a fixed-step one (the exact
/// propagator) with `solver_step` = the fine communication step.
fn reference_run_with<M: System>(
    model: &Model,
    scene: &Scene,
    method: Method,
    tol: f64,
    substeps: usize,
    config: &BenchConfig,
) -> Result<Run, String> {
    let stop = scene.stop_time;
    let fine = config.comm_step / substeps as f64;
    // Both kinds step at most `fine`: the adaptive one capped there (with dense output it
    // would otherwise take the steps its tolerance allows: measured ref_error 1e2 times
    // larger on CompoundPendulum/inverted, 1e6 times on WhippleBicycle/capsize).
    let tol = if method.is_adaptive() {
        tol
    } else {
        M::default_experiment().1
    };
    let mut r = run::<M>(model, scene, method, tol, fine, fine, stop)?;
    fn keep<T>(v: &mut Vec<T>, substeps: usize) {
        let last = v.len() - 1;
        let mut k = 0;
        v.retain(|_| {
            let keep = k % substeps == 0 || k == last;
            k += 1;
            keep
        });
    }
    if r.failure.is_none() {
        let n = r.trajectory.t.len();
        let expected = (stop / config.comm_step).round().max(1.0) as usize + 1;
        keep(&mut r.trajectory.t, substeps);
        keep(&mut r.trajectory.x, substeps);
        keep(&mut r.trajectory.energy, substeps);
        if r.trajectory.t.len() != expected {
            return Err(format!(
                "reference grid of {n} points does not refine the benchmark grid"
            ));
        }
    }
    Ok(r)
}

/// Scale of each state: its largest magnitude along the reference (nominal, else 1, if 0).
fn scales(reference: &Trajectory, nominal: &[f64]) -> Vec<f64> {
    (0..nominal.len())
        .map(|i| {
            let m = reference.x.iter().map(|x| x[i].abs()).fold(0.0, f64::max);
            if m > 0.0 {
                m
            } else {
                nominal[i]
            }
        })
        .collect()
}

fn scaled_error(a: &[f64], b: &[f64], scale: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .zip(scale)
        .map(|((a, b), s)| (a - b).abs() / s)
        .fold(0.0, f64::max)
}

/// (grid error, final error) of a complete run against the reference; a run on another
/// grid (a free run) is compared at the stop time only.
fn errors(run: &Trajectory, reference: &Trajectory, scale: &[f64]) -> (f64, f64) {
    let last = scaled_error(
        run.x.last().expect("recorded"),
        reference.x.last().expect("recorded"),
        scale,
    );
    if run.x.len() != reference.x.len() {
        return (last, last);
    }
    let grid = run
        .x
        .iter()
        .zip(&reference.x)
        .map(|(a, b)| scaled_error(a, b, scale))
        .fold(0.0, f64::max);
    (grid, last)
}

/// max_t |E(t) − E(0)| / |E(0)|.
fn energy_drift(t: &Trajectory) -> f64 {
    let e0 = t.energy[0];
    t.energy
        .iter()
        .map(|e| (e - e0).abs() / e0.abs())
        .fold(0.0, f64::max)
}

/// `E` is treated as an invariant of a scene when the model has an output `E`, it is not
/// zero at the start, and the reference conserves it to 1e-9 (relative): this excludes
/// damping, inputs and built-in forcing without a per-system list.
pub fn energy_is_invariant(reference_drift: f64) -> bool {
    reference_drift.is_finite() && reference_drift < 1e-9
}

/// Every scene of `M`, every method, every setting of `config`.
pub fn bench_system<M: System>(config: &BenchConfig) -> Vec<BenchRow> {
    let model = Model::of::<M>();
    let mut rows = Vec::new();
    for scene in M::scenes() {
        if !config.scenes.is_empty() && !config.scenes.iter().any(|s| s == scene.name) {
            continue;
        }
        let stop = scene.stop_time;
        // The reference: the exact propagator where the scene is linear time-invariant (the
        // closed form e^{At}; DOP853 at REFERENCE_TOL is then its check), else DOP853 at
        // REFERENCE_TOL checked by DOP853 at CHECK_TOL.
        let exact = exact_method().and_then(|m| {
            match reference_run_with::<M>(&model, &scene, m, 0.0, REFERENCE_SUBSTEPS, config) {
                Ok(r) if r.failure.is_none() => Some(r),
                _ => None,
            }
        });
        let (reference_name, first, second) = match exact {
            Some(r) => (
                "ExactLinear",
                Ok(r),
                reference_run::<M>(&model, &scene, REFERENCE_TOL, CHECK_SUBSTEPS, config),
            ),
            None => (
                "DOP853",
                reference_run::<M>(&model, &scene, REFERENCE_TOL, REFERENCE_SUBSTEPS, config),
                reference_run::<M>(&model, &scene, CHECK_TOL, CHECK_SUBSTEPS, config),
            ),
        };
        let (reference, check) = match (first, second) {
            (Ok(r), Ok(c)) if r.failure.is_none() && c.failure.is_none() => (r, c),
            (r, c) => {
                let why = |x: Result<Run, String>| match x {
                    Ok(run) => run.failure.unwrap_or_default(),
                    Err(e) => e,
                };
                eprintln!(
                    "bench: {}/{}: no reference ({} {}), scene skipped",
                    M::NAME,
                    scene.name,
                    why(r),
                    why(c)
                );
                continue;
            }
        };
        let scale = scales(&reference.trajectory, &model.nominal);
        let ref_error = errors(&check.trajectory, &reference.trajectory, &scale).0;
        let invariant =
            model.energy_vr.is_some() && energy_is_invariant(energy_drift(&reference.trajectory));
        if let Some(sink) = &config.sink {
            let text = reference_rows::<M>(
                &model,
                &scene,
                &reference.trajectory,
                &scale,
                ref_error,
                invariant,
                reference_name,
            );
            sink.lock().expect("sink").reference.push_str(&text);
            if let (Some(long), true) = (&config.long_runs, invariant) {
                let (mut summary, mut history) = (String::new(), String::new());
                long_runs::<M>(&model, &scene, config, long, &mut summary, &mut history);
                let mut sink = sink.lock().expect("sink");
                sink.long_runs.push_str(&summary);
                sink.invariant.push_str(&history);
            }
        }
        for method in methods_of(config) {
            let (kind, settings) = if method.is_adaptive() {
                ("tol", &config.tolerances)
            } else {
                ("step", &config.steps)
            };
            let comms = if method.is_adaptive() && config.free_run {
                vec![config.comm_step, stop]
            } else {
                vec![config.comm_step]
            };
            for (&setting, &comm) in settings
                .iter()
                .flat_map(|s| comms.iter().map(move |c| (s, c)))
            {
                let (tol, step) = tol_and_step::<M>(method, setting);
                let mut best = f64::INFINITY;
                let mut outcome = None;
                for _ in 0..config.reps.max(1) {
                    let start = Instant::now();
                    let r = run::<M>(&model, &scene, method, tol, step, comm, stop);
                    let elapsed = start.elapsed().as_secs_f64();
                    best = best.min(elapsed);
                    let failed = !matches!(&r, Ok(run) if run.failure.is_none());
                    outcome = Some(r);
                    if failed || elapsed > TIME_ONCE_ABOVE {
                        break; // a failure is not timed further, a long run once
                    }
                }
                let mut row = BenchRow {
                    system: M::NAME,
                    scene: scene.name,
                    method: method.name(),
                    setting_kind: kind,
                    setting,
                    comm_step: comm,
                    status: "ok",
                    message: String::new(),
                    error: None,
                    error_final: None,
                    cpu_s: best,
                    rhs_evals: 0,
                    steps: 0,
                    rejected: 0,
                    invariant_error: None,
                    ref_error,
                };
                match outcome.expect("at least one repetition") {
                    Err(why) => {
                        row.status = "refused";
                        row.message = why;
                    }
                    Ok(r) => {
                        row.rhs_evals = r.stats.rhs_evals;
                        row.steps = r.stats.steps;
                        row.rejected = r.stats.rejected;
                        if let Some(why) = r.failure {
                            row.status = "failed";
                            row.message = why;
                        } else {
                            let (grid, last) = errors(&r.trajectory, &reference.trajectory, &scale);
                            row.error = Some(grid);
                            row.error_final = Some(last);
                            if invariant && r.trajectory.t.len() == reference.trajectory.t.len() {
                                row.invariant_error = Some(energy_drift(&r.trajectory));
                            }
                        }
                    }
                }
                rows.push(row);
            }
        }
    }
    rows
}

/// Relative energy error |E(t) − E(0)| / |E(0)| of one method on one scene over a long
/// horizon, sampled every `every` seconds: rows (method, setting, t, error).
pub fn energy_history<M: System>(
    scene: &str,
    runs: &[(Method, f64)],
    horizon: f64,
    comm_step: f64,
    every: f64,
) -> Result<Vec<(&'static str, f64, f64, f64)>, String> {
    let model = Model::of::<M>();
    let mut scene = M::scenes()
        .into_iter()
        .find(|s| s.name == scene)
        .ok_or_else(|| format!("{} has no scene {scene}", M::NAME))?;
    scene.stop_time = horizon;
    let mut rows = Vec::new();
    for &(method, setting) in runs {
        let (tol, step) = tol_and_step::<M>(method, setting);
        let r = run::<M>(&model, &scene, method, tol, step, comm_step, horizon)?;
        let traj = &r.trajectory;
        let e0 = traj.energy[0];
        let stride = (every / comm_step).round().max(1.0) as usize;
        for k in (0..traj.t.len()).step_by(stride) {
            rows.push((
                method.name(),
                setting,
                traj.t[k],
                (traj.energy[k] - e0).abs() / e0.abs(),
            ));
        }
    }
    Ok(rows)
}

fn opt(v: Option<f64>) -> String {
    v.map(|v| format!("{v:e}")).unwrap_or_default()
}

/// The rows as CSV (header included). Messages are quoted.
pub fn to_csv(rows: &[BenchRow]) -> String {
    let mut s = String::from(
        "system,scene,method,setting_kind,setting,comm_step,status,error,error_final,cpu_s,rhs_evals,steps,rejected,invariant_error,ref_error,message\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "{},{},{},{},{:e},{:?},{},{},{},{:e},{},{},{},{},{:e},\"{}\"",
            r.system,
            r.scene,
            r.method,
            r.setting_kind,
            r.setting,
            r.comm_step,
            r.status,
            opt(r.error),
            opt(r.error_final),
            r.cpu_s,
            r.rhs_evals,
            r.steps,
            r.rejected,
            opt(r.invariant_error),
            r.ref_error,
            r.message.replace('"', "'")
        );
    }
    s
}

/// The parameters of `scene`: its start values over the declared defaults.
fn parameters(model: &Model, scene: &Scene) -> Vec<f64> {
    let mut p: Vec<(usize, f64)> = model
        .info
        .layout
        .vars
        .iter()
        .filter(|(slot, _)| slot.kind == VarKind::Parameter)
        .map(|(slot, var)| {
            let value = scene
                .start_values
                .iter()
                .rev()
                .find(|(n, _)| *n == var.name)
                .map_or(var.start, |(_, v)| *v);
            (slot.index, value)
        })
        .collect();
    p.sort_by_key(|(i, _)| *i);
    p.into_iter().map(|(_, v)| v).collect()
}

/// Whether the system projects its states after every doStep (`System::project` moves a
/// state slightly off the start): the peers integrate such systems as the raw ODE.
fn projects<M: System>(model: &Model, scene: &Scene, start: &[f64]) -> bool {
    let p = parameters(model, scene);
    let off: Vec<f64> = start.iter().map(|v| v + 1e-3 * (1.0 + v.abs())).collect();
    let mut moved = off.clone();
    M::project(0.0, &p, &mut moved);
    moved != off
}

/// Rows of `reference.csv` for one scene: per state, the reference at the stop time, its
/// scale, nominal and start value (after fmi2ExitInitializationMode: projected for the
/// constrained systems), the reference's estimated error, whether E is an invariant, which
/// reference it is (`ExactLinear`: e^{At}, else `DOP853` at [`REFERENCE_TOL`]) and whether the
/// system projects its states after every doStep.
fn reference_rows<M: System>(
    model: &Model,
    scene: &Scene,
    reference: &Trajectory,
    scale: &[f64],
    ref_error: f64,
    invariant: bool,
    reference_name: &str,
) -> String {
    let layout = &model.info.layout;
    let mut s = String::new();
    let (first, last) = (&reference.x[0], reference.x.last().expect("recorded"));
    let projected = u8::from(projects::<M>(model, scene, first));
    for (i, &vr) in model.state_vrs.iter().enumerate() {
        let _ = writeln!(
            s,
            "{},{},{:?},{},{:?},{:?},{:?},{:?},{:e},{},{reference_name},{projected}",
            M::NAME,
            scene.name,
            scene.stop_time,
            layout.vars[vr as usize].1.name,
            last[i],
            scale[i],
            model.nominal[i],
            first[i],
            ref_error,
            u8::from(invariant)
        );
    }
    s
}

/// One system's sweep, as the catalogue hands it to [`cli`].
pub type BenchFn = fn(&BenchConfig) -> Vec<BenchRow>;

/// The options of `mbfmu bench` (the CLI parses them).
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// Two settings per method, MassSpringDamper and TwoMassChain unless `systems` says.
    pub quick: bool,
    pub out: PathBuf,
    /// Only these systems (all when empty).
    pub systems: Vec<String>,
    /// Only these scenes (all when empty).
    pub scenes: Vec<String>,
    pub reps: Option<usize>,
    /// The long runs of the conservative scenes.
    pub energy: bool,
    /// The springy-vs-rigid comparison.
    pub springy: bool,
}

/// What [`cli`] reports as it goes, so the CLI can draw progress without the library
/// knowing of terminals.
pub enum BenchEvent<'a> {
    /// This many systems will be swept.
    Start(usize),
    /// One system's sweep begins.
    System(&'a str),
    /// One system's sweep ended: its summary line.
    Done(String),
    /// Any other line for the user (files written, the total).
    Note(String),
}

/// `mbfmu bench [--quick] [--out DIR] [--system NAME]... [--scene NAME]... [--reps N]
/// [--no-energy] [--no-springy]`.
///
/// Writes `results.csv` and `reference.csv`; unless `--no-energy`, the long runs of the
/// conservative scenes (`longrun.csv`, `invariant.csv`); unless `--no-springy` or when the
/// selection leaves out SpringyPendulum/stiff, the springy-vs-rigid comparison
/// (`springy_rigid*.csv`).
pub fn cli(
    options: &BenchOptions,
    systems: &[(&'static str, BenchFn)],
    report: &dyn Fn(BenchEvent),
) -> Result<(), String> {
    let clock = Instant::now();
    let BenchOptions {
        quick,
        out,
        systems: mut only,
        scenes,
        reps,
        energy,
        springy,
    } = options.clone();
    let mut config = if quick {
        BenchConfig::quick()
    } else {
        BenchConfig::full()
    };
    if let Some(r) = reps {
        config.reps = r.max(1);
    }
    config.scenes = scenes;
    if energy {
        config.long_runs = Some(if quick {
            LongRuns::quick()
        } else {
            LongRuns::full()
        });
    }
    let sink = Arc::new(Mutex::new(Sink::default()));
    config.sink = Some(Arc::clone(&sink));
    if quick && only.is_empty() {
        only = vec!["MassSpringDamper".into(), "TwoMassChain".into()];
    }
    let entries: Vec<_> = systems
        .iter()
        .filter(|(name, _)| only.is_empty() || only.iter().any(|n| n == name))
        .collect();
    if entries.is_empty() {
        return Err(format!("bench: no system matches {}", only.join(", ")));
    }
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut rows = Vec::new();
    report(BenchEvent::Start(entries.len()));
    for (name, bench) in &entries {
        report(BenchEvent::System(name));
        let start = Instant::now();
        let mine = bench(&config);
        let failed = mine.iter().filter(|r| r.status != "ok").count();
        report(BenchEvent::Done(format!(
            "bench: {:<18} {:>4} runs ({failed} failed or refused) in {:.1} s",
            name,
            mine.len(),
            start.elapsed().as_secs_f64()
        )));
        rows.extend(mine);
    }
    let write = |name: &str, text: &str| {
        let path = out.join(name);
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        report(BenchEvent::Note(format!("wrote {}", path.display())));
        Ok::<(), String>(())
    };
    write("results.csv", &to_csv(&rows))?;
    let sink = std::mem::take(&mut *sink.lock().expect("sink"));
    write(
        "reference.csv",
        &format!("{REFERENCE_HEADER}{}", sink.reference),
    )?;
    if energy {
        write(
            "longrun.csv",
            &format!("{LONG_RUN_HEADER}{}", sink.long_runs),
        )?;
        write(
            "invariant.csv",
            &format!("{INVARIANT_HEADER}{}", sink.invariant),
        )?;
    }
    let wants = |name: &str, list: &[String]| list.is_empty() || list.iter().any(|n| n == name);
    if springy && wants("SpringyPendulum", &only) && wants("stiff", &config.scenes) {
        let start = Instant::now();
        report(BenchEvent::System("springy vs rigid"));
        let cmp = springy_rigid::compare(&config)?;
        report(BenchEvent::Note(format!(
            "bench: springy vs rigid in {:.1} s",
            start.elapsed().as_secs_f64()
        )));
        write("springy_rigid.csv", &cmp.trajectory)?;
        write("springy_rigid_cost.csv", &cmp.cost)?;
        write("springy_rigid_stiffness.csv", &cmp.stiffness)?;
    }
    report(BenchEvent::Note(format!(
        "bench: done in {:.1} s; next: python benches/peers.py --out {dir} && python benches/plot.py --out {dir}",
        clock.elapsed().as_secs_f64(),
        dir = out.display()
    )));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::sample_times;

    #[test]
    fn sample_times_are_increasing_grid_multiples_ending_at_the_horizon() {
        let t = sample_times(100.0, 60, 0.01);
        assert!(t.len() > 30 && t.len() <= 61, "{}", t.len());
        assert_eq!(t[0], 0.01);
        assert_eq!(*t.last().unwrap(), 100.0);
        assert!(t.windows(2).all(|w| w[0] < w[1]));
        assert!(t
            .iter()
            .all(|&x| ((x / 0.01).round() * 0.01 - x).abs() < 1e-12));
        assert_eq!(sample_times(0.01, 60, 0.01), vec![0.01]);
    }
}
