//! Eigenvalues of a linearisation's A, with a bounded iteration.
//!
//! nalgebra's `complex_eigenvalues` runs its Francis QR iteration without a bound, and it
//! does not converge on some matrices a mechanism gives: a robot whose joints are held by
//! friction at the operating point has A with a zero row per held velocity (q̈ = 0 there
//! whatever the state), so a double zero eigenvalue per held joint in a Jordan block,
//! and the unshifted-deflation iteration cycled on TIAGo dual's 202 × 202 A for more than
//! ten minutes. So, as LAPACK's `gebal` does before its QR iteration, eigenvalues that a
//! permutation isolates are taken first: a row (or column) whose off-diagonal entries in
//! the remaining block are all zero makes the matrix block triangular, its diagonal entry
//! is an eigenvalue and the index leaves the block. Only what remains goes through the QR
//! iteration, bounded at 30 iterations per row (LAPACK's `hseqr` bound).

use nalgebra::{Complex, DMatrix, Schur};

/// QR iterations allowed per row of the remaining block (LAPACK's ITMAX factor).
const ITERATIONS_PER_ROW: usize = 30;

/// The eigenvalues of `a` (in no particular order), or why they could not be computed.
pub fn eigenvalues(a: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, String> {
    let mut isolated = Vec::new();
    let mut rest: Vec<usize> = (0..a.nrows()).collect();
    let alone = |rest: &[usize]| {
        rest.iter().position(|&i| {
            rest.iter().all(|&j| j == i || a[(i, j)] == 0.0)
                || rest.iter().all(|&j| j == i || a[(j, i)] == 0.0)
        })
    };
    while let Some(k) = alone(&rest) {
        let i = rest.remove(k);
        isolated.push(Complex::new(a[(i, i)], 0.0));
    }
    if rest.is_empty() {
        return Ok(isolated);
    }
    let block = DMatrix::from_fn(rest.len(), rest.len(), |r, c| a[(rest[r], rest[c])]);
    let n = block.nrows();
    match Schur::try_new(block, f64::EPSILON, ITERATIONS_PER_ROW * n) {
        Some(schur) => {
            isolated.extend(schur.complex_eigenvalues().iter().copied());
            Ok(isolated)
        }
        None => Err(format!(
            "the QR iteration did not converge in {} iterations on the {n} × {n} block left after isolating {} eigenvalues",
            ITERATIONS_PER_ROW * n,
            isolated.len()
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sorted(mut v: Vec<Complex<f64>>) -> Vec<Complex<f64>> {
        v.sort_by(|a, b| a.re.total_cmp(&b.re).then(a.im.total_cmp(&b.im)));
        v
    }

    #[test]
    fn isolates_zero_rows_and_keeps_the_rest() {
        // A pendulum (ω² = 4, so ±2i) beside a held joint (rows of q̈ zero: a Jordan block
        // of 0), coupled one way: the held joint's position enters the pendulum's q̈.
        #[rustfmt::skip]
        let a = DMatrix::from_row_slice(4, 4, &[
            0.0, 0.0, 1.0, 0.0,
            0.0, 0.0, 0.0, 1.0,
            -4.0, 3.0, 0.0, 0.0,
            0.0, 0.0, 0.0, 0.0,
        ]);
        let e = sorted(eigenvalues(&a).unwrap());
        let want = [
            Complex::new(0.0, -2.0),
            Complex::new(0.0, 0.0),
            Complex::new(0.0, 0.0),
            Complex::new(0.0, 2.0),
        ];
        assert_eq!(e.len(), 4);
        for (got, want) in e.iter().zip(want) {
            assert!((got - want).norm() < 1e-12, "{got} vs {want}");
        }
    }

    #[test]
    fn many_held_joints_do_not_stall() {
        // 100 held joints (Jordan blocks of 0) beside 2 free pendulums: the shape of a
        // robot whose joints friction holds at its start; nalgebra's unbounded iteration
        // cycled on such matrices.
        let held = 100;
        let free = 2;
        let n = held + free;
        let mut a = DMatrix::zeros(2 * n, 2 * n);
        for i in 0..n {
            a[(i, n + i)] = 1.0;
        }
        for f in 0..free {
            let r = n + held + f;
            a[(r, held + f)] = -((f + 1) as f64).powi(2);
            for h in 0..held {
                a[(r, h)] = 0.1 * (h as f64 + 1.0).sin();
                a[(r, n + h)] = 0.2;
            }
        }
        let e = eigenvalues(&a).unwrap();
        assert_eq!(e.len(), 2 * n);
        let zeros = e.iter().filter(|l| l.norm() < 1e-12).count();
        assert_eq!(zeros, 2 * held);
        for w in [1.0, 2.0] {
            assert!(e.iter().any(|l| (l - Complex::new(0.0, w)).norm() < 1e-12));
        }
    }
}
