//! The CompoundPendulum FMU: this binary carries only this model.
mbfmu::export_fmu!(mbfmu::systems::CompoundPendulum);
