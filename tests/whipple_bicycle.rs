//! The linearised Whipple bicycle against the published benchmark: Meijaard,
//! Papadopoulos, Ruina, Schwab, Proc. R. Soc. A 463 (2007) 1955–1982 — the matrices of
//! section 5 (the numbers the formulas of Appendix A give for Table 1), and Table 2
//! (the weave and capsize speeds, the eigenvalues against speed).

use mbfmu::linearize::{linearize, OperatingPoint};
use mbfmu::model::jacobian::{directional, Direction};
use mbfmu::model::System;
use mbfmu::systems::WhippleBicycle;
use nalgebra::{Complex, Matrix2, Matrix4};

/// The Table 1 parameters: the declared start values.
fn table1() -> Vec<f64> {
    WhippleBicycle::parameters()
        .iter()
        .map(|v| v.start)
        .collect()
}

fn eigenvalues(v: f64) -> Vec<Complex<f64>> {
    let (a, _) = WhippleBicycle::state_matrix(&table1(), v);
    let mut e: Vec<Complex<f64>> = a.complex_eigenvalues().iter().copied().collect();
    e.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
    e
}

/// Real part of the weave pair: the one complex-conjugate pair (above v ≈ 0.68 m/s).
fn weave_real_part(v: f64) -> f64 {
    let complex: Vec<_> = eigenvalues(v)
        .into_iter()
        .filter(|e| e.im.abs() > 1e-8)
        .collect();
    assert_eq!(complex.len(), 2, "one complex pair at v = {v}: {complex:?}");
    complex[0].re
}

/// The capsize eigenvalue: the largest real one (the caster root is far left).
fn capsize_eigenvalue(v: f64) -> f64 {
    eigenvalues(v)
        .into_iter()
        .filter(|e| e.im == 0.0)
        .map(|e| e.re)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// A sign change of `f` in [lo, hi], bisected until the bracket is one ulp wide.
fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    let f_lo = f(lo);
    assert!(f_lo * f(hi) < 0.0, "no sign change in [{lo}, {hi}]");
    loop {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            return mid;
        }
        if (f(mid) < 0.0) == (f_lo < 0.0) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
}

fn assert_matrix_rel(name: &str, got: Matrix2<f64>, want: [[f64; 2]; 2], tol: f64) {
    for i in 0..2 {
        for j in 0..2 {
            let (g, w) = (got[(i, j)], want[i][j]);
            let err = if w == 0.0 {
                g.abs()
            } else {
                ((g - w) / w).abs()
            };
            println!("{name}[{i}{j}] = {g:.17e} (published {w:.14e}, rel. err {err:.1e})");
            assert!(err <= tol, "{name}[{i}{j}] = {g:e}, published {w:e}");
        }
    }
}

#[test]
fn matrices_from_table1_equal_the_published_ones() {
    let (m, c1, k0, k2) = WhippleBicycle::benchmark_matrices(&table1());
    // Published to 14 decimals: the relative tolerance is the rounding of the print.
    let tol = 1e-13;
    assert_matrix_rel(
        "M",
        m,
        [
            [80.81722, 2.31941332208709],
            [2.31941332208709, 0.29784188199686],
        ],
        tol,
    );
    assert_matrix_rel(
        "C1",
        c1,
        [
            [0.0, 33.86641391492494],
            [-0.85035641456978, 1.68540397397560],
        ],
        tol,
    );
    assert_matrix_rel(
        "K0",
        k0,
        [
            [-80.95, -2.59951685249872],
            [-2.59951685249872, -0.80329488458618],
        ],
        tol,
    );
    assert_matrix_rel(
        "K2",
        k2,
        [[0.0, 76.59734589573222], [0.0, 2.65431523794604]],
        tol,
    );
    // Structural zeros are exact, and M and K0 are symmetric.
    assert_eq!((c1[(0, 0)], k2[(0, 0)], k2[(1, 0)]), (0.0, 0.0, 0.0));
    assert_eq!(m[(0, 1)], m[(1, 0)]);
    assert_eq!(k0[(0, 1)], k0[(1, 0)]);
}

#[test]
fn weave_and_capsize_speeds_equal_table2() {
    let v_w = bisect(weave_real_part, 3.0, 5.0);
    let v_c = bisect(capsize_eigenvalue, 5.5, 7.0);
    println!("weave speed   v_w = {v_w:.15} m/s (Table 2: 4.29238253634111)");
    println!("capsize speed v_c = {v_c:.15} m/s (Table 2: 6.02426201538837)");
    assert!((v_w - 4.29238253634111).abs() < 1e-10, "v_w = {v_w}");
    assert!((v_c - 6.02426201538837).abs() < 1e-10, "v_c = {v_c}");
    // Self-stable in between (every real part negative), not just outside.
    let max_re = |v: f64| eigenvalues(v).iter().map(|e| e.re).fold(f64::MIN, f64::max);
    for k in 1..100 {
        let v = v_w + (v_c - v_w) * k as f64 / 100.0;
        assert!(max_re(v) < 0.0, "unstable at v = {v}: {:?}", eigenvalues(v));
    }
    assert!(max_re(v_w - 1e-6) > 0.0, "{:?}", eigenvalues(v_w - 1e-6));
    assert!(max_re(v_c + 1e-6) > 0.0, "{:?}", eigenvalues(v_c + 1e-6));
}

fn assert_eigenvalues(v: f64, want: &[Complex<f64>], tol: f64) {
    let got = eigenvalues(v);
    println!("v = {v}: {got:?}");
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).norm() < tol, "v = {v}: {g} vs Table 2 {w}");
    }
}

#[test]
fn eigenvalues_equal_table2() {
    let re = |x| Complex::new(x, 0.0);
    // Standing still: two inverted-pendulum pairs.
    assert_eigenvalues(
        0.0,
        &[
            re(-5.53094371765393),
            re(-3.13164324790656),
            re(3.13164324790656),
            re(5.53094371765393),
        ],
        1e-12,
    );
    // Below the weave speed: the weave pair is unstable.
    assert_eigenvalues(
        4.0,
        &[
            re(-12.15861426576447),
            re(-1.42944427361326),
            Complex::new(0.41325331521125, -3.07910818603206),
            Complex::new(0.41325331521125, 3.07910818603206),
        ],
        1e-12,
    );
    // Self-stable: caster, weave pair, capsize.
    assert_eigenvalues(
        5.0,
        &[
            re(-14.07838969279822),
            Complex::new(-0.77534188219585, -4.46486771378823),
            Complex::new(-0.77534188219585, 4.46486771378823),
            re(-0.32286642900409),
        ],
        1e-12,
    );
    // Above the capsize speed: a slowly diverging capsize.
    assert_eigenvalues(
        10.0,
        &[
            re(-24.62459635017404),
            Complex::new(-3.72016840437287, -10.90681139476287),
            Complex::new(-3.72016840437287, 10.90681139476287),
            re(0.16105338653172),
        ],
        1e-12,
    );
}

#[test]
fn exact_jacobian_equals_the_closed_form_state_matrix() {
    let p = table1();
    for v in [0.0, 2.0, 5.0, 8.0] {
        let op = OperatingPoint::from_start_values::<WhippleBicycle>(&[("v".into(), v)]).unwrap();
        let lin = linearize::<WhippleBicycle>(&op);
        let (a, b) = WhippleBicycle::state_matrix(&p, v);
        let a_lin = Matrix4::from_iterator(lin.a.iter().copied());
        let err_a = (a_lin - a).amax() / a.amax();
        let err_b = (lin.b.clone() - nalgebra::DMatrix::from_iterator(4, 2, b.iter().copied()))
            .amax()
            / b.amax();
        println!(
            "v = {v}: max|A_lin − A| = {:.1e}, /max|A| = {err_a:.1e}; /max|B| = {err_b:.1e}",
            (a_lin - a).amax()
        );
        assert!(err_a <= 1e-14 && err_b <= 1e-14, "v = {v}");
        assert_eq!(lin.state_names, ["phi", "delta", "phi_dot", "delta_dot"]);
        assert_eq!(lin.input_names, ["T_phi", "T_delta"]);
    }
}

#[test]
fn derivative_with_respect_to_speed_is_exact() {
    // ∂ẋ/∂v at a state x: the accelerations −M⁻¹(C1 q̇ + 2 v K2 q), the velocities 0.
    let p = table1();
    let (v, x, u) = (5.0, [0.05, -0.02, 0.3, 0.7], [0.0, 0.0]);
    let mut dp = vec![0.0; p.len()];
    dp[4] = 1.0;
    let mut p_at = p.clone();
    p_at[4] = v;
    let (df, _) = directional::<WhippleBicycle>(
        &Direction {
            t: 0.0,
            x: (&x, &[0.0; 4]),
            u: (&u, &[0.0; 2]),
            p: (&p_at, &dp),
        },
        0,
    );
    let (m, c1, _, k2) = WhippleBicycle::benchmark_matrices(&p);
    let q = nalgebra::Vector2::new(x[0], x[1]);
    let qd = nalgebra::Vector2::new(x[2], x[3]);
    let want = -m.try_inverse().unwrap() * (c1 * qd + k2 * q * (2.0 * v));
    println!("∂ẋ/∂v = {df:?}, closed form {want:?}");
    assert_eq!(&df[..2], &[0.0, 0.0]);
    for i in 0..2 {
        assert!((df[2 + i] - want[i]).abs() <= 1e-14 * want.amax(), "{i}");
    }
}

#[test]
fn scenes_sit_where_they_say() {
    let p = table1();
    let max_re = |v: f64| {
        WhippleBicycle::state_matrix(&p, v)
            .0
            .complex_eigenvalues()
            .iter()
            .map(|e| e.re)
            .fold(f64::MIN, f64::max)
    };
    for scene in WhippleBicycle::scenes() {
        let v = scene
            .start_values
            .iter()
            .find(|(n, _)| *n == "v")
            .map(|(_, v)| *v)
            .unwrap();
        let stable = max_re(v) < 0.0;
        assert_eq!(stable, scene.name == "stable", "{} at v = {v}", scene.name);
    }
    // Weave (v = 2): the growing mode oscillates; capsize (v = 8): it is real.
    let growing = |v: f64| {
        eigenvalues(v)
            .into_iter()
            .filter(|e| e.re > 0.0)
            .collect::<Vec<_>>()
    };
    assert!(growing(2.0).iter().all(|e| e.im != 0.0) && growing(2.0).len() == 2);
    assert!(growing(8.0).len() == 1 && growing(8.0)[0].im == 0.0);
}
