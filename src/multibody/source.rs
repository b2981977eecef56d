//! A [`Mechanism`] as Rust source: the builder calls that recreate it, bit for bit, for a
//! crate a user edits (`mbfmu new NAME --from-urdf FILE`) and for the crate `mbfmu build
//! --urdf` compiles.
//!
//! Numbers are printed with `{:?}` (the shortest text that reads back to the same `f64`).
//! Each call is the most readable one that gives back exactly the value read: an origin is
//! `Origin::new(xyz, rpy)` when its rotation is rebuilt exactly from the roll, pitch and yaw
//! recovered from it, else its matrix; an axis is `.axis(a)` when normalising `a` again
//! leaves it unchanged, else set as a field. Every choice is checked on the value it builds,
//! so the text is exact by construction; `mbfmu build --urdf` also compares the compiled
//! crate's mechanism with the URDF's.

use super::mechanism::{Body, Closure, Joint, JointKind, Mechanism, Origin, Spring};

/// The same value, bit for bit (`-0.0` is not `0.0` here, unlike `==`).
fn same<T: std::fmt::Debug>(a: &T, b: &T) -> bool {
    format!("{a:?}") == format!("{b:?}")
}

fn v3(v: &[f64; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", v[0], v[1], v[2])
}

fn m3(m: &[[f64; 3]; 3]) -> String {
    format!("[{}, {}, {}]", v3(&m[0]), v3(&m[1]), v3(&m[2]))
}

fn opt(v: Option<f64>) -> String {
    match v {
        Some(x) => format!("Some({x:?})"),
        None => "None".into(),
    }
}

fn origin(o: &Origin) -> String {
    if same(o, &Origin::IDENTITY) {
        return "Origin::IDENTITY".into();
    }
    if same(&Origin::xyz(o.xyz), o) {
        return format!("Origin::xyz({})", v3(&o.xyz));
    }
    // The roll, pitch and yaw recovered, rounded to the fewest significant digits that
    // rebuild the rotation bit for bit (a URDF's "0.1" comes back as 0.09999999999999999).
    // The pitch by atan2 of the column's parts, accurate next to ±π/2 too (an asin is not:
    // URDF exporters write 1.570796325 for a quarter turn), then `Origin::rpy`'s.
    let r = &o.rotation;
    let pitch = (-r[2][0]).atan2(r[0][0].hypot(r[1][0]));
    let near = [r[2][1].atan2(r[2][2]), pitch, r[1][0].atan2(r[0][0])];
    let rpy = o.rpy();
    for guess in [near, rpy] {
        for digits in 1..=17 {
            let round = |x: f64| -> f64 {
                format!("{x:.*e}", digits - 1)
                    .parse()
                    .expect("a formatted number")
            };
            let candidate = guess.map(round);
            if same(&Origin::new(o.xyz, candidate), o) {
                return format!("Origin::new({}, {})", v3(&o.xyz), v3(&candidate));
            }
        }
    }
    format!(
        "Origin {{ xyz: {}, rotation: {} }} /* rpy ≈ {} */",
        v3(&o.xyz),
        m3(&o.rotation),
        v3(&rpy)
    )
}

fn body(b: &Body) -> String {
    if same(&Body::massless(&b.name), b) {
        return format!("Body::massless({:?})", b.name);
    }
    let mut s = format!("Body::new({:?}, {:?})", b.name, b.mass);
    let mut rebuilt = Body::new(&b.name, b.mass);
    if !same(&rebuilt.com, &b.com) {
        s += &format!("\n            .com({})", v3(&b.com));
        rebuilt = rebuilt.com(b.com);
    }
    let i = &b.inertia;
    let diagonal = Body::new("", 0.0).inertia_diag([i[0][0], i[1][1], i[2][2]]);
    if same(&diagonal.inertia, i) {
        s += &format!(
            "\n            .inertia_diag({})",
            v3(&[i[0][0], i[1][1], i[2][2]])
        );
    } else if !same(&rebuilt.inertia, i) {
        s += &format!("\n            .inertia({})", m3(i));
    }
    s
}

fn kind(k: JointKind) -> &'static str {
    match k {
        JointKind::Revolute => "JointKind::Revolute",
        JointKind::Continuous => "JointKind::Continuous",
        JointKind::Prismatic => "JointKind::Prismatic",
        JointKind::Fixed => "JointKind::Fixed",
    }
}

fn joint(j: &Joint) -> String {
    let new = format!(
        "Joint::new({:?}, {}, {:?}, {:?}, {})",
        j.name,
        kind(j.kind),
        j.parent,
        j.child,
        origin(&j.origin)
    );
    let base = Joint::new(&j.name, j.kind, &j.parent, &j.child, j.origin);
    let mut s = if same(&base.axis, &j.axis) {
        new
    } else if same(&base.clone().axis(j.axis).axis, &j.axis) {
        format!("{new}\n            .axis({})", v3(&j.axis))
    } else {
        // Normalising again would move the last bit: set the field as read.
        format!("Joint {{ axis: {}, ..{new} }}", v3(&j.axis))
    };
    if !same(&base.damping, &j.damping) {
        s += &format!("\n            .damping({:?})", j.damping);
    }
    if !same(&base.friction, &j.friction) {
        s += &format!("\n            .friction({:?})", j.friction);
    }
    if let Some(m) = &j.mimic {
        s += &format!(
            "\n            .mimic({:?}, {:?}, {:?})",
            m.joint, m.multiplier, m.offset
        );
    }
    if !same(&base.limit, &j.limit) {
        let l = &j.limit;
        s += &format!(
            "\n            .limit(Limit {{ lower: {}, upper: {}, effort: {}, velocity: {} }})",
            opt(l.lower),
            opt(l.upper),
            opt(l.effort),
            opt(l.velocity)
        );
    }
    s
}

fn closure(c: &Closure) -> String {
    format!(
        "\n        .closure({:?}, {:?}, {}, {:?}, {}, {:?})",
        c.name,
        c.body_a,
        v3(&c.point_a),
        c.body_b,
        v3(&c.point_b),
        c.axes
    )
}

fn spring(sp: &Spring) -> String {
    format!(
        "\n        .spring({:?}, {:?}, {}, {:?}, {}, {:?}, {:?})",
        sp.name,
        sp.body_a,
        v3(&sp.point_a),
        sp.body_b,
        v3(&sp.point_b),
        sp.stiffness,
        sp.rest_length
    )
}

fn names(list: &[String]) -> String {
    let quoted: Vec<String> = list.iter().map(|n| format!("{n:?}")).collect();
    format!("&[{}]", quoted.join(", "))
}

/// The builder expression of `m` (`Mechanism::new(…).body(…)….joint(…)`, then its loop
/// closures, springs, dependent joints, start positions and torques, coordinate order),
/// indented for the body of a function, with `Body`, `Joint`, `JointKind`, `Limit`,
/// `Mechanism` and `Origin` in scope. Bodies and joints in their order in `m`.
pub fn builder(m: &Mechanism) -> String {
    let mut s = format!("Mechanism::new({:?})", m.name);
    if !same(&Mechanism::new("").gravity, &m.gravity) {
        s += &format!("\n        .gravity({})", v3(&m.gravity));
    }
    for b in &m.bodies {
        s += &format!("\n        .body({})", body(b));
    }
    for j in &m.joints {
        s += &format!("\n        .joint({})", joint(j));
    }
    for c in &m.closures {
        s += &closure(c);
    }
    for sp in &m.springs {
        s += &spring(sp);
    }
    if !m.dependent.is_empty() {
        s += &format!("\n        .dependent({})", names(&m.dependent));
    }
    for (j, v) in &m.start {
        s += &format!("\n        .start({j:?}, {v:?})");
    }
    for (j, v) in &m.start_velocity {
        s += &format!("\n        .start_velocity({j:?}, {v:?})");
    }
    for (j, v) in &m.torques {
        s += &format!("\n        .torque({j:?}, {v:?})");
    }
    if !m.order.is_empty() {
        s += &format!("\n        .order({})", names(&m.order));
    }
    if m.floating_base {
        s += "\n        .floating_base()";
    }
    s
}
