//! The CompoundPendulum FMU: this binary carries only this model.
mbfmu::export_fmu!(lagrangian mbfmu::systems::CompoundPendulum);
