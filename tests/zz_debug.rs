use mbfmu::fmi::{Instance, Logger, ModelInfo};
#[test]
fn debug_humanoid() {
    let path = std::env::var("URDF").unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    mbfmu::multibody::runtime::load("h", &text).unwrap();
    type R = mbfmu::multibody::fmu::Robot<mbfmu::multibody::runtime::Runtime>;
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<R>()));
    let mut inst = Instance::<R>::new(info, Logger::silent("h"));
    inst.set_integer(&[info.layout.vr_of("solver").unwrap()], &[9])
        .unwrap();
    inst.setup_experiment(Some(1e-12), 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let mut t = 0.0;
    for _ in 0..187 {
        if t > 1.845 {
            eprintln!("t = {t}");
        }
        let r = inst.do_step(t, 0.01).unwrap();
        t += 0.01;
        if t > 1.855 {
            eprintln!("{r:?}");
        }
    }
}
