//! modelDescription/ is committed so interface changes are reviewed: it must equal what
//! the code generates. Regenerate with `cargo run --bin mbfmu -- xml`.

use mbfmu::{catalogue, systems};

/// Byte for byte, on whatever machine runs it, against text generated on another one. Every
/// number in the XML is a literal or IEEE arithmetic (+ − × ÷ √, correctly rounded
/// everywhere) except three libm results, whose last bit could in principle differ between
/// machines (glibc picks FMA variants of sin and cos by CPU): SphereSlide's start values
/// x = sin(1e-3), h = cos(1e-3), and sin(π/6) inside RollingHoop's stopTime
/// √(20 / (½ g sin φ)). Their exact values lie 0.026, 0.071 and 0.104 ulp from the doubles
/// written (computed to 60 digits), so every sin/cos with an error below 0.89 ulp returns
/// those doubles; glibc's stay near 0.5 ulp. An exact comparison is therefore right here;
/// a new libm-derived number in the XML needs the same check.
#[test]
fn committed_model_descriptions_are_current() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("modelDescription");
    for e in catalogue::all() {
        let path = dir.join(format!("{}.xml", e.name));
        let committed = std::fs::read_to_string(&path)
            .unwrap_or_else(|err| panic!("{}: {err}", path.display()));
        assert!(
            committed == (e.model_description)(),
            "{} is out of date: run `cargo run --bin mbfmu -- xml`",
            path.display()
        );
    }
}

#[test]
fn generation_is_deterministic_and_guid_tracks_content() {
    for e in catalogue::all() {
        let a = (e.model_description)();
        assert_eq!(a, (e.model_description)());
        let guid = a
            .split("guid=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        assert_eq!(guid.len(), 38, "{guid}");
    }
    let xmls: Vec<String> = catalogue::all()
        .iter()
        .map(|e| (e.model_description)())
        .collect();
    assert_ne!(xmls[0], xmls[1]);
}

#[test]
fn model_structure_lists_exact_dependencies() {
    let xml = mbfmu::xml::model_description::<systems::TwoMassChain>();
    // TwoMassChain: vr 0..4 params, 5 solver, 6 solver_step, 7..10 states (index 8..11),
    // 11..14 derivatives (index 12..15), 15 input F (index 16), 16 E (index 17).
    for needle in [
        r#"<Unknown index="12" dependencies="10"/>"#,
        r#"<Unknown index="14" dependencies="8 9 10 11 16"/>"#,
        r#"<Unknown index="15" dependencies="8 9 10 11"/>"#,
        r#"<Unknown index="17" dependencies="8 9 10 11"/>"#,
        r#"<Real derivative="8" unit="m/s"/>"#,
    ] {
        assert!(xml.contains(needle), "missing {needle} in\n{xml}");
    }
}

/// The `solver` parameter's description lists every method of the enumeration (it is
/// generated from `Method::ALL`; it once named only the first two of twelve).
#[test]
fn the_solver_description_lists_every_method() {
    use mbfmu::integrators::Method;
    for e in catalogue::all() {
        let xml = (e.model_description)();
        let solver = xml
            .split(r#"<ScalarVariable name="solver" "#)
            .nth(1)
            .and_then(|rest| rest.split("description=\"").nth(1))
            .and_then(|rest| rest.split('"').next())
            .unwrap_or_else(|| panic!("{}: no solver variable", e.name));
        for m in Method::ALL {
            let item = format!("{} = {}", m.code(), m.name());
            assert!(
                solver.contains(&item),
                "{}: {item} missing in {solver}",
                e.name
            );
        }
    }
}
