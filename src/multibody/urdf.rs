//! Reading a [`Mechanism`] from URDF (quick-xml, no URDF crate).
//!
//! Read: the robot's name; each link's `<inertial>` (origin xyz rpy, mass, inertia
//! ixx…izz; a link without one is massless); each joint's type, origin, parent, child, axis
//! (default `1 0 0`, normalised), `<limit>`, `<dynamics damping friction>` and `<mimic joint
//! multiplier offset>` (defaults 1 and 0; on a fixed joint it means nothing). Ignored:
//! `<visual>`, `<collision>`, `<transmission>`, `<gazebo>`, `<material>` and anything else
//! not listed. Refused, each with one line naming the file, the element and the reason:
//! malformed XML, a root element other than `<robot>`, unexpanded xacro (an `xacro:`
//! element or `${` in an attribute), floating and planar joints, unknown joint types,
//! and everything [`Mechanism::validate`] refuses (missing links, two parents, cycles,
//! negative mass, bad inertia, a moving joint carrying no mass, a mimic of a missing joint
//! or on a cycle of mimics).

use super::mechanism::{Body, Error, Joint, JointKind, Limit, Mechanism, Origin};
use super::spatial::{mat_mul, transpose};
use quick_xml::events::{BytesStart, Event};
use quick_xml::XmlVersion;
use std::collections::HashMap;

/// Reads the URDF file at `path` (its name is used in messages).
pub fn load(path: &std::path::Path) -> Result<Mechanism, Error> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::new(String::new(), format!("cannot read: {e}")).in_file(&file))?;
    parse(&text, &file)
}

/// Parses URDF `text`; `file` names it in messages. The mechanism returned is valid
/// ([`Mechanism::validate`] passed).
pub fn parse(text: &str, file: &str) -> Result<Mechanism, Error> {
    let mut parser = Parser {
        text,
        lines: HashMap::new(),
        mechanism: Mechanism::new(""),
        link: None,
        joint: None,
    };
    match parser.run() {
        Ok(()) => {}
        Err(e) => return Err(e.in_file(file)),
    }
    let mechanism = parser.mechanism;
    match mechanism.validate() {
        Ok(_) => Ok(mechanism),
        Err(mut e) => {
            // Point at the line where the element named was declared.
            e.line = parser.lines.get(&e.element).copied();
            Err(e.in_file(file))
        }
    }
}

/// What is being read.
struct Parser<'a> {
    text: &'a str,
    /// The declaration line of each element, by its name in messages (`joint "j"`).
    lines: HashMap<String, usize>,
    mechanism: Mechanism,
    link: Option<Body>,
    joint: Option<Joint>,
}

type Attrs = Vec<(String, String)>;

fn get<'a>(attrs: &'a Attrs, key: &str) -> Option<&'a str> {
    attrs
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.as_str())
}

impl Parser<'_> {
    fn line(&self, pos: u64) -> usize {
        let pos = (pos as usize).min(self.text.len());
        self.text.as_bytes()[..pos]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1
    }

    /// The element being read, as messages name it.
    fn element(&self) -> String {
        if let Some(j) = &self.joint {
            format!("joint \"{}\"", j.name)
        } else if let Some(l) = &self.link {
            format!("link \"{}\"", l.name)
        } else {
            String::new()
        }
    }

    fn fail<T>(&self, line: usize, reason: String) -> Result<T, Error> {
        Err(Error::new(self.element(), reason).at_line(line))
    }

    fn attrs(&self, e: &BytesStart, line: usize) -> Result<Attrs, Error> {
        let mut out = Vec::new();
        for a in e.attributes() {
            let a = match a {
                Ok(a) => a,
                Err(err) => return self.fail(line, format!("malformed XML: {err}")),
            };
            let key: &str = a.key.as_ref();
            let key = key.to_string();
            let value = match a.normalized_value(XmlVersion::Implicit1_0) {
                Ok(v) => v.into_owned(),
                Err(err) => return self.fail(line, format!("malformed XML: {err}")),
            };
            if value.contains("${") {
                return self.fail(
                    line,
                    format!("unexpanded xacro: {key}=\"{value}\" (run xacro on the file first)"),
                );
            }
            out.push((key, value));
        }
        Ok(out)
    }

    /// `n` numbers from attribute `key` of `<tag>` (`default` when absent).
    fn numbers<const N: usize>(
        &self,
        attrs: &Attrs,
        tag: &str,
        key: &str,
        default: [f64; N],
        line: usize,
    ) -> Result<[f64; N], Error> {
        let Some(v) = get(attrs, key) else {
            return Ok(default);
        };
        let parsed: Vec<f64> = v
            .split_whitespace()
            .map(|s| s.parse::<f64>())
            .collect::<Result<_, _>>()
            .unwrap_or_default();
        match <[f64; N]>::try_from(parsed) {
            Ok(a) if a.iter().all(|x| x.is_finite()) => Ok(a),
            _ => {
                let what = if N == 1 {
                    "a finite number".to_string()
                } else {
                    format!("{N} finite numbers")
                };
                self.fail(line, format!("<{tag} {key}=\"{v}\">: not {what}"))
            }
        }
    }

    fn origin(&self, attrs: &Attrs, line: usize) -> Result<Origin, Error> {
        let xyz = self.numbers(attrs, "origin", "xyz", [0.0; 3], line)?;
        let rpy = self.numbers(attrs, "origin", "rpy", [0.0; 3], line)?;
        Ok(Origin::new(xyz, rpy))
    }

    fn run(&mut self) -> Result<(), Error> {
        let mut reader = quick_xml::Reader::from_str(self.text);
        let mut stack: Vec<String> = Vec::new();
        // The inertial frame of the link being read, its mass and inertia (in that frame).
        let mut inertial = (Origin::IDENTITY, 0.0, [[0.0; 3]; 3]);
        let mut saw_root = false;
        loop {
            let start = reader.buffer_position();
            let event = match reader.read_event() {
                Ok(ev) => ev,
                Err(err) => {
                    let line = self.line(reader.error_position());
                    return self.fail(line, format!("malformed XML: {err}"));
                }
            };
            let line = self.line(start);
            let (e, empty) = match &event {
                Event::Start(e) => (e, false),
                Event::Empty(e) => (e, true),
                Event::End(_) => {
                    let tag = stack.pop().unwrap_or_default();
                    self.close(&tag, stack.len(), &mut inertial)?;
                    continue;
                }
                Event::Eof => break,
                _ => continue,
            };
            let tag = e.name().as_ref().to_string();
            if tag.starts_with("xacro:") {
                return self.fail(
                    line,
                    format!("unexpanded xacro: <{tag}> (run xacro on the file first)"),
                );
            }
            let attrs = self.attrs(e, line)?;
            let depth = stack.len();
            let path: Vec<&str> = stack.iter().map(String::as_str).collect();
            match (depth, path.as_slice(), tag.as_str()) {
                (0, _, "robot") if !saw_root => {
                    saw_root = true;
                    self.mechanism.name = get(&attrs, "name").unwrap_or("").to_string();
                }
                (0, _, other) => {
                    let why = if saw_root {
                        format!("malformed XML: a second root element <{other}>")
                    } else {
                        format!("not a URDF robot: the root element is <{other}>, not <robot>")
                    };
                    return self.fail(line, why);
                }
                (1, _, "link") => {
                    let Some(name) = get(&attrs, "name") else {
                        return self.fail(line, "<link> has no name".into());
                    };
                    self.lines.insert(format!("link \"{name}\""), line);
                    self.link = Some(Body::massless(name));
                    inertial = (Origin::IDENTITY, 0.0, [[0.0; 3]; 3]);
                }
                (1, _, "joint") => self.open_joint(&attrs, line)?,
                (3, [_, "link", "inertial"], "origin") => {
                    inertial.0 = self.origin(&attrs, line)?;
                }
                (3, [_, "link", "inertial"], "mass") => {
                    if get(&attrs, "value").is_none() {
                        return self.fail(line, "<mass> has no value".into());
                    }
                    inertial.1 = self.numbers(&attrs, "mass", "value", [0.0], line)?[0];
                }
                (3, [_, "link", "inertial"], "inertia") => {
                    // All six are required, as by urdfdom (which drops the whole inertia
                    // of a link missing one: a silent difference if we took 0).
                    let mut v = [0.0; 6];
                    for (k, key) in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"]
                        .iter()
                        .enumerate()
                    {
                        if get(&attrs, key).is_none() {
                            return self.fail(
                                line,
                                format!(
                                    "<inertia> has no {key} (URDF needs all six of ixx ixy \
                                     ixz iyy iyz izz)"
                                ),
                            );
                        }
                        v[k] = self.numbers(&attrs, "inertia", key, [0.0], line)?[0];
                    }
                    let [xx, xy, xz, yy, yz, zz] = v;
                    inertial.2 = [[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]];
                }
                (2, [_, "joint"], child) if self.joint.is_some() => {
                    self.joint_child(child, &attrs, line)?;
                }
                _ => {}
            }
            if empty {
                self.close(&tag, depth, &mut inertial)?;
            } else {
                stack.push(tag);
            }
        }
        if let Some(open) = stack.last() {
            let line = self.line(self.text.len() as u64);
            return self.fail(line, format!("malformed XML: <{open}> is not closed"));
        }
        if !saw_root {
            return Err(Error::new(
                String::new(),
                "not a URDF robot: no <robot> element".into(),
            ));
        }
        Ok(())
    }

    /// The end of element `tag`, which was at `depth`.
    fn close(
        &mut self,
        tag: &str,
        depth: usize,
        inertial: &mut (Origin, f64, [[f64; 3]; 3]),
    ) -> Result<(), Error> {
        if depth != 1 {
            return Ok(());
        }
        match tag {
            "link" => {
                if let Some(mut body) = self.link.take() {
                    let (o, mass, i) = *inertial;
                    body.mass = mass;
                    body.com = o.xyz;
                    // The inertia given in the inertial frame, in link axes: R I Rᵀ.
                    body.inertia = mat_mul(&mat_mul(&o.rotation, &i), &transpose(&o.rotation));
                    self.mechanism.bodies.push(body);
                }
            }
            "joint" => {
                if let Some(j) = self.joint.take() {
                    for (role, link) in [("parent", &j.parent), ("child", &j.child)] {
                        if link.is_empty() {
                            let element = format!("joint \"{}\"", j.name);
                            let line = self.lines.get(&element).copied().unwrap_or(0);
                            let why = format!("has no <{role} link=\"…\"/>");
                            return Err(Error::new(element, why).at_line(line));
                        }
                    }
                    self.mechanism.joints.push(j);
                }
            }
            _ => {}
        }
        Ok(())
    }

    fn open_joint(&mut self, attrs: &Attrs, line: usize) -> Result<(), Error> {
        let Some(name) = get(attrs, "name") else {
            return self.fail(line, "<joint> has no name".into());
        };
        let element = format!("joint \"{name}\"");
        self.lines.insert(element.clone(), line);
        let refuse = |reason: String| Err(Error::new(element.clone(), reason).at_line(line));
        let kind = match get(attrs, "type") {
            Some("revolute") => JointKind::Revolute,
            Some("continuous") => JointKind::Continuous,
            Some("prismatic") => JointKind::Prismatic,
            Some("fixed") => JointKind::Fixed,
            Some("floating") => {
                return refuse(
                    "type \"floating\" is not supported: a free-floating body needs 6 \
                     coordinates with a quaternion, not built yet (the root stays fixed)"
                        .into(),
                )
            }
            Some("planar") => {
                return refuse(
                    "type \"planar\" is not supported: a planar joint has 3 coordinates \
                     (x, y and a rotation), not built yet"
                        .into(),
                )
            }
            Some(other) => {
                return refuse(format!(
                    "unknown type \"{other}\" (URDF has revolute, continuous, prismatic, \
                     fixed, floating and planar)"
                ))
            }
            None => return refuse("has no type".into()),
        };
        // Parent and child are filled from their elements; empty names fail validation.
        self.joint = Some(Joint::new(name, kind, "", "", Origin::IDENTITY));
        Ok(())
    }

    fn joint_child(&mut self, tag: &str, attrs: &Attrs, line: usize) -> Result<(), Error> {
        match tag {
            "origin" => {
                let o = self.origin(attrs, line)?;
                self.joint.as_mut().expect("in a joint").origin = o;
            }
            "parent" | "child" => {
                let Some(link) = get(attrs, "link") else {
                    return self.fail(line, format!("<{tag}> has no link attribute"));
                };
                let j = self.joint.as_mut().expect("in a joint");
                if tag == "parent" {
                    j.parent = link.to_string();
                } else {
                    j.child = link.to_string();
                }
            }
            "axis" => {
                let a = self.numbers(attrs, "axis", "xyz", [1.0, 0.0, 0.0], line)?;
                let j = self.joint.take().expect("in a joint");
                self.joint = Some(j.axis(a));
            }
            "limit" => {
                let mut l = [None; 4];
                for (k, key) in ["lower", "upper", "effort", "velocity"].iter().enumerate() {
                    if get(attrs, key).is_some() {
                        l[k] = Some(self.numbers(attrs, "limit", key, [0.0], line)?[0]);
                    }
                }
                self.joint.as_mut().expect("in a joint").limit = Limit {
                    lower: l[0],
                    upper: l[1],
                    effort: l[2],
                    velocity: l[3],
                };
            }
            "dynamics" => {
                let d = self.numbers(attrs, "dynamics", "damping", [0.0], line)?[0];
                let f = self.numbers(attrs, "dynamics", "friction", [0.0], line)?[0];
                let j = self.joint.as_mut().expect("in a joint");
                j.damping = d;
                j.friction = f;
            }
            "mimic" => {
                let Some(of) = get(attrs, "joint") else {
                    return self.fail(line, "<mimic> has no joint attribute".into());
                };
                let r = self.numbers(attrs, "mimic", "multiplier", [1.0], line)?[0];
                let o = self.numbers(attrs, "mimic", "offset", [0.0], line)?[0];
                let j = self.joint.take().expect("in a joint");
                self.joint = Some(j.mimic(of, r, o));
            }
            _ => {}
        }
        Ok(())
    }
}
