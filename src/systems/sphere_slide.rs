//! A particle sliding without friction from the top of a smooth sphere (notes 6.3,
//! systems.md section 11): a one-sided constraint that lets go, an event inside a step.
//!
//! States, in the sphere's vertical plane through the particle, centre at the origin:
//! `x` (horizontal), `h` (height above the centre), `vx`, `vh`, and the mode
//! `on_surface` (1 on the sphere, 0 in free flight; its derivative is zero, only
//! [`SphereSlide::on_event`] changes it).
//!
//! On the surface the constraint `c = ½ (x² + h² − R²) = 0` is kept by the λ-method: the
//! normal force `N` along the outward radius is the multiplier, from `c̈ = 0`:
//!
//! ```text
//! m a = (0, −m g) + N (x, h)/r,   r = √(x² + h²)
//! c̈ = v² + (x, h)·a = 0   ⇒   N = m (g h − v²)/r = m (g cos θ − v²/R) on the sphere
//! ```
//!
//! A smooth sphere can only push: the particle leaves where N crosses zero. That is the
//! event indicator; [`SphereSlide::on_event`] sets `on_surface = 0`, and the motion goes
//! on as a parabola. Position and velocity drift off the sphere are removed by
//! [`SphereSlide::project`] (on the surface only) after every doStep.

use crate::model::{Scalar, Scene, System, Var};

pub struct SphereSlide;

/// Parameter indices.
const M: usize = 0;
const R: usize = 1;
const G: usize = 2;

/// State indices.
const X: usize = 0;
const H: usize = 1;
const VX: usize = 2;
const VH: usize = 3;
const ON: usize = 4;

/// Start offset from the top of the `slide` scene (and the start values).
const THETA0: f64 = 1e-3;

fn on_surface(mode: f64) -> bool {
    mode >= 0.5
}

/// The normal force of the λ-method, `N = m (g h − v²)/r` (on the surface).
fn normal_force<S: Scalar>(x: &[S], p: &[S]) -> S {
    let r = (x[X] * x[X] + x[H] * x[H]).sqrt();
    let v2 = x[VX] * x[VX] + x[VH] * x[VH];
    p[M] * (p[G] * x[H] - v2) / r
}

impl System for SphereSlide {
    const NAME: &'static str = "SphereSlide";
    const DESCRIPTION: &'static str =
        "A particle sliding without friction off the top of a smooth sphere: it leaves the surface where the normal force vanishes (an event)";
    const EQUATIONS: &'static [&'static str] = &[
        "States x, h (height above the centre), vx, vh in the vertical plane through the particle; mode on_surface (1 on the sphere, 0 in free flight, d(on_surface)/dt = 0)",
        "On the surface, constraint x² + h² = R² kept by the λ-method: m a = (0, −m g) + N (x, h)/r, r = √(x² + h²), N = m (g h − v²)/r from the constraint differentiated twice",
        "On the sphere N = m (g cos θ − v²/R), θ = atan2(x, h) from the top",
        "Event indicator N (on the surface): where it crosses zero the particle leaves (on_surface ← 0); in free flight m a = (0, −m g), N = 0",
        "From rest at θ0: energy gives v² = 2 g R (cos θ0 − cos θ), and N = 0 where g R cos θ = v²: it leaves at cos θ = ⅔ cos θ0 (⅔ from the very top) with speed √(g R cos θ)",
        "After every doStep (and at initialisation), on the surface only: (x, h) scaled onto the sphere, the radial part of (vx, vh) removed",
        "E = ½ m (vx² + vh²) + m g h (conserved: the normal force does no work)",
        "Start on the surface with N > 0 (e.g. at rest, h > 0): the event is the crossing of N from positive to zero",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 1.0, "Mass of the particle").min(1e-12),
            Var::new("R", Some("m"), 1.0, "Radius of the sphere").min(1e-12),
            Var::new("g", Some("m/s2"), 9.81, "Gravitational acceleration"),
        ]
    }

    fn inputs() -> Vec<Var> {
        Vec::new()
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new(
                "x",
                Some("m"),
                THETA0.sin(),
                "Horizontal position from the sphere's centre (start: R sin θ0)",
            )
            .nominal(1.0),
            Var::new(
                "h",
                Some("m"),
                THETA0.cos(),
                "Height above the sphere's centre (start: R cos θ0; on the surface computed: √(R² − x²))",
            )
            .nominal(1.0)
            .dependent(),
            Var::new("vx", Some("m/s"), 0.0, "Horizontal velocity").nominal(1.0),
            Var::new(
                "vh",
                Some("m/s"),
                0.0,
                "Vertical velocity (on the surface computed: −x vx / h)",
            )
            .nominal(1.0)
            .dependent(),
            Var::new(
                "on_surface",
                None,
                1.0,
                "Mode: 1 on the sphere, 0 after leaving it (constant between events)",
            )
            .min(0.0)
            .max(1.0)
            .nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "theta",
                Some("rad"),
                THETA0,
                "Angle from the top, atan2(x, h)",
            ),
            Var::new(
                "N",
                Some("N"),
                0.0,
                "Normal force of the sphere on the particle (0 in free flight)",
            ),
            Var::new(
                "E",
                Some("J"),
                0.0,
                "Mechanical energy ½ m (vx² + vh²) + m g h",
            ),
        ]
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], dx: &mut [S]) {
        dx[X] = x[VX];
        dx[H] = x[VH];
        if on_surface(x[ON].re()) {
            // a = (0, −g) + (N/m) (x, h)/r
            let r = (x[X] * x[X] + x[H] * x[H]).sqrt();
            let k = normal_force(x, p) / (p[M] * r);
            dx[VX] = k * x[X];
            dx[VH] = k * x[H] - p[G];
        } else {
            dx[VX] = S::from(0.0);
            dx[VH] = -p[G];
        }
        dx[ON] = S::from(0.0);
    }

    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        y[0] = x[X].atan2(x[H]);
        y[1] = if on_surface(x[ON].re()) {
            normal_force(x, p)
        } else {
            S::from(0.0)
        };
        y[2] = p[M] * (x[VX] * x[VX] + x[VH] * x[VH]) * 0.5 + p[M] * p[G] * x[H];
    }

    fn scenes() -> Vec<Scene> {
        vec![Scene::new(
            "slide",
            "From rest at θ0 = 1e-3 rad from the top: leaves the sphere at cos θ = ⅔ cos θ0 (t = 2.376 s), then flies",
            3.0,
        )
        .set("x", THETA0.sin())
        .set("h", THETA0.cos())
        .set("vx", 0.0)
        .set("vh", 0.0)
        .set("on_surface", 1.0)]
    }

    fn default_experiment() -> (f64, f64, f64) {
        (3.0, 1e-8, 1e-2)
    }

    /// On the surface: the position scaled radially onto the sphere (the nearest point),
    /// then the radial component of the velocity removed (the nearest tangent velocity);
    /// the mass metric is m times the identity, so both are orthogonal projections in it.
    /// In free flight: nothing.
    /// On the surface: `x² + h² = R²` and `x vx + h vh = 0`; a user sets x and vx (and
    /// the mode), h and vh follow (h on the side of its start value: above the centre).
    const STATE_CONSTRAINTS: usize = 2;

    fn state_constraints<S: Scalar>(_t: f64, x: &[S], p: &[S], residual: &mut [S]) -> bool {
        residual[0] = (x[X] * x[X] + x[H] * x[H] - p[R] * p[R]) * 0.5;
        residual[1] = x[X] * x[VX] + x[H] * x[VH];
        on_surface(x[ON].re())
    }

    fn project(_t: f64, p: &[f64], x: &mut [f64]) {
        if !on_surface(x[ON]) {
            return;
        }
        let radius = p[R];
        let r = x[X].hypot(x[H]);
        if !(r > 0.0 && r.is_finite() && radius > 0.0 && radius.is_finite()) {
            return;
        }
        let (nx, nh) = (x[X] / r, x[H] / r);
        x[X] = radius * nx;
        x[H] = radius * nh;
        let vr = x[VX] * nx + x[VH] * nh;
        x[VX] -= vr * nx;
        x[VH] -= vr * nh;
    }

    /// The normal force N while on the surface (it leaves where N crosses zero); no
    /// events in free flight.
    fn event_indicator(_t: f64, x: &[f64], _u: &[f64], p: &[f64]) -> Option<f64> {
        on_surface(x[ON]).then(|| normal_force(x, p))
    }

    /// The particle leaves the sphere: free flight from here, position and velocity
    /// unchanged.
    fn on_event(_t: f64, x: &mut [f64], _u: &[f64], _p: &[f64]) -> Result<(), String> {
        x[ON] = 0.0;
        Ok(())
    }
}
