//! The full state of an instance (FMU state): model values, time, experiment setup,
//! integrator memory and the mode, plus its portable byte layout.
//!
//! Serialized layout (little-endian): magic (8 bytes), format version (u32), GUID
//! (u32 length + UTF-8), counts of parameters, states, inputs (u32 each), then the
//! fields in the order of [`Snapshot::serialize`], then the CRC-32 (IEEE, as zip and
//! PNG use it) of every byte before it (u32). A blob from another model (GUID), another
//! format version, of the wrong length, or whose checksum does not match (a corrupted
//! copy: CRC-32 detects every single-bit error and every burst of up to 32 bits) is
//! rejected.

use super::mode::{Interface, Mode, States};
use crate::integrators::blob::Reader;
use crate::integrators::{Memory, Method};

pub const SNAPSHOT_MAGIC: [u8; 8] = *b"MBFMU\0ST";
/// 2: adds DOPRI5's dense-output point and stiffness monitor. 3: adds RADAU5's loop state.
/// 4: adds DOP853's dense-output point. 5: ends with a CRC-32 of the blob. 6: adds
/// `solver_max_steps` after `solver_step`. 7: adds the inputs' first and second time
/// derivatives (fmi2SetRealInputDerivatives) after the inputs. 8: counts the Jacobians
/// (doStep's work bound) after the rejected steps. 9: ends (before the checksum) with the
/// interface the state was taken in, `me_projection` and Model Exchange's event reference.
/// 10: the integrator memory as [`Memory::write`] writes it (one point ahead, after its
/// method's code, instead of a flag for each method's).
pub const SNAPSHOT_VERSION: u32 = 10;

/// Bytes of the checksum that ends a blob.
const CRC_LEN: usize = 4;

#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    pub params: Vec<f64>,
    pub x: Vec<f64>,
    pub u: Vec<f64>,
    /// The inputs' first and second time derivatives at `time` (fmi2SetRealInputDerivatives;
    /// zero: held over a doStep).
    pub u_der: [Vec<f64>; 2],
    pub method: Method,
    pub solver_step: f64,
    /// `solver_max_steps`: most internal steps in one doStep.
    pub max_steps: u64,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub tolerance: f64,
    pub memory: Memory,
    pub mode: Mode,
    /// The interface the instance was made for: a state is restored only into an
    /// instance of the same one (its modes are that interface's).
    pub interface: Interface,
    /// `me_projection`: whether Model Exchange keeps a constrained system on its
    /// constraints through step events (Co-Simulation ignores it).
    pub me_projection: bool,
    /// Model Exchange: the event indicator where the last event ended (fmi2NewDiscreteStates,
    /// or fmi2ExitInitializationMode); a sign change against it is an event. `None`: the
    /// model has no indicator here, or Co-Simulation.
    pub event_reference: Option<f64>,
}

impl Snapshot {
    /// The serialized bytes of this snapshot for the model with this GUID.
    pub fn serialize(&self, guid: &str) -> Vec<u8> {
        let mut b = Vec::with_capacity(256);
        b.extend_from_slice(&SNAPSHOT_MAGIC);
        b.extend_from_slice(&SNAPSHOT_VERSION.to_le_bytes());
        b.extend_from_slice(&(guid.len() as u32).to_le_bytes());
        b.extend_from_slice(guid.as_bytes());
        for n in [self.params.len(), self.x.len(), self.u.len()] {
            b.extend_from_slice(&(n as u32).to_le_bytes());
        }
        let f = |b: &mut Vec<u8>, v: f64| b.extend_from_slice(&v.to_bits().to_le_bytes());
        let [u1, u2] = &self.u_der;
        for &v in self
            .params
            .iter()
            .chain(&self.x)
            .chain(&self.u)
            .chain(u1)
            .chain(u2)
        {
            f(&mut b, v);
        }
        b.extend_from_slice(&(self.method.code() as u32).to_le_bytes());
        f(&mut b, self.solver_step);
        b.extend_from_slice(&self.max_steps.to_le_bytes());
        f(&mut b, self.time);
        f(&mut b, self.start_time);
        b.push(self.stop_time.is_some() as u8);
        f(&mut b, self.stop_time.unwrap_or(0.0));
        f(&mut b, self.tolerance);
        self.memory.write(&mut b);
        b.extend_from_slice(&self.mode.code().to_le_bytes());
        b.push(self.interface.code());
        b.push(self.me_projection as u8);
        b.push(self.event_reference.is_some() as u8);
        f(&mut b, self.event_reference.unwrap_or(0.0));
        let crc = crc32fast::hash(&b);
        b.extend_from_slice(&crc.to_le_bytes());
        b
    }

    /// Reads a blob written by [`Snapshot::serialize`] for the model `guid` with the
    /// given counts of parameters, states and inputs. Checks the layout (magic, version,
    /// checksum, GUID, counts, flags, length) and the integrator memory's own invariants;
    /// the model's values are checked by [`crate::fmi::Instance::check_snapshot`].
    pub fn deserialize(bytes: &[u8], guid: &str, counts: [usize; 3]) -> Result<Snapshot, String> {
        let mut r = Reader { bytes };
        if r.take(8)
            .map_err(|_| "not an FMU state of this tool (too short)".to_string())?
            != SNAPSHOT_MAGIC
        {
            return Err("not an FMU state of this tool (bad magic)".into());
        }
        let version = r.u32()?;
        if version != SNAPSHOT_VERSION {
            return Err(format!(
                "FMU state format version {version}, this FMU reads version {SNAPSHOT_VERSION}"
            ));
        }
        // The checksum covers everything before it; checked before any field is read
        // (after the version: a blob of another version may not have one).
        let body_len = bytes.len().saturating_sub(CRC_LEN).max(r.offset(bytes));
        let (body, stored) = bytes.split_at(body_len);
        if stored.len() != CRC_LEN {
            return Err("serialized FMU state is truncated".into());
        }
        let stored = u32::from_le_bytes(stored.try_into().expect("4 bytes"));
        let computed = crc32fast::hash(body);
        if stored != computed {
            return Err(format!(
                "serialized FMU state is corrupted: its CRC-32 is {stored:#010x}, its bytes give {computed:#010x}"
            ));
        }
        r.bytes = &body[r.offset(bytes)..];
        let n = r.u32()? as usize;
        let blob_guid = r.take(n)?;
        if blob_guid != guid.as_bytes() {
            return Err(format!(
                "FMU state belongs to another model (GUID {}), this model is {guid}",
                String::from_utf8_lossy(blob_guid)
            ));
        }
        let found = [r.u32()? as usize, r.u32()? as usize, r.u32()? as usize];
        if found != counts {
            return Err(format!(
                "FMU state has {found:?} parameters/states/inputs, the model {counts:?}"
            ));
        }
        let params = r.f64s(counts[0])?;
        let x = r.f64s(counts[1])?;
        let u = r.f64s(counts[2])?;
        let u_der = [r.f64s(counts[2])?, r.f64s(counts[2])?];
        let code = r.u32()?;
        let method = Method::from_code(code as i32)
            .ok_or_else(|| format!("FMU state names unknown method {code}"))?;
        let solver_step = r.f64()?;
        let max_steps = r.u64()?;
        let time = r.f64()?;
        let start_time = r.f64()?;
        let has_stop = r.take(1)?[0];
        let stop = r.f64()?;
        let tolerance = r.f64()?;
        let memory = Memory::read(&mut r, counts[1])?;
        let code = r.u32()?;
        let mode =
            Mode::from_code(code).ok_or_else(|| format!("FMU state names unknown mode {code}"))?;
        let code = r.take(1)?[0];
        let interface = Interface::from_code(code)
            .ok_or_else(|| format!("FMU state names unknown interface {code}"))?;
        let me_projection = r.flag()?;
        let has_reference = r.flag()?;
        let reference = r.f64()?;
        if !reference.is_finite() {
            return Err("FMU state holds a non-finite event indicator reference".into());
        }
        if !r.bytes.is_empty() {
            return Err(format!("FMU state has {} trailing bytes", r.bytes.len()));
        }
        // The values themselves (finite, in range, consistent) are the instance's to check
        // (`Instance::check_snapshot`), as its setters check them.
        if has_stop > 1 {
            return Err(format!("FMU state has invalid flag {has_stop}"));
        }
        Ok(Snapshot {
            params,
            x,
            u,
            u_der,
            method,
            solver_step,
            max_steps,
            time,
            start_time,
            stop_time: (has_stop == 1).then_some(stop),
            tolerance,
            memory,
            mode,
            interface,
            me_projection,
            event_reference: has_reference.then_some(reference),
        })
    }
}
