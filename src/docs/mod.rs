//! What each FMU carries to explain and check itself, computed at package time inside the
//! model's describe answer (so a user's own model gets the same): runs of the model through
//! its own FMU code ([`run`]), the FMI-LS-REF reference result ([`reference`]) and the
//! documentation page ([`page`]: equations in MathML by [`mathml`], scene plots by [`svg`],
//! a mechanism's stick figures by [`stick`]).
//! Above `fmi`, `xml`, `linearize`, `multibody`; below `describe`, which ships what it makes.

pub mod mathml;
pub mod page;
pub mod reference;
pub mod run;
pub mod stick;
pub mod svg;
pub mod traced;

/// `v` as people write it: the shortest decimal that reads back as `v`, in exponent form
/// when its exponent is below −4 or 6 and above and that form is the shorter (`1e-12`,
/// `2.5e6`; `0.5`, `1000`, `0.0001`, `-3`, and an integer such as `2147483647` whole).
/// Ranges, start values and the constants of traced formulas.
pub fn written(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    // `{:e}` is the shortest round-trip decimal too, as d.ddd…e±x.
    let e = format!("{v:e}");
    let exponent: i32 = e[e.find('e').map_or(e.len(), |k| k + 1)..]
        .parse()
        .unwrap_or(0);
    let plain = format!("{v}");
    if (-4..6).contains(&exponent) || plain.len() <= e.len() {
        plain
    } else {
        e
    }
}

/// A small error or spread to two significant digits (`1.8e-15`), and an exact zero as `0`
/// rather than `0.0e0`.
pub fn rough(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.1e}")
    }
}

#[cfg(test)]
mod tests {
    use super::{rough, written};

    #[test]
    fn numbers_are_written_as_people_write_them() {
        for (v, s) in [
            (1e-12, "1e-12"),
            (0.5, "0.5"),
            (1000.0, "1000"),
            (0.0, "0"),
            (-0.0, "0"),
            (-3.0, "-3"),
            (9.81, "9.81"),
            (0.0001, "0.0001"),
            (0.00001, "1e-5"),
            (1.5e-7, "1.5e-7"),
            (123456.0, "123456"),
            (1e6, "1e6"),
            (2.5e6, "2.5e6"),
            (-1e-12, "-1e-12"),
            (0.1 + 0.2, "0.30000000000000004"),
            (f64::INFINITY, "inf"),
            (2147483647.0, "2147483647"),
            (123456789.0, "123456789"),
            (1e20, "1e20"),
            (1.2345678e-5, "1.2345678e-5"),
        ] {
            assert_eq!(written(v), s, "{v:?}");
            if v.is_finite() {
                assert_eq!(s.parse::<f64>().unwrap(), v, "{s} reads back");
            }
        }
    }

    #[test]
    fn a_zero_spread_is_0() {
        assert_eq!(rough(0.0), "0");
        assert_eq!(rough(1.8e-15), "1.8e-15");
        assert_eq!(rough(0.0123), "1.2e-2");
    }
}
