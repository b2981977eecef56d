//! Finiteness tests for the per-step paths, in two instructions a number.
//!
//! `f64::is_finite` is lowered by LLVM to a class test that x86-64 carries out with about
//! a dozen integer instructions; a fixed-step doStep of a small system asks it a dozen
//! times (its state after each step, the outputs, the step size). `v − v` is `0` exactly
//! when `v` is finite (∞ − ∞ and NaN − NaN are NaN), and IEEE arithmetic may not fold it
//! away, so these ask the same question with a subtraction and a comparison.

/// Whether `v` is finite (neither infinite nor NaN): `v.is_finite()`, cheaper.
#[inline(always)]
#[allow(clippy::eq_op)] // v − v on purpose: not 0 for ∞ and NaN
pub fn finite(v: f64) -> bool {
    v - v == 0.0
}

/// Whether every entry of `v` is finite. (A plain loop: unrolled for arrays, and for the
/// few outputs of a slice shorter than the vectorised loop a fold would give.)
#[inline(always)]
pub fn all_finite(v: &[f64]) -> bool {
    for &x in v {
        if !finite(x) {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn agree_with_is_finite() {
        let specials = [
            0.0,
            -0.0,
            1.0,
            -3.5e300,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            5e-324,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for v in specials {
            assert_eq!(finite(v), v.is_finite(), "{v}");
            for w in specials {
                assert_eq!(
                    all_finite(&[1.0, v, w]),
                    v.is_finite() && w.is_finite(),
                    "{v} {w}"
                );
            }
        }
        assert!(all_finite(&[]));
    }
}
