//! The textbook systems, one file each: physics only, no FMI.

pub mod andrews_squeezer;
pub mod bricard;
mod compound_pendulum;
mod double_pendulum;
pub mod flyball_governor;
pub mod four_bar;
#[rustfmt::skip]
pub mod generated;
mod mass_spring_damper;
pub mod n_four_bar;
mod nonlinear_bicycle;
mod projectile;
mod pulled_pendulum;
mod rigid_body;
mod rolling_disk;
mod rolling_hoop;
mod rotating_hoop_bead;
pub mod slider_crank;
mod sphere_slide;
mod spring_rod_pendulum;
pub mod springy_pendulum;
mod two_mass_chain;
mod whipple_bicycle;

pub use andrews_squeezer::AndrewsSqueezer;
pub use bricard::Bricard;
pub use compound_pendulum::CompoundPendulum;
pub use double_pendulum::DoublePendulum;
pub use flyball_governor::FlyballGovernor;
pub use four_bar::FourBar;
pub use mass_spring_damper::MassSpringDamper;
pub use n_four_bar::NFourBar;
pub use nonlinear_bicycle::NonlinearBicycle;
pub use projectile::Projectile;
pub use pulled_pendulum::PulledPendulum;
pub use rigid_body::RigidBody;
pub use rolling_disk::RollingDisk;
pub use rolling_hoop::RollingHoop;
pub use rotating_hoop_bead::RotatingHoopBead;
pub use slider_crank::{SliderCrank, SliderCrankSurplus};
pub use sphere_slide::SphereSlide;
pub use spring_rod_pendulum::SpringRodPendulum;
pub use springy_pendulum::SpringyPendulum;
pub use two_mass_chain::TwoMassChain;
pub use whipple_bicycle::WhippleBicycle;

/// The mechanisms with loop closures whose right-hand-side terms are generated
/// ([`generated`]): the module name and the declaration's model and coordinate order.
pub fn closed_generated() -> Vec<(&'static str, &'static crate::multibody::fmu::Built)> {
    use crate::multibody::fmu::Declared;
    vec![
        (
            "andrews_squeezer",
            andrews_squeezer::AndrewsMechanism::built(),
        ),
        ("bricard", bricard::BricardMechanism::built()),
        ("four_bar", four_bar::FourBarMechanism::built()),
    ]
}

/// The check every mechanism with generated closed terms passes: they run (their
/// fingerprint is the declaration's) and give the interpreted path's q̈ and λ, and its
/// projection onto the closures, to 1e-12 of their scale, and through dual numbers the
/// same directional derivatives (1e-10), at states near each of `points` (q, and how far to move each coordinate at random: 0 keeps
/// it on the closures, where a redundant mechanism's G loses rank and what is unique is
/// compared), at random velocities within ±`speed` and inputs within ±`torque`; `floor`,
/// the least scale of a compared vector (`f64::MIN_POSITIVE`: none; the mechanism's
/// accelerations', where the values compared may be 0 but for rounding).
#[cfg(test)]
pub(crate) fn check_generated_closed<D: crate::multibody::fmu::Declared>(
    points: &[(Vec<f64>, f64)],
    speed: f64,
    torque: f64,
    floor: f64,
) {
    use crate::model::lagrangian::Lagrangian;
    use crate::multibody::codegen::tests::Rng;
    use crate::multibody::fmu::{
        interpreted_closed_accelerations, interpreted_closed_projection, Robot,
    };
    use num_dual::Dual64;
    let close = |a: &[f64], b: &[f64], tol: f64, what: &str| {
        let scale = b.iter().fold(floor, |m, x| m.max(x.abs()));
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                (x - y).abs() <= tol * scale,
                "{}: {what}[{i}]: {x} vs {y} (scale {scale:e})",
                D::NAME
            );
        }
    };
    let b = D::built();
    assert_eq!(
        D::CLOSED_GENERATED_FROM,
        Some(b.closed_fingerprint),
        "{}",
        D::NAME
    );
    let (n, k) = (b.order.len(), D::CONSTRAINTS);
    let p: Vec<f64> = <Robot<D> as Lagrangian>::parameters()
        .iter()
        .map(|v| v.start)
        .collect();
    // Both paths at (q, q̇, u) in the scalar S: (q̈, λ).
    fn both<D: crate::multibody::fmu::Declared, S: crate::model::Scalar>(
        args: (&[S], &[S], &[S], &[S]),
        n: usize,
        k: usize,
    ) -> [(Vec<S>, Vec<S>); 2] {
        let mut generated = (vec![S::zero(); n], vec![S::zero(); k]);
        assert!(D::generated_closed::<S>(
            0.0,
            args,
            &mut generated.0,
            &mut generated.1
        ));
        let mut interpreted = (vec![S::zero(); n], vec![S::zero(); k]);
        interpreted_closed_accelerations::<D, S>(0.0, args, &mut interpreted.0, &mut interpreted.1);
        [generated, interpreted]
    }
    let mut rng = Rng(0x5eed_1234_abcd);
    for (at, (q0, spread)) in points.iter().enumerate() {
        for _ in 0..20 {
            let q: Vec<f64> = q0
                .iter()
                .map(|&s| s + spread * rng.uniform(-1.0, 1.0))
                .collect();
            let qd: Vec<f64> = (0..n).map(|_| rng.uniform(-speed, speed)).collect();
            let u: Vec<f64> = (0..n).map(|_| rng.uniform(-torque, torque)).collect();
            let [g, i] = both::<D, f64>((&q, &qd, &u, &p), n, k);
            close(&g.0, &i.0, 1e-12, &format!("q̈ at point {at}"));
            // The projection after a step, from the point (on the closures) moved off them
            // by up to 1e-6, what a step's error leaves: the same q and q̇. (Not from the
            // random q: far off, 8 Newton steps need not converge. Nor 1e-3 off: there
            // Bricard's redundant row comes back with a pivot ~1e-6 of S, above the rank
            // tolerance, and the two paths' rounding differs by 4e-12 through it.)
            let mut projected = [q0.clone(), qd.clone()];
            for v in projected[0].iter_mut() {
                *v += 1e-6 * rng.uniform(-1.0, 1.0);
            }
            let mut oracle = projected.clone();
            let [pq, pqd] = &mut projected;
            assert!(D::generated_closed_project(pq, pqd, &p), "{}", D::NAME);
            let [oq, oqd] = &mut oracle;
            interpreted_closed_projection::<D>(oq, oqd, &p);
            close(pq, oq, 1e-12, &format!("projected q at point {at}"));
            close(pqd, oqd, 1e-12, &format!("projected q̇ at point {at}"));
            // On the closures, where G may lose rank (Bricard), λ is not unique (which
            // dependent row is dropped is a tie rounding may break either way, e.g. by
            // the symmetry of Bricard's start), nor is q̈ differentiable along q across
            // them (the rank changes there: measured at Bricard's start, the two paths'
            // one-sided derivatives −2.655 and −2.879, their mean the central difference):
            // there q̈ and its derivatives along q̇ are compared, which are unique.
            let off = *spread > 0.0;
            if off {
                close(&g.1, &i.1, 1e-12, &format!("λ at point {at}"));
            }
            // ∂/∂q_j and ∂/∂q̇_j along one direction each, by dual numbers.
            let j = (rng.uniform(0.0, n as f64) as usize).min(n - 1);
            let dual = |v: &[f64], seed: bool| -> Vec<Dual64> {
                v.iter()
                    .enumerate()
                    .map(|(i, &x)| Dual64::new(x, (seed && i == j) as u8 as f64))
                    .collect()
            };
            let (pd, ud) = (dual(&p, false), dual(&u, false));
            for along_q in [true, false].into_iter().filter(|&a| off || !a) {
                let (qx, qdx) = (dual(&q, along_q), dual(&qd, !along_q));
                let eps = both::<D, Dual64>((&qx, &qdx, &ud, &pd), n, k).map(|(qdd, lambda)| {
                    let lambda = if off { &lambda[..] } else { &[] };
                    qdd.iter()
                        .chain(lambda)
                        .map(|d| d.eps)
                        .collect::<Vec<f64>>()
                });
                let along = if along_q { "q" } else { "q̇" };
                close(
                    &eps[0],
                    &eps[1],
                    1e-10,
                    &format!("derivative at point {at} along {along} {j}"),
                );
            }
        }
    }
}

/// Every module of [`generated`] and its `mod.rs`: (file name, source).
pub fn closed_generated_files() -> Vec<(String, String)> {
    let mut index = String::from(
        "//! The right-hand-side terms generated by `mbfmu::multibody::codegen::loops` for the\n\
         //! mechanisms with loop closures that have them: do not edit; a test checks they are\n\
         //! current. Not formatted by rustfmt (`#[rustfmt::skip]` on `mod generated`): the\n\
         //! generator's layout is what the test compares.\n\n",
    );
    let mut files = Vec::new();
    for (module, built) in closed_generated() {
        let source = crate::multibody::codegen::loops::generate(
            &built.model,
            &built.order,
            &built.mechanism.name,
            "crate",
        );
        files.push((format!("{module}.rs"), source));
        index.push_str(&format!(
            "#[allow(clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]\npub mod {module};\n"
        ));
    }
    files.push(("mod.rs".into(), index));
    files
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{System, Var};

    /// A value no computation produces: a NaN with a payload of its own.
    const UNWRITTEN: u64 = 0x7ff8_dead_beef_0001;

    /// `derivatives` and `extra_outputs` write every component (the contract the
    /// integrators' kept buffers rely on), at the start of every scene.
    fn writes_every_component<M: System>() {
        let starts = |vars: Vec<Var>, scene: &crate::model::Scene| -> Vec<f64> {
            vars.iter()
                .map(|v| {
                    let set = scene.start_values.iter().find(|(name, _)| *name == v.name);
                    set.map_or(v.start, |(_, value)| *value)
                })
                .collect()
        };
        for scene in M::scenes() {
            let (x, u, p) = (
                starts(M::states(), &scene),
                starts(M::inputs(), &scene),
                starts(M::parameters(), &scene),
            );
            let mut dx = vec![f64::from_bits(UNWRITTEN); x.len()];
            M::derivatives(0.0, &x, &u, &p, &mut dx);
            let mut y = vec![f64::from_bits(UNWRITTEN); M::outputs().len()];
            M::extra_outputs(0.0, &x, &u, &p, &mut y);
            for (what, v) in [("derivative", &dx), ("output", &y)] {
                let unwritten = v.iter().position(|v| v.to_bits() == UNWRITTEN);
                assert_eq!(unwritten, None, "{} {}: {what}", M::NAME, scene.name);
            }
        }
    }

    #[test]
    fn every_system_writes_every_derivative_and_output() {
        writes_every_component::<MassSpringDamper>();
        writes_every_component::<TwoMassChain>();
        writes_every_component::<WhippleBicycle>();
        writes_every_component::<RigidBody>();
        writes_every_component::<RollingHoop>();
        writes_every_component::<RollingDisk>();
        writes_every_component::<Projectile>();
        writes_every_component::<SpringyPendulum>();
        writes_every_component::<DoublePendulum>();
        writes_every_component::<CompoundPendulum>();
        writes_every_component::<SphereSlide>();
        writes_every_component::<SpringRodPendulum>();
        writes_every_component::<SliderCrank>();
        writes_every_component::<SliderCrankSurplus>();
        writes_every_component::<NonlinearBicycle>();
        writes_every_component::<RotatingHoopBead>();
        writes_every_component::<PulledPendulum>();
        writes_every_component::<FourBar>();
        writes_every_component::<AndrewsSqueezer>();
        writes_every_component::<NFourBar>();
        writes_every_component::<Bricard>();
        writes_every_component::<FlyballGovernor>();
    }

    /// The committed closed terms are what the generator makes of the declared mechanisms
    /// now (`MBFMU_REGENERATE=1` rewrites them).
    #[test]
    fn generated_closed_terms_are_current() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/systems/generated");
        let regenerate = std::env::var_os("MBFMU_REGENERATE").is_some();
        for (file, source) in closed_generated_files() {
            let path = dir.join(&file);
            if regenerate {
                std::fs::write(&path, &source).unwrap();
                continue;
            }
            let committed = std::fs::read_to_string(&path).unwrap_or_default();
            assert!(
                committed == source,
                "src/systems/generated/{file} is stale: MBFMU_REGENERATE=1 cargo test --release --lib generated_closed_terms"
            );
        }
    }
}
