//! A bounds-checked little-endian cursor over a file held in memory: every read that would run
//! past the end is an error, so no length field from the file is ever trusted.

use anyhow::{bail, ensure, Result};

/// Reads little-endian values from a byte slice, failing cleanly at the end of the data.
pub struct ByteReader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> ByteReader<'a> {
    /// A cursor at the start of `data`.
    pub fn new(data: &'a [u8]) -> Self {
        ByteReader { data, pos: 0 }
    }

    /// The current offset from the start of the data.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Bytes left after the current offset.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    /// Moves to absolute offset `pos`, which must lie within the data.
    pub fn seek(&mut self, pos: u64) -> Result<()> {
        ensure!(
            pos <= self.data.len() as u64,
            "offset {pos} points past the end of the file ({} bytes): the file is truncated or corrupt",
            self.data.len()
        );
        self.pos = pos as usize;
        Ok(())
    }

    /// The next `n` bytes.
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8]> {
        if n > self.remaining() {
            bail!(
                "unexpected end of file at byte {} (needed {n} more bytes, {} left): the file is truncated",
                self.pos,
                self.remaining()
            );
        }
        let out = &self.data[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }

    /// The next `N` bytes as an array.
    pub fn array<const N: usize>(&mut self) -> Result<[u8; N]> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.bytes(N)?);
        Ok(out)
    }

    /// Skips `n` bytes.
    pub fn skip(&mut self, n: u64) -> Result<()> {
        let n = usize::try_from(n).unwrap_or(usize::MAX);
        self.bytes(n).map(|_| ())
    }

    /// One byte.
    pub fn u8(&mut self) -> Result<u8> {
        Ok(self.array::<1>()?[0])
    }

    /// A little-endian u32.
    pub fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    /// A little-endian i32.
    pub fn i32(&mut self) -> Result<i32> {
        Ok(i32::from_le_bytes(self.array()?))
    }

    /// A little-endian i64.
    pub fn i64(&mut self) -> Result<i64> {
        Ok(i64::from_le_bytes(self.array()?))
    }

    /// A little-endian u64.
    pub fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.array()?))
    }

    /// A little-endian f64.
    pub fn f64(&mut self) -> Result<f64> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    /// Three little-endian i32s.
    pub fn coord(&mut self) -> Result<[i32; 3]> {
        Ok([self.i32()?, self.i32()?, self.i32()?])
    }

    /// Three little-endian f64s.
    pub fn vec3d(&mut self) -> Result<[f64; 3]> {
        Ok([self.f64()?, self.f64()?, self.f64()?])
    }

    /// A string stored as a u32 byte count and the bytes (non-UTF-8 bytes are replaced).
    pub fn string(&mut self) -> Result<String> {
        let len = self.u32()? as usize;
        Ok(String::from_utf8_lossy(self.bytes(len)?).into_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_little_endian_and_stops_at_the_end() {
        let data = [1u8, 0, 0, 0, 2, b'a', b'b'];
        let mut r = ByteReader::new(&data);
        assert_eq!(r.u32().unwrap(), 1);
        assert_eq!(r.u8().unwrap(), 2);
        let err = r.u32().unwrap_err().to_string();
        assert!(err.contains("truncated"), "{err}");
        assert_eq!(r.pos(), 5, "a failed read must not move the cursor");
    }

    #[test]
    fn huge_string_length_is_an_error_not_an_allocation() {
        let data = [0xff, 0xff, 0xff, 0xff, b'x'];
        let err = ByteReader::new(&data).string().unwrap_err().to_string();
        assert!(err.contains("needed 4294967295 more bytes"), "{err}");
    }
}
