//! Linearisation against the closed forms of systems.md, and trim.

use mbfmu::linearize::{linearize, to_json, to_py, trim, OperatingPoint, Trim};
use mbfmu::systems::{MassSpringDamper, TwoMassChain};
use nalgebra::DMatrix;

fn at<M: mbfmu::model::System>(overrides: &[(&str, f64)]) -> OperatingPoint {
    let o: Vec<(String, f64)> = overrides.iter().map(|(n, v)| (n.to_string(), *v)).collect();
    OperatingPoint::from_start_values::<M>(&o).unwrap()
}

#[test]
fn mass_spring_damper_matrices_are_exact() {
    let (m, k, c) = (2.0, 50.0, 3.0);
    let l = linearize::<MassSpringDamper>(&at::<MassSpringDamper>(&[("m", m), ("k", k), ("c", c)]));
    assert_eq!(
        l.a,
        DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -k / m, -c / m])
    );
    assert_eq!(l.b, DMatrix::from_row_slice(2, 1, &[0.0, 1.0 / m]));
    assert_eq!(l.output_names, ["x", "v", "E"]);
    // E = ½ m v² + ½ k x² at x = 0.1, v = 0: ∂E/∂x = k x.
    assert_eq!(
        l.c,
        DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 1.0, k * 0.1, 0.0])
    );
    assert_eq!(l.d, DMatrix::zeros(3, 1));
}

#[test]
fn two_mass_chain_matrices_equal_systems_md() {
    let (m1, m2, k1, k2, c2) = (1.5, 0.5, 80.0, 120.0, 3.0);
    let l = linearize::<TwoMassChain>(&at::<TwoMassChain>(&[
        ("m1", m1),
        ("m2", m2),
        ("k1", k1),
        ("k2", k2),
        ("c2", c2),
    ]));
    #[rustfmt::skip]
    let a = DMatrix::from_row_slice(4, 4, &[
        0.0, 0.0, 1.0, 0.0,
        0.0, 0.0, 0.0, 1.0,
        -(k1 + k2) / m1, k2 / m1, -c2 / m1, c2 / m1,
        k2 / m2, -k2 / m2, c2 / m2, -c2 / m2,
    ]);
    // "To rounding": the dual-number quotient (−k1 − k2)·m1 / m1² may differ from
    // −(k1 + k2)/m1 in the last bit.
    approx::assert_relative_eq!(l.a, a, max_relative = 2.0 * f64::EPSILON);
    assert_eq!(
        l.b,
        DMatrix::from_row_slice(4, 1, &[0.0, 0.0, 1.0 / m1, 0.0])
    );
}

#[test]
fn trim_finds_the_static_deflection() {
    // F = 1 N: x1 = F/k1, x2 = x1 (k2 carries no force at rest).
    let mut op = at::<TwoMassChain>(&[("F", 1.0)]);
    let residual = trim::<TwoMassChain>(&mut op, Trim::States).unwrap();
    assert!(residual < 1e-13);
    assert!((op.x[0] - 0.01).abs() < 1e-15 && (op.x[1] - 0.01).abs() < 1e-15);
    // And the force that holds x = 0.05: F = k x.
    let mut op = at::<MassSpringDamper>(&[("x", 0.05)]);
    trim::<MassSpringDamper>(&mut op, Trim::Inputs).unwrap();
    assert!((op.u[0] - 5.0).abs() < 1e-12, "{}", op.u[0]);
}

#[test]
fn exports_keep_shapes_and_round_trip_floats() {
    let l = linearize::<MassSpringDamper>(&at::<MassSpringDamper>(&[("m", 3.0)]));
    let json = to_json(&l);
    assert!(json.contains("\"n\": 2,") && json.contains("\"m\": 1,") && json.contains("\"p\": 3,"));
    // -k/m = -33.333… must be written with all its digits (shortest round-trip text).
    let entry = l.a[(1, 0)];
    assert!((entry + 100.0 / 3.0).abs() < 1e-13);
    assert!(json.contains(&format!("{entry:?}")), "{json}");
    assert_eq!(
        format!("{entry:?}").parse::<f64>().unwrap().to_bits(),
        entry.to_bits()
    );
    let py = to_py(&l);
    assert!(py.contains("return (n, m, p, x0, u0, A, B, C, D, stateVars, inputVars, outputVars)"));
}

/// Spin Ω about each principal axis (I = 1, 2, 3): about the largest and the smallest
/// axis the linearisation has a purely imaginary pair ±iω with
/// ω² = Ω² (Ia − Ib)(Ia − Ic)/(Ib Ic) (a the spin axis); about the intermediate axis a real
/// pair ±λ, λ² = Ω² (I2 − I1)(I3 − I2)/(I1 I3) (systems.md §8).
#[test]
fn rigid_body_spins_about_each_principal_axis() {
    use mbfmu::systems::RigidBody;
    let (i, spin): ([f64; 3], f64) = ([1.0, 2.0, 3.0], 5.0);
    for axis in 0..3 {
        let names = ["omega1", "omega2", "omega3"];
        let mut overrides: Vec<(&str, f64)> = names.iter().map(|n| (*n, 0.0)).collect();
        overrides[axis].1 = spin;
        let l = linearize::<RigidBody>(&at::<RigidBody>(&overrides));
        let eig = l.a.clone().complex_eigenvalues();
        let (b, c) = ((axis + 1) % 3, (axis + 2) % 3);
        let k = (i[axis] - i[b]) * (i[axis] - i[c]) / (i[b] * i[c]);
        let rate = spin * k.abs().sqrt();
        let found = if k > 0.0 {
            // Stable: ±iω, no eigenvalue with a positive real part.
            assert!(eig.iter().all(|e| e.re.abs() < 1e-12), "axis {axis}: {eig}");
            eig.iter().map(|e| e.im).fold(0.0, f64::max)
        } else {
            eig.iter().map(|e| e.re).fold(0.0, f64::max)
        };
        let rel = (found - rate).abs() / rate;
        println!(
            "axis {}: {} {found:.15} vs {rate:.15} (rel. {rel:.1e})",
            axis + 1,
            if k > 0.0 { "ω" } else { "λ" }
        );
        assert!(rel < 1e-12, "axis {axis}: {found} vs {rate}");
    }
}
