//! Bricard's mechanism, the IFToMM benchmark A04, through the FMU's own Instance (doSteps
//! of 0.05 s) for the benchmark's 10 s: its five closure residuals have rank four at every
//! configuration, and it must run on them (least squares at initialisation, the pivoted
//! Schur complement in the dynamics) keeping the energy and the loop closed. P3 against
//! the independent oracle is in tests/python/test_bricard.py (pinocchio, null-space method).

use mbfmu::docs::run::{simulate, RunSettings};
use mbfmu::integrators::Method;
use mbfmu::multibody::fmu::Declared;
use mbfmu::multibody::Mechanism;
use mbfmu::systems::bricard::{equilibrium, mechanism, BricardMechanism, END};
use mbfmu::systems::Bricard;
use num_dual::Dual64;

/// What one run measured: max |E − E0| / |E0|, the largest closure residual (m), and P3
/// at the end.
fn run(method: Method, tol: f64) -> (f64, f64, [f64; 3]) {
    let start = std::time::Instant::now();
    let settings = RunSettings {
        method,
        tol,
        step: 0.0,
        comm_step: 0.05,
        stop: END,
    };
    let run = simulate::<Bricard>(&[], settings).unwrap();
    assert!(run.failure.is_none(), "{:?}", run.failure);
    let col = |name: &str| &run.columns[run.names.iter().position(|n| n == name).expect(name)];
    let e = col("E");
    let drift = e.iter().map(|v| (v - e[0]).abs()).fold(0.0, f64::max) / e[0].abs();
    let residual = run
        .names
        .iter()
        .zip(&run.columns)
        .filter(|(n, _)| n.starts_with("residual_"))
        .flat_map(|(_, c)| c.iter())
        .fold(0.0f64, |a, v| a.max(v.abs()));
    let p3 = ["P3_x", "P3_y", "P3_z"].map(|n| *col(n).last().unwrap());
    println!(
        "METRIC A04 ({} rtol {tol:.0e}, 10 s): |E − E0|/|E0| ≤ {drift:.1e}; closure residual ≤ {residual:.1e} m; P3(10 s) = ({:.9}, {:.9}, {:.9}); {:.2} s",
        method.name(),
        p3[0],
        p3[1],
        p3[2],
        start.elapsed().as_secs_f64()
    );
    (drift, residual, p3)
}

/// The bounds by the default experiment (DOPRI5, rtol 1e-10): energy ≤ 1e-9
/// relative, residuals ≤ 1e-12 m.
#[test]
fn a04_by_the_default_experiment_keeps_the_energy_and_the_loop() {
    let (drift, residual, p3) = run(Method::Dopri5, 1e-10);
    assert!(drift < 1e-9, "{drift}");
    assert!(residual < 1e-12, "{residual}");
    // Near the cube again (the period is 4.9917 s, not 5: the oracle puts P3 at
    // (0.99973, −0.99999996, −0.00027) at 10 s).
    assert!(
        (p3[0] - 0.99973).abs() < 1e-4 && (p3[2] + 2.7e-4).abs() < 1e-5,
        "{p3:?}"
    );
}

/// The redundancy is real: the five rows of G have rank four along the motion (their
/// smallest singular value at rounding, the fourth of order one).
#[test]
fn the_closures_have_rank_four_of_five_everywhere() {
    let built = BricardMechanism::built();
    let model = &built.model;
    // Closed configurations along the loop: J1 from 0 to π, the others solved from the
    // previous configuration's.
    let mut guess: Vec<(String, f64)> = Vec::new();
    for k in 0..=20 {
        let j1 = std::f64::consts::PI * k as f64 / 20.0;
        let mut m = mechanism().start("J1", j1);
        for (joint, q) in &guess {
            m = m.start(joint, *q);
        }
        let b = mbfmu::multibody::fmu::Built::new(m).unwrap();
        guess = (1..5)
            .map(|i| (b.coordinates[i].name.to_string(), b.start[i]))
            .collect();
        // G by dual numbers, a column per joint.
        let q = b.positions_to_model(&b.start);
        let mut a = nalgebra::DMatrix::zeros(5, 5);
        for j in 0..5 {
            let qd: Vec<Dual64> = (0..5)
                .map(|i| Dual64::new(q[i], if i == j { 1.0 } else { 0.0 }))
                .collect();
            let mut phi = vec![Dual64::from(0.0); 5];
            model.closure_residuals_at(&qd, &mut phi);
            for i in 0..5 {
                a[(i, j)] = phi[i].eps;
            }
        }
        let s = a.singular_values();
        let mut s: Vec<f64> = s.iter().copied().collect();
        s.sort_by(|x, y| y.total_cmp(x));
        assert!(s[3] > 0.1 && s[4] < 1e-12, "J1 = {j1}: {s:?}");
    }
}

/// The equilibrium the linearisation is taken at closes the loop exactly, and the tree's
/// gravity there is carried by the closures alone (no holding torque).
#[test]
fn the_equilibrium_closes_and_needs_no_torque() {
    let mut m = mechanism();
    m.torques.clear(); // the start values of the inputs: the torques that hold the start
    for (joint, q) in equilibrium() {
        m = m.start(joint, q);
    }
    let b = mbfmu::multibody::fmu::Built::new(m).unwrap();
    for (name, q) in equilibrium() {
        let k = b.coordinates.iter().position(|v| v.name == name).unwrap();
        assert!(
            (b.start[k] - q).abs() < 1e-12,
            "{name}: {} vs {q}",
            b.start[k]
        );
    }
    assert!(b.hold.iter().all(|t| t.abs() < 1e-12), "{:?}", b.hold);
}

/// A loop that cannot close (the sixth joint's ground point moved 1 cm) is refused with
/// the residual named, never moved to fit.
#[test]
fn an_inconsistent_loop_is_refused_naming_its_residual() {
    let mut m: Mechanism = mechanism();
    m.closures[0].point_b = [0.0, 0.0, 1.01];
    let why = mbfmu::multibody::fmu::Built::new(m)
        .unwrap_err()
        .to_string();
    assert!(
        why.contains("residual") && why.contains("closure J6"),
        "{why}"
    );
}
