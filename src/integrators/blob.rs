//! The little-endian bytes of a serialized FMU state, read with the checks every field
//! needs: the integrators write and read their own blocks of it (see [`super::Memory::write`]).

/// The bytes not yet read; every read that runs past the end is a "truncated" error.
pub struct Reader<'a> {
    pub bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    pub fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if self.bytes.len() < n {
            return Err("serialized FMU state is truncated".into());
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }
    /// How many bytes of `all` (the slice this reader started on) were read.
    pub fn offset(&self, all: &[u8]) -> usize {
        all.len() - self.bytes.len()
    }
    pub fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().expect("4 bytes"),
        ))
    }
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().expect("8 bytes"),
        ))
    }
    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
    pub fn f64s(&mut self, n: usize) -> Result<Vec<f64>, String> {
        (0..n).map(|_| self.f64()).collect()
    }
    pub fn flag(&mut self) -> Result<bool, String> {
        match self.take(1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            other => Err(format!("FMU state has invalid flag {other}")),
        }
    }
}

pub fn put_f64(b: &mut Vec<u8>, v: f64) {
    b.extend_from_slice(&v.to_bits().to_le_bytes());
}

/// Every value of `values`, in order.
pub fn put_f64s<'v>(b: &mut Vec<u8>, values: impl IntoIterator<Item = &'v f64>) {
    for &v in values {
        put_f64(b, v);
    }
}
