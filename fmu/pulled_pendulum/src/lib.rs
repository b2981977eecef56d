//! The PulledPendulum FMU: this binary carries only this model.
mbfmu::export_fmu!(lagrangian mbfmu::systems::PulledPendulum);
