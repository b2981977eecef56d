//! The springy pendulum's `stiff` scene (c = 1e6 N/m) against the rigid pendulum it
//! approximates: a `CompoundPendulum` with `l = r_eq` and `I_O = m r_eq²` (a point mass on a
//! massless rod of the spring's static length `r_eq = r0 + m g / c`), same θ0 and θ̇0.
//!
//! Three tables:
//! - `trajectory`: both references (DOP853 at [`REFERENCE_TOL`]) on the communication grid:
//!   θ and θ̇ of each model, their differences, and the spring's stretch `r − r_eq`.
//! - `cost`: every method at every setting on both models; the error is in (θ, θ̇) only, the
//!   coordinates the two models share, at the stop time, scaled as the bench scales
//!   (by `max_t |θ_ref|`, `max_t |θ̇_ref|`), against each model's own reference. Adaptive
//!   methods run in one doStep (the integrator alone), fixed-step ones on the grid.
//! - `stiffness`: the same trajectory difference for c = 1e2 … 1e6 (r at its static length),
//!   with the RHS evaluations of DOP853 and RADAU5 at tolerance 1e-8 on either model.

use super::*;
use crate::systems::{CompoundPendulum, SpringyPendulum};

/// The CSV texts (headers included).
pub struct Comparison {
    pub trajectory: String,
    pub cost: String,
    pub stiffness: String,
}

/// Stiffnesses of the `stiffness` table (N/m).
pub const STIFFNESSES: [f64; 5] = [1e2, 1e3, 1e4, 1e5, 1e6];

/// A start value of `scene`, else the variable's default.
fn value(model: &Model, scene: &Scene, name: &str) -> Result<f64, String> {
    if let Some((_, v)) = scene.start_values.iter().rev().find(|(n, _)| *n == name) {
        return Ok(*v);
    }
    let layout = &model.info.layout;
    let vr = layout
        .vr_of(name)
        .ok_or_else(|| format!("no variable {name}"))?;
    Ok(layout.vars[vr as usize].1.start)
}

fn state_index(model: &Model, name: &str) -> Result<usize, String> {
    model
        .state_vrs
        .iter()
        .position(|&vr| model.info.layout.vars[vr as usize].1.name == name)
        .ok_or_else(|| format!("no state {name}"))
}

/// The springy scene `base` with stiffness `c` (r at its static length) when `c` is given,
/// the rigid pendulum of the same static length, and that length.
fn pair(springy: &Model, base: &Scene, c: Option<f64>) -> Result<(Scene, Scene, f64), String> {
    let [m, r0, g, theta, theta_dot] =
        ["m", "r0", "g", "theta", "theta_dot"].map(|n| value(springy, base, n));
    let (m, r0, g, theta, theta_dot) = (m?, r0?, g?, theta?, theta_dot?);
    let c = match c {
        Some(c) => c,
        None => value(springy, base, "c")?,
    };
    let r_eq = r0 + m * g / c;
    let scene = Scene::new(base.name, base.description, base.stop_time)
        .set("m", m)
        .set("c", c)
        .set("r0", r0)
        .set("g", g)
        .set("r", r_eq)
        .set("theta", theta)
        .set("r_dot", 0.0)
        .set("theta_dot", theta_dot);
    let rigid = Scene::new(
        "rigid_of_springy_stiff",
        "CompoundPendulum with l = r_eq, I_O = m r_eq²: the rigid pendulum of the springy one",
        base.stop_time,
    )
    .set("m", m)
    .set("l", r_eq)
    .set("I_O", m * r_eq * r_eq)
    .set("g", g)
    .set("theta", theta)
    .set("theta_dot", theta_dot);
    Ok((scene, rigid, r_eq))
}

fn reference<M: System>(model: &Model, scene: &Scene, config: &BenchConfig) -> Result<Run, String> {
    let r = reference_run::<M>(model, scene, REFERENCE_TOL, REFERENCE_SUBSTEPS, config)?;
    match r.failure {
        Some(why) => Err(format!(
            "{}/{}: reference failed: {why}",
            M::NAME,
            scene.name
        )),
        None => Ok(r),
    }
}

/// Error in the states `idx` at the stop time, each scaled by `scale`.
fn shared_error(x: &[f64], reference: &[f64], idx: &[usize], scale: &[f64]) -> f64 {
    idx.iter()
        .zip(scale)
        .map(|(&i, s)| (x[i] - reference[i]).abs() / s)
        .fold(0.0, f64::max)
}

/// Rows of the cost table for one model.
fn sweep<M: System>(
    label: &str,
    model: &Model,
    scene: &Scene,
    config: &BenchConfig,
    idx: &[usize],
    out: &mut String,
) -> Result<(), String> {
    let stop = scene.stop_time;
    let reference = reference::<M>(model, scene, config)?;
    let check = reference_run::<M>(model, scene, CHECK_TOL, CHECK_SUBSTEPS, config)?;
    let scale: Vec<f64> = idx
        .iter()
        .map(|&i| {
            let m = reference
                .trajectory
                .x
                .iter()
                .map(|x| x[i].abs())
                .fold(0.0, f64::max);
            if m > 0.0 {
                m
            } else {
                1.0
            }
        })
        .collect();
    let final_ref = reference.trajectory.x.last().expect("recorded");
    let ref_error = shared_error(
        check.trajectory.x.last().expect("recorded"),
        final_ref,
        idx,
        &scale,
    );
    for method in methods_of(config) {
        let (kind, settings, comm) = if method.is_adaptive() {
            ("tol", &config.tolerances, stop)
        } else {
            ("step", &config.steps, config.comm_step)
        };
        for &setting in settings {
            let (tol, step) = tol_and_step::<M>(method, setting);
            let mut best = f64::INFINITY;
            let mut outcome = None;
            for _ in 0..config.reps.max(1) {
                let clock = Instant::now();
                let r = run::<M>(model, scene, method, tol, step, comm, stop);
                let elapsed = clock.elapsed().as_secs_f64();
                best = best.min(elapsed);
                let failed = !matches!(&r, Ok(run) if run.failure.is_none());
                outcome = Some(r);
                if failed || elapsed > TIME_ONCE_ABOVE {
                    break;
                }
            }
            let (status, error, rhs, steps, rejected, message) =
                match outcome.expect("at least one repetition") {
                    Err(why) => ("refused", String::new(), 0, 0, 0, why),
                    Ok(r) => match r.failure {
                        Some(why) => (
                            "failed",
                            String::new(),
                            r.stats.rhs_evals,
                            r.stats.steps,
                            r.stats.rejected,
                            why,
                        ),
                        None => {
                            let x = r.trajectory.x.last().expect("recorded");
                            let e = shared_error(x, final_ref, idx, &scale);
                            (
                                "ok",
                                format!("{e:e}"),
                                r.stats.rhs_evals,
                                r.stats.steps,
                                r.stats.rejected,
                                String::new(),
                            )
                        }
                    },
                };
            let _ = writeln!(
                out,
                "{label},{},{},{},{kind},{setting:e},{comm:?},{status},{error},{best:e},{rhs},{steps},{rejected},{ref_error:e},\"{}\"",
                M::NAME,
                scene.name,
                method.name(),
                message.replace('"', "'")
            );
        }
    }
    Ok(())
}

/// RHS evaluations of `method` at tolerance 1e-8 in one doStep (None if it failed).
fn rhs_at_1e8<M: System>(model: &Model, scene: &Scene, method: Method) -> Option<u64> {
    let stop = scene.stop_time;
    match run::<M>(model, scene, method, 1e-8, 0.0, stop, stop) {
        Ok(r) if r.failure.is_none() => Some(r.stats.rhs_evals),
        _ => None,
    }
}

/// The three tables for SpringyPendulum/stiff.
pub fn compare(config: &BenchConfig) -> Result<Comparison, String> {
    let springy = Model::of::<SpringyPendulum>();
    let rigid_model = Model::of::<CompoundPendulum>();
    let base = SpringyPendulum::scenes()
        .into_iter()
        .find(|s| s.name == "stiff")
        .ok_or("SpringyPendulum has no scene stiff")?;
    let (_, rigid, r_eq) = pair(&springy, &base, None)?;
    let s_theta = state_index(&springy, "theta")?;
    let s_theta_dot = state_index(&springy, "theta_dot")?;
    let s_r = state_index(&springy, "r")?;
    let r_theta = state_index(&rigid_model, "theta")?;
    let r_theta_dot = state_index(&rigid_model, "theta_dot")?;

    // Trajectories of the two references on the grid.
    let a = reference::<SpringyPendulum>(&springy, &base, config)?;
    let b = reference::<CompoundPendulum>(&rigid_model, &rigid, config)?;
    let mut trajectory = String::from(
        "t,theta_springy,theta_rigid,dtheta,theta_dot_springy,theta_dot_rigid,dtheta_dot,stretch\n",
    );
    for ((t, x), y) in a
        .trajectory
        .t
        .iter()
        .zip(&a.trajectory.x)
        .zip(&b.trajectory.x)
    {
        let _ = writeln!(
            trajectory,
            "{t:?},{:?},{:?},{:e},{:?},{:?},{:e},{:e}",
            x[s_theta],
            y[r_theta],
            x[s_theta] - y[r_theta],
            x[s_theta_dot],
            y[r_theta_dot],
            x[s_theta_dot] - y[r_theta_dot],
            x[s_r] - r_eq
        );
    }

    // Cost of every method on either model, error in (θ, θ̇).
    let mut cost = String::from(
        "model,system,scene,method,setting_kind,setting,comm_step,status,error_final,cpu_s,rhs_evals,steps,rejected,ref_error,message\n",
    );
    sweep::<SpringyPendulum>(
        "springy",
        &springy,
        &base,
        config,
        &[s_theta, s_theta_dot],
        &mut cost,
    )?;
    sweep::<CompoundPendulum>(
        "rigid",
        &rigid_model,
        &rigid,
        config,
        &[r_theta, r_theta_dot],
        &mut cost,
    )?;

    // The difference against the stiffness.
    let mut stiffness = String::from(
        "c,r_eq,max_abs_dtheta,max_abs_dtheta_dot,final_dtheta,max_abs_stretch,rhs_springy_DOP853,rhs_rigid_DOP853,rhs_springy_RADAU5,rhs_rigid_RADAU5\n",
    );
    for c in STIFFNESSES {
        let (scene, rigid, r_eq) = pair(&springy, &base, Some(c))?;
        let a = reference::<SpringyPendulum>(&springy, &scene, config)?;
        let b = reference::<CompoundPendulum>(&rigid_model, &rigid, config)?;
        let diff = |i: usize, j: usize| {
            a.trajectory
                .x
                .iter()
                .zip(&b.trajectory.x)
                .map(|(x, y)| (x[i] - y[j]).abs())
                .fold(0.0, f64::max)
        };
        let stretch = a
            .trajectory
            .x
            .iter()
            .map(|x| (x[s_r] - r_eq).abs())
            .fold(0.0, f64::max);
        let last = (
            a.trajectory.x.last().expect("recorded"),
            b.trajectory.x.last().expect("recorded"),
        );
        let count = |v: Option<u64>| v.map(|v| v.to_string()).unwrap_or_default();
        let _ = writeln!(
            stiffness,
            "{c:e},{r_eq:?},{:e},{:e},{:e},{stretch:e},{},{},{},{}",
            diff(s_theta, r_theta),
            diff(s_theta_dot, r_theta_dot),
            last.0[s_theta] - last.1[r_theta],
            count(rhs_at_1e8::<SpringyPendulum>(
                &springy,
                &scene,
                Method::Dop853
            )),
            count(rhs_at_1e8::<CompoundPendulum>(
                &rigid_model,
                &rigid,
                Method::Dop853
            )),
            count(rhs_at_1e8::<SpringyPendulum>(
                &springy,
                &scene,
                Method::Radau5
            )),
            count(rhs_at_1e8::<CompoundPendulum>(
                &rigid_model,
                &rigid,
                Method::Radau5
            )),
        );
    }
    Ok(Comparison {
        trajectory,
        cost,
        stiffness,
    })
}
