//! Smoke test of `mbfmu bench`: MassSpringDamper, two settings per method. Checks that every
//! run is there and complete, and that errors shrink when the setting tightens. Timing is
//! measured, never asserted.

use mbfmu::bench::{bench_system, BenchConfig, BenchRow};
use mbfmu::integrators::Method;
use mbfmu::systems::MassSpringDamper;

fn rows() -> Vec<BenchRow> {
    let config = BenchConfig {
        reps: 1,
        scenes: vec!["damped".into(), "free".into()],
        ..BenchConfig::quick()
    };
    assert_eq!(config.steps.len(), 2);
    assert_eq!(config.tolerances.len(), 2);
    bench_system::<MassSpringDamper>(&config)
}

#[test]
fn bench_rows_are_complete_and_errors_shrink() {
    let rows = rows();
    for scene in ["damped", "free"] {
        for method in Method::ALL {
            let mine: Vec<&BenchRow> = rows
                .iter()
                .filter(|r| r.scene == scene && r.method == method.name())
                .collect();
            // Adaptive methods run on the 0.01 s grid and once over the whole scene.
            let expected = if method.is_adaptive() { 4 } else { 2 };
            assert_eq!(mine.len(), expected, "{scene} {}", method.name());
            if method.needs_mechanics() {
                // MassSpringDamper is not written as a Lagrangian: RATTLE is refused, and
                // the rows say so.
                assert!(
                    mine.iter()
                        .all(|r| r.status == "refused" && r.message.contains("RATTLE")),
                    "{mine:?}"
                );
                continue;
            }
            for r in &mine {
                assert_eq!(r.system, "MassSpringDamper");
                assert_eq!(r.status, "ok", "{r:?}");
                assert!(r.message.is_empty());
                let (e, ef) = (r.error.unwrap(), r.error_final.unwrap());
                assert!(
                    e.is_finite() && e >= 0.0 && ef.is_finite() && ef <= e,
                    "{r:?}"
                );
                assert!(r.cpu_s > 0.0 && r.rhs_evals > 0 && r.steps > 0, "{r:?}");
                assert!(r.ref_error < 1e-10, "{r:?}");
                assert_eq!(
                    r.setting_kind,
                    if method.is_adaptive() { "tol" } else { "step" }
                );
                // E is conserved only without damping; judged on the grid only.
                let on_grid = r.comm_step == 0.01;
                assert_eq!(
                    r.invariant_error.is_some(),
                    scene == "free" && on_grid,
                    "{r:?}"
                );
            }
            // Errors shrink as the setting tightens (tolerance 1e-4 → 1e-8, step 1e-2 → 1e-3).
            // Adaptive runs are compared over one doStep: on the 0.01 s grid the communication
            // step, not the tolerance, bounds the step at loose tolerances.
            let comparable: Vec<&&BenchRow> = mine
                .iter()
                .filter(|r| !method.is_adaptive() || r.comm_step > 0.01)
                .collect();
            let loose = comparable
                .iter()
                .find(|r| r.setting == 1e-4 || r.setting == 1e-2);
            let tight = comparable
                .iter()
                .find(|r| r.setting == 1e-8 || r.setting == 1e-3);
            let (loose, tight) = (loose.unwrap(), tight.unwrap());
            // Near round-off (DOP853 reaches 1e-14 quickly) there is nothing left to shrink.
            let floor = 1e-12;
            assert!(
                tight.error_final.unwrap() < loose.error_final.unwrap().max(floor),
                "{scene} {}: {:?} then {:?}",
                method.name(),
                loose.error_final,
                tight.error_final
            );
        }
    }
}

#[test]
fn csv_has_one_line_per_row() {
    let rows = rows();
    let csv = mbfmu::bench::to_csv(&rows);
    assert_eq!(csv.lines().count(), rows.len() + 1);
    let columns = csv.lines().next().unwrap().split(',').count();
    for line in csv.lines() {
        // Messages are quoted and empty here, so commas count columns.
        assert_eq!(line.split(',').count(), columns, "{line}");
    }
}

/// The hand-written floors of `mbfmu speed` compute what the models compute (otherwise
/// a ratio to them means nothing): equal right-hand sides at random states.
#[test]
fn the_speed_floors_compute_what_the_models_compute() {
    use mbfmu::bench::floors::{self, Floor};
    use mbfmu::model::System;
    use mbfmu::systems::{CompoundPendulum, DoublePendulum};
    fn agree<M: System, F: Floor<N>, const N: usize>(seed: u64) {
        let mut s = seed;
        let mut uniform = |lo: f64, hi: f64| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
        };
        let mut p: Vec<f64> = M::parameters().iter().map(|v| v.start).collect();
        if M::NAME == "MassSpringDamper" {
            p[3] = 0.0; // the floor has no harmonic forcing
        }
        let u = vec![0.0; M::inputs().len()];
        for _ in 0..50 {
            let x: [f64; N] = std::array::from_fn(|_| uniform(-2.0, 2.0));
            let mut dx = vec![0.0; N];
            M::derivatives(0.0, &x, &u, &p, &mut dx);
            let floor = F::rhs(&x, &p);
            let scale = dx.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            for i in 0..N {
                assert!(
                    (dx[i] - floor[i]).abs() <= 1e-13 * scale,
                    "{}: {dx:?} vs {floor:?}",
                    M::NAME
                );
            }
        }
    }
    agree::<MassSpringDamper, floors::MassSpringDamper, 2>(1);
    agree::<CompoundPendulum, floors::CompoundPendulum, 2>(2);
    agree::<DoublePendulum, floors::DoublePendulum, 4>(3);
}

/// `mbfmu speed`'s row for one system is complete (times are measured, never asserted).
#[test]
fn a_speed_row_is_complete() {
    use mbfmu::bench::speed;
    let row = speed::measure::<MassSpringDamper>(1, speed::floor_of("MassSpringDamper"));
    let (floor_step, floor_rhs) = row.floor.expect("MassSpringDamper has a floor");
    for v in [
        row.dostep_ns,
        row.rhs_ns,
        row.jacobian_ns,
        floor_step,
        floor_rhs,
    ] {
        assert!(v.is_finite() && v > 0.0, "{row:?}");
    }
    assert_eq!(
        speed::csv_line(&row).split(',').count(),
        speed::CSV_HEADER.split(',').count()
    );
}
