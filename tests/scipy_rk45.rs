//! DOPRI5's scipy-RK45 conformance mode against scipy itself: the same Dormand–Prince
//! pair under scipy's controller must take scipy's steps. The reference
//! (tests/data/scipy_rk45.csv: `nfev`, the accepted step times and the end state of
//! `solve_ivp(method="RK45")`) is checked against the installed scipy by
//! tests/python/test_scipy_rk45_reference.py, so it cannot go stale.
//!
//! Equal RHS counts is the claim; the step times agree to rounding (scipy sums the stages
//! in another order). The stored numbers come from scipy on whatever machine last wrote
//! the file, so this is a comparison across machines: our steps differ from them as
//! another machine's scipy would (its BLAS sums in another order too), and the bounds are
//! those of the Python check, derived there (`STEP_TIME_TOL`): step times within 1e-8 of
//! the interval (measured ≤ 3.4e-11 here; scipy on two machines 3.9e-11, emulated machines
//! up to 3.3e-9), end states within 1e-8 (measured 2e-13), RHS counts exact.

use mbfmu::integrators::dopri5::scipy_rk45;
use mbfmu::integrators::Stats;

/// A right-hand side `f(t, y) → dy`.
type Rhs = fn(f64, &[f64], &mut [f64]);

fn oscillator(_t: f64, y: &[f64], dy: &mut [f64]) {
    dy[0] = y[1];
    dy[1] = -100.0 * y[0];
}

fn van_der_pol(_t: f64, y: &[f64], dy: &mut [f64]) {
    let mu = 5.0;
    dy[0] = y[1];
    dy[1] = mu * (1.0 - y[0] * y[0]) * y[1] - y[0];
}

fn numbers(field: &str) -> Vec<f64> {
    field
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect()
}

#[test]
fn scipy_rk45_mode_takes_scipys_steps() {
    let text = include_str!("data/scipy_rk45.csv");
    let mut cases = 0;
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (problem, rtol, atol, t_end, nfev) = (
            f[0],
            f[1].parse::<f64>().unwrap(),
            f[2].parse::<f64>().unwrap(),
            f[3].parse::<f64>().unwrap(),
            f[4].parse::<u64>().unwrap(),
        );
        let (y_end, times) = (numbers(f[5]), numbers(f[6]));
        let (mut rhs, mut y): (Rhs, Vec<f64>) = match problem {
            "oscillator" => (oscillator, vec![1.0, 0.0]),
            "van_der_pol" => (van_der_pol, vec![2.0, 0.0]),
            other => panic!("unknown problem {other}"),
        };
        let mut stats = Stats::default();
        let ours = scipy_rk45(
            &mut rhs,
            0.0,
            &mut y,
            t_end,
            (rtol, &[atol, atol]),
            f64::INFINITY,
            &mut stats,
        )
        .unwrap();
        let worst_t = ours
            .iter()
            .zip(&times)
            .map(|(a, b)| (a - b).abs() / t_end)
            .fold(0.0f64, f64::max);
        let worst_y = y
            .iter()
            .zip(&y_end)
            .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
            .fold(0.0f64, f64::max);
        println!(
            "METRIC {problem} rtol {rtol:e}: nfev {} (scipy {nfev}), {} steps, {} rejected; step times agree to {worst_t:.1e} of the interval, end state to {worst_y:.1e}",
            stats.rhs_evals, stats.steps, stats.rejected
        );
        assert_eq!(stats.rhs_evals, nfev, "{problem} rtol {rtol}");
        assert_eq!(ours.len(), times.len(), "{problem} rtol {rtol}");
        assert!(
            worst_t < 1e-8,
            "{problem} rtol {rtol}: step times differ by {worst_t:e} of the interval"
        );
        assert!(
            worst_y < 1e-8,
            "{problem} rtol {rtol}: end state differs by {worst_y:e}"
        );
        cases += 1;
    }
    assert_eq!(cases, 6);
}
