//! Buffers kept between calls: sized, copied or zeroed without allocating once they have
//! held as many numbers. The bottom of the integrators: every method uses them, they use
//! nothing.

/// `v` as `n` zeros, as `vec![0.0; n]` would give, without allocating once `v` has held `n`.
pub(crate) fn zeroed(v: &mut Vec<f64>, n: usize) -> &mut [f64] {
    v.clear();
    v.resize(n, 0.0);
    v
}

/// `v` with `n` entries, for a buffer written in full before it is read (its old values are
/// left: no clearing in the hot loops), without allocating once `v` has held `n`.
#[inline]
pub(crate) fn sized(v: &mut Vec<f64>, n: usize) -> &mut [f64] {
    // (The test first: `resize` is not inlined, and the hot paths call this each step.)
    if v.len() != n {
        v.resize(n, 0.0);
    }
    v
}

/// `v` holding a copy of `x`, without allocating once `v` has held as many.
#[inline]
pub(crate) fn copied<'a>(v: &'a mut Vec<f64>, x: &[f64]) -> &'a mut [f64] {
    let v = sized(v, x.len());
    v.copy_from_slice(x);
    v
}
