//! The RollingHoop FMU: this binary carries only this model.
mbfmu::export_fmu!(mbfmu::systems::RollingHoop);
