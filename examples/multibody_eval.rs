//! Evaluates the rigid-body dynamics of a URDF mechanism at given points (the Pinocchio
//! comparison of tests/python/test_multibody_pinocchio.py drives it).
//!
//! ```text
//! multibody_eval ROBOT.urdf < points.json      # [{"q": [..], "qd": [..], "tau": [..]}, ..]
//! multibody_eval ROBOT.urdf --bench N          # ns per ABA call (f64), N calls
//! ```
//!
//! Prints JSON: the moving joints (coordinate order), their damping, the tips (ends of
//! branches) and for each point ABA's q̈ (with the URDF damping, `τ − d q̇`), the mass
//! matrix (CRBA), the bias `RNEA(q, q̇, 0)`, kinetic and potential energy, and each tip's
//! position and quaternion (w, x, y, z) in the base frame.

use mbfmu::multibody::{urdf, Model};
use serde_json::{json, Value};
use std::io::Read;
use std::time::Instant;

fn main() {
    if let Err(e) = run() {
        eprintln!("multibody_eval: {e}");
        std::process::exit(1);
    }
}

fn run() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        return Err(
            "usage: multibody_eval ROBOT.urdf [--bench N] (points as JSON on stdin)".into(),
        );
    };
    let mechanism = urdf::load(std::path::Path::new(path)).map_err(|e| e.to_string())?;
    let model = Model::new(&mechanism).map_err(|e| e.to_string())?;
    if args.get(1).map(String::as_str) == Some("--bench") {
        let n: usize = args
            .get(2)
            .and_then(|s| s.parse().ok())
            .ok_or("--bench needs a number of calls")?;
        bench(&model, n);
        return Ok(());
    }
    let mut input = String::new();
    std::io::stdin()
        .read_to_string(&mut input)
        .map_err(|e| e.to_string())?;
    let points: Value = serde_json::from_str(&input).map_err(|e| format!("stdin: {e}"))?;
    let points = points.as_array().ok_or("stdin: a JSON list of points")?;
    let vector = |p: &Value, key: &str| -> Result<Vec<f64>, String> {
        let v: Vec<f64> = p[key]
            .as_array()
            .ok_or(format!("point: no list \"{key}\""))?
            .iter()
            .map(|x| {
                x.as_f64()
                    .ok_or(format!("point: \"{key}\" has a non-number"))
            })
            .collect::<Result<_, _>>()?;
        if v.len() != model.nq() {
            return Err(format!(
                "point: \"{key}\" has {} entries, not {}",
                v.len(),
                model.nq()
            ));
        }
        Ok(v)
    };
    let mut out = Vec::new();
    for p in points {
        let (q, qd, tau) = (vector(p, "q")?, vector(p, "qd")?, vector(p, "tau")?);
        let tips: Vec<Value> = model
            .tip_poses(&q)
            .iter()
            .map(|(p, quat)| json!({"position": p, "quaternion": quat}))
            .collect();
        out.push(json!({
            "qdd": model.aba(&q, &qd, &tau),
            "mass_matrix": model.crba(&q),
            "bias": model.rnea(&q, &qd, &vec![0.0; model.nq()]),
            "kinetic": model.kinetic_energy(&q, &qd),
            "potential": model.potential_energy(&q),
            "tips": tips,
        }));
    }
    let result = json!({
        "name": model.name,
        "joints": model.joints,
        "damping": model.damping,
        "tips": model.tips.iter().map(|t| t.name.clone()).collect::<Vec<_>>(),
        "points": out,
    });
    println!("{result}");
    Ok(())
}

/// Times `calls` ABA calls over 64 fixed pseudo-random states; prints ns per call.
fn bench(model: &Model, calls: usize) {
    let n = model.nq();
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let states: Vec<[Vec<f64>; 3]> = (0..64)
        .map(|_| {
            [
                (0..n).map(|_| 3.0 * next()).collect(),
                (0..n).map(|_| 2.0 * next()).collect(),
                (0..n).map(|_| 10.0 * next()).collect(),
            ]
        })
        .collect();
    let mut sink = 0.0;
    for [q, qd, tau] in states.iter().cycle().take(calls / 10 + 1) {
        sink += model.aba(q, qd, tau)[0];
    }
    let start = Instant::now();
    for [q, qd, tau] in states.iter().cycle().take(calls) {
        sink += std::hint::black_box(model.aba(
            std::hint::black_box(q),
            std::hint::black_box(qd),
            std::hint::black_box(tau),
        ))[0];
    }
    let ns = start.elapsed().as_nanos() as f64 / calls as f64;
    println!(
        "{}",
        json!({"robot": model.name, "nq": n, "calls": calls, "ns_per_aba": ns, "checksum": sink})
    );
}
