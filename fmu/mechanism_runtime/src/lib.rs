//! The mechanism runtime: one binary per platform running any robot, read from its FMU's
//! resources at instantiation (`mbfmu::multibody::runtime`). `mbfmu build --urdf` copies it
//! into a robot's FMU under the robot's modelIdentifier: no compiler needed.
mbfmu::export_fmu!(mechanism_runtime);
