//! An instance of any system through the FMU's own core, for tests that export an FMU of
//! their own (so cannot take `common`, which exports MassSpringDamper):
//! `#[path = "common/instance.rs"] mod instance;`.
#![allow(dead_code)]

/// An instance of `R` through the FMU's own core, started with `values` set (by name),
/// tolerance 1e-10, initialised; and its model info (leaked: one per test).
pub fn started<R: mbfmu::model::System>(
    name: &str,
    values: &[(&str, f64)],
) -> (mbfmu::fmi::Instance<R>, &'static mbfmu::fmi::ModelInfo) {
    use mbfmu::fmi::{Instance, Logger, ModelInfo};
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<R>()));
    let mut inst = Instance::<R>::new(info, Logger::silent(name));
    for (name, v) in values {
        let vr = info.layout.vr_of(name).expect(name);
        inst.set_value(vr, *v).unwrap();
    }
    inst.setup_experiment(Some(1e-10), 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    (inst, info)
}

/// The value of the variable `name` of a started instance.
pub fn value_of<R: mbfmu::model::System>(
    inst: &mbfmu::fmi::Instance<R>,
    info: &mbfmu::fmi::ModelInfo,
    name: &str,
) -> f64 {
    let mut v = [0.0];
    inst.get_real(&[info.layout.vr_of(name).expect(name)], &mut v)
        .unwrap();
    v[0]
}
