//! The AndrewsSqueezer FMU: this binary carries only this model.
mbfmu::export_fmu!(mechanism mbfmu::systems::andrews_squeezer::AndrewsMechanism);
