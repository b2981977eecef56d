//! The RotatingHoopBead FMU: this binary carries only this model.
mbfmu::export_fmu!(lagrangian mbfmu::systems::RotatingHoopBead);
