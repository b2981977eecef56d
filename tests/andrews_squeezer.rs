//! AndrewsSqueezer, declared as bodies, joints, closures and a spring, against the IVP test
//! set's `andrews` problem (Hairer & Wanner, Solving ODEs II, VII.7): its mass matrix,
//! forces, constraints and constraint Jacobian written out here from the test set's
//! formulas (an independent derivation: nothing of the multibody layer), its consistent
//! initial accelerations and multipliers, and its reference solution at t = 0.03 s run
//! through the FMU's own Instance.
// The test set's numbers keep their published digits (they round to the nearest f64), and
// its mass matrix is written with the Fortran's index loops, to be read against it.
#![allow(clippy::excessive_precision, clippy::needless_range_loop)]

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::model::lagrangian::{self, Lagrangian};
use mbfmu::model::System;
use mbfmu::systems::andrews_squeezer::{p::*, COORDINATES, END, REFERENCE, START};
use mbfmu::systems::AndrewsSqueezer as R;

mod support;
use support::Rng;

/// The test set's M(q), f(q, q̇) (spring, drive and velocity terms), g(q) and G = ∂g/∂q,
/// transcribed from its formulas (with q = (β, Θ, γ, Φ, δ, Ω, ε)).
#[allow(clippy::type_complexity, clippy::needless_range_loop)] // indexed as the test set is
fn test_set(q: &[f64], qd: &[f64]) -> ([[f64; 7]; 7], [f64; 7], [f64; 6], [[f64; 7]; 6]) {
    let (sibe, sith, siga, siph, side, siom, siep) = (
        q[0].sin(),
        q[1].sin(),
        q[2].sin(),
        q[3].sin(),
        q[4].sin(),
        q[5].sin(),
        q[6].sin(),
    );
    let (cobe, coth, coga, coph, code, coom, coep) = (
        q[0].cos(),
        q[1].cos(),
        q[2].cos(),
        q[3].cos(),
        q[4].cos(),
        q[5].cos(),
        q[6].cos(),
    );
    let (sibeth, siphde, siomep) = (
        (q[0] + q[1]).sin(),
        (q[3] + q[4]).sin(),
        (q[5] + q[6]).sin(),
    );
    let (cobeth, cophde, coomep) = (
        (q[0] + q[1]).cos(),
        (q[3] + q[4]).cos(),
        (q[5] + q[6]).cos(),
    );
    let (bep, thp, php, dep, omp, epp) = (qd[0], qd[1], qd[3], qd[4], qd[5], qd[6]);
    let mut m = [[0.0; 7]; 7];
    m[0][0] = M1 * RA * RA + M2 * (RR * RR - 2.0 * DA * RR * coth + DA * DA) + I1 + I2;
    m[1][0] = M2 * (DA * DA - DA * RR * coth) + I2;
    m[1][1] = M2 * DA * DA + I2;
    m[2][2] = M3 * (SA * SA + SB * SB) + I3;
    m[3][3] = M4 * (E - EA) * (E - EA) + I4;
    m[4][3] = M4 * ((E - EA) * (E - EA) + ZT * (E - EA) * siph) + I4;
    m[4][4] = M4 * (ZT * ZT + 2.0 * ZT * (E - EA) * siph + (E - EA) * (E - EA))
        + M5 * (TA * TA + TB * TB)
        + I4
        + I5;
    m[5][5] = M6 * (ZF - FA) * (ZF - FA) + I6;
    m[6][5] = M6 * ((ZF - FA) * (ZF - FA) - U * (ZF - FA) * siom) + I6;
    m[6][6] = M6 * ((ZF - FA) * (ZF - FA) - 2.0 * U * (ZF - FA) * siom + U * U)
        + M7 * (UA * UA + UB * UB)
        + I6
        + I7;
    for j in 1..7 {
        for i in 0..j {
            m[i][j] = m[j][i];
        }
    }
    let xd = SD * coga + SC * siga + XB;
    let yd = SD * siga - SC * coga + YB;
    let lang = ((xd - XC) * (xd - XC) + (yd - YC) * (yd - YC)).sqrt();
    let force = -C0 * (lang - L0) / lang;
    let (fx, fy) = (force * (xd - XC), force * (yd - YC));
    let ff = [
        MOM - M2 * DA * RR * thp * (thp + 2.0 * bep) * sith,
        M2 * DA * RR * bep * bep * sith,
        fx * (SC * coga - SD * siga) + fy * (SD * coga + SC * siga),
        M4 * ZT * (E - EA) * dep * dep * coph,
        -M4 * ZT * (E - EA) * php * (php + 2.0 * dep) * coph,
        -M6 * U * (ZF - FA) * epp * epp * coom,
        M6 * U * (ZF - FA) * omp * (omp + 2.0 * epp) * coom,
    ];
    let mut gp = [[0.0; 7]; 6];
    gp[0][0] = -RR * sibe + D * sibeth;
    gp[0][1] = D * sibeth;
    gp[0][2] = -SS * coga;
    gp[1][0] = RR * cobe - D * cobeth;
    gp[1][1] = -D * cobeth;
    gp[1][2] = -SS * siga;
    gp[2][0] = -RR * sibe + D * sibeth;
    gp[2][1] = D * sibeth;
    gp[2][3] = -E * cophde;
    gp[2][4] = -E * cophde + ZT * side;
    gp[3][0] = RR * cobe - D * cobeth;
    gp[3][1] = -D * cobeth;
    gp[3][3] = -E * siphde;
    gp[3][4] = -E * siphde - ZT * code;
    gp[4][0] = -RR * sibe + D * sibeth;
    gp[4][1] = D * sibeth;
    gp[4][5] = ZF * siomep;
    gp[4][6] = ZF * siomep - U * coep;
    gp[5][0] = RR * cobe - D * cobeth;
    gp[5][1] = -D * cobeth;
    gp[5][5] = -ZF * coomep;
    gp[5][6] = -ZF * coomep - U * siep;
    let g = [
        RR * cobe - D * cobeth - SS * siga - XB,
        RR * sibe - D * sibeth + SS * coga - YB,
        RR * cobe - D * cobeth - E * siphde - ZT * code - XA,
        RR * sibe - D * sibeth + E * cophde - ZT * side - YA,
        RR * cobe - D * cobeth - ZF * coomep - U * siep - XA,
        RR * sibe - D * sibeth - ZF * siomep + U * coep - YA,
    ];
    (m, ff, g, gp)
}

fn inputs() -> Vec<f64> {
    <R as System>::inputs().iter().map(|v| v.start).collect()
}

fn params() -> Vec<f64> {
    <R as System>::parameters()
        .iter()
        .map(|v| v.start)
        .collect()
}

#[test]
fn the_coordinates_and_start_values_are_the_test_sets() {
    let names: Vec<String> = <R as Lagrangian>::coordinates()
        .iter()
        .map(|v| v.name.to_string())
        .collect();
    assert_eq!(names, COORDINATES);
    // The published consistent values are kept bit for bit (the closures already hold at
    // rounding there); all but β dependent; the drive mom on β.
    for (v, s) in <R as Lagrangian>::coordinates().iter().zip(START) {
        assert_eq!(v.start, s, "{}", v.name);
        assert_eq!(v.dependent, v.name != "beta", "{}", v.name);
    }
    assert_eq!(inputs(), [MOM, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(<R as Lagrangian>::default_experiment().0, END);
    assert_eq!(<R as Lagrangian>::CONSTRAINTS, 6);
}

/// M, the right-hand side f and the constraints equal the test set's formulas at its
/// initial point and at random states (velocities too: the test set's f carries the
/// velocity terms of K2, K4 and K6, which the mechanism gets from its kinetic energy).
#[test]
fn mass_matrix_forces_and_constraints_equal_the_test_sets_formulas() {
    let (u, p) = (inputs(), params());
    let mut rng = Rng(0xa5d2_e005);
    let mut states = vec![(START.to_vec(), vec![0.0; 7])];
    for _ in 0..50 {
        let q = (0..7).map(|_| rng.uniform(-3.0, 3.0)).collect();
        let qd = (0..7).map(|_| rng.uniform(-500.0, 500.0)).collect();
        states.push((q, qd));
    }
    let (mut wm, mut wf, mut wg, mut wgp) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (q, qd) in &states {
        let (m, ff, g, gp) = test_set(q, qd);
        let ours_m = lagrangian::mass_matrix::<R, f64>(0.0, q, qd, &p);
        let ours_f = lagrangian::generalized_rhs::<R, f64>(0.0, q, qd, &u, &p);
        let ours_g = lagrangian::constraint_values::<R, f64>(0.0, q, &p);
        let ours_gp = lagrangian::constraint_jacobian::<R, f64>(0.0, q, &p);
        let m_scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
        let f_scale = ff.iter().fold(MOM, |s, v| s.max(v.abs()));
        for i in 0..7 {
            for j in 0..7 {
                wm = wm.max((ours_m[i][j] - m[i][j]).abs() / m_scale);
            }
            wf = wf.max((ours_f[i] - ff[i]).abs() / f_scale);
        }
        for r in 0..6 {
            wg = wg.max((ours_g[r] - g[r]).abs() / D);
            for j in 0..7 {
                wgp = wgp.max((ours_gp[r][j] - gp[r][j]).abs() / D);
            }
        }
    }
    println!(
        "METRIC AndrewsSqueezer vs test set formulas (relative): M {wm:.2e}, f {wf:.2e}, g {wg:.2e}, G {wgp:.2e}"
    );
    // Two evaluation orders of the same sums: rounding (M from spatial inertias through
    // hyper-dual numbers, f with the spring's ∂V/∂γ by a dual number).
    assert!(wm < 1e-13 && wf < 1e-12 && wg < 1e-14 && wgp < 1e-14);
}

/// RATTLE's mass matrix and constraint rows by the tree's own algorithms (CRBA, the
/// closures' kinematics: `Lagrangian::mass_matrix_by_algorithm`,
/// `constraint_rows_by_algorithm`) are the test set's formulas too, its force `Q + ∂L/∂q`
/// by RNEA and a dual CRBA (`force_by_algorithm`) is automatic differentiation's, and T
/// has no term linear in q̇ (RATTLE's b = 0).
#[test]
fn rattles_mass_matrix_and_constraint_rows_by_algorithm_are_the_test_sets() {
    let (u, p) = (inputs(), params());
    let mut rng = Rng(0x7a77_1e5e);
    let (mut wm, mut wf, mut wg, mut wgp) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for _ in 0..50 {
        let q: Vec<f64> = (0..7).map(|_| rng.uniform(-3.0, 3.0)).collect();
        let qd: Vec<f64> = (0..7).map(|_| rng.uniform(-500.0, 500.0)).collect();
        let (m, _, g, gp) = test_set(&q, &qd);
        // F = Q + ∂L/∂q, against one dual evaluation of L per coordinate.
        let by_ad = lagrangian::generalized_force::<R>(0.0, &q, &qd, &u, &p);
        let mut ours_f = [0.0; 7];
        assert!(<R as Lagrangian>::force_by_algorithm(
            0.0,
            &q,
            &qd,
            &u,
            &p,
            &mut ours_f
        ));
        let f_scale = by_ad.iter().fold(MOM, |s, v| s.max(v.abs()));
        for (a, b) in ours_f.iter().zip(&by_ad) {
            wf = wf.max((a - b).abs() / f_scale);
        }
        let (mut ours_m, mut ours_g, mut ours_gp) = ([0.0; 49], [0.0; 6], [0.0; 42]);
        assert!(<R as Lagrangian>::mass_matrix_by_algorithm(
            &q,
            &p,
            &mut ours_m
        ));
        assert!(<R as Lagrangian>::constraint_rows_by_algorithm(
            &q,
            &p,
            &mut ours_g,
            &mut ours_gp
        ));
        let m_scale = m.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
        for i in 0..7 {
            for j in 0..7 {
                wm = wm.max((ours_m[i * 7 + j] - m[i][j]).abs() / m_scale);
            }
        }
        for r in 0..6 {
            wg = wg.max((ours_g[r] - g[r]).abs() / D);
            for j in 0..7 {
                wgp = wgp.max((ours_gp[r * 7 + j] - gp[r][j]).abs() / D);
            }
        }
    }
    println!("METRIC AndrewsSqueezer RATTLE's M, g, G by algorithm vs the test set, F vs automatic differentiation (relative): M {wm:.2e}, g {wg:.2e}, G {wgp:.2e}, F {wf:.2e}");
    // Rounding of two evaluation orders, as above.
    assert!(
        wm < 1e-13 && wg < 1e-14 && wgp < 1e-14 && wf < 1e-12,
        "{wm} {wg} {wgp} {wf}"
    );
    assert!(<R as Lagrangian>::kinetic_is_quadratic());
}

/// The test set's consistent initial values also give the accelerations and multipliers
/// at t = 0 (its y₁₅…y₂₇): the λ-method on the mechanism gives them again.
#[test]
#[allow(clippy::excessive_precision)] // the test set's digits, as it prints them
fn initial_accelerations_and_multipliers_are_the_test_sets() {
    let (u, p) = (inputs(), params());
    let qdd_ref = [
        14222.4439199541138705911625887,
        -10666.8329399655854029433719415,
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
    ];
    let lambda_ref = [
        98.5668703962410896057654982170,
        -6.12268834425566265503114393122,
        0.0,
        0.0,
        0.0,
        0.0,
    ];
    let (qdd, lambda) =
        lagrangian::accelerations_and_multipliers::<R, f64>(0.0, &START, &[0.0; 7], &u, &p);
    let ea = qdd
        .iter()
        .zip(qdd_ref)
        .fold(0.0f64, |s, (a, b)| s.max((a - b).abs()))
        / qdd_ref[0];
    let el = lambda
        .iter()
        .zip(lambda_ref)
        .fold(0.0f64, |s, (a, b)| s.max((a - b).abs()))
        / lambda_ref[0];
    println!("METRIC AndrewsSqueezer initial q'' vs test set: {ea:.2e}, lambda: {el:.2e} (relative to the largest)");
    assert!(ea < 1e-12 && el < 1e-12, "{qdd:?} {lambda:?}");
    // And the outputs name them: force_P3_x … force_P6_y are λ₁ … λ₆.
    let x: Vec<f64> = START.iter().copied().chain([0.0; 7]).collect();
    let mut y = vec![0.0; <R as System>::outputs().len()];
    <R as System>::extra_outputs(0.0, &x, &u, &p, &mut y);
    let names: Vec<String> = <R as System>::outputs()
        .iter()
        .map(|v| v.name.to_string())
        .collect();
    // The outputs come from the tree's dynamics and the closures' solve
    // (multibody::closed), λ above from the λ-method on the energies: two derivations,
    // equal to rounding (1e-12 of the largest, as against the test set).
    let at = names.iter().position(|n| n == "force_P3_x").unwrap();
    for (out, want) in y[at..at + 6].iter().zip(lambda_ref) {
        assert!(
            (out - want).abs() < 1e-12 * lambda_ref[0],
            "{:?} vs {lambda_ref:?}",
            &y[at..at + 6]
        );
    }
}

/// The FMU's Instance (its default solver, DOPRI5) from the start values to t = 0.03 in
/// `steps` doSteps at `tol`; returns q(0.03) and the largest closure residual (m) after
/// any doStep.
fn run(tol: f64, steps: usize) -> ([f64; 7], f64) {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<R>()));
    let mut inst = Instance::<R>::new(info, Logger::silent("andrews"));
    let vr = |n: &str| info.layout.vr_of(n).expect(n);
    inst.setup_experiment(Some(tol), 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let qvr: Vec<u32> = COORDINATES.iter().map(|n| vr(n)).collect();
    let p = params();
    let mut q = [0.0; 7];
    let mut worst = 0.0f64;
    let h = END / steps as f64;
    for k in 0..steps {
        let out = inst.do_step(k as f64 * h, h).unwrap();
        assert_eq!(out, StepOutcome::Completed);
        inst.get_real(&qvr, &mut q).unwrap();
        let phi = lagrangian::constraint_values::<R, f64>(0.0, &q, &p);
        worst = phi.iter().fold(worst, |s, v| s.max(v.abs()));
    }
    (q, worst)
}

fn relative_error(q: &[f64; 7]) -> f64 {
    q.iter()
        .zip(REFERENCE)
        .fold(0.0f64, |s, (a, b)| s.max(((a - b) / b).abs()))
}

/// The projection's own stopping rule (`lagrangian::project_onto_constraints`): a residual
/// at rounding of coordinates as large as `q`.
fn rounding(q: &[f64]) -> f64 {
    4.0 * f64::EPSILON * q.iter().fold(1.0f64, |s, v| s.max(v.abs()))
}

/// The reference solution at t = 0.03 (the test set's SOLN): every angle to 1e-6 relative
/// at the default tolerance (DOPRI5, rtol 1e-8, doSteps of 1 ms), tighter at rtol 1e-12;
/// the closures held to rounding after every doStep (the projection).
#[test]
fn the_reference_solution_at_0_03_s() {
    let (_, tol, h) = <R as Lagrangian>::default_experiment();
    let steps = (END / h).round() as usize;
    let (q, residual) = run(tol, steps);
    let e = relative_error(&q);
    println!("METRIC AndrewsSqueezer DOPRI5 rtol {tol:e}: max relative error of the 7 angles at 0.03 s {e:.2e}, max closure residual {residual:.2e} m");
    println!("q(0.03) = {q:?}");
    assert!(e < 1e-6, "{e:e}: {q:?}");
    assert!(residual <= rounding(&REFERENCE), "{residual:e}");
    let mut errors = Vec::new();
    for tight in [1e-10, 1e-12, 1e-13] {
        let (q, residual) = run(tight, steps);
        let err = relative_error(&q);
        println!("METRIC AndrewsSqueezer DOPRI5 rtol {tight:e}: max relative error {err:.2e}, max closure residual {residual:.2e} m");
        assert!(residual <= rounding(&REFERENCE), "{residual:e}");
        errors.push(err);
    }
    // The reference itself is given to 16 digits but computed by an integrator at a
    // finite tolerance: the error stops falling where it is reached.
    assert!(errors[1] < 1e-9 && errors[1] < e / 10.0, "{errors:?}");
}
