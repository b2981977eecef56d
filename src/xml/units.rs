//! UnitDefinitions: every unit a model uses, as exponents of the SI base units, with
//! the display units people read (deg for rad).

use super::{close, empty, fmt_real, open, s, W};
use crate::model::Layout;

/// SI base-unit exponents (kg, m, s, rad) of the units the systems use.
fn base_units(unit: &str) -> Option<[(&'static str, i32); 4]> {
    let u = |kg, m, s, rad| Some([("kg", kg), ("m", m), ("s", s), ("rad", rad)]);
    match unit {
        "kg" => u(1, 0, 0, 0),
        "m" => u(0, 1, 0, 0),
        "s" => u(0, 0, 1, 0),
        "m/s" => u(0, 1, -1, 0),
        "m/s2" => u(0, 1, -2, 0),
        "N" => u(1, 1, -2, 0),
        "N/m" => u(1, 0, -2, 0),
        "N.s/m" => u(1, 0, -1, 0),
        "N.m" => u(1, 2, -2, 0),
        "J" => u(1, 2, -2, 0),
        "W" => u(1, 2, -3, 0),
        "kg.m2" => u(1, 2, 0, 0),
        "kg.m2/s" => u(1, 2, -1, 0),
        "J/kg" => u(0, 2, -2, 0),
        "rad" => u(0, 0, 0, 1),
        "rad/s" => u(0, 0, -1, 1),
        "rad/s2" => u(0, 0, -2, 1),
        "1/s" => u(0, 0, -1, 0),
        "m/s2/s" => u(0, 1, -3, 0),
        _ => None,
    }
}

/// The display unit written as `displayUnit` on variables of this unit.
pub fn display_unit(unit: &str) -> Option<&'static str> {
    match unit {
        "rad" => Some("deg"),
        "rad/s" => Some("deg/s"),
        _ => None,
    }
}

const DEG_PER_RAD: f64 = 180.0 / std::f64::consts::PI;

/// Writes `<UnitDefinitions>` with the units of `layout`, in order of first use.
pub(super) fn write_unit_definitions(w: &mut W, layout: &Layout) {
    let mut used: Vec<&str> = Vec::new();
    for (_, var) in &layout.vars {
        if let Some(unit) = var.unit.as_deref() {
            if !used.contains(&unit) {
                used.push(unit);
            }
        }
    }
    open(w, "UnitDefinitions", &[]);
    for unit in used {
        open(w, "Unit", &[("name", s(unit))]);
        let exps = base_units(unit).unwrap_or_else(|| panic!("unit {unit} has no SI definition"));
        let attrs: Vec<(&str, String)> = exps
            .iter()
            .filter(|(_, e)| *e != 0)
            .map(|(k, e)| (*k, s(e)))
            .collect();
        empty(w, "BaseUnit", &attrs);
        if let Some(display) = display_unit(unit) {
            empty(
                w,
                "DisplayUnit",
                &[("name", s(display)), ("factor", fmt_real(DEG_PER_RAD))],
            );
        }
        close(w, "Unit");
    }
    close(w, "UnitDefinitions");
}
