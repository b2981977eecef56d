//! The stiff flyball governor of the IFToMM benchmark A05 ([`FlyballGovernor`]): a shaft
//! free to spin about the vertical z, a slider along it, two rods hinged at its top and
//! carrying 5 kg balls, and two stiff spring-dampers from the slider to the rods' midpoints
//! (K = 8e5 N/m, C = 4e4 N·s/m): numbers and sources in docs/iftomm-sources.md (the
//! official specification's body could not be retrieved; the OpenSim and Exudyn
//! reproductions agree on every number used here).
//!
//! The dampers make it stiff: a stretch of the springs relaxes at rates near
//! C / m ≈ 8e3 s⁻¹ (the balls' 5 kg), while the governor's own motion has a period of
//! about a second. DOPRI5 runs it only at steps its stability allows (about 3e-4 s);
//! RADAU5, L-stable, steps by the accuracy the motion needs. The FMU's `E_dissipated` is
//! the energy the dampers took out, integrated with the motion, so `E + E_dissipated`
//! is kept (tests: tests/flyball_governor.rs).
//!
//! Coordinates: `shaft` (its angle about z), `s` (the slider centre's height above the
//! shaft's bottom), `alpha_A`, `alpha_B` (each rod's angle below the horizontal, the rods
//! mirrored: rod A towards +x about +y, rod B towards −x about −y).

use crate::model::Scene;
use crate::multibody::fmu::Robot;
use crate::multibody::{Body, Mechanism, Origin};

/// The specification's numbers (SI units).
pub mod p {
    /// Shaft, rods: prisms 1 × 0.01 × 0.01 m of density 3000 kg/m³.
    pub const ROD_LENGTH: f64 = 1.0;
    pub const ROD_SIDE: f64 = 0.01;
    pub const ROD_MASS: f64 = 0.3;
    /// The slider: a cube of 0.1 m, 3 kg.
    pub const SLIDER_SIDE: f64 = 0.1;
    pub const SLIDER_MASS: f64 = 3.0;
    /// Each flyball: a point mass at its rod's free end.
    pub const BALL_MASS: f64 = 5.0;
    /// The rods' pivots at the shaft's top, 0.1 m apart.
    pub const PIVOT_X: f64 = 0.05;
    /// The spring-dampers, from the slider's sides (±0.05 m) to the rods' midpoints.
    pub const STIFFNESS: f64 = 8e5;
    pub const DAMPING: f64 = 4e4;
    pub const REST_LENGTH: f64 = 0.5;
    pub const G: f64 = 9.81;
    /// Start: s = 0.5 m, the rods 30° below the horizontal (the springs at rest length),
    /// the shaft at 2π rad/s.
    pub const S0: f64 = 0.5;
    pub const ALPHA0: f64 = std::f64::consts::FRAC_PI_6;
    pub const OMEGA0: f64 = 2.0 * std::f64::consts::PI;
    pub const END: f64 = 10.0;
}

/// A prism of `mass` with its long side (`length`) along the unit `axis` index, square
/// section `side`, centred at `com`: its principal moments.
fn prism(mass: f64, length: f64, side: f64, axis: usize) -> [f64; 3] {
    let along = mass * 2.0 * side * side / 12.0;
    let across = mass * (length * length + side * side) / 12.0;
    std::array::from_fn(|i| if i == axis { along } else { across })
}

pub fn mechanism() -> Mechanism {
    use p::*;
    let cube = SLIDER_MASS * 2.0 * SLIDER_SIDE * SLIDER_SIDE / 12.0;
    let mut m = Mechanism::new("FlyballGovernor")
        .gravity([0.0, 0.0, -G])
        .body(Body::massless("ground"))
        .body(
            Body::new("shaft", ROD_MASS)
                .com([0.0, 0.0, 0.5 * ROD_LENGTH])
                .inertia_diag(prism(ROD_MASS, ROD_LENGTH, ROD_SIDE, 2)),
        )
        .continuous(
            "shaft",
            "ground",
            "shaft",
            Origin::xyz([0.0; 3]),
            [0.0, 0.0, 1.0],
        )
        .body(Body::new("slider", SLIDER_MASS).inertia_diag([cube; 3]))
        .prismatic(
            "s",
            "shaft",
            "slider",
            Origin::xyz([0.0; 3]),
            [0.0, 0.0, 1.0],
        );
    for (side, sign) in [("A", 1.0), ("B", -1.0)] {
        let (rod, ball) = (format!("rod_{side}"), format!("ball_{side}"));
        m = m
            .body(
                Body::new(&rod, ROD_MASS)
                    .com([sign * 0.5 * ROD_LENGTH, 0.0, 0.0])
                    .inertia_diag(prism(ROD_MASS, ROD_LENGTH, ROD_SIDE, 0)),
            )
            .continuous(
                &format!("alpha_{side}"),
                "shaft",
                &rod,
                Origin::xyz([sign * PIVOT_X, 0.0, ROD_LENGTH]),
                [0.0, sign, 0.0],
            )
            .body(Body::new(&ball, BALL_MASS))
            .fixed(
                &format!("{ball}_on_{rod}"),
                &rod,
                &ball,
                Origin::xyz([sign * ROD_LENGTH, 0.0, 0.0]),
            )
            .spring_damper(
                &format!("spring_{side}"),
                ("slider", [sign * 0.5 * SLIDER_SIDE, 0.0, 0.0]),
                (&rod, [sign * 0.5 * ROD_LENGTH, 0.0, 0.0]),
                STIFFNESS,
                DAMPING,
                REST_LENGTH,
            )
            .start(&format!("alpha_{side}"), ALPHA0);
    }
    // Unactuated: the inputs start at 0 (a mechanism's default holds its start at rest).
    for joint in ["shaft", "s", "alpha_A", "alpha_B"] {
        m = m.torque(joint, 0.0);
    }
    m.start("s", S0).start_velocity("shaft", OMEGA0)
}

/// The governor's steady spin at `omega` (rad/s): the slider's height and the rods' angle
/// `(s, α)` at which the balls' centrifugal pull, gravity and the springs balance, so that
/// the state stays where it is but for the shaft's angle (a relative equilibrium, the
/// operating point a governor is designed about). Newton's method on `(s̈, α̈) = 0` with the
/// rods kept symmetric, from the start values, the exact Jacobian by dual numbers; `None`
/// where it does not converge.
pub fn steady_spin(omega: f64) -> Option<(f64, f64)> {
    use crate::model::System;
    use num_dual::Dual64;
    let start =
        |vars: Vec<crate::model::Var>| -> Vec<f64> { vars.iter().map(|v| v.start).collect() };
    let (x0, u, params) = (
        start(FlyballGovernor::states()),
        start(FlyballGovernor::inputs()),
        start(FlyballGovernor::parameters()),
    );
    let lift = |v: &[f64]| -> Vec<Dual64> { v.iter().map(|&a| Dual64::from(a)).collect() };
    let (u, params) = (lift(&u), lift(&params));
    // (s̈, α̈_A) at (s, α) and their derivatives along `direction` (0: s, 1: α).
    let accelerations = |(s, alpha): (f64, f64), direction: usize| -> [Dual64; 2] {
        let mut x = lift(&x0);
        x[1] = Dual64::new(s, (direction == 0) as u8 as f64);
        x[2] = Dual64::new(alpha, (direction == 1) as u8 as f64);
        x[3] = x[2];
        x[4] = Dual64::from(omega);
        let mut dx = vec![Dual64::from(0.0); x.len()];
        FlyballGovernor::derivatives(0.0, &x, &u, &params, &mut dx);
        [dx[5], dx[6]]
    };
    let norm = |r: [Dual64; 2]| r[0].re.hypot(r[1].re);
    let mut at = (p::S0, p::ALPHA0);
    for _ in 0..100 {
        let (ds, dalpha) = (accelerations(at, 0), accelerations(at, 1));
        let residual = norm(ds);
        if residual < 1e-9 {
            return Some(at);
        }
        // [∂/∂s ∂/∂α] step = −residual, 2×2 by Cramer's rule; halved until the residual
        // falls (the stiff springs make the full step overshoot far from the solution).
        let (a, b, c, d) = (ds[0].eps, dalpha[0].eps, ds[1].eps, dalpha[1].eps);
        let det = a * d - b * c;
        if !det.is_finite() || det == 0.0 {
            return None;
        }
        let step = (
            -(d * ds[0].re - b * ds[1].re) / det,
            -(a * ds[1].re - c * ds[0].re) / det,
        );
        let mut scale = 1.0;
        loop {
            let next = (at.0 + scale * step.0, at.1 + scale * step.1);
            if norm(accelerations(next, 0)) < residual {
                at = next;
                break;
            }
            scale *= 0.5;
            if scale < 1e-12 {
                return None;
            }
        }
    }
    None
}

crate::mechanism_fmu!(
    /// The flyball governor's declaration (its FMU model is [`FlyballGovernor`]).
    pub FlyballGovernorMechanism,
    "FlyballGovernor",
    mechanism,
    notes = [
        "IFToMM benchmark A05, the stiff flyball governor: a shaft (1 m, 0.3 kg) free to spin about z, a slider (0.1 m cube, 3 kg) along it, two rods (1 m, 0.3 kg) hinged 0.1 m apart at its top with 5 kg balls at their ends; gravity 9.81 m/s² along −z",
        "Two spring-dampers from the slider's sides to the rods' midpoints: F = K (ℓ − ℓ₀) + C dℓ/dt along the line, K = 8e5 N/m, C = 4e4 N·s/m, ℓ₀ = 0.5 m; as generalised forces −(K (ℓ − ℓ₀) + C dℓ/dt) ∂ℓ/∂q",
        "Start: s = 0.5 m, rods 30° below the horizontal (springs at rest length), shaft at 2π rad/s; 10 s",
        "Stiff: a spring's stretch relaxes at about C/m ≈ 8e3 s⁻¹ beside a motion of period about 1 s. The default solver is RADAU5 (L-stable, exact Jacobian by dual numbers); DOPRI5 runs it at the steps its stability allows",
        "E_dissipated = ∫ Σ C (dℓ/dt)² dt, integrated with the motion: E + E_dissipated is constant",
    ],
    {
        const DESCRIPTION: &'static str =
            "The stiff flyball governor of the IFToMM benchmark A05: a spinning shaft, a slider and two flyball rods held by stiff spring-dampers";
        // RADAU5 at 1e-10: E + E_dissipated within 1e-8 (6e-9) at every doStep's end,
        // where its dense output answers to about 0.1 rtol^(2/3) (1.1e-7 at rtol 1e-8).
        const DEFAULT_EXPERIMENT: (f64, f64, f64) = (p::END, 1e-10, 0.01);
        const DISSIPATED_ENERGY: bool = true;
        const DEFAULT_METHOD: crate::integrators::Method = crate::integrators::Method::Radau5;

        /// The steady spin at the benchmark's 2π rad/s ([`steady_spin`]): the motion of the
        /// benchmark oscillates about it. (At rest the balls would hang: no governor.)
        fn linearization_point() -> Vec<(String, f64)> {
            let Some((s, alpha)) = steady_spin(p::OMEGA0) else {
                return Vec::new();
            };
            [("s", s), ("alpha_A", alpha), ("alpha_B", alpha), ("shaft_dot", p::OMEGA0)]
                .iter()
                .map(|&(name, value)| (name.to_string(), value))
                .collect()
        }

        /// The benchmark's run first, then the mechanisms' own (released at rest: it
        /// collapses; held, the shaft's torque stepped: it spins up and the balls rise).
        fn scenes(generated: Vec<Scene>) -> Vec<Scene> {
            let benchmark = Scene::new(
                "benchmark",
                "IFToMM A05: the shaft spun at 2π rad/s, the rods 30° below the horizontal, the springs at rest length, no torque; 10 s (the start values)",
                p::END,
            );
            std::iter::once(benchmark).chain(generated).collect()
        }
    }
);

pub type FlyballGovernor = Robot<FlyballGovernorMechanism>;
